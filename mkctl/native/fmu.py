"""Native FMUs (model-spec section 7b): the knee and the actuator as FMI 2.0 co-simulation FMUs in compiled C.

    python -m mkctl.native.fmu [--out DIR]      # writes DIR/native/McKibbenKnee.fmu, DIR/native/McKibbenActuator.fmu

:func:`build_native` writes FMUs with the same model names, variables (names, value references, causality,
variability, units, descriptions, start values) and default experiments as the pythonfmu FMUs of ``build_fmu.py``,
because it reads them from the same declaration: it instantiates the pythonfmu slave classes of
:mod:`mkctl.fmu.models` and walks their registered variables (start values for a Params from their
``start_values``). The model code is
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
from xml.dom.minidom import parseString
from xml.etree import ElementTree as ET

from ..errors import MkctlError, ParameterError
from ..fmu.units import fmi_unit, unit_definitions
from ..physics.params import DEFAULT, PARAMETER_NAMES, Params

HERE = Path(__file__).resolve().parent
C_DIR = HERE / "fmu_c"
#: The models, named as the pythonfmu slave classes of :mod:`mkctl.fmu.models` whose interface they repeat.
MODEL_NAMES = ("McKibbenKnee", "McKibbenActuator")
#: The model's part of the wrapper, by model name.
MODEL_SOURCES = {"McKibbenKnee": "knee_fmu.c", "McKibbenActuator": "actuator_fmu.c"}

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
    """One FMU variable, as the pythonfmu slave declares it."""

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

    def by_name(self) -> dict[str, Variable]:
        return {v.name: v for v in self.variables}


def _load_slave_class(model_name: str):
    """The pythonfmu slave class of a model (:mod:`mkctl.fmu.models`)."""
    from ..fmu import models
    return getattr(models, model_name)


def slave_interface(model_name: str, params: Params | None = None) -> Interface:
    """The interface of a model's pythonfmu slave, start values taken from params (default: the slave's own).

    With params, every parameter starts at params' value, ``X0`` (knee) at the hip height at alpha = 60 deg of
    params' geometry and the knee's input commands at the pressures that hold it there.
    """
    cls = _load_slave_class(model_name)
    slave = cls(instance_name="mkctl-native-build")
    starts = {} if params is None else cls.start_values(params)  # the slave's own start values for a Params
    variables = []
    for vr, var in slave.vars.items():
        kind = type(var).__name__
        causality = var.causality.name
        start = None
        if causality != "output":
            start = starts.get(var.name, getattr(slave, var.name))
            start = int(start) if kind == "Integer" else float(start)
        unit = fmi_unit(slave.units[var.name]) if kind == "Real" else None
        variables.append(Variable(var.name, vr, kind, causality, var.variability.name, var.description, unit,
                                  start))
    experiment = cls.default_experiment
    default_experiment = {key: str(value) for key, value in (("startTime", experiment.start_time),
                                                             ("stopTime", experiment.stop_time),
                                                             ("stepSize", experiment.step_size),
                                                             ("tolerance", experiment.tolerance))
                          if value is not None}
    return Interface(model_name, cls.description, cls.author, default_experiment, tuple(variables),
                     cls.undefined_outputs, dict(getattr(cls, "pressure_outputs", {})))


def parameter_rule(name: str) -> str:
    """The check :class:`Params` applies to a Real parameter on its own: "positive", "not_negative" or "any".

    Read from Params itself (a value of 0 or -1 in an otherwise default set), so that the C wrapper checks what
    the library checks. ``n`` is "any" here: the wrapper checks it only when it is given (not left at its start).
    """
    if name not in DEFAULT.as_dict() or name in ("n", "model"):
        return "any"
    for value, rule, words in ((0.0, "positive", "must be positive"), (-1.0, "not_negative", "must not be negative")):
        try:
            DEFAULT.replace(**{name: value})
        except ParameterError as error:
            if words in str(error):
                return rule
    return "any"


def integer_rule(name: str) -> tuple[int, int, str]:
    """(low, high, message) of an Integer parameter: the values Params accepts (a range) and its message for a
    bad one, with "%d" for the value; read from Params itself."""
    allowed = []
    for value in range(-3, 6):
        try:
            DEFAULT.replace(**{name: value})
            allowed.append(value)
        except ParameterError:
            pass
    if not allowed or allowed != list(range(allowed[0], allowed[-1] + 1)):
        raise NativeBuildError(f"Integer parameter {name}: Params accepts {allowed}, not a range")
    bad = 987654
    try:
        DEFAULT.replace(**{name: bad})
    except ParameterError as error:
        message = str(error).replace("%", "%%")
    else:
        raise NativeBuildError(f"Integer parameter {name}: Params accepts {bad}")
    if str(bad) not in message:
        raise NativeBuildError(f"Integer parameter {name}: Params' message does not show the value: {message}")
    return allowed[0], allowed[-1], message.replace(str(bad), "%d")


# --- generated files -------------------------------------------------------------------------------------------

def model_description(interface: Interface, guid: str, source_files: list[str]) -> bytes:
    """modelDescription.xml of the native FMU (FMI 2.0 co-simulation, source files listed)."""
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "2.0", "modelName": interface.model_name, "guid": guid,
        "description": interface.description, "author": interface.author,
        "generationTool": "mkctl.native.fmu (C generated from mkctl's equations)",
        "generationDateAndTime": now, "variableNamingConvention": "structured",
        "numberOfEventIndicators": "0"})
    cosim = ET.SubElement(root, "CoSimulation", {
        "modelIdentifier": interface.model_name, "needsExecutionTool": "false",
        "canHandleVariableCommunicationStepSize": "true", "canInterpolateInputs": "false",
        "canBeInstantiatedOnlyOncePerProcess": "false", "canNotUseMemoryManagementFunctions": "true",
        "canGetAndSetFMUstate": "true", "canSerializeFMUstate": "true",
        "providesDirectionalDerivative": "false"})
    sources = ET.SubElement(cosim, "SourceFiles")
    for name in source_files:
        ET.SubElement(sources, "File", name=name)
    try:
        root.append(unit_definitions(v.unit for v in interface.variables if v.unit is not None))
    except ValueError as error:
        raise NativeBuildError(str(error)) from None
    categories = ET.SubElement(root, "LogCategories")
    for name, text in _LOG_CATEGORIES.items():
        ET.SubElement(categories, "Category", name=name, description=text)
    ET.SubElement(root, "DefaultExperiment", interface.default_experiment)
    variables = ET.SubElement(root, "ModelVariables")
    for v in interface.variables:
        node = ET.SubElement(variables, "ScalarVariable", {
            "name": v.name, "valueReference": str(v.vr), "description": v.description, "causality": v.causality,
            "variability": v.variability})
        attributes = {}
        if v.start is not None:
            attributes["start"] = repr(v.start)
        if v.unit is not None:
            attributes["unit"] = v.unit
        ET.SubElement(node, v.type, attributes)
    structure = ET.SubElement(root, "ModelStructure")
    indices = [str(k) for k, v in enumerate(interface.variables, start=1) if v.causality == "output"]
    for section in ("Outputs", "InitialUnknowns"):
        node = ET.SubElement(structure, section)
        for index in indices:
            ET.SubElement(node, "Unknown", index=index)
    return parseString(ET.tostring(root, "UTF-8")).toprettyxml(indent="\t", encoding="UTF-8")


def _c_string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _c_double(value: float) -> str:
    if not math.isfinite(value):
        raise NativeBuildError(f"start value {value!r} is not a finite number")
    return repr(float(value))


def _core_has_slack() -> bool:
    """Whether the compiled core tells slack = 1 from slack = 0: its variants follow every structural effect of
    the registry, slack included."""
    from .variants import structural_effects
    return any(e.name == "slack" for e in structural_effects())


def variables_header(interface: Interface, guid: str) -> str:
    """model_variables.h: names, value references, GUID."""
    lines = ["/* Generated by mkctl.native.fmu from the pythonfmu slave's interface: do not edit. */",
             "#ifndef MODEL_VARIABLES_H", "#define MODEL_VARIABLES_H", "",
             f"#define MK_MODEL_NAME {_c_string(interface.model_name)}",
             f"#define MK_GUID {_c_string(guid)}",
             f"#define MK_UNDEFINED_OUTPUTS {_c_string(interface.undefined_outputs)}",
             f"#define NV {len(interface.variables)}",
             f"#define MK_NPARAM {len(PARAMETER_NAMES)} /* the core's parameter vector */",
             f"#define MK_CORE_HAS_SLACK {int(_core_has_slack())} /* the core generates slack = 1 variants */", ""]
    for v in interface.variables:
        if not v.name.isidentifier():
            raise NativeBuildError(f"variable name {v.name!r} is not a C identifier")
        lines.append(f"#define VR_{v.name} {v.vr}")
    lines += ["", "#endif", ""]
    return "\n".join(lines)


def variables_source(interface: Interface) -> str:
    """model_variables.c: the table of variables (start values exact to the last bit), check order, inputs."""
    types = {"Real": "MK_REAL", "Integer": "MK_INTEGER", "Boolean": "MK_BOOLEAN"}
    causalities = {"input": "MK_INPUT", "parameter": "MK_PARAMETER", "output": "MK_OUTPUT"}
    rules = {"any": "MK_ANY", "positive": "MK_POSITIVE", "not_negative": "MK_NOT_NEGATIVE"}
    lines = ["/* Generated by mkctl.native.fmu from the pythonfmu slave's interface: do not edit. */",
             '#include "mk_fmu.h"', "", "const mk_variable mk_variables[NV] = {"]
    for v in sorted(interface.variables, key=lambda v: v.vr):
        rule = parameter_rule(v.name) if v.causality == "parameter" and v.type == "Real" else "any"
        start = _c_double(v.start) if v.start is not None else "0.0"
        lines.append(f"    {{{_c_string(v.name)}, {types[v.type]}, {causalities[v.causality]}, {rules[rule]}, "
                     f"{_c_string(v.unit or '')}, {start}}}, /* vr {v.vr} */")
    lines.append("};")
    names = interface.by_name()
    order = [names[f].vr for f in DEFAULT.as_dict()
             if f in names and names[f].causality == "parameter" and names[f].type == "Real"]
    inputs = [v.vr for v in interface.variables if v.causality == "input"]
    integer_rules = [(v.vr, *integer_rule(v.name)) for v in interface.variables
                     if v.causality == "parameter" and v.type == "Integer"]
    lines += [f"const int mk_params_order[] = {{{', '.join(map(str, order))}}};",
              f"const int mk_n_params_order = {len(order)};",
              f"const int mk_inputs[] = {{{', '.join(map(str, inputs))}}};",
              f"const int mk_n_inputs = {len(inputs)};",
              "const mk_integer_rule mk_integer_rules[] = {",
              *[f"    {{{vr}, {low}, {high}, {_c_string(message)}}}," for vr, low, high, message in integer_rules],
              "    {-1, 0, 0, \"\"}", "};", f"const int mk_n_integer_rules = {len(integer_rules)};",
              "const mk_pressure_output mk_pressure_outputs[] = {",
              *[f"    {{{names[o].vr}, {_c_string(muscle)}}}," for o, muscle in interface.pressure_outputs.items()
                if "P_rated" in names],
              "    {-1, \"\"}", "};",
              f"const int mk_n_pressure_outputs = {len(interface.pressure_outputs) if 'P_rated' in names else 0};",
              "",
              "void mk_param_vector(const mk_data *d, double n, double *p)", "{"]
    for index, name in enumerate(PARAMETER_NAMES):
        if name == "n":
            lines.append(f"    p[{index}] = n; /* n, given or derived */")
        elif name in names:
            lines.append(f"    p[{index}] = d->v[VR_{name}];")
        else:
            lines.append(f"    p[{index}] = {_c_double(getattr(DEFAULT, name))}; /* {name}: not a variable here, "
                         "Params' default */")
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
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"').replace("\001", '\\001""') + '"'


_core_sources: dict[str, str] = {}


def core_source() -> str:
    """:func:`generate_core_source`, cached on disk beside the core's own generated sources
    (:func:`mkctl.native.build.cache_dir`), keyed by everything it is generated from (the core's inputs and
    this module): tracing the equations takes seconds, and every build of the FMUs needs the same text."""
    import hashlib

    from . import build
    from .variants import all_variants
    digest = hashlib.sha256(build.input_key(all_variants()).encode())
    digest.update(Path(__file__).read_bytes())
    key = digest.hexdigest()[:20]  # the registry's effects included: an effect registered since then counts
    if key in _core_sources:
        return _core_sources[key]
    path = build.cache_dir() / f"fmu-core-{key}.c"
    if path.is_file():
        _core_sources[key] = path.read_text()
        return _core_sources[key]
    text = _core_sources[key] = generate_core_source()
    try:
        build._write_atomic(path, text.encode())
    except OSError:  # a read-only cache only costs time
        pass
    return text


def generate_core_source() -> str:
    """The C of the compiled core (:mod:`mkctl.native.codegen`, every variant) with the FMUs' additions, all
    generated from mkctl's equations: the hip height at a kneecap angle (knee.X_from_alpha, for the default X0),
    the posture at a hip height (knee.geometry_at_X, for the outputs that can still be given when the pressures
    are not numbers), every domain check's message, and KneeSimulator's integrator settings."""
    import sympy

    from ..physics import integrate, knee
    from ..physics.params import PARAMETER_NAMES
    from ..physics.simulate import KneeSimulator
    from ..physics.stability import DEFAULT_ALPHA
    from . import codegen
    from .variants import all_variants

    collected = []  # every check, in the order the CheckTable numbers them
    original = codegen.CheckTable.add

    def add(self, check):
        collected.append(check)
        return original(self, check)

    codegen.CheckTable.add = add
    try:
        source, entries = codegen.generate_source(all_variants())
        table = codegen.CheckTable()
        table.entries = list(entries)
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
            "{", "    return fmu_posture_once(p, NULL, X, out, fault);", "}", ""]
    finally:
        codegen.CheckTable.add = original
    if len(collected) != len(table.entries):
        raise NativeBuildError("the core's domain checks could not be collected in order")
    sim = KneeSimulator(Params(tau=1.0))
    lines = ["", "/* ---- added for the native FMUs by mkctl/native/fmu.py (generated too) ---- */", *extra,
             "const char *const mk_fmu_fault_templates[] = {",
             *[f"    {_c_template(_fault_template(check))}," for check in collected], "};",
             f"const int mk_fmu_fault_count = {len(collected)};",
             f"const char MK_FMU_COLLAPSE_MESSAGE[] = {_c_string(integrate.COLLAPSE_MESSAGE)};",
             f"const char MK_FMU_TOO_MANY_STEPS_MESSAGE[] = {_c_string(integrate.TOO_MANY_STEPS_MESSAGE)};",
             f"const double MK_FMU_DEFAULT_ALPHA = {_c_double(DEFAULT_ALPHA)};",
             f"const double MK_FMU_KNEE_RTOL = {_c_double(sim.rtol)};",
             "const double MK_FMU_KNEE_ATOL[4] = {" + ", ".join(_c_double(a) for a in sim.atol) + "};",
             f"const double MK_FMU_KNEE_H0 = {_c_double(sim.step_hint)};", ""]
    return source + "\n".join(lines)


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
    units = ["fmi2_wrapper.c", MODEL_SOURCES[interface.model_name], "mk_core_api.c", "model_variables.c"]
    for name in units[:3]:
        shutil.copy2(C_DIR / name, dest / name)
    if model_source is not None:
        shutil.copy2(model_source, dest / units[1])
    (dest / "model_variables.h").write_text(variables_header(interface, guid))
    (dest / "model_variables.c").write_text(variables_source(interface))
    (dest / "mkctl_core.c").write_text(core_source())
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
    if not target.is_file():
        target.parent.mkdir(parents=True, exist_ok=True)
        temporary = target.with_name(f"{target.name}.{os.getpid()}.tmp")
        _run_compiler([*compiler, *_compiler_flags(), "-c", "-o", str(temporary), str(sources / "mkctl_core.c")],
                      "mkctl_core.c")
        os.replace(temporary, target)
    return target


def compile_binary(sources: Path, units: list[str], target: Path) -> None:
    """Compile the units into a shared library (only the fmi2* functions exported), with the compiler the core
    uses (:func:`mkctl.native.build.find_compiler`: $CC, else cc, gcc or clang)."""
    from .build import find_compiler
    found = find_compiler()
    if found is None:
        raise NativeBuildError("no C compiler found (CC, cc, gcc, clang): the native FMUs need one to build")
    target.parent.mkdir(parents=True, exist_ok=True)
    objects = [str(_core_object(sources, found))] if "mkctl_core.c" in units else []
    own = [str(sources / u) for u in units if u != "mkctl_core.c"]
    _run_compiler([*found, *_compiler_flags(), "-shared", "-I", str(sources), "-o", str(target), *own, *objects,
                   "-lm"], target.name)


def _validate(fmu: Path) -> None:
    from fmpy.validation import validate_fmu
    problems = validate_fmu(str(fmu))
    if problems:
        raise NativeBuildError(f"{fmu.name} failed fmpy's validation:\n  " + "\n  ".join(problems))


def build_one(model_name: str, target: Path, params: Params | None = None, model_source: Path | None = None) -> Path:
    """Generate, compile, pack and validate one native FMU at target (model_source: see :func:`write_sources`)."""
    interface = slave_interface(model_name, params)
    guid = "{" + str(uuid.uuid4()) + "}"
    with tempfile.TemporaryDirectory(prefix="mkctl_native_") as temp:
        stage = Path(temp) / "fmu"
        units = write_sources(interface, guid, stage / "sources", model_source)
        (stage / "modelDescription.xml").write_bytes(model_description(interface, guid, units))
        compile_binary(stage / "sources", units, stage / "binaries" / "linux64" / f"{model_name}.so")
        target.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as fmu:
            for path in sorted(stage.rglob("*")):
                if path.is_file():
                    fmu.write(path, path.relative_to(stage).as_posix())
    _validate(target)
    return target


def build_native(out: Path, params: Params | None = None) -> dict[str, Path]:
    """Write ``out/native/McKibbenKnee.fmu`` and ``out/native/McKibbenActuator.fmu``; returns their paths by
    model name. params: a :class:`Params` whose values become the start values (default: Table I, II, effects off).
    Raises :class:`NativeBuildError` (no compiler, a compile error, fmpy's validation failing)."""
    folder = Path(out) / "native"
    return {name: build_one(name, folder / f"{name}.fmu", params) for name in MODEL_NAMES}


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description="Build the native FMUs (model-spec section 7b).")
    parser.add_argument("--out", type=Path, default=Path("dist"), help="output folder (default: dist in the "
                        "working folder); the FMUs go into OUT/native")
    args = parser.parse_args(argv)
    try:
        built = build_native(args.out)
    except MkctlError as error:
        print(f"mkctl.native.fmu: {error}", file=sys.stderr)
        return 2
    for path in built.values():
        print(f"built {path} (validated)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
