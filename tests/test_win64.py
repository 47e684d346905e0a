"""The Windows binaries of the native FMUs (model-spec section 7c), proven by running them under Wine.

With MinGW-w64 installed, every native FMU carries a Windows DLL (``binaries/win64`` in FMI 2.0,
``binaries/x86_64-windows`` in FMI 3.0). The C hosts of ``fmu/`` are cross-compiled too and run under Wine on the
DLLs; their results must equal the Linux binaries' in the Linux build of the same hosts to 1e-9. Without MinGW-w64,
ziglang builds the DLL (against the Universal C Runtime of Windows 10 and later): that DLL runs under Wine too,
with the same results. Without a cross compiler or Wine the tests skip with a one-line reason (and fail under
``MKCTL_REQUIRE_TOOLCHAINS=1``, CI), and the build says so in one line (tested without them).
Wine's first start (wineboot) in a fresh prefix takes seconds: it is done once per module, time-boxed.
"""
from __future__ import annotations

import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from mkctl.native.cross import (find_cross_compiler, find_wine, missing_cross_compiler, wine_environment,
                                WINE_PACKAGES)
from mkctl.physics.simulate import default_commands

ROOT = Path(__file__).resolve().parents[1]
PE0, PF0 = default_commands()
#: Time box of Wine's first start in a fresh prefix [s] (about 6 s on the development machine).
WINEBOOT_SECONDS = 180


def _compiler():
    from mkctl.native.build import find_compiler
    return find_compiler()


pytestmark = pytest.mark.skipif(_compiler() is None, reason="no C compiler: no native FMUs")


#: CI sets it: a toolchain the tests need and do not find is a failure there, not a skip.
REQUIRE = "MKCTL_REQUIRE_TOOLCHAINS"


def missing(reason: str):
    """Skip with the reason, or fail when the toolchains are required
    (``MKCTL_REQUIRE_TOOLCHAINS=1``)."""
    if os.environ.get(REQUIRE) == "1":
        pytest.fail(f"{reason} ({REQUIRE}=1: CI promises this toolchain)")
    pytest.skip(reason)


@pytest.fixture(scope="module")
def wine(tmp_path_factory):
    """(wine command, its environment) with the prefix initialized, or a skip saying what is missing."""
    if find_cross_compiler() is None:
        missing(missing_cross_compiler())
    command = find_wine()
    if command is None:
        missing(f"Wine is not installed (Debian: apt-get install {WINE_PACKAGES}): the Windows binaries cannot "
                "be run here")
    env = wine_environment(tmp_path_factory.mktemp("wineprefix"))
    try:
        subprocess.run([*command, "wineboot", "--init"], env=env, capture_output=True, timeout=WINEBOOT_SECONDS)
    except subprocess.TimeoutExpired:
        missing(f"Wine's first start (wineboot) took more than {WINEBOOT_SECONDS} s here")
    return command, env


@pytest.fixture(scope="module")
def hosts(tmp_path_factory, wine):
    """{("fmi2" | "fmi3", "linux" | "windows"): the C host binary}, compiled with gcc and MinGW-w64."""
    from mkctl.native.fmu import fmi2_headers
    folder = tmp_path_factory.mktemp("hosts")
    built = {}
    for version in ("fmi2", "fmi3"):
        source = str(ROOT / "fmu" / f"{version}_host.c")
        built[version, "linux"] = folder / f"{version}_host"
        subprocess.run([*_compiler(), "-Wall", "-Werror", "-I", str(fmi2_headers()), "-o", str(built[version, "linux"]),
                        source, "-ldl"], check=True, capture_output=True)
        built[version, "windows"] = folder / f"{version}_host.exe"
        subprocess.run([*find_cross_compiler(), "-Wall", "-Werror", "-D__USE_MINGW_ANSI_STDIO=1", "-I",
                        str(fmi2_headers()), "-o", str(built[version, "windows"]), source],
                       check=True, capture_output=True)
    return built


@pytest.fixture(scope="module")
def fmus(tmp_path_factory, wine):
    """{("fmi2" | "fmi3", "knee" | "actuator"): the unzipped FMU folder}, built with the Windows binaries."""
    from mkctl.native.fmi3 import build_fmi3
    from mkctl.native.fmu import build_native
    out = tmp_path_factory.mktemp("win64")
    short = {"McKibbenKnee": "knee", "McKibbenActuator": "actuator"}
    folders = {}
    for version, built in (("fmi2", build_native(out)), ("fmi3", build_fmi3(out))):
        for name, path in built.items():
            folder = out / version / short[name]
            with zipfile.ZipFile(path) as archive:
                archive.extractall(folder)
            folders[version, short[name]] = folder
    return folders


def _run(command: list[str], env: dict | None, timeout: float = 120) -> np.ndarray:
    done = subprocess.run(command, capture_output=True, text=True, env=env, timeout=timeout)
    assert done.returncode == 0, f"{command[0]} failed ({done.returncode}):\n{done.stderr[-3000:]}"
    return np.loadtxt(done.stdout.splitlines())


