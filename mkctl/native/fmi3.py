"""FMI 3.0 twins of the native FMUs (model-spec section 7c): ``dist/fmi3/McKibbenKnee.fmu``, ``McKibbenActuator.fmu``.

    python -m mkctl.native.fmi3 [--out DIR]      # writes DIR/fmi3/McKibbenKnee.fmu, DIR/fmi3/McKibbenActuator.fmu

Same variables (names, value references, causality, variability, units, descriptions, start values), model
names and default experiments as the FMI 2.0 FMUs, read from the same declarations (:func:`mkctl.native.fmu.
slave_interface` and the Model Exchange variables of :func:`mkctl.native.fmu.me_variables`), plus what FMI 3.0
asks for: the independent variable ``time`` (value reference: the one after the FMI 2.0 FMU's variables, ``NV``)
and one variable per event indicator (``event_indicator_1`` ..., the value references after ``time``). The C is the
FMI 2.0 FMU's (:func:`mkctl.native.fmu.write_sources`) with ``fmi3_wrapper.c`` in place of ``fmi2_wrapper.c``: the
FMI 3.0 functions over the FMI 2.0 implementation (included, under other names), so both FMUs compute the same
numbers with the same code. Types: Real -> Float64, Integer -> Int32, Boolean -> Boolean. Both interfaces, Model
Exchange and Co-Simulation (no event mode in Co-Simulation).

Each FMU carries ``sources/`` (an FMI 3.0 source-code FMU: ``sources/buildDescription.xml`` lists the compilation
units) and the binaries ``binaries/x86_64-linux/<model>.so`` and, when their toolchains are installed
(:mod:`mkctl.native.cross`: MinGW-w64 or ziglang), ``x86_64-windows/<model>.dll``, ``aarch64-linux/<model>.so``,
``x86_64-darwin/<model>.dylib`` and ``aarch64-darwin/<model>.dylib``. Building needs what the FMI 2.0 native FMUs
need (a C compiler, sympy) and fmpy's FMI 3.0 headers (``fmpy/c-code``).
"""
from __future__ import annotations

import datetime
import shutil
import sys
import tempfile
import uuid
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from ..fmi.xml import xml_bytes
from ..physics.params import Params
from . import fmu as fmi2
from .fmu import C_DIR, MODEL_NAMES, Interface, NativeBuildError

#: The FMI 3.0 platform tuples of the binaries (FMI 2.0: linux64, win64).
LINUX = "x86_64-linux"
WINDOWS = "x86_64-windows"
HEADERS = ("fmi3Functions.h", "fmi3FunctionTypes.h", "fmi3PlatformTypes.h")
#: FMI 3.0 variable types of the FMI 2.0 ones.
TYPES = {"Real": "Float64", "Integer": "Int32", "Boolean": "Boolean"}
#: The independent variable every FMI 3.0 FMU declares.
TIME = ("time", "simulation time", "s")
#: FMI 3.0 declares event indicators as variables (ModelStructure/EventIndicator): their names, numbered from 1.
EVENT_INDICATOR = "event_indicator_{}"


def fmi3_headers() -> Path:
    """The folder with the FMI 3.0 headers (fmpy ships the standard ones, beside the FMI 2.0 ones)."""
    folder = fmi2.fmi2_headers()
    missing = [name for name in HEADERS if not (folder / name).is_file()]
    if missing:
        raise NativeBuildError(f"no FMI 3.0 headers {missing} in {folder} (fmpy >= 0.3 ships them)")
    return folder


def all_variables(interface: Interface) -> tuple:
    """The FMI 2.0 FMU's variables: the slave's and those Model Exchange adds (value references 0 .. NV-1)."""
    variables = interface.variables + fmi2.me_variables(interface)
    references = sorted(v.vr for v in variables)
    if references != list(range(len(references))):
        raise NativeBuildError(f"{interface.model_name}: value references are not 0 .. {len(references) - 1}")
    return variables


def time_reference(interface: Interface) -> int:
    """The value reference of ``time``: NV, the one after the FMI 2.0 FMU's (fmi3_wrapper.c: MK3_VR_TIME)."""
    return len(all_variables(interface))


