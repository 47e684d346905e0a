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
``actuator_lagged_pressure_<variant>``  :func:`mkctl.physics.actuator.pressure_after` (an exact step)
``actuator_pressure_rate_<variant>``    :func:`mkctl.physics.actuator.pressure_derivative`, where no exact step
                                        covers the variant's pressure dynamics: ``mk_pressure_integrate``
                                        integrates it over dt, as ``pressure_after`` does
``mk_stop_positions``                   :func:`mkctl.physics.knee.X_from_alpha` at the stop angles
``mk_step_checks``                      :func:`mkctl.physics.actuator.check_pressure` of the two commands
domain checks (every function)          the checks those functions make (``check_length``, ``check_pressure``,
                                        ``knee._check_range``), traced with their bounds
``MK_A``, ``MK_E``, step control        the constants of :mod:`mkctl.physics.integrate`
======================================  ========================================================================

The integrator itself (:file:`core_template.c`) is the algorithm of :func:`mkctl.physics.integrate.integrate`
written in C; it holds no equation of the model. So is ``mk_pressure_integrate`` (:data:`PRESSURE_INTEGRATOR`, one
actuator pressure), emitted only when a variant needs it.

Nothing here names an effect either: the effects come from the registry (:mod:`mkctl.physics.effects`), and
their terms are traced like every other equation. Branches on the parameter structure (the registry's
*structural* effects: ``model`` 1 or 2, a pressure lag ``tau > 0``, ``slack``) are resolved by generating one
*variant* per structure (:mod:`mkctl.native.variants`): the tracing parameters hold a structural effect's switch
as its off value, or as a positive symbol (a whole-number switch: its "on" value) when on, so the library's own
``if`` statements pick the branch; the other effects' terms are always compiled in. The end stops are one-sided: they trace to sympy ``Piecewise``/``Max`` (C ``?:``, ``fmax``)
with the stop positions as run-time inputs (+-inf for none). A C dispatcher (``mk_variant``) picks the
variant from the run-time parameter vector; a source may hold any set of variants.
"""
from __future__ import annotations

import math
from typing import NamedTuple

import sympy
from sympy.functions.elementary.piecewise import ExprCondPair
from sympy.printing.c import C99CodePrinter

from ..physics import actuator, integrate, isotonic, knee, simulate
from ..physics.params import DEFAULT, PARAMETER_NAMES, rubber_volume
from . import TEMPLATE
from .variants import Variant, all_variants

#: Knee outputs in the order of :data:`mkctl.physics.simulate.KNEE_OUTPUTS` ("stable" last, as 1/0).
KNEE_OUTPUT_NAMES = tuple(simulate.KNEE_OUTPUTS)
MAX_STATES = 4


def SymbolicParams(variant: Variant) -> actuator.SymbolicParams:
    """The tracing parameters of a variant: every value a sympy symbol named after its parameter, the structural
    effects switched on or off as the variant says (their switch parameter a positive symbol, a whole-number
    switch or the off value), every non-structural effect on (its term is compiled in; it vanishes at its off
    value at run time)."""
    return actuator.SymbolicParams(on=variant.traced_effects())


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
    """Every domain check of a generated source, numbered: the C reports a failure by this number. It also keeps
    what the native FMUs generate more C from: each check as traced, and each emitted function's arguments."""

    def __init__(self):
        self.entries: list[str] = []  # what is checked, in words
        self.checks: list = []  # the checks themselves (value, low, high, ..., what), in the same order
        self.emitted: dict = {}  # name -> (arguments, call, bindings, constant, traced), as emit_function got them

    def add(self, check) -> int:
        _, low, _, _, what = check
        self.entries.append(f"{what} must be finite" if low is None else f"{what} is out of range")
        self.checks.append(check)
        return len(self.entries) - 1

    def copy(self) -> "CheckTable":
        """A table numbering on from this one, which can grow without changing it."""
        table = CheckTable()
        table.entries, table.checks, table.emitted = list(self.entries), list(self.checks), dict(self.emitted)
        return table


def _c_number(x) -> str:
    return repr(float(x))


