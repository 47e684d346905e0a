"""What the cross-platform tests share (tests/test_win64.py, test_platforms.py, test_zig.py): ziglang
required or skipped, the native FMUs unzipped, and the C hosts of ``fmu/`` compiled and run on them.

A missing toolchain goes through conftest's switch (:func:`conftest.require_or_skip`): a skip on a
user's clone, a failure under ``MKCTL_REQUIRE_TOOLCHAINS=1`` (CI). The hosts print ``time value``
rows for one output of an FMU: the same arguments on two platforms' binaries must give the same
rows (:data:`HOST_CASES`).
"""
from __future__ import annotations

import subprocess
import zipfile
from pathlib import Path

import numpy as np

from conftest import ROOT, require_or_skip
from mkctl.physics.simulate import default_commands

PE0, PF0 = default_commands()
#: The FMUs' model identifiers and the short names the tests use.
SHORT = {"McKibbenKnee": "knee", "McKibbenActuator": "actuator"}
#: model: (output, stop time [s], start values): a knee that moves (damping, lag, a step), the
#: actuator's tension.
HOST_CASES = {
    "knee": ("X", 0.5, {"c": 40.0, "tau": 0.02, "Fc": 2.0, "pe_cmd": PE0 * 1.05}),
    "actuator": ("f", 0.2, {"tau": 0.05, "c": 10.0, "Fc": 3.0, "p_cmd": 4e5, "L": 0.17,
                            "Ldot": -0.01}),
}


def require_zig(what: str) -> None:
    """Carry on when the system C compiler and ziglang (pip's C toolchain) are both there; else skip
    or fail (CI) saying which is missing and that there is then no ``what``."""
    from mkctl.native import toolchain

    require_or_skip(toolchain.system_compiler() is not None, f"no system C compiler: no {what}")
    require_or_skip(toolchain.zig_installed(),
                    f"the {toolchain.ZIG_PACKAGE} package is not installed "
                    f"(pip install {toolchain.ZIG_EXTRA}): no {what}")


def unzipped_fmus(out: Path) -> dict:
    """{("fmi2" | "fmi3", "knee" | "actuator"): the unzipped FMU folder}: the native FMUs of both
    FMI versions built into ``out`` (with every platform's binary the machine can build)."""
    from mkctl.native.fmi3 import build_fmi3
    from mkctl.native.fmu import build_native

    folders = {}
    for version, built in (("fmi2", build_native(out)), ("fmi3", build_fmi3(out))):
        for name, path in built.items():
            folder = out / version / SHORT[name]
            with zipfile.ZipFile(path) as archive:
                archive.extractall(folder)
            folders[version, SHORT[name]] = folder
    return folders


def compile_host(compiler: list, version: str, target: Path, flags=(), libraries=("-ldl",)) -> Path:
    """Compile ``fmu/{version}_host.c`` (version ``fmi2``, ``fmi3`` or ``fmi2_me``, the Model Exchange
    host) with ``compiler`` (a command
    list: gcc, MinGW-w64, ``zig cc -target ...``) into ``target``, warnings as errors."""
    from mkctl.native.fmu import fmi2_headers

    source = ROOT / "fmu" / f"{version}_host.c"
    done = subprocess.run([*compiler, "-Wall", "-Werror", *flags, "-I", str(fmi2_headers()), "-o",
                           str(target), str(source), *libraries], capture_output=True, text=True)
    assert done.returncode == 0, f"{compiler[0]} on {source.name}:\n{done.stderr[-3000:]}"
    return target


def host_arguments(folder: Path, output: str, stop: float, **start: float) -> list[str]:
    """A host's arguments: the unzipped FMU, its GUID, the stop time, a 1 ms step, the output's value
    reference and ``reference=value`` start values (names looked up in modelDescription.xml)."""
    from fmpy import read_model_description

    md = read_model_description(str(folder))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    return [str(folder), md.guid, repr(stop), "0.001", str(vr[output]),
            *[f"{vr[name]}={value!r}" for name, value in start.items()]]


def run_host(command: list, env: dict | None = None, timeout: float = 300) -> np.ndarray:
    """Run a host (under an emulator when ``command`` starts with one) in ``env`` (default: an empty
    environment: no Python, no preload); its ``time value`` rows as an array."""
    done = subprocess.run(command, capture_output=True, text=True, env=env or {}, timeout=timeout)
    assert done.returncode == 0, f"{command[0]} failed ({done.returncode}):\n{done.stderr[-3000:]}"
    return np.loadtxt(done.stdout.splitlines())
