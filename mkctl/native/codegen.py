"""Generate the C source of the compiled core from the library's own equations.

Nothing here writes an equation. The physics functions run on Python floats, numpy arrays and, for this
module, sympy symbols (:func:`mkctl.physics.actuator.math_for`): :func:`trace` evaluates them with a symbol
for every state, input and parameter and gets back the expressions the library computes; sympy's
common-subexpression elimination (``sympy.cse``) and C printer (``sympy.ccode``) turn them into C.

What is generated from what:

======================================  ========================================================================
C function                              traced Python function
======================================  ========================================================================
``knee_rhs_<variant>``                  :func:`mkctl.physics.knee.knee_derivatives` (Eq. 17, effects, end stops)
``knee_outputs_<variant>``              :func:`mkctl.physics.simulate.knee_outputs` (a1, a2 from the partials)
``actuator_tension_<variant>``          :func:`mkctl.physics.actuator.tension`
``actuator_lagged_pressure_<variant>``  :func:`mkctl.physics.actuator.lagged_pressure`
``mk_stop_positions``                   :func:`mkctl.physics.knee.X_from_alpha` at the stop angles
``mk_step_checks``                      :func:`mkctl.physics.actuator.check_pressure` of the two commands
domain checks (every function)          the checks those functions make (``check_length``, ``check_pressure``,
                                        ``knee._check_range``), traced with their bounds
``MK_A``, ``MK_E``, step control        the constants of :mod:`mkctl.physics.integrate`
======================================  ========================================================================

The integrator itself (:file:`core_template.c`) is the algorithm of :func:`mkctl.physics.integrate.integrate`
written in C; it holds no equation of the model.

Branches on the parameter structure (``model`` 1 or 2, friction ``Fc > 0``, pressure lag ``tau > 0``) are
resolved by generating one *variant* per structure: the tracing parameters hold the structural values as
numbers (``Fc`` and ``tau`` as positive symbols when on, 0 when off), so the library's own ``if`` statements
pick the branch. The end stops are one-sided: they trace to sympy ``Piecewise``/``Max`` (C ``?:``, ``fmax``)
with the stop positions as run-time inputs (+-inf for none). A C dispatcher (``mk_variant``) picks the
variant from the run-time parameter vector; a source may hold any set of variants.
"""
from __future__ import annotations

from typing import NamedTuple

import sympy

from ..physics import actuator, integrate, knee, simulate
from ..physics.params import PARAMETER_NAMES, Params, rubber_volume
from . import TEMPLATE
from .variants import ALL_VARIANTS, Variant

#: Knee outputs in the order of :data:`mkctl.physics.simulate.KNEE_OUTPUTS` ("stable" last, as 1/0).
KNEE_OUTPUT_NAMES = tuple(simulate.KNEE_OUTPUTS)
MAX_STATES = 4


class SymbolicParams:
    """A stand-in for :class:`mkctl.physics.params.Params` whose values are sympy symbols named after the
    parameters, except the structural ones of the variant (model a number; Fc, tau positive symbols or 0)."""

    def __init__(self, variant: Variant):
        for name in PARAMETER_NAMES:
            setattr(self, name, sympy.Symbol(name, real=True))
        self.model = variant.model
        self.Fc = sympy.Symbol("Fc", positive=True) if variant.friction else 0.0
        self.tau = sympy.Symbol("tau", positive=True) if variant.lag else 0.0

    @property
    def V_r(self):
        return rubber_volume(self.t0, self.D0, self.L0)


def _real(name: str) -> sympy.Symbol:
    return sympy.Symbol(name, real=True)


class Traced(NamedTuple):
    """One traced function: its results and the domain checks met on the way, in the order Python makes them."""

    outputs: list
    checks: list  #: (value, low, high, message, what), duplicates removed


def trace(function, *args, **kwargs) -> Traced:
    """Call a library function on symbolic arguments; return its results and its domain checks."""
    with actuator.tracing_domain_checks() as checks:
        result = function(*args, **kwargs)
    if isinstance(result, dict):
        outputs = list(result.values())
    elif isinstance(result, (list, tuple)):
        outputs = list(result)
    else:
        outputs = [result]
    unique, seen = [], set()
    for check in checks:
        key = (sympy.srepr(check[0]), str(check[1]), str(check[2]))
        if key not in seen:
            seen.add(key)
            unique.append(check)
    return Traced([sympy.sympify(o) for o in outputs], unique)


