"""The FMUs in a host that is not Python: fmu/fmi2_host.c, compiled with gcc, run with the recipe of docs/fmu.md
(libpython preloaded, PYTHONHOME and PYTHONPATH set), against mkctl; and the exit fix of mkctl.fmu.build.

The host returns from ``main`` normally, so every library's exit handlers run: pythonfmu 0.7's unfixed binary
corrupts the heap there (docs/fmu.md, "Exit"). Whether that corruption aborts a given run depends on the heap
layout (the folder's length changes it), so the no-abort test runs each FMU from 20 folders of different lengths,
and valgrind (when installed) shows the invalid access itself: present in the unfixed binary, gone from ours.
"""
from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from mkctl.fmu.build import (EXIT_HANDLER, VERIFIED_BINARIES, BuildError, elf_symbol_offset, fix_exit_handler)
from mkctl.physics.params import Params
from mkctl.physics.simulate import KneeSimulator, default_commands, default_hip_height

ROOT = Path(__file__).resolve().parents[1]
LONG = "a_deliberately_long_folder_name_"


def python_environment() -> dict[str, str]:
    """The recipe: preload the shared libpython and point the embedded interpreter at this Python's modules."""
    import fmpy
    import numpy
    libpython = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    site_packages = str(Path(numpy.__file__).parents[1])
    assert Path(fmpy.__file__).parents[1] == Path(site_packages)
    # MKCTL_FMU_STDERR too: importing mkctl.scenarios sets it to 0 in a test process, which would silence the FMU
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON") and k != "MKCTL_FMU_STDERR"}
    env.update(LD_PRELOAD=str(libpython), PYTHONHOME=sys.base_prefix, PYTHONPATH=site_packages)
    return env


@pytest.fixture(scope="module")
def host(tmp_path_factory):
    if shutil.which("gcc") is None:
        pytest.skip("gcc is not installed: cannot compile the C host")
    if not sysconfig.get_config_var("Py_ENABLE_SHARED"):
        pytest.skip("this Python has no shared libpython to preload")
    import fmpy
    build = tmp_path_factory.mktemp("c_host")
    binary = build / "fmi2_host"
    subprocess.run(["gcc", "-Wall", "-Werror", "-I", str(Path(fmpy.__file__).parent / "c-code"), "-o", str(binary),
                    str(ROOT / "fmu" / "fmi2_host.c"), "-ldl"], check=True, capture_output=True)
    return binary


@pytest.fixture(scope="module")
def unfixed_fmus(tmp_path_factory):
    """Both FMUs built with pythonfmu's binary left as it is (the private switch of mkctl.fmu.build.build)."""
    out = tmp_path_factory.mktemp("unfixed")
    code = "import sys; from mkctl.fmu.build import build; build(sys.argv[1], run=False, _fix_exit=False)"
    subprocess.run([sys.executable, "-c", code, str(out)], check=True, capture_output=True, cwd=ROOT,
                   env={**os.environ, "PYTHONPATH": str(ROOT)})
    return {"knee": out / "McKibbenKnee.fmu", "actuator": out / "McKibbenActuator.fmu"}


def _unzip(fmu: Path, folder: Path) -> Path:
    with zipfile.ZipFile(fmu) as archive:
        archive.extractall(folder)
    return folder


def _command(host: Path, fmu: Path, folder: Path, stop: float = 0.05, *settings: str) -> list[str]:
    md = read_model_description(str(fmu))
    out_vr = next(v.valueReference for v in md.modelVariables if v.causality == "output")
    return [str(host), str(folder), md.guid, repr(stop), "0.001", str(out_vr), *settings]