def _arguments(folder: Path, output: str, stop: float, **start: float) -> list[str]:
    from fmpy import read_model_description
    md = read_model_description(str(folder))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return [str(folder), md.guid, repr(stop), "0.001", str(vr[output]),
            *[f"{vr[name]}={value!r}" for name, value in start.items()]]


CASES = {  # model, output, stop, start values: a knee that moves (damping, lag, a step), the actuator's tension
    "knee": ("X", 0.5, {"c": 40.0, "tau": 0.02, "Fc": 2.0, "pe_cmd": PE0 * 1.05}),
    "actuator": ("f", 0.2, {"tau": 0.05, "c": 10.0, "Fc": 3.0, "p_cmd": 4e5, "L": 0.17, "Ldot": -0.01}),
}


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
@pytest.mark.parametrize("model", ["knee", "actuator"])
def test_the_windows_binary_under_wine_gives_the_linux_results(wine, hosts, fmus, version, model):
    command, env = wine
    output, stop, start = CASES[model]
    arguments = _arguments(fmus[version, model], output, stop, **start)
    linux = _run([str(hosts[version, "linux"]), *arguments], env={})  # no Python, no preload
    windows = _run([*command, str(hosts[version, "windows"]), *arguments], env=env)
    assert linux.shape == windows.shape == (round(stop / 1e-3) + 1, 2)
    if model == "knee":  # the actuator's inputs are held from the start: its tension is constant
        assert np.ptp(linux[:, 1]) > 1e-3 * np.abs(linux[:, 1]).max()  # it moved
    np.testing.assert_allclose(windows, linux, rtol=0, atol=1e-9 * max(1.0, np.abs(linux).max()))


def test_the_windows_binary_refuses_a_bad_parameter_with_the_linux_message(wine, hosts, fmus):
    command, env = wine
    arguments = _arguments(fmus["fmi2", "knee"], "X", 0.01, m=-1.0)
    runs = [subprocess.run(c, capture_output=True, text=True, env=e, timeout=120)
            for c, e in (([str(hosts["fmi2", "linux"]), *arguments], {}),
                         ([*command, str(hosts["fmi2", "windows"]), *arguments], env))]
    assert [run.returncode for run in runs] == [1, 1]
    message = "invalid parameters: parameter m must be positive, got -1.0"
    assert all(message in run.stderr for run in runs), runs[1].stderr


def test_without_mingw_ziglang_builds_the_windows_binary_and_it_gives_the_linux_results(
        wine, hosts, tmp_path, monkeypatch):
    from mkctl.native import toolchain
    from mkctl.native.fmi3 import build_one
    if not toolchain.zig_installed():
        missing(f"the {toolchain.ZIG_PACKAGE} package is not installed "
                f"(pip install {toolchain.ZIG_EXTRA})")
    monkeypatch.setenv("MKCTL_MINGW_CC", "/nonexistent/x86_64-w64-mingw32-gcc")  # MinGW-w64 missing
    assert find_cross_compiler() is None
    folder = tmp_path / "knee"
    with zipfile.ZipFile(build_one("McKibbenKnee", tmp_path / "knee.fmu")) as archive:
        archive.extractall(folder)
    dll = folder / "binaries" / "x86_64-windows" / "McKibbenKnee.dll"
    assert sorted(p.name for p in dll.parent.iterdir()) == [dll.name]  # no .pdb or .lib beside it
    data = dll.read_bytes()
    assert b"api-ms-win-crt" in data and b"msvcrt.dll" not in data.lower()  # zig's: the UCRT
    command, env = wine
    output, stop, start = CASES["knee"]
    arguments = _arguments(folder, output, stop, **start)
    linux = _run([str(hosts["fmi3", "linux"]), *arguments], env={})
    windows = _run([*command, str(hosts["fmi3", "windows"]), *arguments], env=env)
    assert linux.shape == windows.shape and np.ptp(linux[:, 1]) > 1e-3 * np.abs(linux[:, 1]).max()
    np.testing.assert_allclose(windows, linux, rtol=0, atol=1e-9 * max(1.0, np.abs(linux).max()))


def test_without_a_cross_compiler_the_build_says_so_in_one_line(tmp_path):
    code = ("import sys; from mkctl.native.fmu import build_native; from mkctl.native.fmi3 import build_fmi3; "
            "build_native(sys.argv[1]); build_fmi3(sys.argv[1])")
    env = {**os.environ, "MKCTL_MINGW_CC": ""}
    done = subprocess.run([sys.executable, "-c", code, str(tmp_path)], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=600)
    assert done.returncode == 0, done.stderr[-3000:]
    notes = [line for line in done.stderr.splitlines() if "MinGW-w64" in line]
    assert len(notes) == 1 and notes[0].startswith("mkctl.native: note: no MinGW-w64 cross compiler"), notes
    for fmu in list((tmp_path / "native").glob("*.fmu")) + list((tmp_path / "fmi3").glob("*.fmu")):
        with zipfile.ZipFile(fmu) as archive:
            assert not [n for n in archive.namelist() if n.endswith(".dll")], fmu