class CheckTable:
    """Every domain check of a generated source, numbered: the C reports a failure by this number."""

    def __init__(self):
        self.entries: list[str] = []  # what is checked, in words

    def add(self, check) -> int:
        _, low, _, _, what = check
        self.entries.append(f"{what} must be finite" if low is None else f"{what} is out of range")
        return len(self.entries) - 1


def _c_number(x) -> str:
    return repr(float(x))


def emit_function(signature: str, bindings: dict, traced: Traced, out: str, checks: CheckTable,
                  extra_outputs: tuple[str, ...] = ()) -> str:
    """C body: bind the inputs, compute the CSE'd expressions, test the checks in order, store out[i]."""
    symbols = set()
    for expr in traced.outputs:
        symbols |= expr.free_symbols
    exprs = list(traced.outputs)
    for value, low, high, _, _ in traced.checks:
        exprs.append(sympy.sympify(value))
        if low is not None:
            exprs += [sympy.sympify(low), sympy.sympify(high)]
    for expr in exprs:
        symbols |= expr.free_symbols
    unknown = sorted(str(s) for s in symbols if s.name not in bindings)
    if unknown:
        raise ValueError(f"unbound symbols {unknown} in {signature}")
    temporaries = sympy.numbered_symbols("t_")
    replacements, reduced = sympy.cse(exprs, symbols=temporaries, order="none")
    lines = [signature, "{"]
    for sym in sorted(symbols, key=lambda s: s.name):
        if bindings[sym.name] != sym.name:  # not an argument of that name already
            lines.append(f"    const double {sym.name} = {bindings[sym.name]};")
    for tmp, expr in replacements:
        lines.append(f"    const double {tmp} = {sympy.ccode(expr)};")
    n_out = len(traced.outputs)
    position = n_out
    for check in traced.checks:
        index = checks.add(check)
        value = sympy.ccode(reduced[position])
        if check[1] is None:
            lines.append(f"    if (!isfinite({value})) return mk_fail(fault, {index}, {value}, NAN, NAN);")
            position += 1
        else:
            low, high = sympy.ccode(reduced[position + 1]), sympy.ccode(reduced[position + 2])
            lines.append(f"    if (!(({low}) < ({value}) && ({value}) < ({high}))) "
                         f"return mk_fail(fault, {index}, {value}, {low}, {high});")
            position += 3
    for i in range(n_out):
        lines.append(f"    {out}[{i}] = {sympy.ccode(reduced[i])};")
    lines += list(extra_outputs)
    lines += ["    return 0;", "}", ""]
    return "\n".join(lines)


def _parameter_bindings() -> dict:
    return {name: f"p[MK_P_{name}]" for name in PARAMETER_NAMES}


def variant_functions(variant: Variant, checks: CheckTable) -> str:
    """The C of every variant-dependent function for one variant."""
    sp = SymbolicParams(variant)
    X, V, Pe, Pf, pe_cmd, pf_cmd = (_real(n) for n in ("X", "V", "Pe", "Pf", "pe_cmd", "pf_cmd"))
    X_low, X_high = _real("X_low"), _real("X_high")
    P_, L_, Ldot_, P_cmd_, dt_ = (_real(n) for n in ("P", "L", "Ldot", "P_cmd", "dt"))
    v = variant.name
    parts = []
    state = [X, V, Pe, Pf][: variant.nstate]
    bindings = {**_parameter_bindings(), "X": "y[0]", "V": "y[1]", "pe_cmd": "pe_cmd", "pf_cmd": "pf_cmd",
                "X_low": "(stops ? stops[0] : -INFINITY)", "X_high": "(stops ? stops[1] : INFINITY)"}
    if variant.lag:
        bindings.update(Pe="y[2]", Pf="y[3]")
    parts.append(emit_function(
        f"static int knee_rhs_{v}(const double *p, const double *stops, const double *y, double pe_cmd, "
        "double pf_cmd, double *out, mk_fault *fault)",
        bindings, trace(knee.knee_derivatives, state, pe_cmd, pf_cmd, sp, (X_low, X_high)), "out", checks))

    traced = trace(simulate.knee_outputs, X, V, Pe, Pf, sp)
    a1, a2 = KNEE_OUTPUT_NAMES.index("a1"), KNEE_OUTPUT_NAMES.index("a2")
    stable = KNEE_OUTPUT_NAMES.index("stable")
    if stable != len(traced.outputs):
        raise ValueError("'stable' must be the last knee output, after those of simulate.knee_outputs")
    parts.append(emit_function(
        f"static int knee_outputs_{v}(const double *p, double X, double V, double Pe, double Pf, double *out, "
        "mk_fault *fault)",
        {**_parameter_bindings(), "X": "X", "V": "V", "Pe": "Pe", "Pf": "Pf"}, traced, "out", checks,
        extra_outputs=(f"    out[{stable}] = (out[{a1}] < 0 && out[{a2}] < 0) ? 1.0 : 0.0;",)))

    parts.append(emit_function(
        f"static int actuator_tension_{v}(const double *p, double L, double P, double Ldot, double *out, "
        "mk_fault *fault)",
        {**_parameter_bindings(), "L": "L", "P": "P", "Ldot": "Ldot"},
        trace(actuator.tension, L_, P_, Ldot_, sp), "out", checks))
    parts.append(emit_function(
        f"static int actuator_lagged_pressure_{v}(const double *p, double P, double P_cmd, double dt, "
        "double *out, mk_fault *fault)",
        {**_parameter_bindings(), "P": "P", "P_cmd": "P_cmd", "dt": "dt"},
        trace(actuator.lagged_pressure, P_, P_cmd_, sp.tau, dt_), "out", checks))
    return "\n".join(parts)