def test_knee_fmu_runs_in_a_c_host_with_libpython_preloaded(host, built_fmus, tmp_path):
    unzipped = _unzip(built_fmus["knee"], tmp_path / (LONG * 3) / "knee")
    md = read_model_description(str(built_fmus["knee"]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    pe = default_commands()[0] * 1.05
    args = [str(host), str(unzipped), md.guid, "0.5", "0.001", str(vr["X"]), f"{vr['c']}=40", f"{vr['pe_cmd']}={pe!r}"]

    done = subprocess.run(args, capture_output=True, text=True, env=python_environment(), timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    time, X = np.loadtxt(done.stdout.splitlines()).T
    assert time[-1] == pytest.approx(0.5) and len(X) == 501

    sim = KneeSimulator(Params(c=40.0), default_hip_height(), pe, default_commands()[1])
    direct = [sim.state[0]] + [sim.step(1e-3, pe, default_commands()[1])[0] for _ in range(500)]
    assert np.ptp(direct) > 1e-3
    np.testing.assert_allclose(X, direct, rtol=0, atol=1e-12)
    # the rated-pressure warning reaches a host that is not Python, once (the default extensor needs ~1.7 MPa)
    assert done.stderr.count("exceeds the rated pressure P_rated = 0.6 MPa") == 2  # the FMI logger, and stderr

    # without the recipe the FMU's library cannot even be loaded: the preload is what makes it work
    bare = {k: v for k, v in os.environ.items() if k not in ("LD_PRELOAD", "PYTHONHOME", "PYTHONPATH")}
    failed = subprocess.run(args, capture_output=True, text=True, env=bare, timeout=60)
    assert failed.returncode != 0 and "undefined symbol" in failed.stderr


@pytest.mark.parametrize("model", ["knee", "actuator"])
def test_the_c_host_never_aborts_at_exit_from_folders_of_20_lengths(host, built_fmus, tmp_path, model):
    env = python_environment()
    statuses = []
    for k in range(20):  # folder paths from ~100 to ~195 characters: several heap layouts
        folder = _unzip(built_fmus[model], tmp_path / (LONG * 2) / ("x" * (5 * k + 1)) / model)
        done = subprocess.run(_command(host, built_fmus[model], folder), capture_output=True, text=True, env=env,
                              timeout=120)
        statuses.append((len(str(folder)), done.returncode, done.stderr.strip().splitlines()[-1:]))
        shutil.rmtree(folder)
    assert [s for s in statuses if s[1] != 0] == [], statuses


@pytest.mark.skipif(shutil.which("valgrind") is None, reason="valgrind is not installed")
def test_valgrind_sees_the_invalid_exit_access_in_pythonfmus_binary_and_not_in_ours(host, built_fmus, unfixed_fmus,
                                                                                     tmp_path):
    env = python_environment()
    runs = {}
    for kind, fmus in (("unfixed", unfixed_fmus), ("fixed", built_fmus)):
        folder = _unzip(fmus["knee"], tmp_path / kind)
        # the exit bug is a read of freed memory: an addressability error, which memcheck reports without
        # tracking undefined values (a third of its cost)
        memcheck = ["valgrind", "--error-exitcode=99", "--undef-value-errors=no"]
        runs[kind] = subprocess.Popen([*memcheck, *_command(host, fmus["knee"], folder, 0.002)],
                                      stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True, env=env)
    reports = {kind: run.communicate(timeout=600)[1] for kind, run in runs.items()}

    def invalid_accesses_in_the_fmu(report: str) -> list[str]:
        blocks = report.split("==\n")
        return [b for b in blocks if "Invalid" in b and "binaries/linux64" in b]

    unfixed = invalid_accesses_in_the_fmu(reports["unfixed"])
    assert any(EXIT_HANDLER in b and "free'd" in b for b in unfixed), reports["unfixed"][-3000:]
    assert invalid_accesses_in_the_fmu(reports["fixed"]) == [], reports["fixed"][-3000:]
    assert EXIT_HANDLER not in reports["fixed"]


def test_the_exit_fix_writes_ret_where_the_symbol_table_says_and_refuses_other_binaries(built_fmus):
    # the installed distribution's file, not ``pythonfmu.builder.HERE``: a pythonfmu FMU loaded earlier in this
    # process may have put its packed copy of pythonfmu (without binaries, in a folder since deleted) first
    binary = Path(metadata.distribution("pythonfmu").locate_file(
        "pythonfmu/resources/binaries/linux64/libpythonfmu-export.so"))
    original = binary.read_bytes()
    if hashlib.sha256(original).hexdigest() not in VERIFIED_BINARIES:
        pytest.skip("the installed pythonfmu binary is not the verified one (the build refuses it: tested below)")
    offset, size = elf_symbol_offset(original, EXIT_HANDLER)
    if shutil.which("nm"):  # an independent reader of the symbol table: binutils
        listing = subprocess.run(["nm", "-D", "--defined-only", str(binary)],
                                 capture_output=True, text=True, check=True).stdout
        address = next(int(line.split()[0], 16) for line in listing.splitlines() if line.endswith(" " + EXIT_HANDLER))
        assert offset == address  # in this library the text segment's file offsets equal its addresses
    fixed = fix_exit_handler(original)
    difference = [i for i, (a, b) in enumerate(zip(original, fixed)) if a != b]
    assert len(fixed) == len(original) and difference == [offset + 4]
    assert fixed[offset:offset + 5] == bytes.fromhex("f30f1efa") + b"\xc3"  # endbr64; ret
    with zipfile.ZipFile(built_fmus["knee"]) as fmu:
        assert fmu.read("binaries/linux64/McKibbenKnee.so") == fixed

    changed = bytearray(original)
    changed[100] ^= 1
    with pytest.raises(BuildError, match="not a pythonfmu binary the exit fix was verified on"):
        fix_exit_handler(bytes(changed))
