"""Native FMUs of any mechanism (model-spec 3b, 7d): ``McKibben<Name>.fmu``, FMI 2.0 and 3.0.

    python build_fmu.py --mechanism NAME|FILE.py   # dist/native/, dist/fmi3/McKibben<Name>.fmu

The knee keeps its own FMU (:mod:`mkctl.native.fmu`, McKibbenKnee). Any other mechanism
(:class:`mkctl.physics.mechanism.Mechanism`: a built-in or a user's file) gets an FMU with the same
wrapper (``fmu_c/fmi2_wrapper.c``, ``fmi3_wrapper.c``, ``mk_run.c``: both interfaces, Co-Simulation
and Model Exchange, a dead time, the parameter checks of Params), the same compiled core
(``mkctl_core.c``: its command delay), and one more compilation unit generated here,
``mechanism_core.c``:

=============================  ==================================================================
C function                     traced Python function
=============================  ==================================================================
``mech_rhs_<variant>``         :func:`mkctl.physics.mechanism.mechanism_derivatives` (virtual work,
                               every effect of the variant, end stops)
``mech_outputs_<variant>``     :func:`mkctl.physics.mechanism.mechanism_force` (lengths, tensions)
                               and :func:`~mkctl.physics.mechanism.coefficients_at` (a1, a2)
``mech_switches_<variant>``    the switching functions of ``mech_rhs`` (Model Exchange's event
                               indicators, :func:`mkctl.native.fmu.switching_functions`)
``mech_air_flows_<variant>``   built with the air: each muscle's net air mass flow,
                               :func:`mkctl.physics.actuator.air_mass_flow` at the regulator's
                               opening (:func:`~mkctl.physics.actuator.valve_opening`)
``mech_stop_positions``        the mechanism's ``stops(p)``
``mech_step_checks``           :func:`mkctl.physics.actuator.check_pressure` of the commands
integrator                     the core's Dormand-Prince 5(4) (``core_template.c``, the text of
                               ``mk_integrate`` and ``mk_step_variant`` with the mechanism's
                               right-hand side in place of the knee's)
=============================  ==================================================================

Nothing of a user's file is pasted into C or XML: its parameters become the symbols ``mp_<i>``
(``p[MK_NPARAM + i]`` at run time), its names reach C only through
:func:`mkctl.native.fmu.c_identifier` and the octal-escaped string literals of
:func:`mkctl.native.fmu._c_string`, and the XML through ElementTree.

The interface (:func:`mechanism_interface`): inputs ``p_cmd_<muscle>`` [Pa]; parameters: the
actuator FMU's (model-spec sections 2 and 4: Table I, the effects), the Params fields the
mechanism's functions read (``m``, ``g``), its own parameters, ``q0`` (the start coordinate; its
start value is the stable equilibrium at the start commands) and ``P_rated``; outputs ``q``,
``qdot``, each muscle's ``L_<muscle>``, ``f_<muscle>``, ``P_<muscle>``, ``a1``, ``a2`` and
``stable`` (a1 < 0 and a2 < 0 at the present state). Model Exchange states: ``q``, ``qdot`` and
one pressure state per muscle, ``P_lag_<muscle>`` (inert without a lag or the air).

Built with the air (model-spec 4d, 7d; ``air``, by default when the build's parameters switch it
on): the air's variants are compiled in as the knee's (:mod:`mkctl.native.variants`: the right-hand
side traced with each pressure from :func:`mkctl.physics.actuator.air_pressure_derivative`, coupled
to the motion through dV/dt), section 4d's parameters and the switch ``valve_flow`` are offered
(the inputs ``p_cmd_<muscle>`` are then the set-points of pressure regulators), and the outputs add
``q_<muscle>``, each muscle's net air mass flow in [kg/s] (the knee's ``qe``, ``qf``; the
mechanism's outputs name the muscle after the kind, as ``L_<muscle>``). The air's temperature as a
state (``air_heat``) is refused at the build in one line, as the knee refuses it.
"""
from __future__ import annotations

import dataclasses
import math
import re
from pathlib import Path

from ..errors import DomainError, ParameterError
from ..physics import actuator
from ..physics import mechanism as mech
from ..physics.params import PARAMETER_NAMES, RATED_PRESSURE, TABLE_II, UNITS, Params
from . import TEMPLATE
from . import fmu as fmi2
from .fmu import Interface, MEState, NativeBuildError, Variable