def common_functions(checks: CheckTable) -> str:
    """The C of the functions that do not depend on the variant."""
    sp = SymbolicParams(Variant(2, False, False))
    pe_cmd, pf_cmd = _real("pe_cmd"), _real("pf_cmd")

    def both(pe, pf):
        actuator.check_pressure(pe)
        actuator.check_pressure(pf)
        return []

    parts = [emit_function("int mk_step_checks(const double *p, double pe_cmd, double pf_cmd, mk_fault *fault)",
                           {**_parameter_bindings(), "pe_cmd": "pe_cmd", "pf_cmd": "pf_cmd"},
                           trace(both, pe_cmd, pf_cmd), "out", checks)]

    def stops(params):
        # knee.stop_positions, traced: the stop angles as sympy numbers, so the posture math runs on symbols
        return [knee.X_from_alpha(sympy.Float(knee.ALPHA_STOP_LOW), params),
                knee.X_from_alpha(sympy.Float(knee.ALPHA_STOP_HIGH), params)]

    parts.append(emit_function("int mk_stop_positions(const double *p, double *out, mk_fault *fault)",
                               _parameter_bindings(), trace(stops, sp), "out", checks))
    return "\n".join(parts)


def _dispatch(variants: tuple[Variant, ...]) -> str:
    lines = [f"#define MK_NVARIANTS {len(variants)}",
             "static const int mk_variant_nstates[MK_NVARIANTS] = {"
             + ", ".join(str(v.nstate) for v in variants) + "};",
             "",
             "/* index of the compiled variant for parameter vector p, or -1 */",
             "int mk_variant(const double *p)", "{"]
    for i, v in enumerate(variants):
        lines.append(f"    if ({v.c_condition()}) return {i};")
    lines += ["    return -1;", "}", "",
              "static int mk_variant_nstate(int variant)", "{",
              "    return variant < 0 ? 2 : mk_variant_nstates[variant];", "}", "",
              "/* number of knee states for parameter vector p: 4 with a pressure lag, else 2 */",
              "int mk_knee_nstate(const double *p)", "{", "    return mk_variant_nstate(mk_variant(p));", "}", ""]

    def switch(kind, signature, call):
        body = [signature, "{", "    switch (variant) {"]
        for i, v in enumerate(variants):
            body.append(f"    case {i}: return {kind}_{v.name}({call});")
        body += ["    }", "    return mk_fault_code(fault, MK_FAULT_VARIANT);", "}", ""]
        return body

    lines += switch("knee_rhs", "static int mk_knee_rhs_variant(int variant, const double *p, const double *stops, "
                    "const double *y, double pe_cmd, double pf_cmd, double *out, mk_fault *fault)",
                    "p, stops, y, pe_cmd, pf_cmd, out, fault")
    lines += switch("knee_outputs", "static int mk_knee_outputs_variant(int variant, const double *p, double X, "
                    "double V, double Pe, double Pf, double *out, mk_fault *fault)",
                    "p, X, V, Pe, Pf, out, fault")
    lines += switch("actuator_tension", "static int mk_actuator_tension_variant(int variant, const double *p, "
                    "double L, double P, double Ldot, double *out, mk_fault *fault)", "p, L, P, Ldot, out, fault")
    lines += switch("actuator_lagged_pressure", "static int mk_actuator_lagged_pressure_variant(int variant, "
                    "const double *p, double P, double P_cmd, double dt, double *out, mk_fault *fault)",
                    "p, P, P_cmd, dt, out, fault")
    lines += [
        "/* right-hand side of Eq. 17 (knee.knee_derivatives): dy = f(y) for the variant of p */",
        "int mk_knee_rhs(const double *p, const double *stops, const double *y, double pe_cmd, double pf_cmd, "
        "double *dy, mk_fault *fault)",
        "{", "    return mk_knee_rhs_variant(mk_variant(p), p, stops, y, pe_cmd, pf_cmd, dy, fault);", "}", "",
        "/* actuator tension f(L, P, Ldot) [N] (actuator.tension) */",
        "int mk_actuator_tension(const double *p, double L, double P, double Ldot, double *f, mk_fault *fault)",
        "{", "    return mk_actuator_tension_variant(mk_variant(p), p, L, P, Ldot, f, fault);", "}", "",
        "/* pressure after dt with the command held (actuator.lagged_pressure, exact) */",
        "int mk_actuator_lagged_pressure(const double *p, double P, double P_cmd, double dt, double *out, "
        "mk_fault *fault)",
        "{", "    return mk_actuator_lagged_pressure_variant(mk_variant(p), p, P, P_cmd, dt, out, fault);", "}", ""]
    return "\n".join(lines)