class _Printer(C99CodePrinter):
    """sympy's C printer, with small integer and half-integer powers as products and sqrt (``pow`` is a
    library call; ``x*x*x`` is what the Python equations compute anyway)."""

    def _print_Pow(self, expr):
        base, exponent = expr.args
        if exponent.is_Integer and 2 <= abs(int(exponent)) <= 4:
            b = self.parenthesize(base, 1000)  # parenthesise anything but an atom
            product = "*".join([b] * abs(int(exponent)))
            return f"({product})" if exponent > 0 else f"(1.0/({product}))"
        if exponent.is_Rational and exponent.q == 2 and 1 <= abs(exponent.p) <= 3:
            root = f"sqrt({self._print(base)})"
            power = root if abs(exponent.p) == 1 else f"({self.parenthesize(base, 1000)}*{root})"
            return power if exponent > 0 else f"(1.0/{power})"
        return super()._print_Pow(expr)


_PRINTER = _Printer()  # one for every expression: doprint starts afresh each time, and making one costs


def ccode(expr) -> str:
    return _PRINTER.doprint(expr)


_BASIC_FREE_SYMBOLS = sympy.Basic.free_symbols  # the plain union of the arguments' free symbols


def _split_constants(exprs, constant: set, prefix: str):
    """Replace every largest subexpression of exprs made of constant symbols only by a new symbol.

    Returns (the new expressions, [(symbol, constant subexpression)]): what a record computes once, not at
    every evaluation. Sums and products keep their variable terms and gather their constant ones.
    """
    table: dict = {}
    # Both memos only save time (a traced function repeats its subexpressions many times, and sympy recomputes
    # free_symbols and re-evaluates Max/Min on every rebuild): a second visit of an expression returns what the
    # first did, since name_of gives an expression the same symbol every time.
    constant_memo: dict = {}
    visited: dict = {}

    def name_of(expr):
        if expr not in table:
            table[expr] = sympy.Symbol(f"{prefix}[{len(table)}]", real=True)
        return table[expr]

    symbols_memo: dict = {}

    def symbols_of(expr):  # expr.free_symbols, from the arguments' (sympy walks the whole tree at every call)
        if expr not in symbols_memo:
            if expr.is_Atom or type(expr).free_symbols is not _BASIC_FREE_SYMBOLS:  # bound variables: sympy's
                symbols_memo[expr] = frozenset(expr.free_symbols)
            else:
                symbols_memo[expr] = frozenset().union(*(symbols_of(a) for a in expr.args))
        return symbols_memo[expr]

    def is_constant(expr):
        if expr not in constant_memo:
            symbols = symbols_of(expr)
            constant_memo[expr] = bool(symbols) and symbols <= constant
        return constant_memo[expr]

    def visit(expr):
        if expr.is_Atom:
            return expr
        if expr not in visited:
            visited[expr] = rebuilt(expr)
        return visited[expr]

    def rebuilt(expr):
        if isinstance(expr, ExprCondPair):  # a Piecewise's (value, condition): the condition stays a condition
            cond = expr.cond
            return ExprCondPair(visit(expr.expr), cond.func(*[visit(a) for a in cond.args]) if cond.args else cond)
        if is_constant(expr):
            return name_of(expr)
        if isinstance(expr, (sympy.Add, sympy.Mul)):
            fixed = [a for a in expr.args if is_constant(a) or a.is_Number]
            if all(a.is_Number for a in fixed):
                fixed = []
            rest = [visit(a) for a in expr.args if a not in fixed]
            if fixed:
                rest.append(name_of(expr.func(*fixed)))
            return expr.func(*rest, evaluate=False)
        if isinstance(expr, (sympy.Max, sympy.Min)):  # already evaluated once; evaluating again costs the most
            return expr.func(*[visit(a) for a in expr.args], evaluate=False)
        return expr.func(*[visit(a) for a in expr.args])

    return [visit(e) for e in exprs], [(symbol, expr) for expr, symbol in table.items()]


#: Largest number of per-record constants one function may have (the size of the C arrays holding them).
MAX_CONSTANTS = 96