#: The model part and the Model Exchange part of a mechanism FMU (fmu_c/).
MODEL_SOURCES = ("mechanism_fmu.c", "mechanism_me.c")
#: The generated compilation unit.
CORE_FILE = "mechanism_core.c"
#: Its header (fmu_c/), what the model parts use of it.
HEADER = "mechanism_core.h"
#: The start commands of a mechanism FMU [Pa], each muscle's (q0 starts at their equilibrium).
START_COMMAND = 300e3
#: Arguments of the generated right-hand side, outputs and switching functions (after p, stops, k).
RHS_ARGUMENTS = ("const double *y, double c1, double c2, double *out, mk_fault *fault",
                 "y, c1, c2, out, fault")
OUTPUT_ARGUMENTS = ("double q, double qdot, double P1, double P2, double *out, mk_fault *fault",
                    "q, qdot, P1, P2, out, fault")
#: Arguments of the generated air mass flows (after p, stops, k): the pressures and the commands.
FLOW_ARGUMENTS = ("double P1, double P2, double c1, double c2, double *out, mk_fault *fault",
                  "P1, P2, c1, c2, out, fault")


def model_name(mechanism: mech.Mechanism) -> str:
    """``McKibben<Name>``: the CamelCase of the mechanism's name (pulley_joint: PulleyJoint)."""
    name = "McKibben" + "".join(part[:1].upper() + part[1:] for part in mechanism.name.split("_"))
    if not re.fullmatch(r"[A-Za-z][A-Za-z0-9]*", name):
        raise NativeBuildError(f"mechanism name {mechanism.name!r} gives no FMU model name "
                               "(letters, digits and underscores only)")
    return name


def _muscle_names(mechanism) -> dict:
    """Each muscle's variable names, checked as C identifiers."""
    names = {}
    for muscle in mechanism.muscles:
        kinds = ("p_cmd", "L", "f", "P", "P_lag", "q")
        names[muscle] = {kind: f"{kind}_{muscle}" for kind in kinds}
        for text in names[muscle].values():
            fmi2.c_identifier(text)
    return names


def _mechanism_params_used(mechanism) -> list[str]:
    """Params fields the mechanism's own functions read (``m``, ``g``), in Params' order."""
    used = set(mechanism.traced.names)
    return [name for name in PARAMETER_NAMES if name in used]


