"""Native FMUs (model-spec sections 7b, 7c): the knee and the actuator as FMI 2.0 FMUs in compiled C, with both
interfaces, Co-Simulation and Model Exchange, in one binary and one modelDescription.xml.

    python -m mkctl.native.fmu [--out DIR]      # writes DIR/native/McKibbenKnee.fmu, DIR/native/McKibbenActuator.fmu

:func:`build_native` writes FMUs with the same model names, variables (names, value references, causality,
variability, units, descriptions, start values) and default experiments as the pythonfmu FMUs of ``build_fmu.py``,
because it reads them from the same declaration, the one the pythonfmu slaves register: :mod:`mkctl.fmi.interface`
(start values for a Params from its ``start_values``). The model code is
the compiled core of :mod:`mkctl.native` (C generated from mkctl's equations); around it sit the FMI wrapper
(``fmu_c/fmi2_wrapper.c``, shared) and the model's part (``fmu_c/knee_fmu.c``, ``fmu_c/actuator_fmu.c``).

Each FMU carries its C sources in ``sources/`` (an FMI 2.0 source-code FMU: ``<SourceFiles>`` lists the
compilation units; the FMI 2.0 headers are included) and the ``linux64`` binary, compiled with the core's
compiler and flags (``-O2 -fPIC -shared -ffp-contract=off -fno-fast-math``, only ``fmi2*`` exported). The host
needs no Python. Building needs a C compiler and sympy; the generated core source and its object file are cached
in mkctl's cache folder (:func:`mkctl.native.build.cache_dir`).

The parameter checks of the C wrapper are those of :class:`mkctl.physics.params.Params`: the per-parameter rules
(positive, not negative; the values of an Integer parameter) are read from ``Params`` itself at build time
(:func:`parameter_rule`, :func:`integer_rule`), the two rules between parameters are written in the wrapper with
Params' own messages; tests compare both on every parameter. Domain errors during a run carry the library's
messages too: each traced domain check of the core gets its Python message as a template (:func:`core_source`).

Model Exchange (:data:`ME_STATES`): the continuous states are the knee's X, V and its two pressure-lag states
(``Pe_lag``, ``Pf_lag``: local variables, inert with derivative 0 when tau = 0, since FMI 2.0 fixes the number of
states), or the actuator's ``P_lag``; each has a ``der(...)`` variable. The derivatives are the core's generated
right-hand side (``mk_knee_rhs``) and, for the actuator, the time derivative at dt = 0 of the core's exact lag
(``actuator_lagged_pressure``), differentiated symbolically. The event indicators are found in those generated
expressions themselves (:func:`switching_functions`): every Piecewise condition, Max/Min, Abs, sign or Heaviside
argument that depends on the state or an input (end-stop contact, the stop's damper letting go, slack, a lag's
direction), one generated C function per variant, so that no effect is named in hand-written C. Parameters that
Model Exchange cannot represent (:data:`ME_REFUSED_PARAMETERS`, none today) are refused at initialization.

A dead time (``delay > 0``, model-spec section 4b) runs in both interfaces (``fmu_c/mk_run.c``, ``mk_delay_*``):
the pressure commands on their way are kept in the FMU state (at most ``MK_HISTORY`` changes, ``fmu_c/mk_fmu.h``).
Co-Simulation cuts each step where a command given earlier arrives, as ``KneeSimulator.step`` does; Model Exchange
records the pressure inputs as the host sets them and switches the commands the actuators see at time events.
"""
from __future__ import annotations

import argparse
import dataclasses
import datetime
import math
import os
import shutil
import subprocess
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from ..fmi.xml import xml_bytes
from ..errors import MkctlError, ParameterError
from ..fmi.interface import check_carried, model_for
from ..fmi.units import fmi_unit, unit_definitions
from ..physics.params import PARAMETER_NAMES, UNITS, Params, domain_of, outside_domain_message

HERE = Path(__file__).resolve().parent
C_DIR = HERE / "fmu_c"
#: The models, named as the pythonfmu slave classes of :mod:`mkctl.fmu.models` whose interface they repeat.
MODEL_NAMES = ("McKibbenKnee", "McKibbenActuator")
#: The model's part of the wrapper, by model name.
MODEL_SOURCES = {"McKibbenKnee": "knee_fmu.c", "McKibbenActuator": "actuator_fmu.c"}
#: The model's Model Exchange part (derivatives and event indicators from the generated core), by model name.
ME_SOURCES = {"McKibbenKnee": "knee_me.c", "McKibbenActuator": "actuator_me.c"}
#: The wrapper's C, shared by every model (the FMI 2.0 functions; the run's checks and Model Exchange logic).
WRAPPER_SOURCES = ("fmi2_wrapper.c", "mk_run.c")


@dataclasses.dataclass(frozen=True)
class MEState:
    """One continuous state of the Model Exchange interface (model-spec section 7c)."""

    name: str  #: the variable holding it: an output of the slave, or a local variable added for Model Exchange
    unit: str  #: FMI unit of the state
    derivative_unit: str  #: FMI unit of its derivative
    nominal: float  #: its magnitude (fmi2GetNominalsOfContinuousStates; a host scales its tolerance by it)
    description: str | None = None  #: for a local added here; None: the slave's own output


#: The continuous states, in the order of the core's state vector y (knee.state_names with a lag: X, V, Pe, Pf).
ME_STATES = {
    "McKibbenKnee": (
        MEState("X", "m", "m/s", 1.0),
        MEState("V", "m/s", "m/s2", 1.0),
        MEState("Pe_lag", "Pa", "Pa/s", 1e6, "extensor pressure-lag state (Model Exchange): equal to Pe when tau > 0; "
                "inert (derivative 0) when tau = 0, where Pe is pe_cmd"),
        MEState("Pf_lag", "Pa", "Pa/s", 1e6, "flexor pressure-lag state (Model Exchange): equal to Pf when tau > 0; "
                "inert (derivative 0) when tau = 0, where Pf is pf_cmd"),
    ),
    "McKibbenActuator": (
        MEState("P_lag", "Pa", "Pa/s", 1e6, "pressure-lag state (Model Exchange): equal to P when tau > 0; inert "
                "(derivative 0) when tau = 0, where P is p_cmd"),
    ),
}

#: Parameters Model Exchange cannot represent, with the reason, refused at initialization when not 0 (model-spec
#: section 7c). None today: a dead time runs under Model Exchange too (the FMU records the commands as the host sets
#: them; docs/fmu.md, "Dead time").
ME_REFUSED_PARAMETERS: dict[str, str] = {}

_LOG_CATEGORIES = {
    "logStatusWarning": "Log messages with fmi2Warning status.",
    "logStatusDiscard": "Log messages with fmi2Discard status.",
    "logStatusError": "Log messages with fmi2Error status.",
    "logStatusFatal": "Log messages with fmi2Fatal status.",
    "logAll": "Log all messages.",
}


class NativeBuildError(MkctlError):
    """The native FMUs could not be generated, compiled or validated."""


@dataclasses.dataclass(frozen=True)
class Variable:
    """One FMU variable, as the pythonfmu slave declares it (:class:`mkctl.fmi.interface.Variable`, FMI unit)."""

    name: str
    vr: int
    type: str  #: "Real", "Integer" or "Boolean"
    causality: str  #: "input", "parameter" or "output"
    variability: str  #: "continuous", "fixed" or "discrete"
    description: str
    unit: str | None  #: FMI unit name (Real variables only)
    start: float | int | None  #: None for outputs


