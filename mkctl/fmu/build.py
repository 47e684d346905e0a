"""Build the FMI 2.0 co-simulation FMUs of model-spec section 7 and check them.

    python -m mkctl.fmu.build [--out DIR] [--no-run] [--params MUSCLE.json] [--effects FILE.py ...]
    python build_fmu.py ...                    (the same, from a checkout)
    python build_fmu.py --mechanism NAME|FILE.py [--no-native] ...

writes ``DIR/McKibbenKnee.fmu`` and ``DIR/McKibbenActuator.fmu`` (DIR defaults to ``dist``; with
parameters that switch on the air, both with it), or
with ``--mechanism`` the mechanism's ``DIR/McKibben<Name>.fmu`` (:func:`build_mechanism_fmus`; its
script ``mckibben_mechanism.py`` serves every mechanism, named in the FMU's resources as data, a
mechanism file carried as itself):

1. pythonfmu packs each slave script of :mod:`mkctl.fmu.scripts` with the ``mkctl`` modules the scripts import
   (and nothing else), among them the slave classes (``mkctl/fmu/models.py``) and
   ``mkctl/fmu/slave.py``, the base class both share, and with
   ``mkctl_start.json``, the start values of the build's parameters (``--params``, default Table I and II);
2. the modelDescription.xml is completed where pythonfmu 0.7 leaves gaps: ``<UnitDefinitions>`` and a
   ``unit`` on every Real variable, and ``<InitialUnknowns>`` for the calculated outputs;
3. pythonfmu's linux64 binary gets the exit fix (:func:`fix_exit_handler`): only a binary whose SHA-256 is in
   :data:`VERIFIED_BINARIES` is accepted;
4. ``fmpy.validation.validate_fmu`` must report no problem, and (unless ``--no-run``) each FMU runs its default
   experiment under fmpy in a fresh process (the FMU must use its packed mkctl, not this process's) and must
   reach the stop time; then all of them run one after the other in one process: they share the module
   names ``mkctl``, ``mkctl.fmu.slave`` and ``pythonfmu``, which resolve to the FMU loaded first.

The exit fix. pythonfmu 0.7's binary keeps its interpreter state in a namespace-scope
``std::shared_ptr<PyState> pyState`` and also clears it from an ``__attribute__((destructor))`` function,
``finalizePythonInterpreter``. At process exit the static destructor runs first, then the destructor function
assigns nullptr to the destroyed pointer: it decrements a reference count inside a block already freed, which
corrupts glibc's heap lists and makes the host abort at exit ("corrupted double-linked list", "free():
corrupted unsorted chunks") whenever that chunk sits in a bin. The fix writes ``ret`` after the ``endbr64`` of
``finalizePythonInterpreter``, so that it returns at once. Nothing else calls it, and what it would have done
(drop the last reference to the interpreter state, once) the static destructor has done already. See docs/fmu.md.
"""
from __future__ import annotations

import argparse
import hashlib
import json
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zipfile
from pathlib import Path
from xml.etree import ElementTree as ET

from ..fmi.xml import xml_bytes
from ..errors import MkctlError
from ..fmi.interface import check_carried, mechanism_model, model_for
from ..physics.actuator import air_is_on
from ..physics.params import Params
from ..fmi.units import fmi_unit, unit_definitions

SCRIPTS = Path(__file__).resolve().parent / "scripts"
#: The slave script of each FMU, by model name (a one-line import of the slave class, see mkctl/fmu/scripts).
FMU_SCRIPTS = {"McKibbenKnee": SCRIPTS / "mckibben_knee.py",
               "McKibbenActuator": SCRIPTS / "mckibben_actuator.py"}
#: The slave script of every mechanism's FMU (model-spec 3b, 7d): the FMU's model name
#: McKibben<Name> comes from the mechanism the build names in its resources, so one script serves
#: them all and nothing is generated.
MECHANISM_SCRIPT = SCRIPTS / "mckibben_mechanism.py"