def emit_function(name: str, arguments: str, call: str, bindings: dict, constant: set, traced: Traced, out: str,
                  checks: CheckTable, extra_outputs: tuple[str, ...] = ()) -> str:
    """C for one traced function: ``<name>_constants(p, stops, k)`` computes the subexpressions that depend on
    the parameters (and stops) only, once per record; ``<name>(p, stops, k, <arguments>)`` binds the inputs,
    computes the CSE'd expressions, tests the domain checks in the order Python makes them, stores out[i]."""
    checks.emitted[name] = (arguments, call, bindings, constant, traced)
    exprs = list(traced.outputs)
    layout = []
    for value, low, high, _, _ in traced.checks:
        layout.append(len(exprs))
        value = sympy.sympify(value)
        if low is not None:
            low, high = sympy.sympify(low), sympy.sympify(high)
            if isinstance(value, sympy.acos) and low.is_zero and high == sympy.Float(math.pi):
                # 0 < acos(u) < pi exactly when -1 < u < 1 (acos is decreasing, acos(1) = 0, acos(-1) = pi
                # as rounded, NaN fails both): the same check without a library call in the inner loop
                value, low, high = value.args[0], sympy.Integer(-1), sympy.Integer(1)
            exprs += [value, low, high]
        else:
            exprs.append(value)
    symbols = set().union(*(e.free_symbols for e in exprs))
    unknown = sorted(str(s) for s in symbols if s.name not in bindings)
    if unknown:
        raise ValueError(f"unbound symbols {unknown} in {name}")
    exprs, constants = _split_constants(exprs, {s for s in symbols if s.name in constant}, "k")
    if len(constants) > MAX_CONSTANTS:
        raise ValueError(f"{name} has {len(constants)} constants, more than MAX_CONSTANTS = {MAX_CONSTANTS}")

    def bind(used, indent="    "):
        return [f"{indent}const double {sym.name} = {bindings[sym.name]};"
                for sym in sorted(used, key=lambda s: s.name) if bindings.get(sym.name, sym.name) != sym.name]

    head = ["static void " + name + "_constants(const double *p, const double *stops, double *k)", "{"]
    values = [expr for _, expr in constants]
    replacements, reduced = sympy.cse(values, symbols=sympy.numbered_symbols("c_"), order="none")
    head += bind(set().union(set(), *(v.free_symbols for v in values)) - {s for s, _ in replacements})
    head += [f"    const double {tmp} = {ccode(expr)};" for tmp, expr in replacements]
    head += [f"    {sym.name} = {ccode(expr)};" for (sym, _), expr in zip(constants, reduced)]
    head += ["    (void)p; (void)stops; (void)k;", "}", ""]

    lines = [f"static int {name}(const double *p, const double *stops, const double *k, {arguments})", "{"]
    replacements, reduced = sympy.cse(exprs, symbols=sympy.numbered_symbols("t_"), order="none")
    used = set().union(set(), *(e.free_symbols for e in exprs)) - set(s for s, _ in constants)
    lines += bind(used)
    lines += [f"    const double {tmp} = {ccode(expr)};" for tmp, expr in replacements]
    for check, position in zip(traced.checks, layout):
        index = checks.add(check)
        value = ccode(reduced[position])
        if check[1] is None:
            lines.append(f"    if (!isfinite({value})) return mk_fail(fault, {index}, {value}, NAN, NAN);")
        else:
            low, high = ccode(reduced[position + 1]), ccode(reduced[position + 2])
            lines.append(f"    if (!(({low}) < ({value}) && ({value}) < ({high}))) "
                         f"return mk_fail(fault, {index}, {value}, {low}, {high});")
    lines += [f"    {out}[{i}] = {ccode(reduced[i])};" for i in range(len(traced.outputs))]
    lines += list(extra_outputs)
    lines += ["    (void)p; (void)stops; (void)k;", "    return 0;", "}", ""]
    # the one-call form: constants on the stack
    lines += [f"static int {name}_once(const double *p, const double *stops, {arguments})", "{",
              "    double k[MAX_CONSTANTS_PLACEHOLDER];", f"    {name}_constants(p, stops, k);",
              f"    return {name}(p, stops, k, {call});", "}", ""]
    return "\n".join(head + lines).replace("MAX_CONSTANTS_PLACEHOLDER", "MK_MAX_CONSTANTS")


