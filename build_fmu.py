"""Build the FMI 2.0 co-simulation FMUs of model-spec section 7 and check them.

    python build_fmu.py [--out DIR] [--no-run]

writes ``DIR/McKibbenKnee.fmu`` and ``DIR/McKibbenActuator.fmu`` (DIR defaults to ``dist``):

1. pythonfmu packs the slave script of ``fmu/`` with the ``mkctl`` modules the slave scripts import (and
   nothing else), among them ``mkctl/fmu/slave.py``, the base class both slaves share; both FMUs get the same
   files, staged once;
2. the modelDescription.xml is completed where pythonfmu 0.7 leaves gaps: ``<UnitDefinitions>`` and a
   ``unit`` on every Real variable, and ``<InitialUnknowns>`` for the calculated outputs;
3. ``fmpy.validation.validate_fmu`` must report no problem, and (unless ``--no-run``) each FMU runs its default
   experiment under fmpy in a fresh process (the FMU must use its packed mkctl, not this process's) and must
   reach the stop time; then all of them run one after the other in one process: they share the module
   names ``mkctl``, ``mkctl.fmu.slave`` and ``pythonfmu``, which resolve to the FMU loaded first.
"""
from __future__ import annotations

import argparse
import importlib
import shutil
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path
from xml.dom.minidom import parseString
from xml.etree import ElementTree as ET

HERE = Path(__file__).resolve().parent
FMU_SCRIPTS = {"McKibbenKnee": HERE / "fmu" / "mckibben_knee.py",
               "McKibbenActuator": HERE / "fmu" / "mckibben_actuator.py"}

#: FMI unit names for the unit strings of mkctl, and their SI base-unit exponents.
_UNIT_NAMES = {"N s/m": "N.s/m", "m/s^2": "m/s2"}
_BASE_UNITS = {
    "m": {"m": 1}, "s": {"s": 1}, "kg": {"kg": 1}, "rad": {"rad": 1}, "1": {},
    "N": {"kg": 1, "m": 1, "s": -2}, "Pa": {"kg": 1, "m": -1, "s": -2}, "m/s": {"m": 1, "s": -1},
    "m/s2": {"m": 1, "s": -2}, "N.s/m": {"kg": 1, "s": -1}, "1/s": {"s": -1}, "1/s2": {"s": -2},
}


class BuildError(Exception):
    """The FMUs could not be built or failed their checks."""


def _load_scripts():
    """Import the slave scripts (with this repository's mkctl) and return them by model name."""
    for path in (str(HERE), str(HERE / "fmu")):
        if path not in sys.path:
            sys.path.insert(0, path)
    return {name: importlib.import_module(script.stem) for name, script in FMU_SCRIPTS.items()}


def _stage_mkctl(dest: Path) -> Path:
    """Copy the mkctl modules imported by the slave scripts into dest/mkctl (the FMUs' own copy)."""
    import mkctl
    package_dir = Path(mkctl.__file__).parent
    target = dest / "mkctl"
    target.mkdir(parents=True)
    names = sorted(m for m in sys.modules if m == "mkctl" or m.startswith("mkctl."))
    for module in names:
        source = Path(sys.modules[module].__file__)
        if package_dir not in source.parents:
            raise BuildError(f"module {module} was imported from {source}, not from {package_dir}")
        relative = source.relative_to(package_dir)
        (target / relative).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(source, target / relative)
    return target