@dataclasses.dataclass(frozen=True)
class Interface:
    """What an FMU shows a host: its variables and model data, the same for the pythonfmu and the native FMU."""

    model_name: str
    description: str
    author: str
    default_experiment: dict[str, str]
    variables: tuple[Variable, ...]
    undefined_outputs: str
    pressure_outputs: dict[str, str]  #: {output: muscle} checked against P_rated (when the FMU has it)
    # A model that is not one of MODEL_NAMES (a mechanism FMU, mkctl/native/mechanism_fmu.py) brings these:
    me_states: tuple | None = None  #: its Model Exchange states (None: ME_STATES of the model name)
    event_indicators: int | None = None  #: their count (None: core_event_indicators of the model name)
    model_sources: tuple | None = None  #: its model part and Model Exchange part in fmu_c/ (None: by name)
    generated_sources: tuple = ()  #: ((file name, C text), ...): further compilation units, generated
    core_parameters: tuple = ()  #: Real parameters after Params' fields in the core's parameter vector p
    air: bool = False  #: built with the air: the core's air variants and the air's parameters (model-spec 7d)
    valves: bool = False  #: built with valve openings as inputs (model-spec 7d): implies air

    def by_name(self) -> dict[str, Variable]:
        return {v.name: v for v in self.variables}


def slave_interface(model_name: str, params: Params | None = None, air: bool = False,
                    valves: bool = False) -> Interface:
    """The interface of a model (:data:`mkctl.fmi.interface.MODELS`, which its pythonfmu slave registers too),
    start values taken from params (default: the current model's defaults, the slave's own).
    ``air``: built with the air (:data:`mkctl.fmi.interface.KNEE_WITH_AIR`, native FMUs only);
    ``valves``: with valve openings as inputs (:func:`mkctl.fmi.interface.model_for`).

    With params, every parameter starts at params' value, ``X0`` (knee) at the hip height at alpha = 60 deg of
    params' geometry and the knee's input commands at the pressures that hold it there.
    """
    model = model_for(model_name, air or valves, valves)
    if model.valves:  # the air on in its start values: the valves drive nothing without it
        params = with_valves(params)
    if params is not None:
        try:
            check_carried(params, model.air)
        except ParameterError as error:
            raise NativeBuildError(str(error)) from None
    variables = tuple(Variable(v.name, v.vr, v.type, v.causality, v.variability, v.description,
                               fmi_unit(v.unit) if v.type == "Real" else None, v.start)
                      for v in model.variables(Params() if params is None else params))
    experiment = {"startTime": "start_time", "stopTime": "stop_time", "stepSize": "step_size", "tolerance": "tolerance"}
    default_experiment = {key: str(model.default_experiment[field]) for key, field in experiment.items()
                          if model.default_experiment.get(field) is not None}
    interface = Interface(model_name, model.description, model.author, default_experiment,
                          variables, model.undefined_outputs, dict(model.pressure_outputs),
                          air=model.air, valves=model.valves)
    if model.air and model_name == "McKibbenActuator":  # its air: a generated unit of its own
        text, switches = actuator_air_source(model.valves)
        core = core_event_indicators(model_name, model.air, model.valves)
        interface = dataclasses.replace(interface, generated_sources=((ACTUATOR_AIR_FILE, text),),
                                        event_indicators=max(switches, core))
    return interface


def parameter_rule(name: str) -> str:
    """The check :class:`Params` applies to a Real parameter on its own: "positive", "not_negative" or "any".

    Read from Params itself (a value of 0 or -1 in an otherwise default set), so that the C wrapper checks what
    the library checks. ``n`` is "any" here: the wrapper checks it only when it is given (not left at its start).
    """
    defaults = Params()  # the current model's: an effect registered at run time (spec 4c) included
    if name not in defaults.as_dict() or name in ("n", "model"):
        return "any"
    for value, rule, words in ((0.0, "positive", "must be positive"), (-1.0, "not_negative", "must not be negative")):
        try:
            defaults.replace(**{name: value})
        except ParameterError as error:
            if words in str(error):
                return rule
    return "any"


def integer_rule(name: str) -> tuple[int, int, str]:
    """(low, high, message) of an Integer parameter: the values Params accepts (a range) and its message for a
    bad one, with "%d" for the value; read from Params itself."""
    allowed, defaults = [], Params()  # the current model's
    for value in range(-3, 6):
        try:
            defaults.replace(**{name: value})
            allowed.append(value)
        except ParameterError:
            pass
    if not allowed or allowed != list(range(allowed[0], allowed[-1] + 1)):
        raise NativeBuildError(f"Integer parameter {name}: Params accepts {allowed}, not a range")
    bad = 987654
    try:
        defaults.replace(**{name: bad})
    except ParameterError as error:
        message = str(error).replace("%", "%%")
    else:
        raise NativeBuildError(f"Integer parameter {name}: Params accepts {bad}")
    if str(bad) not in message:
        raise NativeBuildError(f"Integer parameter {name}: Params' message does not show the value: {message}")
    return allowed[0], allowed[-1], message.replace(str(bad), "%d")


# --- generated files -------------------------------------------------------------------------------------------

def model_me_states(interface: Interface) -> tuple:
    """The Model Exchange states of an interface: its own, else :data:`ME_STATES` of its model name."""
    return interface.me_states if interface.me_states is not None else ME_STATES[interface.model_name]


def event_indicator_count(interface: Interface) -> int:
    """The number of event indicators: the interface's own, else :func:`core_event_indicators`."""
    if interface.event_indicators is not None:
        return interface.event_indicators
    return core_event_indicators(interface.model_name, interface.air, interface.valves)


def me_variables(interface: Interface) -> tuple[Variable, ...]:
    """The variables Model Exchange adds to the slave's: the lag states that are not outputs and a ``der(...)``
    variable for every state (all local, continuous, calculated), value references after the slave's."""
    names = interface.by_name()
    vr = max(v.vr for v in interface.variables) + 1
    added = []
    for state in model_me_states(interface):
        if state.description is None:
            if state.name not in names or names[state.name].type != "Real":
                raise NativeBuildError(f"Model Exchange state {state.name} is not a Real variable of the slave")
        else:
            added.append(Variable(state.name, vr, "Real", "local", "continuous", state.description, state.unit,
                                  None))
            vr += 1
    for state in model_me_states(interface):
        added.append(Variable(f"der({state.name})", vr, "Real", "local", "continuous",
                              f"time derivative of {state.name} (Model Exchange)", state.derivative_unit, None))
        vr += 1
    return tuple(added)


def model_description(interface: Interface, guid: str, source_files: list[str], event_indicators: int = 0) -> bytes:
    """modelDescription.xml of the native FMU: FMI 2.0 Model Exchange and Co-Simulation in one, source files
    listed; the slave's variables, then those Model Exchange adds (:func:`me_variables`)."""
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    variables_all = interface.variables + me_variables(interface)
    index = {v.name: k for k, v in enumerate(variables_all, start=1)}
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": interface.model_name, "guid": guid,
        "description": interface.description, "author": interface.author,
        "generationTool": "mkctl.native.fmu (C generated from mkctl's equations)",
        "generationDateAndTime": now, "variableNamingConvention": "structured",
        "numberOfEventIndicators": str(event_indicators)})
    common = {"modelIdentifier": interface.model_name, "needsExecutionTool": "false"}
    shared = {"canBeInstantiatedOnlyOncePerProcess": "false", "canNotUseMemoryManagementFunctions": "true",
              "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true", "providesDirectionalDerivative": "false"}
    me = ET.SubElement(root, "ModelExchange", {**common, "completedIntegratorStepNotNeeded": "false", **shared})
    cosim = ET.SubElement(root, "CoSimulation", {
        **common, "canHandleVariableCommunicationStepSize": "true", "canInterpolateInputs": "false", **shared})
    for element in (me, cosim):
        sources = ET.SubElement(element, "SourceFiles")
        for name in source_files:
            ET.SubElement(sources, "File", name=name)
    try:
        root.append(unit_definitions(v.unit for v in variables_all if v.unit is not None))
    except ValueError as error:
        raise NativeBuildError(str(error)) from None
    categories = ET.SubElement(root, "LogCategories")
    for name, text in _LOG_CATEGORIES.items():
        ET.SubElement(categories, "Category", name=name, description=text)
    ET.SubElement(root, "DefaultExperiment", interface.default_experiment)
    variables = ET.SubElement(root, "ModelVariables")
    states = {f"der({state.name})": state for state in model_me_states(interface)}
    for v in variables_all:
        node = ET.SubElement(variables, "ScalarVariable", {
            "name": v.name, "valueReference": str(v.vr), "description": v.description, "causality": v.causality,
            "variability": v.variability})
        attributes = {}
        if v.start is not None:
            attributes["start"] = repr(v.start)
        if v.unit is not None:
            attributes["unit"] = v.unit
        if v.name in states:
            attributes["derivative"] = str(index[states[v.name].name])
        ET.SubElement(node, v.type, attributes)
    structure = ET.SubElement(root, "ModelStructure")
    outputs = [str(index[v.name]) for v in variables_all if v.causality == "output"]
    derivatives = [str(index[name]) for name in states]
    initial = sorted({*outputs, *derivatives, *(str(index[s.name]) for s in states.values())}, key=int)
    for section, indices in (("Outputs", outputs), ("Derivatives", derivatives), ("InitialUnknowns", initial)):
        node = ET.SubElement(structure, section)
        for position in indices:
            ET.SubElement(node, "Unknown", index=position)
    return xml_bytes(root)