#: SHA-256 of the pythonfmu linux64 binaries the exit fix was verified on (disassembled, run under valgrind, and
#: run 20 times from a long folder by a C host that returns from main), and what they are.
VERIFIED_BINARIES = {
    "4be156a552c16f30eb4395805c59855d8d4086056d0f165442565f6c5fbac0c9":
        "pythonfmu 0.7.0, resources/binaries/linux64/libpythonfmu-export.so",
}
#: The function the fix disables, and its first instructions in the verified binaries:
#: endbr64; push %rbp; pxor %xmm0,%xmm0; push %rbx.
EXIT_HANDLER = "finalizePythonInterpreter"
_EXPECTED_PROLOGUE = bytes.fromhex("f30f1efa" "55" "660fefc0" "53")
_ENDBR64 = 4  # the fix keeps endbr64 (an indirect-branch target under CET) and writes ret after it
_RET = b"\xc3"


class BuildError(MkctlError):
    """The FMUs could not be built or failed their checks."""


# --- the exit fix -----------------------------------------------------------------------------------------

def elf_symbol_offset(data: bytes, name: str) -> tuple[int, int]:
    """(file offset [bytes], size [bytes]) of the function symbol name in a little-endian ELF64 shared library,
    read from its symbol tables (``.dynsym``, ``.symtab``). Raises BuildError if it is not there."""
    if data[:4] != b"\x7fELF" or data[4] != 2 or data[5] != 1:
        raise BuildError("not a little-endian 64-bit ELF file")
    shoff, = struct.unpack_from("<Q", data, 0x28)
    shentsize, shnum = struct.unpack_from("<HH", data, 0x3A)
    sections = [struct.unpack_from("<IIQQQQIIQQ", data, shoff + i * shentsize) for i in range(shnum)]
    wanted = name.encode()
    for _, sh_type, _, _, offset, size, link, _, _, entsize in sections:
        if sh_type not in (2, 11) or entsize == 0:  # SHT_SYMTAB, SHT_DYNSYM
            continue
        strtab_offset = sections[link][4]
        for start in range(offset, offset + size, entsize):
            st_name, st_info, _, st_shndx, st_value, st_size = struct.unpack_from("<IBBHQQ", data, start)
            if st_info & 0xF != 2 or st_shndx == 0 or st_shndx >= len(sections):  # STT_FUNC, defined here
                continue
            end = data.index(b"\0", strtab_offset + st_name)
            if data[strtab_offset + st_name:end] == wanted:
                section = sections[st_shndx]  # file offset = address - section address + section offset
                return st_value - section[3] + section[4], st_size
    raise BuildError(f"no function symbol {name} in the ELF symbol tables")


def fix_exit_handler(data: bytes, what: str = "pythonfmu's binary") -> bytes:
    """pythonfmu's linux64 binary with ``finalizePythonInterpreter`` returning at once (see the module docstring).

    Refuses (BuildError) a binary whose SHA-256 is not in :data:`VERIFIED_BINARIES`, or whose function does not
    start with the instructions the fix was verified on."""
    digest = hashlib.sha256(data).hexdigest()
    if digest not in VERIFIED_BINARIES:
        raise BuildError(
            f"{what} (SHA-256 {digest}) is not a pythonfmu binary the exit fix was verified on "
            f"({', '.join(VERIFIED_BINARIES.values())}); an unfixed binary aborts its host at exit. Install "
            f"pythonfmu 0.7.0 (pip install 'pythonfmu==0.7.0'), or verify this binary and add its hash to "
            f"mkctl.fmu.build.VERIFIED_BINARIES (see docs/fmu.md)")
    offset, size = elf_symbol_offset(data, EXIT_HANDLER)
    if size < len(_EXPECTED_PROLOGUE) or data[offset:offset + len(_EXPECTED_PROLOGUE)] != _EXPECTED_PROLOGUE:
        raise BuildError(f"{what}: {EXIT_HANDLER} does not start with the instructions the exit fix expects")
    fixed = bytearray(data)
    fixed[offset + _ENDBR64:offset + _ENDBR64 + 1] = _RET
    return bytes(fixed)


# --- staging: the mkctl modules and start values packed into the FMUs ------------------------------------------

_LIST_MODULES = """
import importlib, json, sys
for name in sys.argv[1:]:
    importlib.import_module(name)
print(json.dumps({name: module.__file__ for name, module in sys.modules.items()
                  if name == "mkctl" or name.startswith("mkctl.")}))
"""


def _script_modules() -> list[str]:
    scripts = (*FMU_SCRIPTS.values(), MECHANISM_SCRIPT)
    return [f"mkctl.fmu.scripts.{script.stem}" for script in scripts]