def _start(v) -> str:
    if v.type == "Boolean":
        return "true" if v.start else "false"
    return str(int(v.start)) if v.type == "Integer" else repr(float(v.start))


def model_description(interface: Interface, token: str, event_indicators: int) -> bytes:
    """modelDescription.xml of the FMI 3.0 FMU: Model Exchange and Co-Simulation (the sources are listed in
    buildDescription.xml); event_indicators: their number (:func:`mkctl.native.fmu.core_event_indicators`)."""
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    variables_all = all_variables(interface)
    vr = {v.name: v.vr for v in variables_all}
    time_vr = len(variables_all)
    root = ET.Element("fmiModelDescription", {
        "fmiVersion": "3.0", "modelName": interface.model_name, "instantiationToken": token,
        "description": interface.description, "author": interface.author,
        "generationTool": "mkctl.native.fmi3 (C generated from mkctl's equations)",
        "generationDateAndTime": now, "variableNamingConvention": "structured"})
    common = {"modelIdentifier": interface.model_name, "needsExecutionTool": "false",
              "canBeInstantiatedOnlyOncePerProcess": "false", "canGetAndSetFMUState": "true",
              "canSerializeFMUState": "true", "providesDirectionalDerivatives": "false",
              "providesAdjointDerivatives": "false"}
    ET.SubElement(root, "ModelExchange", {**common, "needsCompletedIntegratorStep": "true",
                                          "providesEvaluateDiscreteStates": "false"})
    ET.SubElement(root, "CoSimulation", {
        **common, "canHandleVariableCommunicationStepSize": "true",
        "maxOutputDerivativeOrder": "0", "providesIntermediateUpdate": "false",
        "mightReturnEarlyFromDoStep": "false", "canReturnEarlyAfterIntermediateUpdate": "false",
        "hasEventMode": "false"})
    try:
        root.append(fmi2.unit_definitions([TIME[2], *(v.unit for v in variables_all if v.unit is not None)]))
    except ValueError as error:
        raise NativeBuildError(str(error)) from None
    categories = ET.SubElement(root, "LogCategories")
    for name, text in fmi2._LOG_CATEGORIES.items():
        ET.SubElement(categories, "Category", name=name, description=text.replace("fmi2", "fmi3"))
    ET.SubElement(root, "DefaultExperiment", interface.default_experiment)
    variables = ET.SubElement(root, "ModelVariables")
    ET.SubElement(variables, "Float64", {"name": TIME[0], "valueReference": str(time_vr),
                                         "description": TIME[1], "causality": "independent",
                                         "variability": "continuous", "unit": TIME[2]})
    states = {f"der({state.name})": state.name for state in fmi2.model_me_states(interface)}
    for v in variables_all:
        attributes = {"name": v.name, "valueReference": str(v.vr), "description": v.description,
                      "causality": v.causality, "variability": v.variability}
        if v.start is not None:
            attributes["start"] = _start(v)
        if v.unit is not None:
            attributes["unit"] = v.unit
        if v.name in states:  # FMI 3.0: the state's value reference (FMI 2.0: its index)
            attributes["derivative"] = str(vr[states[v.name]])
        ET.SubElement(variables, TYPES[v.type], attributes)
    indicators = [time_vr + k for k in range(1, event_indicators + 1)]
    for k, reference in enumerate(indicators, start=1):
        ET.SubElement(variables, "Float64", {
            "name": EVENT_INDICATOR.format(k), "valueReference": str(reference),
            "description": f"event indicator {k} (Model Exchange): a function of the state and inputs whose sign "
                           "change switches the right-hand side (an end-stop contact, slack, a lag's direction)",
            "causality": "local", "variability": "continuous"})
    structure = ET.SubElement(root, "ModelStructure")
    outputs = [v.vr for v in variables_all if v.causality == "output"]
    derivatives = [vr[name] for name in states]
    initial = sorted({*outputs, *derivatives, *(vr[name] for name in states.values())})
    for section, references in (("Output", outputs), ("ContinuousStateDerivative", derivatives),
                                ("InitialUnknown", initial), ("EventIndicator", indicators)):
        for reference in references:
            ET.SubElement(structure, section, valueReference=str(reference))
    return xml_bytes(root)