def _c_string(text: str) -> str:
    """A C string literal of text's UTF-8 bytes, built from the bytes: printable ASCII as it is, every other byte
    (a quote, a backslash, '?' of a trigraph, a line break, a control character, non-ASCII) as a 3-digit octal
    escape, so that no text (a user's unit) can end the literal or the line."""
    plain = set(b" !#$&'()*+,-./0123456789:;<=>@ABCDEFGHIJKLMNOPQRSTUVWXYZ[]^_`abcdefghijklmnopqrstuvwxyz{|}~%")
    data = text.encode("utf-8", "backslashreplace")
    return '"' + "".join(chr(b) if b in plain else f"\\{b:03o}" for b in data) + '"'


def _value_format(message: str) -> str:
    """A printf format of a message with one marker \\001 where the value goes: every other '%' (a user's unit
    "%") doubled, the marker "%.6g"; exactly one marker, or the build stops."""
    pieces = message.split("\001")
    if len(pieces) != 2:
        raise NativeBuildError(f"cannot make a C format of the message {message!r}")
    return "%.6g".join(piece.replace("%", "%%") for piece in pieces)


def _c_double(value: float) -> str:
    if not math.isfinite(value):
        raise NativeBuildError(f"start value {value!r} is not a finite number")
    return repr(float(value))


def c_identifier(name: str) -> str:
    """The C name of a variable in ``VR_<name>``: ``der(X)`` becomes ``der_X``."""
    text = name.replace("(", "_").replace(")", "")
    if not (text.isascii() and text.isidentifier()):
        raise NativeBuildError(f"variable name {name!r} has no C identifier")
    return text


def core_event_indicators(model_name: str, air: bool = False, valves: bool = False) -> int:
    """The number of event indicators of a model's Model Exchange interface: the most switching functions of any
    variant in the generated core (:func:`generate_core_source`; a variant with fewer pads with constants)."""
    import re
    key = {"McKibbenKnee": "KNEE", "McKibbenActuator": "ACTUATOR"}[model_name]
    found = re.search(rf"^#define MK_FMU_{key}_NZ (\d+)$", core_source(air, valves), re.MULTILINE)
    if found is None:
        raise NativeBuildError(f"the generated core has no event-indicator count for {model_name}")
    return int(found.group(1))


def _message_format(message, *fields: str) -> str:
    """A C printf format (one %s per field, in order) of a message function of the slaves."""
    markers = [chr(1 + k) for k in range(len(fields))]
    text = message(*markers).replace("%", "%%")
    positions = [text.index(m) for m in markers]
    if positions != sorted(positions):
        raise NativeBuildError(f"message fields {fields} are not in order in {text!r}")
    for marker in markers:
        text = text.replace(marker, "%s")
    return text


def variables_header(interface: Interface, guid: str) -> str:
    """model_variables.h: names, value references, GUID, Model Exchange's sizes."""
    variables = interface.variables + me_variables(interface)
    nz = event_indicator_count(interface)
    lines = ["/* Generated by mkctl.native.fmu from the pythonfmu slave's interface: do not edit. */",
             "#ifndef MODEL_VARIABLES_H", "#define MODEL_VARIABLES_H", "",
             f"#define MK_MODEL_NAME {_c_string(interface.model_name)}",
             f"#define MK_GUID {_c_string(guid)}",
             f"#define MK_UNDEFINED_OUTPUTS {_c_string(interface.undefined_outputs)}",
             f"#define NV {len(variables)}",
             f"#define MK_NPARAM {len(PARAMETER_NAMES) + len(interface.core_parameters)} /* the core's "
             "parameter vector */",
             f"#define MK_ME_NX {len(model_me_states(interface))} /* Model Exchange: continuous states */",
             f"#define MK_ME_NZ {nz} /* Model Exchange: event indicators */", ""]
    for v in variables:
        lines.append(f"#define VR_{c_identifier(v.name)} {v.vr}")
    lines += ["", "#endif", ""]
    return "\n".join(lines)


