"""The knee as a system of FMUs (model-spec 7d, issue 31): ``dist/McKibbenKneeSystem.ssp``.

    python build_fmu.py --ssp      # dist/McKibbenKneeSystem.ssp

An SSP 1.0 archive (System Structure and Parameterization): ``SystemStructure.ssd`` and, in
``resources/``, the knee's mechanism alone (``McKibbenKneeMechanism.fmu``: inputs the two muscles'
tensions ``f_extensor``, ``f_flexor``; outputs ``X``'s ``q``, ``qdot`` and each muscle's length and
rate, :func:`mkctl.native.mechanism_fmu.mechanism_interface` with ``alone=True``) and the native
actuator FMU (``McKibbenActuator.fmu``: inputs ``p_cmd``, ``L``, ``Ldot``; output ``f``), used
twice, as the components ``extensor`` and ``flexor``. The connections: each muscle's length and rate
from the mechanism to its actuator, each actuator's tension back. Parameter bindings start the
actuators' commands at the knee FMU's start commands (the leg at rest at alpha = 60 deg).

A co-simulation user can swap a muscle (another actuator FMU) or the mechanism. The system matches
the monolithic knee FMU within the co-simulation step's error (docs/fmu.md, "The knee as a system of
FMUs": the error against the step size). Every text of the SSD is written by ElementTree (escaped),
and the SSD is checked against the SSP 1.0 schema (fmpy's) before the build reports it.
"""
from __future__ import annotations

import datetime
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from ..fmi.xml import xml_bytes
from ..physics.params import Params
from .fmu import NativeBuildError

SSD = "http://ssp-standard.org/SSP1/SystemStructureDescription"
SSC = "http://ssp-standard.org/SSP1/SystemStructureCommon"
SSV = "http://ssp-standard.org/SSP1/SystemStructureParameterValues"
SYSTEM_NAME = "McKibbenKneeSystem"
#: The components: the mechanism alone and one actuator FMU per muscle (named after the muscle).
MECHANISM = "mechanism"


def system_description(muscles, mechanism_fmu: str, actuator_fmu: str, commands,
                       stop_time: float = 2.0) -> bytes:
    """SystemStructure.ssd: the mechanism alone and one actuator per muscle, connected (see the
    module docstring); commands: each actuator's start command p_cmd [Pa]."""
    for prefix, uri in (("ssd", SSD), ("ssc", SSC), ("ssv", SSV)):
        ET.register_namespace(prefix, uri)
    now = datetime.datetime.now(datetime.timezone.utc).isoformat(timespec="seconds")
    root = ET.Element(f"{{{SSD}}}SystemStructureDescription", {
        "version": "1.0", "name": SYSTEM_NAME, "generationTool": "mkctl.native.ssp",
        "generationDateAndTime": now})
    system = ET.SubElement(root, f"{{{SSD}}}System", name="knee", description=(
        "the knee of model-spec section 3: its mechanism alone and one actuator FMU per muscle"))
    elements = ET.SubElement(system, f"{{{SSD}}}Elements")

    def component(name, source, connectors):
        node = ET.SubElement(elements, f"{{{SSD}}}Component", name=name, source=source,
                             type="application/x-fmu-sharedlibrary")
        group = ET.SubElement(node, f"{{{SSD}}}Connectors")
        for connector, kind, unit in connectors:
            item = ET.SubElement(group, f"{{{SSD}}}Connector", name=connector, kind=kind)
            ET.SubElement(item, f"{{{SSC}}}Real", unit=unit)
        return node

    lengths = [(f"{kind}_{m}", "output", unit) for m in muscles
               for kind, unit in (("L", "m"), ("Ldot", "m/s"))]
    component(MECHANISM, f"resources/{mechanism_fmu}",
              [*((f"f_{m}", "input", "N") for m in muscles), ("q", "output", "m"),
               ("qdot", "output", "m/s"), *lengths])
    for muscle, command in zip(muscles, commands):
        node = component(muscle, f"resources/{actuator_fmu}",
                         [("p_cmd", "input", "Pa"), ("L", "input", "m"), ("Ldot", "input", "m/s"),
                          ("f", "output", "N")])
        bindings = ET.SubElement(node, f"{{{SSD}}}ParameterBindings")
        binding = ET.SubElement(bindings, f"{{{SSD}}}ParameterBinding")
        values = ET.SubElement(binding, f"{{{SSD}}}ParameterValues")
        parameter_set = ET.SubElement(values, f"{{{SSV}}}ParameterSet", version="1.0", name="start")
        parameters = ET.SubElement(parameter_set, f"{{{SSV}}}Parameters")
        parameter = ET.SubElement(parameters, f"{{{SSV}}}Parameter", name="p_cmd")
        ET.SubElement(parameter, f"{{{SSV}}}Real", value=repr(float(command)), unit="Pa")
    connections = ET.SubElement(system, f"{{{SSD}}}Connections")
    for muscle in muscles:
        for start, end in ((f"L_{muscle}", "L"), (f"Ldot_{muscle}", "Ldot")):
            ET.SubElement(connections, f"{{{SSD}}}Connection", startElement=MECHANISM,
                          startConnector=start, endElement=muscle, endConnector=end)
        ET.SubElement(connections, f"{{{SSD}}}Connection", startElement=muscle, startConnector="f",
                      endElement=MECHANISM, endConnector=f"f_{muscle}")
    units = ET.SubElement(root, f"{{{SSD}}}Units")
    for name, base in (("m", {"m": "1"}), ("m/s", {"m": "1", "s": "-1"}),
                       ("N", {"kg": "1", "m": "1", "s": "-2"}),
                       ("Pa", {"kg": "1", "m": "-1", "s": "-2"})):
        unit = ET.SubElement(units, f"{{{SSC}}}Unit", name=name)
        ET.SubElement(unit, f"{{{SSC}}}BaseUnit", base)
    ET.SubElement(root, f"{{{SSD}}}DefaultExperiment", startTime="0.0",
                  stopTime=repr(float(stop_time)))
    return xml_bytes(root)


def build_knee_ssp(out, params: Params | None = None, platforms: bool = True) -> Path:
    """Write ``out/McKibbenKneeSystem.ssp`` (see the module docstring); params: the start values of
    both FMUs (default: the current model's defaults). Returns its path. Raises
    :class:`NativeBuildError`."""
    from ..physics.mechanism import KNEE
    from ..physics.simulate import default_commands
    from . import fmu
    from .mechanism_fmu import build_mechanism
    params = Params() if params is None else params
    target = Path(out) / f"{SYSTEM_NAME}.ssp"
    with tempfile.TemporaryDirectory(prefix="mkctl_ssp_") as temp:
        temp = Path(temp)
        built = build_mechanism(KNEE, temp, params, platforms=platforms, alone=True)
        mechanism = built["native/McKibbenKneeMechanism"]
        actuator = fmu.build_one("McKibbenActuator", temp / "McKibbenActuator.fmu", params,
                                 windows=platforms)
        ssd = system_description(KNEE.muscles, mechanism.name, actuator.name,
                                 default_commands(params))
        target.parent.mkdir(parents=True, exist_ok=True)
        with zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as archive:
            archive.writestr("SystemStructure.ssd", ssd)
            for path in (mechanism, actuator):
                archive.write(path, f"resources/{path.name}")
    from fmpy.ssp.ssd import read_ssd
    try:  # against the SSP 1.0 schema fmpy ships
        read_ssd(str(target), validate=True)
    except Exception as error:  # fmpy raises its own and lxml's errors
        raise NativeBuildError(f"{target.name} failed the SSP 1.0 schema: {error}") from None
    return target