def _stage_mkctl(dest: Path) -> Path:
    """Copy the mkctl modules that the slave scripts import into dest/mkctl (the FMUs' own copy). The modules are
    listed by importing the scripts in a fresh interpreter, so that what this process imported does not count."""
    package_dir = Path(__file__).resolve().parents[1]
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(package_dir.parent),
                                                                      os.environ.get("PYTHONPATH")]))}
    done = subprocess.run([sys.executable, "-c", _LIST_MODULES, *_script_modules()],
                          capture_output=True, text=True, env=env, cwd=tempfile.gettempdir())
    if done.returncode != 0:
        raise BuildError(f"the slave scripts do not import: {done.stderr.strip()[-2000:]}")
    target = dest / "mkctl"
    target.mkdir(parents=True)
    for module, source in sorted(json.loads(done.stdout.splitlines()[-1]).items()):
        if module.startswith("mkctl.fmu.scripts"):
            continue  # each script becomes its FMU's top-level module instead
        source = Path(source).resolve()
        if package_dir not in source.parents:
            raise BuildError(f"module {module} was imported from {source}, not from {package_dir}")
        relative = source.relative_to(package_dir)
        (target / relative).parent.mkdir(parents=True, exist_ok=True)
        shutil.copy2(source, target / relative)
    return target


def _stage_starts(dest: Path, interface, params: Params) -> Path:
    """Write the start values of params for one FMU's interface (the file the slave reads at
    instantiation)."""
    from .slave import START_FILE
    try:
        values = interface.start_values(params)
    except MkctlError as error:
        raise BuildError(f"no start values for {interface.name} with these parameters: "
                         f"{error}") from None
    dest.mkdir(parents=True)
    path = dest / START_FILE
    path.write_text(json.dumps(values, indent=1))
    return path


def _stage_build(dest: Path, air: bool, mechanism=None) -> list[Path]:
    """Write the build file (:data:`mkctl.fmu.slave.BUILD_FILE`: the air, the mechanism) into dest,
    and copy a mechanism file into dest/mkctl_mechanism as it is; returns what to pack into the
    resources."""
    from .slave import BUILD_FILE, MECHANISM_FOLDER
    dest.mkdir(parents=True)
    build: dict = {"air": bool(air)}
    packed = [dest / BUILD_FILE]
    if mechanism is not None and mechanism.reload:  # read from a file: the FMU carries the file
        source = Path(mechanism.reload[1])
        folder = dest / MECHANISM_FOLDER
        folder.mkdir()
        shutil.copy2(source, folder / source.name)
        build["mechanism"] = {"file": source.name}
        packed.append(folder)
    elif mechanism is not None:
        build["mechanism"] = {"builtin": mechanism.name}
    packed[0].write_text(json.dumps(build, indent=1))
    return packed


# --- completing pythonfmu's FMU ------------------------------------------------------------------------------

def _complete_model_description(xml: bytes, units: dict[str, str], needs: str = "numpy and scipy",
                                description: str | None = None) -> bytes:
    """Add units (UnitDefinitions + unit attributes) and InitialUnknowns to pythonfmu's
    modelDescription; write ``description`` (the interface's: that of the FMU as built, with the
    air, a mechanism's) when given."""
    root = ET.fromstring(xml)
    for node in root.iter():  # drop pythonfmu's indentation, re-indented below
        if node.text is not None and not node.text.strip():
            node.text = None
        if node.tail is not None and not node.tail.strip():
            node.tail = None
    fmi_units = {name: fmi_unit(unit) for name, unit in units.items()}
    try:
        definitions = unit_definitions(fmi_units.values())
    except ValueError as error:
        raise BuildError(str(error)) from None
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
    # the FMU runs its Python source in the host's interpreter: the build's minor version
    description = root.get("description", "") if description is None else description
    root.set("description", f"{description} (pythonfmu FMU: the host needs Python "
             f"{sys.version_info.major}.{sys.version_info.minor} with {needs})")
    structure = root.find("ModelStructure")
    if outputs and structure.find("InitialUnknowns") is None:
        initial = ET.SubElement(structure, "InitialUnknowns")
        for index in outputs:
            ET.SubElement(initial, "Unknown", index=str(index))
    return xml_bytes(root)