def variables_source(interface: Interface) -> str:
    """model_variables.c: the table of variables (start values exact to the last bit), check order, inputs, the
    Model Exchange states, and the slaves' messages for a negative pressure and a non-finite output."""
    from ..fmi.interface import negative_pressure_message, non_finite_output_message
    types = {"Real": "MK_REAL", "Integer": "MK_INTEGER", "Boolean": "MK_BOOLEAN"}
    causalities = {"input": "MK_INPUT", "parameter": "MK_PARAMETER", "output": "MK_OUTPUT", "local": "MK_LOCAL"}
    rules = {"any": "MK_ANY", "positive": "MK_POSITIVE", "not_negative": "MK_NOT_NEGATIVE"}
    lines = ["/* Generated by mkctl.native.fmu from the pythonfmu slave's interface: do not edit. */",
             '#include "mk_fmu.h"', '#include "mk_run.h"', "", "const mk_variable mk_variables[NV] = {"]
    for v in sorted(interface.variables + me_variables(interface), key=lambda v: v.vr):
        rule = parameter_rule(v.name) if v.causality == "parameter" and v.type == "Real" else "any"
        start = _c_double(v.start) if v.start is not None else "0.0"
        lines.append(f"    {{{_c_string(v.name)}, {types[v.type]}, {causalities[v.causality]}, {rules[rule]}, "
                     f"{_c_string(v.unit or '')}, {start}}}, /* vr {v.vr} */")
    lines.append("};")
    names = interface.by_name()
    order = [names[f].vr for f in PARAMETER_NAMES
             if f in names and names[f].causality == "parameter" and names[f].type == "Real"]
    inputs = [v.vr for v in interface.variables if v.causality == "input"]
    pressures = [v.vr for v in interface.variables if v.causality == "input" and v.unit == "Pa"]
    integer_rules = [(v.vr, *integer_rule(v.name)) for v in interface.variables
                     if v.causality == "parameter" and v.type == "Integer"]
    range_rules = [(v.vr, *domain,
                    _value_format(outside_domain_message(v.name, "\001", *domain, UNITS.get(v.name, "1"))))
                   for v in interface.variables
                   if v.causality == "parameter" and v.type == "Real" and v.name != "n"  # n: checked only when given
                   and (domain := domain_of(v.name)) is not None]
    states = model_me_states(interface)
    refused = [(names[name].vr, reason) for name, reason in ME_REFUSED_PARAMETERS.items()
               if name in names and names[name].causality == "parameter"]
    lines += [f"const int mk_params_order[] = {{{', '.join(map(str, order))}}};",
              f"const int mk_n_params_order = {len(order)};",
              f"const int mk_inputs[] = {{{', '.join(map(str, inputs))}}};",
              f"const int mk_n_inputs = {len(inputs)};",
              "const mk_integer_rule mk_integer_rules[] = {",
              *[f"    {{{vr}, {low}, {high}, {_c_string(message)}}}," for vr, low, high, message in integer_rules],
              "    {-1, 0, 0, \"\"}", "};", f"const int mk_n_integer_rules = {len(integer_rules)};",
              "const mk_range_rule mk_range_rules[] = {",
              *[f"    {{{vr}, {_c_double(low)}, {_c_double(high)}, {_c_string(message)}}},"
                for vr, low, high, message in range_rules],
              "    {-1, 0.0, 0.0, \"\"}", "};", f"const int mk_n_range_rules = {len(range_rules)};",
              "const mk_pressure_output mk_pressure_outputs[] = {",
              *[f"    {{{names[o].vr}, {_c_string(muscle)}}}," for o, muscle in interface.pressure_outputs.items()
                if "P_rated" in names],
              "    {-1, \"\"}", "};",
              f"const int mk_n_pressure_outputs = {len(interface.pressure_outputs) if 'P_rated' in names else 0};",
              "",
              "/* the inputs that are gauge pressures (refused below 0), and the slaves' messages */",
              f"const int mk_pressure_inputs[] = {{{', '.join(map(str, pressures + [-1]))}}};",
              f"const int mk_n_pressure_inputs = {len(pressures)};",
              "const char MK_NEGATIVE_PRESSURE_FORMAT[] = "
              f"{_c_string(_message_format(negative_pressure_message, 'name', 'value'))};",
              "const char MK_NON_FINITE_OUTPUT_FORMAT[] = "
              f"{_c_string(_message_format(non_finite_output_message, 'name', 'value', 'unit'))};",
              "",
              "/* Model Exchange: the continuous states (the core's state vector y, in order), their derivatives and",
              " * nominal values; the parameters Model Exchange refuses when not 0, with the reason */",
              "const int mk_me_state_vr[MK_ME_NX] = {" + ", ".join(f"VR_{c_identifier(x.name)}" for x in states) + "};",
              "const int mk_me_derivative_vr[MK_ME_NX] = {"
              + ", ".join(f"VR_{c_identifier(f'der({x.name})')}" for x in states) + "};",
              "const double mk_me_nominal[MK_ME_NX] = {" + ", ".join(_c_double(x.nominal) for x in states) + "};",
              "const mk_me_refusal mk_me_refused[] = {",
              *[f"    {{{vr}, {_c_string(reason)}}}," for vr, reason in refused],
              "    {-1, \"\"}", "};", f"const int mk_n_me_refused = {len(refused)};",
              "",
              "void mk_param_vector(const mk_data *d, double n, double *p)", "{"]
    defaults = Params()  # the current model's: the values of the names that are no variable here
    for index, name in enumerate(PARAMETER_NAMES):
        if name == "n":
            lines.append(f"    p[{index}] = n; /* n, given or derived */")
        elif name in names:
            lines.append(f"    p[{index}] = d->v[VR_{name}];")
        else:
            lines.append(f"    p[{index}] = {_c_double(getattr(defaults, name))}; /* {name}: not a variable here, "
                         "Params' default */")
    for index, name in enumerate(interface.core_parameters, start=len(PARAMETER_NAMES)):
        lines.append(f"    p[{index}] = d->v[VR_{c_identifier(name)}];")
    lines += ["}", ""]
    return "\n".join(lines)


# --- sources, compilation, packing ------------------------------------------------------------------------------

def fmi2_headers() -> Path:
    """The folder with the FMI 2.0 headers (fmpy ships the standard ones)."""
    import fmpy
    folder = Path(fmpy.__file__).parent / "c-code"
    if not (folder / "fmi2Functions.h").is_file():
        raise NativeBuildError(f"no FMI 2.0 headers in {folder}")
    return folder


#: Stand-ins for the numbers of a domain check's message (value, low, high): the library's message is written
#: with them and each is replaced by a marker the C fills in (mk_core_api.c: mk_fault_message).
_SENTINELS = {"B": 1.2345678901234567e-300, "L": 2.2345678901234567e-300, "H": 3.2345678901234567e-300}


def _fault_template(check) -> str:
    """The library's error message of a traced domain check, as a template for mk_fault_message."""
    _, _, _, message, what = check
    text = message(*_SENTINELS.values())
    for key, value in _SENTINELS.items():
        text = text.replace(repr(value), "\001" + key).replace(format(value, "g"), "\001" + key.lower())
    if "e-300" in text:
        raise NativeBuildError(f"cannot make a message template of the check on {what}: {text!r}")
    return text


def _c_template(text: str) -> str:
    return _c_string(text)  # the marker \001 becomes the octal escape \001 like any control character


#: core_source's texts in this process, by the key of what they are generated from (the effect registry included:
#: an effect registered at run time, then unregistered, must not leave its core behind).
_CORE_SOURCES: dict[str, str] = {}


def core_source(air: bool = False, valves: bool = False) -> str:
    """:func:`generate_core_source`, cached on disk beside the core's own generated sources
    (:func:`mkctl.native.build.cache_dir`) and in this process, keyed by everything it is generated from (the
    core's inputs, the effect registry and this module): tracing the equations takes seconds, and every build of
    the FMUs needs the same text. ``air``: with the air's variants too (an FMU built with the air);
    ``valves``: the air's variants only, with valve openings as inputs
    (:func:`mkctl.native.variants.valve_input_variants`)."""
    import hashlib

    from . import build
    from .variants import all_variants, valve_input_variants
    variants = valve_input_variants() if valves else all_variants(air)
    digest = hashlib.sha256(build.input_key(variants).encode())
    digest.update(Path(__file__).read_bytes())
    key = digest.hexdigest()[:20]
    if key in _CORE_SOURCES:
        return _CORE_SOURCES[key]
    path = build.cache_dir() / f"fmu-core-{key}.c"
    with build.cache_lock(path):  # processes starting together generate it once
        if path.is_file():
            text = path.read_text()
        else:
            text = (generate_core_source(valves=True) if valves
                    else generate_core_source(air) if air else generate_core_source())
            try:
                build._write_atomic(path, text.encode())
            except OSError:  # a read-only cache only costs time
                pass
    _CORE_SOURCES[key] = text
    return text