def _parameter_bindings() -> dict:
    return {name: f"p[MK_P_{name}]" for name in PARAMETER_NAMES}


#: The generated functions: kind -> (C arguments after p, stops, k; the call passing them on).
KINDS = {
    "knee_rhs": ("const double *y, double pe_cmd, double pf_cmd, double *out, mk_fault *fault",
                 "y, pe_cmd, pf_cmd, out, fault"),
    "knee_outputs": ("double X, double V, double Pe, double Pf, double *out, mk_fault *fault",
                     "X, V, Pe, Pf, out, fault"),
    "actuator_tension": ("double L, double P, double Ldot, double *out, mk_fault *fault", "L, P, Ldot, out, fault"),
    "actuator_lagged_pressure": ("double P, double P_cmd, double dt, double *out, mk_fault *fault",
                                 "P, P_cmd, dt, out, fault"),
    "actuator_static": ("double L, double P, double *out, mk_fault *fault", "L, P, out, fault"),
}


def _static_tension_and_slope(L, P, params):
    """What the damped isotonic test needs: (actuator.static_tension, actuator.static_tension_dL, the play band's
    half-width actuator.play_half_width, the damping actuator.viscous_coefficient)."""
    return (actuator.static_tension(L, P, params), actuator.static_tension_dL(L, P, params),
            actuator.play_half_width(P, params), actuator.viscous_coefficient(params))


#: The C arguments of ``actuator_pressure_rate_<variant>`` after p, stops, k: dP/dt [Pa/s] of one actuator.
PRESSURE_RATE_ARGUMENTS = "double P, double P_cmd, double *out, mk_fault *fault"


def integrates_pressure(variant: Variant) -> bool:
    """Whether the variant has pressure dynamics that no effect's exact step covers (a user effect with only a
    ``pressure_rate``): its pressure step is then the traced rate integrated in C (``mk_pressure_integrate``)."""
    variant = actuator_variant(variant)
    return variant.lag and actuator.exact_pressure_step(SymbolicParams(variant)) is None


def actuator_variant(variant: Variant) -> Variant:
    """The structure one actuator's functions are traced with: the variant's, without the air (one muscle's air
    is no state of these functions, which take the pressure as given; with the air the knee's right-hand side
    and outputs are what carries it)."""
    return variant._replace(air=False, opening=False)


def _integrated_pressure_step(v: str) -> str:
    """``actuator_lagged_pressure_<v>`` (its three forms) for a variant without an exact step: its rate
    ``actuator_pressure_rate_<v>`` integrated over dt by ``mk_pressure_integrate`` (:data:`PRESSURE_INTEGRATOR`),
    with the rate's per-record constants."""
    arguments, call = KINDS["actuator_lagged_pressure"]
    name, rate = f"actuator_lagged_pressure_{v}", f"actuator_pressure_rate_{v}"
    return "\n".join([
        f"static void {name}_constants(const double *p, const double *stops, double *k)", "{",
        f"    {rate}_constants(p, stops, k);", "}", "",
        "/* the pressure after dt with the command held (actuator.pressure_after): no exact step covers this",
        " * variant's pressure dynamics, so its rate is integrated as the Python path integrates it */",
        f"static int {name}(const double *p, const double *stops, const double *k, {arguments})", "{",
        f"    return mk_pressure_integrate({rate}, p, stops, k, P, P_cmd, dt, out, fault);", "}", "",
        f"static int {name}_once(const double *p, const double *stops, {arguments})", "{",
        "    double k[MK_MAX_CONSTANTS];", f"    {name}_constants(p, stops, k);",
        f"    return {name}(p, stops, k, {call});", "}", ""])


#: Declared before the generated functions when a variant integrates its pressure (defined after the tableau).
PRESSURE_INTEGRATOR_DECLARATION = """\
/* dP/dt [Pa/s] of one actuator: a generated actuator_pressure_rate_<variant> */
typedef int (*mk_pressure_rate)(const double *p, const double *stops, const double *k, double P, double P_cmd,
                                double *out, mk_fault *fault);
static int mk_pressure_integrate(mk_pressure_rate rate, const double *p, const double *stops, const double *k,
                                 double P, double P_cmd, double dt, double *out, mk_fault *fault);
"""