def mechanism_interface(mechanism: mech.Mechanism, params: Params | None = None,
                        alone: bool = False, air: bool | None = None) -> Interface:
    """What a mechanism FMU shows a host (see the module docstring), start values from params (the
    muscle's; default: the current model's defaults) and the mechanism's own defaults.

    alone: the mechanism alone (model-spec 7d, the SSP system of :mod:`mkctl.native.ssp`), model
    ``McKibben<Name>Mechanism``: inputs each muscle's tension ``f_<muscle>`` [N]; outputs ``q``,
    ``qdot``, each muscle's ``L_<muscle>`` and ``Ldot_<muscle>``; parameters the muscle's Table I
    (its domain 0 < L < b), the Params fields the mechanism reads, its own and ``q0``; states q,
    qdot. The knee is built this way only (its pressure-driven FMU is McKibbenKnee); its start
    values are the knee FMU's (X0 at alpha = 60 deg, the tensions of the commands that hold it).

    air: built with the air (model-spec 4d, 7d; None: when params switch it on,
    :func:`mkctl.native.fmu.wants_air`): section 4d's parameters and the switch ``valve_flow``
    offered, the air's variants compiled in (the pressures states of the muscles' mass balance),
    and the outputs ``q_<muscle>``, each muscle's net air mass flow in [kg/s]. Without it an effect
    that moves the air is not offered. The mechanism alone has no air.

    Raises :class:`NativeBuildError` for a name that is no C identifier or clashes with another
    variable, when the start commands have no stable equilibrium, and for params that switch on
    an effect the FMU does not carry (the air without ``air``; the air's temperature as a state).
    """
    from ..fmi.interface import (_MUSCLE, ACTUATOR, P_RATED_DESCRIPTION, _effect_reals,
                                 check_carried, fmu_integer_parameters)
    from ..fmi.units import fmi_unit
    params = Params() if params is None else params
    air = False if alone else (fmi2.wants_air(params) if air is None else bool(air))
    if not alone:
        try:
            check_carried(params, air)
        except ParameterError as error:
            raise NativeBuildError(f"mechanism {mechanism.name}: {error}") from None
    if mechanism.name == "knee" and not alone:
        raise NativeBuildError("the knee has its own FMU (McKibbenKnee): build it without "
                               "--mechanism")
    name = model_name(mechanism) + ("Mechanism" if alone else "")
    muscles = _muscle_names(mechanism)
    unit, rate = mechanism.unit, f"{mechanism.unit}/s"
    try:
        p = mechanism.bind(params)
        if mechanism.name == "knee":
            from ..physics.simulate import default_commands, default_hip_height
            commands, q0 = tuple(default_commands(params)), default_hip_height(params)
        else:
            commands = tuple(START_COMMAND for _ in mechanism.muscles)
            q0 = mech.equilibrium(mechanism, commands, p)
        tensions = mech.mechanism_force(mechanism, q0, 0.0, commands, p).f
    except (DomainError, ParameterError) as error:
        raise NativeBuildError(f"mechanism {mechanism.name}: no start coordinate q0 at the start "
                               f"commands ({START_COMMAND:g} Pa): {error}") from None
    real = [*_MUSCLE, *(() if alone else _effect_reals(air))]
    real += [n for n in _mechanism_params_used(mechanism) if n not in real]
    own = {q.name: q for q in mechanism.parameters}
    rows = []  # (name, type, causality, variability, description, unit, start)

    def real_row(name, causality, description, unit_, start=None):
        variability = "fixed" if causality == "parameter" else "continuous"
        rows.append((name, "Real", causality, variability, description, unit_, start))

    for muscle, command, tension in zip(mechanism.muscles, commands, tensions):
        if alone:
            real_row(f"f_{muscle}", "input", f"tension of {muscle} (positive pulls)", "N",
                     float(tension))
        else:
            real_row(muscles[muscle]["p_cmd"], "input", f"commanded gauge pressure of {muscle}",
                     "Pa", float(command))
    for n in real:
        text = TABLE_II[n].description if n in TABLE_II else ACTUATOR.description_of(n)
        real_row(n, "parameter", text, UNITS[n], float(getattr(params, n)))
    for n in () if alone else fmu_integer_parameters(air):
        rows.append((n, "Integer", "parameter", "fixed", ACTUATOR.description_of(n), None,
                     int(getattr(params, n))))
    for q in mechanism.parameters:
        real_row(q.name, "parameter", q.description or f"parameter of {mechanism.name}", q.unit,
                 float(p.__getattr__(q.name)))
    real_row("q0", "parameter", f"initial {mechanism.coordinate}, at rest; its start value is the "
             "stable equilibrium at the start commands", unit, float(q0))
    if not alone:
        real_row("P_rated", "parameter", P_RATED_DESCRIPTION, "Pa", RATED_PRESSURE)
    real_row("q", "output", f"the coordinate {mechanism.coordinate}", unit)
    real_row("qdot", "output", f"the rate of {mechanism.coordinate}", rate)
    kinds = ((("L", "length", "m"), ("Ldot", "lengthening rate", "m/s")) if alone else
             (("L", "length", "m"), ("f", "tension (positive pulls)", "N"),
              ("P", "gauge pressure", "Pa")))
    for kind, text, u in kinds:
        for muscle in mechanism.muscles:
            real_row(f"{kind}_{muscle}", "output", f"{muscle} {text}", u)
    if not alone:
        real_row("a1", "output", "Eq. 18 coefficient a1 = (dF/dqdot)/M at the present state (end "
                 "stops excluded)", "1/s")
        real_row("a2", "output", "Eq. 18 coefficient a2 = (dF/dq)/M at the present state (end "
                 "stops excluded)", "1/s^2")
        rows.append(("stable", "Boolean", "output", "discrete", "Routh-Hurwitz verdict at the "
                     "present state: a1 < 0 and a2 < 0; no unit", None, None))
    for muscle in mechanism.muscles if air else ():
        real_row(muscles[muscle]["q"], "output", f"{muscle}'s net air mass flow in (valve and "
                 "leak; negative: out), 0 without the air", "kg/s")
    seen = set()
    for row in rows:
        if row[0] in seen or row[0] in ("time",) or row[0].startswith("der("):
            raise NativeBuildError(f"mechanism {mechanism.name}: the variable name {row[0]!r} is "
                                   "taken twice (a parameter or muscle named like another "
                                   "variable)")
        seen.add(row[0])
        fmi2.c_identifier(row[0])
    variables = tuple(Variable(n, vr, t, c, v, d, None if u is None else fmi_unit(u), s)
                      for vr, (n, t, c, v, d, u, s) in enumerate(rows))
    if not alone:  # the pythonfmu FMU's variables too: one definition (mkctl.fmi.interface)
        from ..fmi.interface import mechanism_model
        try:
            listed = mechanism_model(mechanism, air).variables(params)
        except ParameterError as error:
            raise NativeBuildError(str(error)) from None
        variables = tuple(Variable(v.name, v.vr, v.type, v.causality, v.variability, v.description,
                                   None if v.unit is None else fmi_unit(v.unit), v.start)
                          for v in listed)
        for variable in variables:
            fmi2.c_identifier(variable.name)
    states = (MEState("q", fmi_unit(unit), fmi_unit(rate), 1.0),
              MEState("qdot", fmi_unit(rate), fmi_unit(f"{unit}/s^2"), 1.0),
              *(() if alone else
                (MEState(muscles[m]["P_lag"], "Pa", "Pa/s", 1e6, _state_text(m, air))
                 for m in mechanism.muscles)))
    outputs = [v.name for v in variables if v.causality == "output"]
    inputs = [v.name for v in variables if v.causality == "input"]
    source, nz = generate_core(mechanism, {v.name: v.vr for v in variables}, alone, inputs, outputs,
                               air)
    driven = ("alone, its muscles' tensions as inputs (for a system of FMUs)" if alone
              else "driven by McKibben muscles")
    description = (f"{mechanism.description or mechanism.name}: a mechanism of one coordinate "
                   f"({mechanism.coordinate} [{unit}]) {driven} (model-spec sections 3b, 7d)"
                   + ("; the air in the muscles (model-spec 4d) when valve_flow = 1"
                      if air else ""))
    experiment = {"startTime": "0.0", "stopTime": "2.0", "stepSize": "0.001"}
    pressures = {} if alone else {muscles[m]["P"]: m for m in mechanism.muscles}
    header = (fmi2.C_DIR / HEADER).read_text()
    return Interface(name, description, "mkctl", experiment, variables,
                     "outputs that depend on the pressures are undefined", pressures,
                     me_states=states, event_indicators=nz, model_sources=MODEL_SOURCES,
                     generated_sources=((CORE_FILE, source), (HEADER, header)),
                     core_parameters=tuple(own), air=air)


