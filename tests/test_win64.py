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

import numpy as np
import pytest

from conftest import require_or_skip
from mkctl.native.cross import (find_cross_compiler, find_wine, missing_cross_compiler, wine_environment,
                                WINE_PACKAGES)
from toolchain_helpers import HOST_CASES, compile_host, host_arguments, require_zig, run_host, unzipped_fmus

#: Time box of Wine's first start in a fresh prefix [s] (about 6 s on the development machine).
WINEBOOT_SECONDS = 180


def _compiler():
    from mkctl.native.build import find_compiler
    return find_compiler()


pytestmark = pytest.mark.skipif(_compiler() is None, reason="no C compiler: no native FMUs")


@pytest.fixture(scope="module")
def wine(tmp_path_factory):
    """(wine command, its environment) with the prefix initialized, or a skip saying what is missing."""
    require_or_skip(find_cross_compiler() is not None, missing_cross_compiler())
    command = find_wine()
    require_or_skip(command is not None, f"Wine is not installed (Debian: apt-get install {WINE_PACKAGES}): the "
                    "Windows binaries cannot be run here")
    env = wine_environment(tmp_path_factory.mktemp("wineprefix"))
    try:
        subprocess.run([*command, "wineboot", "--init"], env=env, capture_output=True, timeout=WINEBOOT_SECONDS)
    except subprocess.TimeoutExpired:
        require_or_skip(False, f"Wine's first start (wineboot) took more than {WINEBOOT_SECONDS} s here")
    return command, env


@pytest.fixture(scope="module")
def hosts(tmp_path_factory, wine):
    """{("fmi2" | "fmi3", "linux" | "windows"): the C host binary}, compiled with gcc and MinGW-w64."""
    folder = tmp_path_factory.mktemp("hosts")
    built = {}
    for version in ("fmi2", "fmi3"):
        built[version, "linux"] = compile_host(_compiler(), version, folder / f"{version}_host")
        built[version, "windows"] = compile_host(find_cross_compiler(), version, folder / f"{version}_host.exe",
                                                 flags=("-D__USE_MINGW_ANSI_STDIO=1",), libraries=())
    return built


@pytest.fixture(scope="module")
def fmus(tmp_path_factory, wine):
    """{("fmi2" | "fmi3", "knee" | "actuator"): the unzipped FMU folder}, built with the Windows binaries."""
    return unzipped_fmus(tmp_path_factory.mktemp("win64"))


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
@pytest.mark.parametrize("model", ["knee", "actuator"])
def test_the_windows_binary_under_wine_gives_the_linux_results(wine, hosts, fmus, version, model):
    command, env = wine
    output, stop, start = HOST_CASES[model]
    arguments = host_arguments(fmus[version, model], output, stop, **start)
    linux = run_host([str(hosts[version, "linux"]), *arguments], env={})  # no Python, no preload
    windows = run_host([*command, str(hosts[version, "windows"]), *arguments], env=env)
    assert linux.shape == windows.shape == (round(stop / 1e-3) + 1, 2)
    if model == "knee":  # the actuator's inputs are held from the start: its tension is constant
        assert np.ptp(linux[:, 1]) > 1e-3 * np.abs(linux[:, 1]).max()  # it moved
    np.testing.assert_allclose(windows, linux, rtol=0, atol=1e-9 * max(1.0, np.abs(linux).max()))


def test_the_windows_binary_refuses_a_bad_parameter_with_the_linux_message(wine, hosts, fmus):
    command, env = wine
    arguments = host_arguments(fmus["fmi2", "knee"], "X", 0.01, m=-1.0)
    runs = [subprocess.run(c, capture_output=True, text=True, env=e, timeout=120)
            for c, e in (([str(hosts["fmi2", "linux"]), *arguments], {}),
                         ([*command, str(hosts["fmi2", "windows"]), *arguments], env))]
    assert [run.returncode for run in runs] == [1, 1]
    message = "invalid parameters: parameter m must be positive, got -1.0"
    assert all(message in run.stderr for run in runs), runs[1].stderr


def test_without_mingw_ziglang_builds_the_windows_binary_and_it_gives_the_linux_results(
        wine, hosts, tmp_path, monkeypatch):
    from mkctl.native.fmi3 import build_one
    require_zig("Windows binary built by ziglang")
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
    output, stop, start = HOST_CASES["knee"]
    arguments = host_arguments(folder, output, stop, **start)
    linux = run_host([str(hosts["fmi3", "linux"]), *arguments], env={})
    windows = run_host([*command, str(hosts["fmi3", "windows"]), *arguments], env=env)
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