def _complete_fmu(fmu: Path, target: Path, interface, fix_exit: bool,
                  needs: str = "numpy and scipy") -> None:
    """Copy pythonfmu's FMU to target with the model description completed and the linux64 binary fixed."""
    with zipfile.ZipFile(fmu) as source, zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as out:
        for item in source.infolist():
            data = source.read(item.filename)
            if item.filename == "modelDescription.xml":
                data = _complete_model_description(data, interface.units, needs,
                                                   interface.description)
            elif fix_exit and item.filename.startswith("binaries/linux64/") and item.filename.endswith(".so"):
                data = fix_exit_handler(data, f"{target.name}'s {item.filename}")
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
    mkctl, not this process's); each must reach its stop time, and the process must end cleanly."""
    done = subprocess.run([sys.executable, "-c", _RUN_CHECK, *map(str, fmus)], capture_output=True, text=True,
                          cwd=tempfile.gettempdir())
    if done.returncode != 0:
        what = f"{fmus[0].name} failed its" if len(fmus) == 1 else \
            " and ".join(f.name for f in fmus) + " in one process failed their"
        raise BuildError(f"{what} default experiment (exit status {done.returncode}): "
                         f"{done.stderr.strip()[-2000:]}")


# --- the build ---------------------------------------------------------------------------------------------

def _stage_effects(dest: Path, files) -> Path | None:
    """Copy the effect files into dest/mkctl_effects as ``NN_<name>`` (their order kept), or None without any."""
    from .slave import EFFECTS_FOLDER
    if not files:
        return None
    folder = dest / EFFECTS_FOLDER
    folder.mkdir(parents=True)
    for number, path in enumerate(files):
        shutil.copy2(path, folder / f"{number:02d}_{Path(path).name}")
    return folder


def build(out, run: bool = True, params: Params | None = None, native: bool = True, *,
          effects=(), _fix_exit: bool = True) -> dict[str, Path]:
    """Build, complete and check both FMUs, and (``native``) their compiled twins in ``out/native``.

    Parameters: out, the folder to write ``McKibbenKnee.fmu`` and ``McKibbenActuator.fmu`` to (created if
    needed); run, whether to run each default experiment (in a fresh process) as a check; params, the muscle and
    knee whose values become the FMUs' start values (default: the current model's defaults, Table I and
    II, effects off). ``_fix_exit=False`` leaves pythonfmu's binary as it is: only for the tests and the bench
    that show what the fix prevents. effects, the user's effect files (model-spec section 4c) the FMUs carry: they
    are registered here (before params' values are read, so a muscle file may set their parameters: register them
    first), packed into the pythonfmu FMUs' resources (the slave registers them when it loads) and compiled into
    the native ones; their parameters become FMU parameters.

    The native FMUs (model-spec section 7b, :func:`mkctl.native.fmu.build_native`) need a C compiler; without one
    they are skipped with a note on stderr and the pythonfmu FMUs are still built.
    Returns the FMUs' paths by model name (the native ones as ``native/<model>``). Raises :class:`BuildError`.
    """
    from ..analysis.effect_files import register_effect_files
    effect_files = [Path(f).resolve() for f in effects or ()]
    register_effect_files(effect_files)
    params = Params() if params is None else params
    air = air_is_on(params)
    check_carried(params, air)  # what the FMUs do not carry is refused, not silently dropped
    out = Path(out).resolve()  # the checks run in another folder
    out.mkdir(parents=True, exist_ok=True)
    built = {}
    with tempfile.TemporaryDirectory(prefix="mkctl_fmu_") as temp:
        temp = Path(temp)
        package = _stage_mkctl(temp / "stage")
        packed = _stage_effects(temp / "effects", effect_files)
        for name, script in FMU_SCRIPTS.items():
            interface = model_for(name, air)
            built[name] = _pack(script, interface, params, out / f"{name}.fmu", temp / name,
                                [package, *([packed] if packed else [])], air, fix_exit=_fix_exit)
    if run:
        for target in built.values():
            _run_check(target)
        _run_check(*built.values())
    if native:
        built.update(_build_native(out, params))
    return built


def _pack(script: Path, interface, params: Params, target: Path, stage: Path, project_files: list,
          air: bool, mechanism=None, fix_exit: bool = True, needs: str = "numpy and scipy") -> Path:
    """pythonfmu's FMU of one slave script with the build's start values, build file (and mechanism
    file), then completed and validated at target."""
    from pythonfmu import FmuBuilder
    starts = _stage_starts(stage / "starts", interface, params)
    build_files = _stage_build(stage / "build", air, mechanism)
    raw = FmuBuilder.build_FMU(script, dest=stage / f"{interface.name}.fmu",
                               project_files=[*project_files, starts, *build_files],
                               canGetAndSetFMUstate=True, canSerializeFMUstate=True)
    _complete_fmu(Path(raw), target, interface, fix_exit=fix_exit, needs=needs)
    _validate(target)
    return target