def build_description(model_name: str, units: list[str]) -> bytes:
    """sources/buildDescription.xml: the compilation units, C99, and the core's floating-point flags (the C
    must round as Python does, operation by operation)."""
    root = ET.Element("fmiBuildDescription", fmiVersion="3.0")
    configuration = ET.SubElement(root, "BuildConfiguration", modelIdentifier=model_name)
    flags = " ".join(f for f in fmi2.core_compiler_flags() if f not in ("-O2", "-fPIC", "-shared"))
    files = ET.SubElement(configuration, "SourceFileSet", language="C99", compilerOptions=flags)
    for name in units:
        ET.SubElement(files, "SourceFile", name=name)
    return xml_bytes(root)


def write_sources(interface: Interface, token: str, dest: Path, model_source: Path | None = None) -> list[str]:
    """The FMI 2.0 FMU's sources with the FMI 3.0 headers and ``fmi3_wrapper.c`` as the compilation unit in place
    of ``fmi2_wrapper.c`` (which stays in ``sources/``: ``fmi3_wrapper.c`` includes it). Returns the units.
    model_source: as :func:`mkctl.native.fmu.write_sources` (the benchmark's no-op model)."""
    units = fmi2.write_sources(interface, token, dest, model_source)
    headers = fmi3_headers()
    for name in HEADERS:
        shutil.copy2(headers / name, dest / name)
    shutil.copy2(C_DIR / "fmi3_wrapper.c", dest / "fmi3_wrapper.c")
    return ["fmi3_wrapper.c" if name == "fmi2_wrapper.c" else name for name in units]


def build_one(model_name: str, target: Path, params: Params | None = None, model_source: Path | None = None,
              interface: Interface | None = None, platforms: bool = True, air: bool = False,
              valves: bool = False) -> Path:
    """Generate, compile, pack and validate one FMI 3.0 FMU at target (model_source: see :func:`write_sources`;
    interface: another model's, a mechanism's, in place of the slave's; platforms=False: linux only;
    air, valves: as :func:`mkctl.native.fmu.build_one`)."""
    from .cross import add_platform_binaries
    if interface is None:
        interface = fmi2.slave_interface(model_name, params, air, valves)
    token = "{" + str(uuid.uuid4()) + "}"
    with tempfile.TemporaryDirectory(prefix="mkctl_fmi3_") as temp:
        stage = Path(temp) / "fmu"
        sources = stage / "sources"
        units = write_sources(interface, token, sources, model_source)
        (sources / "buildDescription.xml").write_bytes(build_description(model_name, units))
        (stage / "modelDescription.xml").write_bytes(
            model_description(interface, token, fmi2.event_indicator_count(interface)))
        fmi2.compile_binary(sources, units, stage / "binaries" / LINUX / f"{model_name}.so")
        if platforms:
            add_platform_binaries(sources, units, stage / "binaries", model_name, "3.0",
                                  fmi2.compile_binary)
        target.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as archive:
            for path in sorted(stage.rglob("*")):
                if path.is_file():
                    archive.write(path, path.relative_to(stage).as_posix())
    fmi2._validate(target)
    return target


def build_fmi3(out: Path, params: Params | None = None, air: bool | None = None,
               valves: bool = False) -> dict[str, Path]:
    """Write ``out/fmi3/McKibbenKnee.fmu`` and ``out/fmi3/McKibbenActuator.fmu``; returns their paths by model
    name. params, air, valves: as :func:`mkctl.native.fmu.build_native`. Raises
    :class:`NativeBuildError`."""
    folder = Path(out) / "fmi3"
    air = fmi2.wants_air(params) if air is None else air
    return {name: build_one(name, folder / f"{name}.fmu", params, air=air, valves=valves)
            for name in MODEL_NAMES}


def main(argv=None) -> int:
    return fmi2.command_line(argv, build_fmi3, "Build the FMI 3.0 native FMUs (model-spec section 7c).", "fmi3",
                             "mkctl.native.fmi3")

if __name__ == "__main__":
    sys.exit(main())