def _state_text(muscle: str, air: bool) -> str:
    """The description of a muscle's pressure state (Model Exchange)."""
    if air:
        return (f"pressure state of {muscle} (Model Exchange): equal to P_{muscle}, from the air's "
                "mass balance with valve_flow or leak on, a lag's state with a lag; inert "
                "(derivative 0) without either")
    return (f"pressure-lag state of {muscle} (Model Exchange): equal to P_{muscle} with a lag; "
            "inert (derivative 0) without one")


# --- the generated unit -------------------------------------------------------------------------

def _real(name):
    import sympy
    return sympy.Symbol(name, real=True)


def _template_part(start: str, end: str) -> str:
    text = TEMPLATE.read_text()
    i, j = text.find(start), text.find(end)
    if i < 0 or j < i:
        raise NativeBuildError(f"core_template.c has no part from {start!r} to {end!r}")
    return text[i:j]


def _substituted(text: str, changes) -> str:
    for old, new, count in changes:
        if text.count(old) != count:
            raise NativeBuildError(f"core_template.c: {old!r} appears {text.count(old)} times, "
                                   f"not {count}")
        text = text.replace(old, new)
    return text


def _value_message(error_text: str, sentinel: float) -> tuple[str, str]:
    """(printf format, kind) of a library message about the value sentinel: "repr" (C: mk_repr,
    %s) or "g" (%.6g)."""
    for shown, kind in ((repr(sentinel), "repr"), (format(sentinel, ".6g"), "g")):
        if error_text.count(shown) == 1:
            before, after = error_text.split(shown)
            marker = "%s" if kind == "repr" else "%.6g"
            return before.replace("%", "%%") + marker + after.replace("%", "%%"), kind
    raise NativeBuildError(f"cannot make a C format of the message {error_text!r}")


def _own_checks(mechanism) -> list[str]:
    """C lines of mk_mech_check_parameters: each own parameter finite and within its bounds, with
    the library's messages (Mechanism.bind, Parameter.check)."""

    def message(call, value) -> tuple[str, str]:
        try:
            call(value)
        except ParameterError as error:
            return _value_message(str(error), value)
        raise NativeBuildError(f"mechanism {mechanism.name}: {value!r} passes a parameter's check")

    def fail(test, text, kind, value):
        return (f"    if ({test}) return mk_mech_fail(msg, size, {fmi2._c_string(text)}, {value}, "
                f"{int(kind == 'g')});")

    lines = []
    for i, q in enumerate(mechanism.parameters):
        value = f"p[MK_NPARAM + {i}]"
        text, kind = message(lambda x: mechanism.bind(**{q.name: x}), math.nan)
        lines.append(fail(f"!isfinite({value})", text, kind, value))
        if math.isfinite(q.lower):
            text, kind = message(q.check, q.lower - 1.2345678901)
            low = fmi2._c_double(q.lower)
            test = f"!({value} > {low})" if q.strict else f"{value} < {low}"
            lines.append(fail(test, text, kind, value))
        if math.isfinite(q.upper):
            text, kind = message(q.check, q.upper + 1.2345678901)
            lines.append(fail(f"{value} > {fmi2._c_double(q.upper)}", text, kind, value))
    return lines