def _build_native(out: Path, params: Params) -> dict[str, Path]:
    """The native FMUs into out/native and their FMI 3.0 twins into out/fmi3, or none (with a note) on a machine
    without a C compiler."""
    from ..native.build import find_compiler
    from ..native.fmu import build_native
    if find_compiler() is None:
        print("build_fmu: note: no C compiler found (CC, cc, gcc, clang): the native FMUs are not built",
              file=sys.stderr)
        return {}
    from ..native.fmi3 import build_fmi3
    built = {f"native/{name}": path for name, path in build_native(out, params).items()}
    built.update({f"fmi3/{name}": path for name, path in build_fmi3(out, params).items()})  # FMI 3.0 twins
    return built


def build_mechanism_fmus(name_or_path, out, params: Params | None = None, platforms: bool = True,
                         run: bool = True, native: bool = True, *, effects=()) -> dict[str, Path]:
    """Both kinds of a mechanism's FMUs (a built-in name or a mechanism file, model-spec 3b, 7d).

    ``out/McKibben<Name>.fmu``, the pythonfmu FMU (:class:`mkctl.fmu.models.McKibbenMechanism`: the
    library's mechanism stepped in the host's Python; a file's mechanism carried as the file
    itself, loaded by :func:`mkctl.analysis.mechanism_files.load_mechanism_file`), its default
    experiment run in a fresh process (``run``); and (``native``) the native FMUs in ``out/native``
    and ``out/fmi3`` (:func:`mkctl.native.mechanism_fmu.build_mechanism`; platforms=False: the
    Linux x86-64 binary only), or a note on stderr without a C compiler. Both kinds show one
    interface (:func:`mkctl.fmi.interface.mechanism_model`). Params switching on the air
    (valve_flow) build the pythonfmu FMU with section 4d's parameters and each muscle's air mass
    flow; the native ones, which do not carry the air yet, are then not built (a note says so).
    effects: the user's effect files (model-spec 4c), registered here, packed into the pythonfmu
    FMU and compiled into the native ones, as :func:`build`'s. Returns the paths by "<model>",
    "native/<model>", "fmi3/<model>". Raises an MkctlError (a one-line message) for a bad file or
    parameters."""
    from ..analysis.effect_files import register_effect_files
    from ..analysis.mechanism_files import mechanism
    effect_files = [Path(f).resolve() for f in effects or ()]
    register_effect_files(effect_files)
    params = Params() if params is None else params
    found = mechanism(str(name_or_path), params)
    air = air_is_on(params)
    check_carried(params, air)
    interface = mechanism_model(found, air)
    out = Path(out).resolve()
    out.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory(prefix="mkctl_fmu_") as temp:
        temp = Path(temp)
        packed = _stage_effects(temp / "effects", effect_files)
        project = [_stage_mkctl(temp / "stage"), *([packed] if packed else [])]
        target = _pack(MECHANISM_SCRIPT, interface, params, out / f"{interface.name}.fmu",
                       temp / "mechanism", project, air, mechanism=found,
                       needs="numpy, scipy and sympy")
    if run:
        _run_check(target)
    built = {interface.name: target}
    if native:
        from ..native.build import find_compiler
        from ..native.mechanism_fmu import build_mechanism
        if find_compiler() is None:
            print("build_fmu: note: no C compiler found (CC, cc, gcc, clang): the native FMUs are "
                  "not built", file=sys.stderr)
        else:
            built.update(build_mechanism(found, out, params, platforms=platforms))
    return built


def build_knee_system(out, params: Params | None = None, platforms: bool = True) -> dict[str, Path]:
    """``out/McKibbenKneeSystem.ssp``: the knee as a system of FMUs (:func:`mkctl.native.ssp.build_knee_ssp`).
    Returns {"McKibbenKneeSystem": path}. Raises an MkctlError (one line) without a C compiler."""
    from ..native.build import find_compiler
    from ..native.ssp import SYSTEM_NAME, build_knee_ssp
    if find_compiler() is None:
        raise BuildError("no C compiler found (CC, cc, gcc, clang): the system's native FMUs need one")
    return {SYSTEM_NAME: build_knee_ssp(Path(out).resolve(), params, platforms=platforms)}