def generate_core_source(air: bool = False, valves: bool = False) -> str:
    """The C of the compiled core (:mod:`mkctl.native.codegen`, every variant; ``air``: the air's too, after the
    others: :func:`mkctl.native.variants.all_variants`; ``valves``: the air's only, with valve
    openings as inputs, :func:`mkctl.native.variants.valve_input_variants`, and the messages of
    :func:`valve_input_refusals`) with the FMUs' additions, all
    generated from mkctl's equations: the hip height at a kneecap angle (knee.X_from_alpha, for the default X0),
    the posture at a hip height (knee.geometry_at_X, for the outputs that can still be given when the pressures
    are not numbers), every domain check's message, and KneeSimulator's integrator settings."""
    import sympy

    from ..physics import integrate, knee
    from ..physics.params import PARAMETER_NAMES
    from ..physics.simulate import KneeSimulator
    from ..physics.stability import DEFAULT_ALPHA
    from . import build, codegen
    from .variants import all_variants, valve_input_variants

    variants = valve_input_variants() if valves else all_variants(air)
    source, core_table = build.generation(variants)
    table = core_table.copy()  # the additions' checks number on from the core's
    sp = codegen.SymbolicParams(all_variants()[0])  # the geometry does not depend on the variant
    bindings = {name: f"p[MK_P_{name}]" for name in PARAMETER_NAMES}
    alpha, X = sympy.Symbol("alpha", real=True), sympy.Symbol("X", real=True)

    def posture(X, params):
        geo = knee.geometry_at_X(X, params, derivatives=False)
        return [geo.alpha, geo.beta, geo.Le, geo.Lf]

    def emit(name, arguments, call, bindings_, traced):
        # codegen's form: static <name>(p, stops, k, ...) and <name>_once(p, stops, ...); parameters constant
        return codegen.emit_function(name, arguments, call, bindings_, set(bindings), traced, "out", table)

    extra = [
        emit("fmu_X_from_alpha", "double alpha, double *out, mk_fault *fault", "alpha, out, fault",
             {**bindings, "alpha": "alpha"},
             codegen.trace(lambda a, params: [knee.X_from_alpha(a, params)], alpha, sp)),
        emit("fmu_posture", "double X, double *out, mk_fault *fault", "X, out, fault", {**bindings, "X": "X"},
             codegen.trace(posture, X, sp)),
        "int mk_fmu_X_from_alpha(const double *p, double alpha, double *out, mk_fault *fault)",
        "{", "    return fmu_X_from_alpha_once(p, NULL, alpha, out, fault);", "}", "",
        "int mk_fmu_posture(const double *p, double X, double *out, mk_fault *fault)",
        "{", "    return fmu_posture_once(p, NULL, X, out, fault);", "}", "",
        model_exchange_functions(core_table.emitted, table, variants)]
    if air or valves:
        extra.append(air_flow_functions(variants, table))
    if valves:
        extra.append(valve_input_refusals())
    sim = KneeSimulator(Params(tau=1.0))
    lines = ["", "/* ---- added for the native FMUs by mkctl/native/fmu.py (generated too) ---- */", *extra,
             "const char *const mk_fmu_fault_templates[] = {",
             *[f"    {_c_template(_fault_template(check))}," for check in table.checks], "};",
             f"const int mk_fmu_fault_count = {len(table.checks)};",
             f"const char MK_FMU_COLLAPSE_MESSAGE[] = {_c_string(integrate.COLLAPSE_MESSAGE)};",
             f"const char MK_FMU_TOO_MANY_STEPS_MESSAGE[] = {_c_string(integrate.TOO_MANY_STEPS_MESSAGE)};",
             f"const double MK_FMU_DEFAULT_ALPHA = {_c_double(DEFAULT_ALPHA)};",
             f"const double MK_FMU_KNEE_RTOL = {_c_double(sim.rtol)};",
             "const double MK_FMU_KNEE_ATOL[4] = {" + ", ".join(_c_double(a) for a in sim.atol) + "};",
             f"const double MK_FMU_KNEE_H0 = {_c_double(sim.step_hint)};", ""]
    return source + "\n".join(lines)


def air_flow_functions(variants, table) -> str:
    """``mk_fmu_air_flows(p, Pe, Pf, pe_cmd, pf_cmd, out, fault)``: each muscle's net air mass flow [kg/s], out[0]
    the extensor's, out[1] the flexor's, traced from :func:`mkctl.physics.actuator.air_mass_flow` at the
    regulator's opening (:func:`mkctl.physics.actuator.valve_opening`) for the air's variants, 0 for the others
    (the knee built with the air, outputs ``qe``, ``qf``); a variant with valve openings as inputs
    (``opening``) takes pe_cmd, pf_cmd as the openings (:func:`mkctl.physics.knee.valve_input`)."""
    import sympy

    from ..physics import actuator
    from . import codegen
    Pe, Pf, pe_cmd, pf_cmd = (sympy.Symbol(n, real=True) for n in ("Pe", "Pf", "pe_cmd", "pf_cmd"))
    bindings = {name: f"p[MK_P_{name}]" for name in PARAMETER_NAMES}
    bindings.update(Pe="Pe", Pf="Pf", pe_cmd="pe_cmd", pf_cmd="pf_cmd")
    arguments = "double Pe, double Pf, double pe_cmd, double pf_cmd, double *out, mk_fault *fault"
    call = "Pe, Pf, pe_cmd, pf_cmd, out, fault"

    def flows(params, opening=False):
        from ..physics.knee import valve_input
        return [actuator.air_mass_flow(P, valve_input(command) if opening else
                                       actuator.valve_opening(P, command, params), params)
                for P, command in ((Pe, pe_cmd), (Pf, pf_cmd))]

    parts, cases = [], []
    for k, variant in enumerate(variants):
        if variant.air:
            name = f"fmu_air_flows_{variant.name}"
            sp = codegen.SymbolicParams(variant)
            traced = (codegen.trace(flows, sp, True) if variant.opening
                      else codegen.trace(flows, sp))
            parts.append(codegen.emit_function(name, arguments, call, bindings,
                                               set(PARAMETER_NAMES), traced, "out", table))
            cases.append(f"    case {k}: return {name}_once(p, NULL, {call});")
    parts += ["/* each muscle's net air mass flow [kg/s] (actuator.air_mass_flow at the regulator's opening) */",
              f"int mk_fmu_air_flows(const double *p, {arguments})", "{", "    out[0] = out[1] = 0.0;",
              "    switch (mk_variant(p)) {", *cases, "    }", "    return 0; /* no air: no flow */", "}", ""]
    return "\n".join(parts)


#: The generated unit of an actuator FMU built with the air (:func:`actuator_air_source`).
ACTUATOR_AIR_FILE = "actuator_air.c"
_ACTUATOR_AIR_SOURCES: dict = {}

#: The C API of :func:`actuator_air_source` (``{templates}``, ``{count}``, ``{air_on}``, ``{nz}``,
#: ``{switches}`` filled in).
_ACTUATOR_AIR_API = """
/* ---- the actuator FMU's air (actuator_fmu.c, actuator_me.c) ---- */
void mk_fault_message(const mk_fault *fault, char *msg, size_t size);
void mk_fault_format(const char *template_text, const mk_fault *fault, char *msg, size_t size);
static const char *const air_templates[] = {{{templates}}};

int mk_fmu_actuator_air_on(const double *p) {{ return {air_on}; }}

void mk_fmu_actuator_air_fault(const mk_fault *fault, char *msg, size_t size)
{{
    if (fault->code == MK_FAULT_DOMAIN && fault->check >= 0 && fault->check < {count})
        mk_fault_format(air_templates[fault->check], fault, msg, size);
    else
        mk_fault_message(fault, msg, size);
}}

int mk_fmu_actuator_air_step(const double *p, double P, double P_cmd, double L, double Ldot,
                             double dt, double *out, mk_fault *fault)
{{
    double moving[2], k[MK_MAX_CONSTANTS];
    moving[0] = L;
    moving[1] = Ldot;
    actuator_air_rate_constants(p, moving, k);
    return mk_pressure_integrate(actuator_air_rate, p, moving, k, P, P_cmd, dt, out, fault);
}}

int mk_fmu_actuator_air_rate(const double *p, double P, double P_cmd, double L, double Ldot,
                             double *out, mk_fault *fault)
{{
    double moving[2];
    moving[0] = L;
    moving[1] = Ldot;
    return actuator_air_rate_once(p, moving, P, P_cmd, out, fault);
}}

int mk_fmu_actuator_air_flow(const double *p, double P, double P_cmd, double *out,
                             mk_fault *fault)
{{
    return actuator_air_flow_once(p, NULL, P, P_cmd, out, fault);
}}

const int mk_fmu_actuator_air_nz = {nz};
int mk_fmu_actuator_air_switches(const double *p, double P, double P_cmd, double L, double Ldot,
                                 double *out, mk_fault *fault)
{{
    double moving[2];
    moving[0] = L;
    moving[1] = Ldot;
    {switches}
}}
"""


