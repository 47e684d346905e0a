"""Shared fixtures: the FMUs, built once per test session, and a way to run code in a fresh Python; and the
switch that turns a skip for a missing toolchain into a failure in CI.

Toolchains: a test that needs a tool the machine may lack (a C compiler, MinGW-w64, Wine, ...) calls
``require_or_skip(available, what)``. On a user's clone it skips, saying what is missing and that CI would fail
there; with ``MKCTL_REQUIRE_TOOLCHAINS=1`` (set by ``.ci/run``: CI promises these tools) it fails, naming what is
missing. The skips the test files already had (``pytest.skip(...)``, ``skipif`` marks, ``importorskip``) follow
the same switch through :func:`pytest_runtest_makereport`: a skip whose reason names a toolchain of
:data:`TOOLCHAIN_SKIPS` fails under the switch.

The FMUs run in the host's Python: a process that already imported mkctl would make them use that copy
instead of the packed one (DEVELOPERS.md, "Known pitfalls"). Tests therefore drive the FMUs in a subprocess
(``run_python``) and compare with mkctl in the test process.
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]

#: The environment switch under which a missing toolchain fails the test instead of skipping it (.ci/run sets it).
REQUIRE_TOOLCHAINS = "MKCTL_REQUIRE_TOOLCHAINS"
#: Skip reasons that name a toolchain CI promises (what is missing, matched in the reason, case-insensitive).
TOOLCHAIN_SKIPS = {
    "a C compiler": r"no C compiler|gcc is not installed|no shared libpython",
    "MinGW-w64": r"MinGW",
    "Wine": r"\bWine\b",
    "cmake": r"cmake is not installed",
    "valgrind": r"valgrind is not installed",
    "libcosimpy": r"libcosimpy",
    "git": r"\bgit\b|cannot clone this checkout",
}


def toolchains_required() -> bool:
    """Whether a missing toolchain is a failure here (``MKCTL_REQUIRE_TOOLCHAINS`` set, not 0): CI."""
    return os.environ.get(REQUIRE_TOOLCHAINS, "").strip() not in ("", "0")


def require_or_skip(available, what: str) -> None:
    """Carry on when ``available`` is true; else fail under ``MKCTL_REQUIRE_TOOLCHAINS=1`` (CI promises the tool)
    or skip (a user's clone), the message naming ``what`` is missing (e.g. "no C compiler (gcc, cc, clang)").
    Other helpers call it too (a cross toolchain, an emulator)."""
    if available:
        return
    if toolchains_required():
        pytest.fail(f"{what}, and {REQUIRE_TOOLCHAINS}=1 says this machine must have it (CI)", pytrace=False)
    pytest.skip(f"{what} (a missing toolchain: CI fails here, with {REQUIRE_TOOLCHAINS}=1)")


def missing_toolchain(reason: str) -> str | None:
    """The toolchain a skip's reason says is missing (a key of :data:`TOOLCHAIN_SKIPS`), or None."""
    for name, pattern in TOOLCHAIN_SKIPS.items():
        if re.search(pattern, reason, re.IGNORECASE):
            return name
    return None


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    """Under ``MKCTL_REQUIRE_TOOLCHAINS=1``, a skip for a missing toolchain (its reason names one of
    :data:`TOOLCHAIN_SKIPS`) is reported as a failure naming it; a skip for anything else (slow, a platform's
    limit) stays a skip."""
    outcome = yield
    report = outcome.get_result()
    if not (report.skipped and toolchains_required()) or hasattr(report, "wasxfail"):
        return
    reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
    tool = missing_toolchain(reason)
    if tool is not None:
        report.outcome = "failed"
        report.longrepr = (f"{tool} is missing ({reason.removeprefix('Skipped: ')}), and {REQUIRE_TOOLCHAINS}=1 "
                           f"says this machine must have it (CI)")


@pytest.fixture(scope="session")
def built_fmus(tmp_path_factory) -> dict[str, Path]:
    """``{"knee": Path, "actuator": Path}``: the FMUs built by ``build_fmu.py`` (validated) into a temp folder."""
    out = tmp_path_factory.mktemp("fmus")
    done = subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "--out", str(out), "--no-run", "--no-native"],
                          capture_output=True, text=True, cwd=ROOT)
    if done.returncode != 0:
        pytest.fail(f"build_fmu.py failed:\n{done.stdout}\n{done.stderr}")
    return {"knee": out / "McKibbenKnee.fmu", "actuator": out / "McKibbenActuator.fmu"}


@pytest.fixture(scope="session")
def run_python(tmp_path_factory):
    """``run_python(code, *args, timeout=120) -> object``: run code in a fresh interpreter (outside the repository,
    so that ``import mkctl`` cannot pick up this checkout), and return the JSON it prints on its last line."""
    workdir = tmp_path_factory.mktemp("subprocess")

    def run(code: str, *args, timeout: float = 120):
        done = subprocess.run([sys.executable, "-c", code, *map(str, args)], capture_output=True, text=True,
                              cwd=workdir, timeout=timeout)
        if done.returncode != 0:
            raise AssertionError(f"subprocess failed ({done.returncode}):\n{done.stdout[-3000:]}\n"
                                 f"{done.stderr[-3000:]}")
        return json.loads(done.stdout.strip().splitlines()[-1])

    return run


def pytest_collection_modifyitems(config, items):
    """Tests marked ``slow`` (end-to-end runs of the docs' commands) run only with ``MKCTL_SLOW=1``, as in ``.ci/run``:
    the README's test command stays quick on a user's machine, and CI still runs everything."""
    if os.environ.get("MKCTL_SLOW", "").strip() not in ("", "0"):
        return
    skip = pytest.mark.skip(reason="slow: runs with MKCTL_SLOW=1 (as .ci/run does)")
    for item in items:
        if "slow" in item.keywords:
            item.add_marker(skip)