def _default_rtol() -> float:
    import inspect
    return float(inspect.signature(mech.simulate_mechanism).parameters["rtol"].default)


def _stops_format(mechanism) -> str:
    """Mechanism.stop_positions' message for stops that are no interval, as a C format (%g, %g)."""
    low, high = 2.2345678901234567e-300, 1.2345678901234567e-300
    try:
        dataclasses.replace(mechanism, stops=lambda p: (low, high)).stop_positions(None)
    except ParameterError as error:
        text = str(error)
    else:
        raise NativeBuildError("Mechanism.stop_positions accepts stops that are no interval")
    pieces = text.replace("%", "%%").split(format(low, "g"))
    if len(pieces) != 2 or pieces[1].count(format(high, "g")) != 1:
        raise NativeBuildError(f"cannot make a C format of the message {text!r}")
    return pieces[0] + "%g" + pieces[1].replace(format(high, "g"), "%g")


def generate_core(mechanism: mech.Mechanism, vr: dict, alone: bool, inputs: list,
                  output_names: list, air: bool = False) -> tuple[str, int]:
    """The C of ``mechanism_core.c`` (see the module docstring) and its number of event indicators.
    vr: the FMU's value references by variable name; alone: the mechanism alone (tensions in, see
    :func:`mechanism_interface`); inputs, output_names: the FMU's, in order; air: the air's
    variants too (:func:`mkctl.native.variants.all_variants`) and each muscle's air mass flow
    after the other outputs."""
    import sympy

    from . import codegen
    from .variants import all_variants

    k = len(mechanism.muscles)
    air = air and not alone
    variants = all_variants(air)
    table = codegen.CheckTable()
    own = {q.name: _real(f"mp_{i}") for i, q in enumerate(mechanism.parameters)}
    parameters = {n: f"p[MK_P_{n}]" for n in PARAMETER_NAMES}
    parameters.update({f"mp_{i}": f"p[MK_NPARAM + {i}]" for i in range(len(own))})
    constant = set(parameters)
    q, qdot = _real("q"), _real("qdot")
    commands = [_real("c1"), _real("c2")][:k]
    pressures = [_real("P1"), _real("P2")][:k]
    stops = (_real("q_low"), _real("q_high"))
    rhs_bindings = {**parameters, "q": "y[0]", "qdot": "y[1]", "P1": "y[2]", "P2": "y[3]",
                    "c1": "c1", "c2": "c2", "q_low": "(stops ? stops[0] : -INFINITY)",
                    "q_high": "(stops ? stops[1] : INFINITY)"}
    rhs_constant = constant | {"q_low", "q_high"}

    def outputs(q, qdot, P, p):
        if alone:  # lengths and rates (the tension at P = 0 unused: its checks, 0 < L < b)
            force = mech.mechanism_force(mechanism, q, qdot, (0.0,) * k, p)
            return [*force.L, *force.Ldot]
        force = mech.mechanism_force(mechanism, q, qdot, tuple(P), p)
        a1, a2 = mech.coefficients_at(mechanism, q, qdot, tuple(P), p)
        return [*force.L, *force.f, a1, a2]

    def air_flows(P, c, p):  # each muscle's net mass flow in at the regulator's opening
        return [actuator.air_mass_flow(P_i, actuator.valve_opening(P_i, c_i, p), p)
                for P_i, c_i in zip(P, c)]

    parts, rhs_cases, switch_cases, counts, flow_cases = [], [], [], [], []
    try:
        # the mechanism alone has no muscle: one variant's functions serve every variant
        emitted = variants[:1] if alone else variants
        for index, variant in enumerate(emitted):
            p = mech.MechanismParams(codegen.SymbolicParams(variant), own)
            if alone:
                traced = codegen.trace(mech.motion_under_tensions, [q, qdot], commands, mechanism,
                                       p, stops)
            else:
                state = [q, qdot, *(pressures if variant.lag else [])]
                traced = codegen.trace(mech.mechanism_derivatives, state, commands, mechanism, p,
                                       stops)
            name = f"mech_rhs_{variant.name}"
            parts.append(codegen.emit_function(name, *RHS_ARGUMENTS, rhs_bindings, rhs_constant,
                                               traced, "out", table))
            rhs_cases.append((index, name))
            switches = fmi2.switching_functions(traced.outputs, rhs_constant)
            counts.append(len(switches))
            if switches:
                parts.append(codegen.emit_function(f"mech_switches_{variant.name}", *RHS_ARGUMENTS,
                                                   rhs_bindings, rhs_constant,
                                                   codegen.Traced(switches, []), "out", table))
                switch_cases.append((index, f"mech_switches_{variant.name}"))
            traced = codegen.trace(outputs, q, qdot, pressures, p)
            a1, a2 = 2 * k, 2 * k + 1
            verdict = f"    out[{a2 + 1}] = (out[{a1}] < 0 && out[{a2}] < 0) ? 1.0 : 0.0;"
            stable = () if alone else (verdict,)
            bindings = {**parameters, "q": "q", "qdot": "qdot", "P1": "P1", "P2": "P2"}
            parts.append(codegen.emit_function(f"mech_outputs_{variant.name}", *OUTPUT_ARGUMENTS,
                                               bindings, constant, traced, "out", table, stable))
            if variant.air:
                name = f"mech_air_flows_{variant.name}"
                traced = codegen.trace(air_flows, pressures, commands,
                                       codegen.SymbolicParams(variant))
                parts.append(codegen.emit_function(
                    name, *FLOW_ARGUMENTS, {**parameters, "P1": "P1", "P2": "P2", "c1": "c1",
                                            "c2": "c2"}, constant, traced, "out", table))
                flow_cases.append((index, name))
        p = mech.MechanismParams(codegen.SymbolicParams(variants[0]), own)
        traced = codegen.trace(lambda pp: [sympy.sympify(s) for s in mechanism.stops(pp)], p)
        parts.append(codegen.emit_function("mech_stop_positions", "double *out, mk_fault *fault",
                                           "out, fault", parameters, constant, traced, "out",
                                           table))

        def step_checks(c1, c2):  # what the run checks before it integrates: finite pressures
            if not alone:
                actuator.check_pressure(c1)
                actuator.check_pressure(c2)
            return []

        parts.append(codegen.emit_function(
            "mech_step_checks", "double pe_cmd, double pf_cmd, mk_fault *fault",
            "pe_cmd, pf_cmd, fault",
            {**parameters, "pe_cmd": "pe_cmd", "pf_cmd": "pf_cmd"}, constant,
            codegen.trace(step_checks, _real("pe_cmd"), _real("pf_cmd")), "out", table))
    except (ValueError, TypeError, AttributeError) as error:
        raise NativeBuildError(f"mechanism {mechanism.name} cannot be generated into C: "
                               f"{error}") from None
    nz = max(counts)
    if alone:
        rhs_cases = [(i, rhs_cases[0][1]) for i in range(len(variants))]
        switch_cases = [(i, name) for i in range(len(variants)) for _, name in switch_cases[:1]]
    lag_states = [2 + k if v.lag else 2 for v in variants]

    def dispatch(signature, call, cases, fallback):
        lines = [signature, "{", "    switch (variant) {"]
        lines += [f"    case {i}: {call.format(name=n)}" for i, n in cases]
        return lines + ["    }", f"    {fallback}", "}", ""]

    head_p = "int variant, const double *p"
    outputs_cases = [(i, f"mech_outputs_{emitted[min(i, len(emitted) - 1)].name}")
                     for i in range(len(variants))]
    variant_fault = "return mk_fault_code(fault, MK_FAULT_VARIANT);"
    dispatchers = [
        f"static const int mech_nstates[{len(variants)}] = {{{', '.join(map(str, lag_states))}}};",
        "static int mech_nstate(int variant)",
        "{", "    return variant < 0 ? 2 : mech_nstates[variant];", "}", "",
        *dispatch(f"static void mech_rhs_constants_variant({head_p}, const double *stops,\n"
                  "                                      double *kc)",
                  "{name}_constants(p, stops, kc); return;", rhs_cases, "return;"),
        *dispatch(f"static int mech_rhs_variant({head_p}, const double *stops, const double *kc,\n"
                  "                            const double *y, double c1, double c2,\n"
                  "                            double *out,\n"
                  "                            mk_fault *fault)",
                  "return {name}(p, stops, kc, y, c1, c2, out, fault);", rhs_cases, variant_fault),
        *dispatch(f"static int mech_switches_variant({head_p}, const double *stops,\n"
                  "                                 const double *y, double c1, double c2,\n"
                  "                                 double *out, mk_fault *fault)",
                  "return {name}_once(p, stops, y, c1, c2, out, fault);", switch_cases,
                  "return 0;"),
        *dispatch(f"static int mech_outputs_variant({head_p}, double q, double qdot, double P1,\n"
                  "                                double P2, double *out, mk_fault *fault)",
                  "return {name}_once(p, NULL, q, qdot, P1, P2, out, fault);", outputs_cases,
                  variant_fault)]
    if air:  # the variants without the air: no flow
        dispatchers += dispatch(
            f"static int mech_air_flows_variant({head_p}, double P1, double P2, double c1,\n"
            "                                  double c2, double *out, mk_fault *fault)",
            "return {name}_once(p, NULL, P1, P2, c1, c2, out, fault);", flow_cases,
            "out[0] = 0.0;" + (" out[1] = 0.0;" if k == 2 else "") + "\n    return 0;")
    integrator = _substituted(
        _template_part("/* Dense output of a record run",
                       "/* Integrate the knee state y (MK_P_tau > 0"),
        [("mk_knee_rhs_variant(", "mech_rhs_variant(", 2),
         ("mk_variant_nstate(variant)", "mech_nstate(variant)", 2),
         ("mk_step_checks(p, pe_cmd, pf_cmd, fault)",
          "mech_step_checks_once(p, NULL, pe_cmd, pf_cmd, fault)", 1)])
    head = _template_part("#include <math.h>", "/* ---- generated equations")
    head = head.replace("@PARAMETER_MACROS@", codegen._parameter_macros())
    vr_of = {name: vr[name] for name in vr}
    output_vr = [vr_of[n] for n in output_names]
    if output_names[:2] != ["q", "qdot"]:
        raise NativeBuildError("a mechanism FMU's first outputs are q and qdot")
    if alone:  # the traced outputs as they are: L..., Ldot...
        arrange = f"for (i = 0; i < {2 * k}; i++) out[i] = t[i];"
    else:  # L..., f... traced; P... the lag states or the commands; a1, a2, stable traced
        arrange = (f"for (i = 0; i < {2 * k}; i++) out[i] = t[i]; out[{2 * k}] = P1; "
                   + (f"out[{2 * k + 1}] = P2; " if k == 2 else "")
                   + f"for (i = 0; i < 3; i++) out[{3 * k} + i] = t[{2 * k} + i];")
        if air:  # then each muscle's air mass flow (0 without the air)
            arrange += (f"\n    rc = mech_air_flows_variant(variant, p, P1, P2, c1, c2, "
                        f"out + {3 * k + 3}, fault);\n    if (rc)\n        return rc;")
    expected = 3 * k + 3 + (k if air else 0) if not alone else 2 * k
    if len(output_names) - 2 != expected:
        raise NativeBuildError(f"a mechanism FMU's outputs after q, qdot number {expected}, "
                               f"not {len(output_names) - 2}")
    templates = [fmi2._c_string(fmi2._fault_template(check)) for check in table.checks]
    atol = ", ".join(fmi2._c_double(a) for a in (*mech.RUN_ATOL, mech.RUN_ATOL[2]))
    api = f"""
/* ---- the mechanism FMU's API (mechanism_fmu.c, mechanism_me.c) ---- */
int mk_variant(const double *p); /* the core's: the variants are all_variants() in both */
const int mk_mech_muscles = {k};
const int mk_mech_command_vr[2] = {{{vr_of[inputs[0]]}, {vr_of[inputs[-1]]}}};
const int mk_mech_q0_vr = {vr_of['q0']};
/* q, qdot, then what mk_mech_outputs gives: L..., f..., P..., a1, a2, stable
 * (the mechanism alone: L..., Ldot...) */
const int mk_mech_output_vr[{len(output_vr)}] = {{{', '.join(map(str, output_vr))}}};
const int mk_mech_nout = {len(output_vr) - 2};
const int mk_mech_nz = {nz};
const char *const mk_mech_fault_templates[] = {{{', '.join(templates) or '""'}}};
const int mk_mech_fault_count = {len(templates)};
const double MK_MECH_ATOL[4] = {{{atol}}}; /* mechanism.RUN_ATOL */
const double MK_MECH_RTOL = {fmi2._c_double(_default_rtol())};
const double MK_MECH_H0 = {fmi2._c_double(mech.RUN_FIRST_STEP)};
const char MK_MECH_STOPS_FORMAT[] = {fmi2._c_string(_stops_format(mechanism))};
const char *mk_repr(double value, char *buffer, size_t size);
int snprintf(char *str, size_t size, const char *format, ...);

int mk_mech_nstate(const double *p) {{ return mech_nstate(mk_variant(p)); }}

int mk_mech_stops(const double *p, double *out, mk_fault *fault)
{{
    return mech_stop_positions_once(p, NULL, out, fault);
}}

int mk_mech_step(const double *p, const double *stops, double *y, double dt, double c1, double c2,
                 double rtol, double *h_hint, double *k, int *k1_valid, double *k_c1, double *k_c2,
                 mk_fault *fault)
{{
    const int variant = mk_variant(p);
    double kc[MK_MAX_CONSTANTS];
    if (variant < 0)
        return mk_fault_code(fault, MK_FAULT_VARIANT);
    mech_rhs_constants_variant(variant, p, stops, kc);
    return mk_step_variant(variant, p, stops, kc, y, dt, c1, c2, rtol, MK_MECH_ATOL, h_hint, k,
                           k1_valid, k_c1, k_c2, fault);
}}

int mk_mech_rhs(const double *p, const double *stops, const double *y, double c1, double c2,
                double *dy, mk_fault *fault)
{{
    const int variant = mk_variant(p);
    double kc[MK_MAX_CONSTANTS];
    if (variant < 0)
        return mk_fault_code(fault, MK_FAULT_VARIANT);
    mech_rhs_constants_variant(variant, p, stops, kc);
    return mech_rhs_variant(variant, p, stops, kc, y, c1, c2, dy, fault);
}}

int mk_mech_event_indicators(const double *p, const double *stops, const double *y, double c1,
                             double c2, double *out, mk_fault *fault)
{{
    int i;
    for (i = 0; i < {max(nz, 1)}; i++) out[i] = 1.0;
    return mech_switches_variant(mk_variant(p), p, stops, y, c1, c2, out, fault);
}}

/* every output after q and qdot (mk_mech_output_vr's order) at state y; the pressures: the lag
 * states, or the commands */
int mk_mech_outputs(const double *p, const double *y, double c1, double c2, double *out,
                    mk_fault *fault)
{{
    const int variant = mk_variant(p);
    const int lag = mech_nstate(variant) > 2;
    const double P1 = lag ? y[2] : c1, P2 = lag ? y[1 + mk_mech_muscles] : c2;
    double t[16];
    int i, rc;
    if (variant < 0)
        return mk_fault_code(fault, MK_FAULT_VARIANT);
    rc = mech_outputs_variant(variant, p, y[0], y[1], P1, P2, t, fault);
    if (rc)
        return rc;
    {arrange}
    (void)P2;
    return 0;
}}

static int mk_mech_fail(char *msg, size_t size, const char *format, double value, int plain)
{{
    char number[40];
    if (plain) snprintf(msg, size, format, value);
    else snprintf(msg, size, format, mk_repr(value, number, sizeof number));
    return 1;
}}

/* the mechanism's own parameters: finite, within their bounds (Mechanism.bind's messages) */
int mk_mech_check_parameters(const double *p, char *msg, size_t size)
{{
{chr(10).join(_own_checks(mechanism))}
    (void)p; (void)msg; (void)size; (void)mk_mech_fail;
    return 0;
}}
"""
    source = "\n".join([
        f"/* {model_name(mechanism)}: the mechanism's equations, GENERATED by",
        " * mkctl/native/mechanism_fmu.py from the library's own functions (mechanism_derivatives,",
        " * mechanism_force, coefficients_at, the mechanism's stops"
        + (", actuator.air_mass_flow" if air else "") + ") and the core's integrator",
        " * (core_template.c). Do not edit. */",
        head.replace("@VARIANT_NAMES@", ", ".join(v.name for v in variants)),
        "/* ---- generated equations ---- */", *parts, *dispatchers, codegen._tableau(), integrator,
        api])
    return source, nz


def build_mechanism(mechanism: mech.Mechanism, out: Path, params: Params | None = None,
                    platforms: bool = True, alone: bool = False, air: bool | None = None
                    ) -> dict[str, Path]:
    """Write ``out/native/McKibben<Name>.fmu`` (FMI 2.0) and ``out/fmi3/McKibben<Name>.fmu``
    (FMI 3.0), both interfaces, linux64 and (platforms) the other platforms' binaries whose
    toolchains are installed
    (:mod:`mkctl.native.cross`, as the knee's). Returns the paths by "native/<name>", "fmi3/<name>".
    alone: the mechanism alone, air: with the air (None: when params switch it on; see
    :func:`mechanism_interface`). Raises :class:`NativeBuildError`."""
    from . import fmi3
    interface = mechanism_interface(mechanism, params, alone, air)
    name = interface.model_name
    native = fmi2.build_one(name, Path(out) / "native" / f"{name}.fmu", windows=platforms,
                            interface=interface)
    three = fmi3.build_one(name, Path(out) / "fmi3" / f"{name}.fmu", interface=interface,
                           platforms=platforms)
    return {f"native/{name}": native, f"fmi3/{name}": three}