#: The pressure step of a variant without an exact one: the algorithm of mkctl.physics.integrate.integrate for one
#: state, called as actuator.pressure_after calls it (first step dt, its tolerances, no dense output).
PRESSURE_INTEGRATOR = """\
#define MK_PRESSURE_ATOL (@ATOL@)
#define MK_PRESSURE_RTOL (@RTOL@)

/* The pressure [Pa] after dt [s] with the command P_cmd held, from P: dP/dt = rate(P, P_cmd) integrated over dt
 * as actuator.pressure_after integrates it (mkctl.physics.integrate.integrate, line by line, for one state: the
 * first step dt, absolute tolerance MK_PRESSURE_ATOL, relative MK_PRESSURE_RTOL); P itself unless dt > 0. */
static int mk_pressure_integrate(mk_pressure_rate rate, const double *p, const double *stops, const double *k,
                                 double P, double P_cmd, double dt, double *out, mk_fault *fault)
{
    double stages[7], y = P, yi = P, t = 0.0, h = dt;
    long steps = 0;
    int s, j, rc, domain_failed = 0;
    if (!(dt > 0)) {
        out[0] = P;
        return 0;
    }
    rc = rate(p, stops, k, y, P_cmd, stages, fault);
    if (rc)
        return rc;
    while (t < dt) {
        const int last = h >= dt - t;
        const double h_try = last ? dt - t : h;
        double err;
        rc = 0;
        for (s = 1; s < 7 && !rc; s++) {
            double acc = 0.0;
            for (j = 0; j < s; j++)
                acc += MK_A[s][j] * stages[j];
            yi = y + h_try * acc;
            rc = rate(p, stops, k, yi, P_cmd, stages + s, fault);
        }
        if (rc == MK_FAULT_DOMAIN) {  /* a trial stage outside the domain: reject the step, as too large */
            domain_failed = 1;
            err = INFINITY;
        } else if (rc) {
            return rc;
        } else {
            double e = 0.0, scale;
            for (j = 0; j < 7; j++)
                e += MK_E[j] * stages[j];
            e *= h_try;
            scale = MK_PRESSURE_ATOL + MK_PRESSURE_RTOL * MK_PY_MAX(fabs(y), fabs(yi));
            err = sqrt((e / scale) * (e / scale));
        }
        if (err <= 1.0) {  /* yi: the 5th-order solution, where the 7th stage was evaluated */
            const double factor = err == 0 ? MK_MAX_GROWTH
                                           : MK_PY_MIN(MK_MAX_GROWTH, MK_SAFETY * pow(err, MK_ACCEPT_EXPONENT));
            t = last ? dt : t + h_try;
            y = yi;
            stages[0] = stages[6];
            steps += 1;
            h = last ? MK_PY_MAX(MK_PY_MAX(h, dt), h_try * factor) : h_try * factor;
        } else {
            h = h_try * MK_PY_MAX(MK_MAX_SHRINK, MK_SAFETY * pow(err, MK_REJECT_EXPONENT));
            if (h < MK_COLLAPSE * MK_PY_MAX(MK_PY_MAX(1.0, dt), t))
                return domain_failed ? MK_FAULT_DOMAIN : mk_fault_code(fault, MK_FAULT_COLLAPSE);
        }
        if (steps > MK_MAX_STEPS)
            return mk_fault_code(fault, MK_FAULT_STEPS);
    }
    out[0] = y;
    return 0;
}
"""