def actuator_air_source(valves: bool = False) -> tuple[str, int]:
    """The C of one muscle's air for the actuator FMU built with the air (model-spec 4d, 7d), and
    its number of switching functions: a compilation unit of its own beside the core (whose C stays
    as it is), generated from the library's equations like the core.

    - ``mk_fmu_actuator_air_step(p, P, c, L, Ldot, dt, out, fault)``: the pressure after dt, the
      command c (a set-point [Pa], or with ``valves`` the opening u) and L, Ldot held: the rate
      traced from :func:`mkctl.physics.actuator.air_pressure_derivative`, integrated by
      ``mk_pressure_integrate`` (the algorithm of :func:`mkctl.physics.integrate.integrate`) at
      :data:`mkctl.physics.simulate.AIR_STEP_ATOL`, ``AIR_STEP_RTOL``, as
      :class:`mkctl.physics.simulate.ActuatorSimulator` does;
    - ``mk_fmu_actuator_air_rate`` (Model Exchange's derivative), ``mk_fmu_actuator_air_switches``
      (its event indicators: :func:`switching_functions` of the rate), ``mk_fmu_actuator_air_flow``
      (the output q, :func:`mkctl.physics.actuator.air_mass_flow` at the valve's opening),
      ``mk_fmu_actuator_air_on`` (an effect that moves the air is on) and
      ``mk_fmu_actuator_air_fault`` (a fault in the library's words).
    """
    from ..physics import actuator, simulate
    from ..physics.knee import valve_input
    from . import TEMPLATE, build, codegen
    from .variants import Variant, air_effects
    key = (valves, build.input_key([Variant((), air=True, opening=valves)]))
    if key in _ACTUATOR_AIR_SOURCES:
        return _ACTUATOR_AIR_SOURCES[key]
    import sympy
    P, c, L, Ldot = (sympy.Symbol(n, real=True) for n in ("P", "P_cmd", "L", "Ldot"))
    sp = codegen.SymbolicParams(Variant((), air=True))
    table = codegen.CheckTable()
    parameters = {name: f"p[MK_P_{name}]" for name in PARAMETER_NAMES}
    fixed = set(parameters)
    held = {**parameters, "P": "P", "P_cmd": "P_cmd"}
    moving = {**held, "L": "stops[0]", "Ldot": "stops[1]"}  # L, Ldot passed where stops go

    def rate(P, c, L, Ldot, params):
        command = valve_input(c) if valves else c
        return [actuator.air_pressure_derivative(P, command, L, Ldot, params, valves)]

    def flow(P, c, params):
        u = valve_input(c) if valves else actuator.valve_opening(P, c, params)
        return [actuator.air_mass_flow(P, u, params)]

    traced_rate = codegen.trace(rate, P, c, L, Ldot, sp)
    switches = switching_functions(traced_rate.outputs, fixed)
    arguments, call = codegen.PRESSURE_RATE_ARGUMENTS, "P, P_cmd, out, fault"
    parts = [codegen.PRESSURE_INTEGRATOR_DECLARATION,
             codegen.emit_function("actuator_air_rate", arguments, call, moving, fixed, traced_rate,
                                   "out", table),
             codegen.emit_function("actuator_air_flow", arguments, call, held, fixed,
                                   codegen.trace(flow, P, c, sp), "out", table)]
    if switches:
        parts.append(codegen.emit_function("actuator_air_switches", arguments, call, moving, fixed,
                                           codegen.Traced(switches, []), "out", table))
    switches_of = [e.switch_parameter for e in air_effects()]
    air_on = " || ".join(f"(p[MK_P_{q.name}] != {float(q.off)!r})" for q in switches_of) or "0"
    templates = ", ".join(_c_template(_fault_template(check)) for check in table.checks) or '""'
    api = _ACTUATOR_AIR_API.format(
        templates=templates, count=len(table.checks), air_on=air_on, nz=len(switches),
        switches=("return actuator_air_switches_once(p, moving, P, P_cmd, out, fault);" if switches
                  else "(void)p; (void)P; (void)P_cmd; (void)out; (void)fault; (void)moving; "
                       "return 0;"))
    template = TEMPLATE.read_text()  # its head: includes, the parameter macros, mk_fault, mk_fail
    head = template[template.index("#include <math.h>"):
                    template.index("/* ---- generated equations")]
    head = head.replace("@PARAMETER_MACROS@", codegen._parameter_macros())
    integrator = codegen.PRESSURE_INTEGRATOR.replace(
        "@ATOL@", codegen._c_number(simulate.AIR_STEP_ATOL)).replace(
        "@RTOL@", codegen._c_number(simulate.AIR_STEP_RTOL))
    text = "\n".join(["/* Generated by mkctl.native.fmu from mkctl's equations (one muscle's air): "
                      "do not edit. */", head, codegen._tableau(), *parts, integrator, api])
    _ACTUATOR_AIR_SOURCES[key] = (text, len(switches))
    return _ACTUATOR_AIR_SOURCES[key]


def valve_input_refusals() -> str:
    """The C of what a knee FMU with valve inputs refuses at initialization, in the library's
    words: ``MK_FMU_VALVE_AIR_MESSAGE`` (the air switched off:
    :func:`mkctl.physics.simulate.check_inputs`'s error; the core then has no variant for the
    parameters) and ``MK_FMU_VALVE_DELAY_MESSAGE`` (a dead time, which this FMU does not carry: its
    delay line holds pressure commands), naming the switches from the effect registry."""
    from ..physics import effects, simulate
    try:
        off = {e.switch_parameter.name: e.switch_parameter.off
               for e in effects.all_effects() if e.moves_air}
        simulate.check_inputs("opening", Params().replace(**off))
    except ParameterError as error:
        air = str(error)
    else:
        raise NativeBuildError("the library accepts valve openings without the air")
    delays = [e.switch_parameter for e in effects.all_effects() if e.command_delay is not None]
    how = " and ".join(f"{q.name} = {q.off:g}" for q in delays) or "no dead time"
    delay = f"a knee FMU with valve inputs carries no dead time (model-spec 4b): set {how}"
    return "\n".join(["/* a knee FMU with valve inputs: what it refuses at initialization (the "
                      "library's words) */",
                      f"const char MK_FMU_VALVE_AIR_MESSAGE[] = {_c_string(air)};",
                      f"const char MK_FMU_VALVE_DELAY_MESSAGE[] = {_c_string(delay)};", ""])


def switching_functions(expressions, fixed: set[str]) -> list:
    """The functions whose sign change switches a right-hand side (the event indicators of model-spec section 7c),
    read off the traced expressions themselves: the condition of every Piecewise branch (``X < X_low`` gives
    ``X - X_low``), the difference of the arguments of every Max or Min (``Max(f, 0)``, slack, gives ``f``), and
    the argument of every Abs, sign and Heaviside. Those built from ``fixed`` symbols only (parameters, the stop
    positions: constant during a run) never change sign and are left out; each is kept once, up to its sign."""
    import sympy

    found = []

    def add(expression):
        expression = sympy.sympify(expression)
        if {symbol.name for symbol in expression.free_symbols} <= fixed:
            return
        if not any(expression == other or expression == -other for other in found):
            found.append(expression)

    def visit(expression):
        if isinstance(expression, sympy.Piecewise):
            for _, condition in expression.args:
                visit(condition)
        elif isinstance(expression, (sympy.Max, sympy.Min)):
            arguments = sorted(expression.args, key=lambda a: a.is_Number)  # numbers last: Max(0, f) gives f
            for i, a in enumerate(arguments):
                for b in arguments[i + 1:]:
                    add(a - b)
        elif isinstance(expression, (sympy.Abs, sympy.sign, sympy.Heaviside)):
            add(expression.args[0])
        elif isinstance(expression, sympy.core.relational.Relational):
            add(expression.lhs - expression.rhs)
        for argument in expression.args:
            visit(argument)

    for expression in expressions:
        visit(expression)
    return found