def _tableau() -> str:
    rows = []
    for row in integrate._A:
        padded = list(row) + [0.0] * (7 - len(row))
        rows.append("    {" + ", ".join(_c_number(a) for a in padded) + "}")
    constants = {"MK_SAFETY": integrate.SAFETY, "MK_MAX_GROWTH": integrate.MAX_GROWTH,
                 "MK_MAX_SHRINK": integrate.MAX_SHRINK, "MK_ACCEPT_EXPONENT": integrate.ACCEPT_EXPONENT,
                 "MK_REJECT_EXPONENT": integrate.REJECT_EXPONENT, "MK_COLLAPSE": integrate.COLLAPSE}
    lines = ["static const double MK_A[7][7] = {", ",\n".join(rows), "};",
             "static const double MK_E[7] = {" + ", ".join(_c_number(e) for e in integrate._E) + "};"]
    lines += [f"#define {name} ({_c_number(value)})" for name, value in constants.items()]
    lines.append(f"#define MK_MAX_STEPS {int(integrate.MAX_STEPS)}L")
    return "\n".join(lines)


def _parameter_macros() -> str:
    lines = [f"#define MK_NPARAM {len(PARAMETER_NAMES)}", f"#define MK_MAX_STATES {MAX_STATES}",
             f"#define MK_KNEE_NOUT {len(KNEE_OUTPUT_NAMES)}",
             "/* knee outputs: " + ", ".join(f"{i} {name}" for i, name in enumerate(KNEE_OUTPUT_NAMES)) + " */"]
    lines += [f"#define MK_P_{name} {i}" for i, name in enumerate(PARAMETER_NAMES)]
    return "\n".join(lines)


def generate_source(variants=ALL_VARIANTS) -> tuple[str, list[str]]:
    """The C source of the core for the given variants, and its table of domain checks (in words)."""
    variants = tuple(variants)
    checks = CheckTable()
    generated = [common_functions(checks)] + [variant_functions(v, checks) for v in variants]
    table = ["/* domain checks, by the number a fault reports: */",
             "const char *const mk_check_what[] = {"]
    table += [f"    \"{text}\"," for text in checks.entries]
    table += ["};", f"const int mk_check_count = {len(checks.entries)};"]
    source = TEMPLATE.read_text()
    for key, text in {"@PARAMETER_MACROS@": _parameter_macros(),
                      "@GENERATED@": "\n".join(table) + "\n\n" + "\n".join(generated),
                      "@DISPATCH@": _dispatch(variants), "@TABLEAU@": _tableau(),
                      "@VARIANT_NAMES@": ", ".join(v.name for v in variants)}.items():
        source = source.replace(key, text)
    return source, checks.entries