def variant_functions(variant: Variant, checks: CheckTable) -> str:
    """The C of every variant-dependent function for one variant."""
    sp, sp_actuator = SymbolicParams(variant), SymbolicParams(actuator_variant(variant))
    X, V, Pe, Pf, pe_cmd, pf_cmd = (_real(n) for n in ("X", "V", "Pe", "Pf", "pe_cmd", "pf_cmd"))
    X_low, X_high = _real("X_low"), _real("X_high")
    P_, L_, Ldot_, P_cmd_, dt_ = (_real(n) for n in ("P", "L", "Ldot", "P_cmd", "dt"))
    v = variant.name
    parameters = _parameter_bindings()
    constant = set(parameters)
    state = [X, V, Pe, Pf][: variant.nstate]
    bindings = {**parameters, "X": "y[0]", "V": "y[1]", "pe_cmd": "pe_cmd", "pf_cmd": "pf_cmd",
                "X_low": "(stops ? stops[0] : -INFINITY)", "X_high": "(stops ? stops[1] : INFINITY)"}
    if variant.lag:
        bindings.update(Pe="y[2]", Pf="y[3]")

    def emit(kind, bindings, constant, traced, extra=()):
        arguments, call = KINDS[kind]
        return emit_function(f"{kind}_{v}", arguments, call, bindings, constant, traced, "out", checks, extra)

    # with valve openings as inputs (variant.opening) pe_cmd, pf_cmd carry the openings ue, uf
    stops = (X_low, X_high)
    rhs = (trace(knee.knee_derivatives, state, pe_cmd, pf_cmd, sp, stops, opening=True)
           if variant.opening else trace(knee.knee_derivatives, state, pe_cmd, pf_cmd, sp, stops))
    parts = [emit("knee_rhs", bindings, constant | {"X_low", "X_high"}, rhs)]
    traced = trace(simulate.knee_outputs, X, V, Pe, Pf, sp)
    a1, a2 = KNEE_OUTPUT_NAMES.index("a1"), KNEE_OUTPUT_NAMES.index("a2")
    stable = KNEE_OUTPUT_NAMES.index("stable")
    if stable != len(traced.outputs):
        raise ValueError("'stable' must be the last knee output, after those of simulate.knee_outputs")
    parts.append(emit("knee_outputs", {**parameters, "X": "X", "V": "V", "Pe": "Pe", "Pf": "Pf"}, constant, traced,
                      (f"    out[{stable}] = (out[{a1}] < 0 && out[{a2}] < 0) ? 1.0 : 0.0;",)))
    parts.append(emit("actuator_tension", {**parameters, "L": "L", "P": "P", "Ldot": "Ldot"}, constant,
                      trace(actuator.tension, L_, P_, Ldot_, sp_actuator)))
    if integrates_pressure(variant):  # no exact step: the traced rate, integrated in C as pressure_after does
        parts.append(emit_function(f"actuator_pressure_rate_{v}", PRESSURE_RATE_ARGUMENTS, "P, P_cmd, out, fault",
                                   {**parameters, "P": "P", "P_cmd": "P_cmd"}, constant,
                                   trace(actuator.pressure_derivative, P_, P_cmd_, sp_actuator), "out", checks))
        parts.append(_integrated_pressure_step(v))
    else:
        parts.append(emit("actuator_lagged_pressure", {**parameters, "P": "P", "P_cmd": "P_cmd", "dt": "dt"},
                          constant, trace(actuator.pressure_after, P_, P_cmd_, dt_, sp_actuator)))
    parts.append(emit("actuator_static", {**parameters, "L": "L", "P": "P"}, constant,
                      trace(_static_tension_and_slope, L_, P_, sp_actuator)))
    return "\n".join(parts)