#: What Model Exchange expects of the core's generated functions it builds on (codegen.KINDS): their arguments.
_ME_KNEE_RHS_ARGUMENTS = "const double *y, double pe_cmd, double pf_cmd, double *out, mk_fault *fault"
_ME_LAG_ARGUMENTS = "double P, double P_cmd, double dt, double *out, mk_fault *fault"


def model_exchange_functions(emitted: dict, table, variants) -> str:
    """C for Model Exchange, generated from the core's own traced functions (``emitted``: name -> the arguments
    codegen's emit_function got), for every variant, with a dispatcher on the variant of p:

    - ``mk_fmu_knee_event_indicators(p, stops, y, pe_cmd, pf_cmd, out, fault)``: the switching functions
      (:func:`switching_functions`) of the knee's right-hand side ``knee_rhs_<variant>``, ``MK_FMU_KNEE_NZ`` values
      (a variant with fewer pads with 1.0, which never changes sign);
    - ``mk_fmu_actuator_pressure_rate(p, P, P_cmd, out, fault)``: dP/dt of the actuator, the derivative at dt = 0
      of the core's exact lag ``actuator_lagged_pressure_<variant>`` (sympy.diff; 0 without a lag), or where no
      exact step covers the variant's pressure dynamics, the core's traced rate ``actuator_pressure_rate_<variant>``;
    - ``mk_fmu_actuator_event_indicators(p, P, P_cmd, out, fault)``: the switching functions of that rate.
    """
    import re

    import sympy

    from . import codegen

    parts = []
    names = [v.name for v in variants]

    def dispatcher(signature, cases, count, fill):
        lines = [f"int {signature}", "{", "    int i;", f"    for (i = 0; i < {count}; i++) out[i] = {fill};",
                 "    (void)i;", "    switch (mk_variant(p)) {"]
        lines += [f"    case {k}: return {call};" for k, call in cases]
        lines += ["    }", "    return mk_fault_code(fault, MK_FAULT_VARIANT);", "}", ""]
        return lines

    def generated(kind, variant):
        name = f"{kind}_{variant}"
        if name not in emitted:
            raise NativeBuildError(f"the generated core has no {name}: Model Exchange builds on it")
        return emitted[name]

    # the knee: the switching functions of the right-hand side
    knee_cases, knee_counts = [], []
    for k, variant in enumerate(names):
        arguments, call, bindings, constant, traced = generated("knee_rhs", variant)
        if arguments != _ME_KNEE_RHS_ARGUMENTS:
            raise NativeBuildError(f"knee_rhs takes ({arguments}); Model Exchange expects ({_ME_KNEE_RHS_ARGUMENTS})")
        switches = switching_functions(traced.outputs, set(constant))
        knee_counts.append(len(switches))
        if switches:
            name = f"fmu_knee_switches_{variant}"
            parts.append(codegen.emit_function(name, arguments, call, bindings, constant,
                                               codegen.Traced(switches, []), "out", table))
            knee_cases.append((k, f"{name}_once(p, stops, {call})"))
        else:
            knee_cases.append((k, "0"))
    knee_nz = max(knee_counts)
    parts += [f"#define MK_FMU_KNEE_NZ {knee_nz}",
              "/* the knee's event indicators: where its right-hand side switches (knee.knee_derivatives) */",
              *dispatcher("mk_fmu_knee_event_indicators(const double *p, const double *stops, const double *y, "
                          "double pe_cmd, double pf_cmd, double *out, mk_fault *fault)", knee_cases, knee_nz, "1.0")]

    # the actuator: dP/dt from the exact lag, and its switching functions
    rate_cases, switch_cases, actuator_counts = [], [], []
    for k, variant in enumerate(names):
        if f"actuator_pressure_rate_{variant}" in emitted:  # no exact step: the core integrates this rate itself
            arguments, call, bindings, constant, traced = generated("actuator_pressure_rate", variant)
            if arguments != codegen.PRESSURE_RATE_ARGUMENTS:
                raise NativeBuildError(f"actuator_pressure_rate takes ({arguments}); Model Exchange expects "
                                       f"({codegen.PRESSURE_RATE_ARGUMENTS})")
            rate, call_at_0 = traced.outputs[0], call
        else:
            arguments, call, bindings, constant, traced = generated("actuator_lagged_pressure", variant)
            if arguments != _ME_LAG_ARGUMENTS:
                raise NativeBuildError(f"actuator_lagged_pressure takes ({arguments}); Model Exchange expects "
                                       f"({_ME_LAG_ARGUMENTS})")
            dt = sympy.Symbol("dt", real=True)
            rate = sympy.diff(traced.outputs[0], dt).subs(dt, 0)
            call_at_0 = re.sub(r"\bdt\b", "0.0", call)
        name = f"fmu_actuator_rate_{variant}"
        parts.append(codegen.emit_function(name, arguments, call, bindings, constant, codegen.Traced([rate], []),
                                           "out", table))
        rate_cases.append((k, f"{name}_once(p, NULL, {call_at_0})"))
        switches = switching_functions([rate], set(constant))
        actuator_counts.append(len(switches))
        if switches:
            name = f"fmu_actuator_switches_{variant}"
            parts.append(codegen.emit_function(name, arguments, call, bindings, constant,
                                               codegen.Traced(switches, []), "out", table))
            switch_cases.append((k, f"{name}_once(p, NULL, {call_at_0})"))
        else:
            switch_cases.append((k, "0"))
    actuator_nz = max(actuator_counts)
    parts += ["/* the actuator's dP/dt [Pa/s]: d/d(dt) of actuator.lagged_pressure at dt = 0 */",
              *dispatcher("mk_fmu_actuator_pressure_rate(const double *p, double P, double P_cmd, double *out, "
                          "mk_fault *fault)", rate_cases, 1, "0.0"),
              f"#define MK_FMU_ACTUATOR_NZ {actuator_nz}",
              "/* the actuator's event indicators: where its dP/dt switches */",
              *dispatcher("mk_fmu_actuator_event_indicators(const double *p, double P, double P_cmd, double *out, "
                          "mk_fault *fault)", switch_cases, actuator_nz, "1.0"),
              "const int mk_fmu_knee_nz = MK_FMU_KNEE_NZ;", "const int mk_fmu_actuator_nz = MK_FMU_ACTUATOR_NZ;",
              ""]
    return "\n".join(parts)


def core_compiler_flags() -> tuple[str, ...]:
    """The core's compiler flags (no fused multiply-add, no fast-math: the C rounds as Python does)."""
    from .build import CFLAGS
    return tuple(CFLAGS)


def write_sources(interface: Interface, guid: str, dest: Path, model_source: Path | None = None) -> list[str]:
    """Write every source file of the FMU into dest; returns the compilation units (file names).

    model_source: another model part than the model's own (the benchmark's no-op FMU measures fmpy's cost)."""
    dest.mkdir(parents=True, exist_ok=True)
    headers = fmi2_headers()
    for name in ("fmi2Functions.h", "fmi2FunctionTypes.h", "fmi2TypesPlatform.h"):
        shutil.copy2(headers / name, dest / name)
    shutil.copy2(C_DIR / "mk_fmu.h", dest / "mk_fmu.h")
    shutil.copy2(C_DIR / "mk_core_api.h", dest / "mk_core_api.h")  # the FMUs' view of the core
    shutil.copy2(C_DIR / "mk_run.h", dest / "mk_run.h")  # the run's checks and Model Exchange, for every wrapper
    model_sources = interface.model_sources or (MODEL_SOURCES[interface.model_name],
                                                ME_SOURCES[interface.model_name])
    own = [*WRAPPER_SOURCES, *model_sources, "mk_core_api.c"]
    for name in own:
        shutil.copy2(C_DIR / name, dest / name)
    if model_source is not None:
        shutil.copy2(model_source, dest / model_sources[0])
    units = [*own, "model_variables.c"]
    for name, text in interface.generated_sources:  # a header is written, not compiled
        (dest / name).write_text(text)
        if not name.endswith(".h"):
            units.append(name)
    (dest / "model_variables.h").write_text(variables_header(interface, guid))
    (dest / "model_variables.c").write_text(variables_source(interface))
    (dest / "mkctl_core.c").write_text(core_source(interface.air, interface.valves))
    units.append("mkctl_core.c")
    return units