def _complete_model_description(xml: bytes, units: dict[str, str]) -> bytes:
    """Add units (UnitDefinitions + unit attributes) and InitialUnknowns to pythonfmu's modelDescription."""
    root = ET.fromstring(xml)
    for node in root.iter():  # drop pythonfmu's indentation, re-indented below
        if node.text is not None and not node.text.strip():
            node.text = None
        if node.tail is not None and not node.tail.strip():
            node.tail = None
    fmi_units = {name: _UNIT_NAMES.get(unit, unit) for name, unit in units.items()}
    used = sorted(set(fmi_units.values()))
    unknown = [u for u in used if u not in _BASE_UNITS]
    if unknown:
        raise BuildError(f"no base-unit definition for unit(s) {unknown}")
    definitions = ET.Element("UnitDefinitions")
    for unit in used:
        node = ET.SubElement(definitions, "Unit", name=unit)
        if _BASE_UNITS[unit]:
            ET.SubElement(node, "BaseUnit", {k: str(v) for k, v in _BASE_UNITS[unit].items()})
    # the schema's order: CoSimulation, UnitDefinitions, TypeDefinitions, LogCategories, ...
    position = list(root).index(root.find("CoSimulation")) + 1
    root.insert(position, definitions)

    outputs = []
    for index, variable in enumerate(root.find("ModelVariables"), start=1):
        name = variable.get("name")
        if not variable.get("description"):
            raise BuildError(f"variable {name} has no description")
        real = variable.find("Real")
        if real is not None:
            if name not in fmi_units:
                raise BuildError(f"Real variable {name} has no unit")
            real.set("unit", fmi_units[name])
        if variable.get("causality") == "output" and variable.get("initial") in (None, "calculated"):
            outputs.append(index)
    structure = root.find("ModelStructure")
    if outputs and structure.find("InitialUnknowns") is None:
        initial = ET.SubElement(structure, "InitialUnknowns")
        for index in outputs:
            ET.SubElement(initial, "Unknown", index=str(index))
    return parseString(ET.tostring(root, "UTF-8")).toprettyxml(encoding="UTF-8")


def _rewrite_model_description(fmu: Path, target: Path, units: dict[str, str]) -> None:
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as out:
        for item in source.infolist():
            data = source.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = _complete_model_description(data, units)
            out.writestr(item, data)


def _validate(fmu: Path) -> None:
    from fmpy.validation import validate_fmu
    problems = validate_fmu(str(fmu))
    if problems:
        raise BuildError(f"{fmu.name} failed fmpy's validation:\n  " + "\n  ".join(problems))


_RUN_CHECK = """
import sys
from fmpy import read_model_description, simulate_fmu
for fmu in sys.argv[1:]:
    md = read_model_description(fmu)
    stop = float(md.defaultExperiment.stopTime)
    result = simulate_fmu(fmu, output_interval=float(md.defaultExperiment.stepSize))
    if abs(result['time'][-1] - stop) > 1e-9:
        sys.exit(f"{fmu}: stopped at t = {result['time'][-1]} s instead of {stop} s")
"""


def _run_check(*fmus: Path) -> None:
    """Run the default experiments, one after the other, in one fresh process (so that the FMUs load a packed
    mkctl, not this process's); each must reach its stop time."""
    done = subprocess.run([sys.executable, "-c", _RUN_CHECK, *map(str, fmus)], capture_output=True, text=True,
                          cwd=tempfile.gettempdir())
    if done.returncode != 0:
        what = f"{fmus[0].name} failed its" if len(fmus) == 1 else \
            " and ".join(f.name for f in fmus) + " in one process failed their"
        raise BuildError(f"{what} default experiment: {done.stderr.strip()[-2000:]}")


def build(out: Path = HERE / "dist", run: bool = True) -> dict[str, Path]:
    """Build, complete and check both FMUs; returns their paths by model name."""
    from pythonfmu import FmuBuilder

    scripts = _load_scripts()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    built = {}
    with tempfile.TemporaryDirectory(prefix="mkctl_fmu_") as temp:
        temp = Path(temp)
        package = _stage_mkctl(temp / "stage")
        for name, script in FMU_SCRIPTS.items():
            raw = FmuBuilder.build_FMU(script, dest=temp / f"{name}.fmu", project_files=[package],
                                       canGetAndSetFMUstate=True, canSerializeFMUstate=True)
            target = out / f"{name}.fmu"
            _rewrite_model_description(Path(raw), target, scripts[name].VARIABLE_UNITS)
            _validate(target)
            if run:
                _run_check(target)
            built[name] = target
    if run and len(built) > 1:
        _run_check(*built.values())
    return built


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=HERE / "dist", help="output folder (default: dist)")
    parser.add_argument("--no-run", action="store_true", help="skip running the default experiments")
    args = parser.parse_args(argv)
    try:
        built = build(args.out, run=not args.no_run)
    except BuildError as error:
        print(f"build_fmu: {error}", file=sys.stderr)
        return 1
    for name, path in built.items():
        print(f"built {path} (validated{'' if args.no_run else ', default experiment run'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