def build_valve_fmus(out, params: Params | None = None, platforms: bool = True) -> dict[str, Path]:
    """The native FMUs with valve openings as inputs (model-spec 7d; the air on;
    :func:`mkctl.native.fmu.build_one` with ``valves``): the knee with ``ue``, ``uf`` in [-1, 1] in
    place of ``pe_cmd``, ``pf_cmd``, the actuator with ``u`` in place of ``p_cmd``, into
    ``out/native/`` and ``out/fmi3/``. Returns the paths by "native/<model>", "fmi3/<model>".
    Raises an MkctlError (one line) without a C compiler."""
    from ..native import fmi3, fmu
    from ..native.build import find_compiler
    if find_compiler() is None:
        raise BuildError("no C compiler found (CC, cc, gcc, clang): the FMUs with valve inputs "
                         "are native FMUs")
    out, built = Path(out).resolve(), {}
    for name in fmu.MODEL_NAMES:
        built[f"native/{name}"] = fmu.build_one(name, out / "native" / f"{name}.fmu", params,
                                                windows=platforms, air=True, valves=True)
        built[f"fmi3/{name}"] = fmi3.build_one(name, out / "fmi3" / f"{name}.fmu", params,
                                               platforms=platforms, air=True, valves=True)
    return built


def main(argv=None, default_out: Path = Path("dist")) -> int:
    parser = argparse.ArgumentParser(prog="build_fmu", description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=default_out, help=f"output folder (default: {default_out})")
    parser.add_argument("--no-run", action="store_true", help="skip running the default experiments")
    parser.add_argument("--no-native", action="store_true", help="skip the native (compiled) FMUs of dist/native")
    parser.add_argument("--params", type=Path, default=None, metavar="MUSCLE.json",
                        help="a muscle file (mkctl calibrate writes one): its values become the FMUs' defaults")
    parser.add_argument("--effects", action="append", default=[], type=Path, metavar="FILE.py",
                        help="a file of your own effects (model-spec section 4c, docs/effects.md): the FMUs carry "
                             "them, their parameters become FMU parameters (repeatable)")
    parser.add_argument("--mechanism", default=None, metavar="NAME|FILE.py",
                        help="build the FMUs of this mechanism instead (model-spec sections 3b, "
                             "7d): a built-in name or a mechanism file; writes "
                             "OUT/McKibben<Name>.fmu (pythonfmu) and OUT/native/, "
                             "OUT/fmi3/McKibben<Name>.fmu (native; not with --no-native) (knee: "
                             "the usual build)")
    parser.add_argument("--ssp", action="store_true",
                        help="build the knee as a system of FMUs instead: OUT/McKibbenKneeSystem.ssp (the knee's "
                             "mechanism alone and two native actuator FMUs, SSP 1.0; docs/fmu.md)")
    parser.add_argument("--valve-inputs", action="store_true",
                        help="build the native FMUs with the air and the valves' openings in "
                             "[-1, 1] as inputs (model-spec 7d): the knee's ue, uf instead of "
                             "pe_cmd, pf_cmd, the actuator's u instead of p_cmd; OUT/native/ and "
                             "OUT/fmi3/")
    args = parser.parse_args(argv)
    try:
        params = None
        if args.effects:  # before the muscle file, which may set their parameters
            from ..analysis.effect_files import register_effect_files
            register_effect_files(args.effects)
        if args.params is not None:
            from ..io.muscle import read_muscle
            params = read_muscle(args.params)
        if args.ssp:
            built = build_knee_system(args.out, params)
        elif args.valve_inputs:
            built = build_valve_fmus(args.out, params)
        elif args.mechanism is not None and args.mechanism != "knee":
            built = build_mechanism_fmus(args.mechanism, args.out, params, run=not args.no_run,
                                         native=not args.no_native, effects=args.effects)
        else:
            built = build(args.out, run=not args.no_run, params=params, native=not args.no_native,
                          effects=args.effects)
    except MkctlError as error:
        print(f"build_fmu: {error}", file=sys.stderr)
        return 2 if not isinstance(error, BuildError) else 1
    ran = not args.no_run and not args.ssp and not args.valve_inputs
    for name, path in built.items():
        print(f"built {path} (validated{', default experiment run' if ran else ''})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