def _compiler_flags() -> list[str]:
    flags = [f for f in core_compiler_flags() if f not in ("-O2", "-fPIC", "-shared")]
    return ["-O2", "-fPIC", *flags, "-fvisibility=hidden", "-Wall"]


def _run_compiler(command: list[str], what: str) -> None:
    done = subprocess.run(command, capture_output=True, text=True)
    if done.returncode != 0:
        raise NativeBuildError(f"compiling {what} failed:\n{done.stderr.strip()[-3000:]}")


def _core_object(sources: Path, compiler: list[str]) -> Path:
    """mkctl_core.c compiled once (the largest unit by far, the same in both FMUs), cached beside its source."""
    import hashlib

    from . import build
    source = (sources / "mkctl_core.c").read_bytes()
    key = hashlib.sha256(source + " ".join([*compiler, *_compiler_flags()]).encode()).hexdigest()[:20]
    target = build.cache_dir() / f"fmu-core-{key}.o"
    if target.is_file():
        return target
    with build.cache_lock(target):  # processes starting together compile it once
        if not target.is_file():
            target.parent.mkdir(parents=True, exist_ok=True)
            temporary = target.with_name(f"{target.name}.{os.getpid()}.tmp")
            _run_compiler([*compiler, *_compiler_flags(), "-c", "-o", str(temporary),
                           str(sources / "mkctl_core.c")], "mkctl_core.c")
            os.replace(temporary, target)
    return target


def compile_binary(sources: Path, units: list[str], target: Path, compiler: list[str] | None = None,
                   link_flags: tuple[str, ...] = ()) -> None:
    """Compile the units into a shared library (only the fmi2* functions exported), with the compiler the core
    uses (:func:`mkctl.native.build.find_compiler`: $CC, else cc, gcc or clang), or another one (a cross compiler,
    :mod:`mkctl.native.cross`) with its own link_flags."""
    from .build import find_compiler
    found = find_compiler() if compiler is None else compiler
    if found is None:
        raise NativeBuildError("no C compiler found (CC, cc, gcc, clang): the native FMUs need one to build")
    target.parent.mkdir(parents=True, exist_ok=True)
    objects = [str(_core_object(sources, found))] if "mkctl_core.c" in units else []
    own = [str(sources / u) for u in units if u != "mkctl_core.c"]
    _run_compiler([*found, *_compiler_flags(), "-shared", *link_flags, "-I", str(sources), "-o", str(target), *own,
                   *objects, "-lm"], target.name)


def _validate(fmu: Path) -> None:
    from fmpy.validation import validate_fmu
    problems = validate_fmu(str(fmu))
    if problems:
        raise NativeBuildError(f"{fmu.name} failed fmpy's validation:\n  " + "\n  ".join(problems))


def build_one(model_name: str, target: Path, params: Params | None = None, model_source: Path | None = None,
              windows: bool = True, interface: Interface | None = None, air: bool = False,
              valves: bool = False) -> Path:
    """Generate, compile, pack and validate one native FMU at target (model_source: see :func:`write_sources`).
    windows=False leaves out the other platforms' binaries (otherwise added when their toolchains
    are installed: :mod:`mkctl.native.cross`): a fraction of the build's compiling, for an FMU that
    will only run here. interface: another model's (a mechanism's), in place of the slave's. air:
    the knee built with the air (:func:`build_native`); valves: with valve openings as inputs."""
    if interface is None:
        interface = slave_interface(model_name, params, air, valves)
    guid = "{" + str(uuid.uuid4()) + "}"
    with tempfile.TemporaryDirectory(prefix="mkctl_native_") as temp:
        stage = Path(temp) / "fmu"
        units = write_sources(interface, guid, stage / "sources", model_source)
        (stage / "modelDescription.xml").write_bytes(
            model_description(interface, guid, units, event_indicator_count(interface)))
        compile_binary(stage / "sources", units, stage / "binaries" / "linux64" / f"{model_name}.so")
        if windows:  # win64 and darwin64 too, when their toolchains are installed (cross.py)
            from .cross import add_platform_binaries
            add_platform_binaries(stage / "sources", units, stage / "binaries", model_name, "2.0",
                                  compile_binary)
        target.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as fmu:
            for path in sorted(stage.rglob("*")):
                if path.is_file():
                    fmu.write(path, path.relative_to(stage).as_posix())
    _validate(target)
    return target


def build_native(out: Path, params: Params | None = None, air: bool | None = None,
                 valves: bool = False) -> dict[str, Path]:
    """Write ``out/native/McKibbenKnee.fmu`` and ``out/native/McKibbenActuator.fmu``; returns their paths by
    model name. params: a :class:`Params` whose values become the start values (default: Table I, II, effects off).
    air: build the knee with the air (model-spec 7d: its parameters offered, the core's air variants compiled in);
    None: when params switch it on. valves: with valve openings as inputs in place of the pressure
    commands (model-spec 7d: the knee's ue, uf, the actuator's u; the air built in and switched on
    in its start values: :func:`with_valves`). Raises :class:`NativeBuildError` (no compiler, a
    compile error, fmpy's validation failing)."""
    folder = Path(out) / "native"
    air = wants_air(params) if air is None else air
    return {name: build_one(name, folder / f"{name}.fmu", params, air=air, valves=valves)
            for name in MODEL_NAMES}


def with_valves(params: Params | None) -> Params:
    """params (default: the defaults, ``Params()``) with the air on, as an FMU with valve inputs
    needs it: the switch of the effect that opens a valve (valve_flow) set to 1 when no effect
    that moves the air is on."""
    from ..physics import effects
    from ..physics.actuator import air_is_on
    params = Params() if params is None else params
    if air_is_on(params):
        return params
    return params.replace(**{e.switch_parameter.name: 1 for e in effects.all_effects()
                             if e.valve_opening is not None})


def wants_air(params: Params | None) -> bool:
    """Whether params switch on an effect that moves the air (an FMU built for them needs the air)."""
    from ..physics.actuator import air_is_on
    return params is not None and air_is_on(params)


def command_line(argv, build, description: str, folder: str, program: str) -> int:
    """The small command line of a native build (``python -m mkctl.native.fmu``, ``python -m mkctl.native.fmi3``):
    ``build(out)`` writes the FMUs into ``OUT/<folder>``; one line per FMU, or one line and exit 2 on an error."""
    parser = argparse.ArgumentParser(description=description)
    parser.add_argument("--out", type=Path, default=Path("dist"), help="output folder (default: dist in the "
                        f"working folder); the FMUs go into OUT/{folder}")
    parser.add_argument("--air", action="store_true", help="build the knee with the air in the muscles "
                        "(model-spec 7d: the valve's and the volume's parameters; about a third more C)")
    parser.add_argument("--valve-inputs", action="store_true",
                        help="build with the air and the valves' openings in [-1, 1] as inputs "
                             "(model-spec 7d): the knee's ue, uf instead of pe_cmd, pf_cmd, the "
                             "actuator's u instead of p_cmd")
    args = parser.parse_args(argv)
    try:
        built = (build(args.out, air=True, valves=True) if args.valve_inputs else
                 build(args.out, air=True) if args.air else build(args.out))
    except MkctlError as error:
        print(f"{program}: {error}", file=sys.stderr)
        return 2
    for path in built.values():
        print(f"built {path} (validated)")
    return 0


def main(argv=None) -> int:
    return command_line(argv, build_native, "Build the native FMUs (model-spec section 7b).", "native",
                        "mkctl.native.fmu")

if __name__ == "__main__":
    sys.exit(main())