def common_functions(checks: CheckTable) -> str:
    """The C of the functions that do not depend on the variant: the commands' checks, the stop positions."""
    sp = SymbolicParams(Variant.of(DEFAULT))  # the paper's structure: these checks and stops depend on no effect
    parameters = _parameter_bindings()
    pe_cmd, pf_cmd = _real("pe_cmd"), _real("pf_cmd")

    def step_checks(pe, pf):  # what KneeSimulator.step checks before it integrates
        actuator.check_pressure(pe)
        actuator.check_pressure(pf)
        return []

    def stops(params):  # knee.stop_positions, with the stop angles as sympy numbers
        return [knee.X_from_alpha(sympy.Float(knee.ALPHA_STOP_LOW), params),
                knee.X_from_alpha(sympy.Float(knee.ALPHA_STOP_HIGH), params)]

    every = actuator.SymbolicParams()  # every effect on: the delay of whichever are on at run time (0 when off)
    parts = [emit_function("command_delay", "double *out, mk_fault *fault", "out, fault", parameters,
                           set(parameters), trace(lambda params: [actuator.command_delay(params)], every), "out",
                           checks),
             "/* how late the actuators see their commands [s] (actuator.command_delay: a dead time) */",
             "int mk_command_delay(const double *p, double *out, mk_fault *fault)",
             "{", "    return command_delay_once(p, NULL, out, fault);", "}", "",
             emit_function("step_checks", "double pe_cmd, double pf_cmd, mk_fault *fault", "pe_cmd, pf_cmd, fault",
                           {**parameters, "pe_cmd": "pe_cmd", "pf_cmd": "pf_cmd"}, set(parameters),
                           trace(step_checks, pe_cmd, pf_cmd), "out", checks),
             emit_function("stop_positions", "double *out, mk_fault *fault", "out, fault", parameters,
                           set(parameters), trace(stops, sp), "out", checks),
             "/* the commands' checks of KneeSimulator.step: finite pressures */",
             "int mk_step_checks(const double *p, double pe_cmd, double pf_cmd, mk_fault *fault)",
             "{", "    return step_checks_once(p, NULL, pe_cmd, pf_cmd, fault);", "}", "",
             "/* hip heights [m] of the lower and upper end stops (knee.stop_positions) */",
             "int mk_stop_positions(const double *p, double *out, mk_fault *fault)",
             "{", "    return stop_positions_once(p, NULL, out, fault);", "}", ""]
    return "\n".join(parts)


def _dispatch(variants: tuple[Variant, ...]) -> str:
    lines = [f"#define MK_NVARIANTS {len(variants)}",
             "static const int mk_variant_nstates[MK_NVARIANTS] = {"
             + ", ".join(str(v.nstate) for v in variants) + "};",
             "",
             "/* index of the compiled variant for parameter vector p, or -1 */",
             "int mk_variant(const double *p)", "{"]
    # the air's variants first: the others' tests name no air parameter (variants.Variant.c_condition)
    for i, v in sorted(enumerate(variants), key=lambda pair: not pair[1].air):
        lines.append(f"    if ({v.c_condition()}) return {i};")
    lines += ["    return -1;", "}", "",
              "static int mk_variant_nstate(int variant)", "{",
              "    return variant < 0 ? 2 : mk_variant_nstates[variant];", "}", "",
              "/* number of knee states for parameter vector p: 4 with a pressure lag, else 2 */",
              "int mk_knee_nstate(const double *p)", "{", "    return mk_variant_nstate(mk_variant(p));", "}", "",
              "/* 1 when the actuator pressure is a state for parameter vector p (an effect with pressure dynamics) */",
              "int mk_pressure_is_state(const double *p)", "{", "    return mk_variant_nstate(mk_variant(p)) == 4;",
              "}", ""]

    for kind, (arguments, call) in KINDS.items():
        forms = [("_constants", "static void", "const double *p, const double *stops, double *k", "p, stops, k",
                  "    return;"),
                 ("", "static int", f"const double *p, const double *stops, const double *k, {arguments}",
                  f"p, stops, k, {call}", "    return mk_fault_code(fault, MK_FAULT_VARIANT);"),
                 ("_once", "static int", f"const double *p, const double *stops, {arguments}", f"p, stops, {call}",
                  "    return mk_fault_code(fault, MK_FAULT_VARIANT);")]
        for suffix, returns, signature, passed, otherwise in forms:
            lines += [f"{returns} mk_{kind}{suffix}_variant(int variant, {signature})", "{", "    switch (variant) {"]
            for i, v in enumerate(variants):
                lines.append(f"    case {i}: " + (f"{kind}_{v.name}{suffix}({passed}); return;" if returns ==
                                                   "static void" else f"return {kind}_{v.name}{suffix}({passed});"))
            lines += ["    }", otherwise, "}", ""]
    lines += [
        "/* right-hand side of Eq. 17 (knee.knee_derivatives): dy = f(y) for the variant of p; stops NULL: none */",
        "int mk_knee_rhs(const double *p, const double *stops, const double *y, double pe_cmd, double pf_cmd, "
        "double *dy, mk_fault *fault)",
        "{", "    return mk_knee_rhs_once_variant(mk_variant(p), p, stops, y, pe_cmd, pf_cmd, dy, fault);", "}", "",
        "/* actuator tension f(L, P, Ldot) [N] (actuator.tension) */",
        "int mk_actuator_tension(const double *p, double L, double P, double Ldot, double *f, mk_fault *fault)",
        "{", "    return mk_actuator_tension_once_variant(mk_variant(p), p, NULL, L, P, Ldot, f, fault);", "}", "",
        "/* pressure after dt with the command held (actuator.lagged_pressure, exact) */",
        "int mk_actuator_lagged_pressure(const double *p, double P, double P_cmd, double dt, double *out, "
        "mk_fault *fault)",
        "{", "    return mk_actuator_lagged_pressure_once_variant(mk_variant(p), p, NULL, P, P_cmd, dt, out, fault);",
        "}", ""]
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
             "static const double MK_E[7] = {" + ", ".join(_c_number(e) for e in integrate._E) + "};",
             "/* continuous extension (dense output): b_i(theta) = sum_j MK_DENSE[i][j] theta^(j+1) */",
             "static const double MK_DENSE[7][4] = {",
             ",\n".join("    {" + ", ".join(_c_number(d) for d in row) + "}" for row in integrate.DENSE), "};"]
    lines += [f"#define {name} ({_c_number(value)})" for name, value in constants.items()]
    lines.append(f"#define MK_MAX_STEPS {int(integrate.MAX_STEPS)}L")
    lines += ["/* the damped isotonic test (mkctl/physics/isotonic.py): the length bracket as fractions of b, and the",
              " * most Newton/bisection steps per sample */",
              f"#define MK_ISO_SHORTEST ({_c_number(isotonic.SHORTEST)})",
              f"#define MK_ISO_LONGEST ({_c_number(isotonic.LONGEST)})",
              f"#define MK_ISO_ITERATIONS {int(isotonic.MAX_ITERATIONS)}"]
    return "\n".join(lines)


def _parameter_macros() -> str:
    lines = [f"#define MK_NPARAM {len(PARAMETER_NAMES)}", f"#define MK_MAX_STATES {MAX_STATES}",
             f"#define MK_MAX_CONSTANTS {MAX_CONSTANTS}",
             f"#define MK_KNEE_NOUT {len(KNEE_OUTPUT_NAMES)}",
             "/* knee outputs: " + ", ".join(f"{i} {name}" for i, name in enumerate(KNEE_OUTPUT_NAMES)) + " */"]
    lines += [f"#define MK_P_{name} {i}" for i, name in enumerate(PARAMETER_NAMES)]
    return "\n".join(lines)


def generate_source(variants=None) -> tuple[str, list[str]]:
    """The C source of the core for the given variants, and its table of domain checks (in words)."""
    source, checks = generate(variants)
    return source, checks.entries


def generate(variants=None) -> tuple[str, CheckTable]:
    """The C source of the core for the given variants, and its :class:`CheckTable` (the checks in words and as
    traced, and every emitted function)."""
    variants = all_variants() if variants is None else tuple(variants)
    checks = CheckTable()
    generated = [common_functions(checks)] + [variant_functions(v, checks) for v in variants]
    integrator = ""
    if any(integrates_pressure(v) for v in variants):  # only then: the other sources stay as they were
        generated.insert(0, PRESSURE_INTEGRATOR_DECLARATION)
        integrator = "\n\n" + PRESSURE_INTEGRATOR.replace("@ATOL@", _c_number(actuator.PRESSURE_STEP_ATOL)).replace(
            "@RTOL@", _c_number(actuator.PRESSURE_STEP_RTOL))
    table = ["/* domain checks, by the number a fault reports: */",
             "const char *const mk_check_what[] = {"]
    table += [f"    \"{text}\"," for text in checks.entries]
    table += ["};", f"const int mk_check_count = {len(checks.entries)};"]
    source = TEMPLATE.read_text()
    for key, text in {"@PARAMETER_MACROS@": _parameter_macros(),
                      "@GENERATED@": "\n".join(table) + "\n\n" + "\n".join(generated),
                      "@DISPATCH@": _dispatch(variants), "@TABLEAU@": _tableau() + integrator,
                      "@VARIANT_NAMES@": ", ".join(v.name for v in variants)}.items():
        source = source.replace(key, text)
    return source, checks

