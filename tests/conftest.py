"""Shared fixtures: the FMUs, built once per test session, and a way to run code in a fresh Python.

The FMUs run in the host's Python: a process that already imported mkctl would make them use that copy
instead of the packed one (DEVELOPERS.md, "Known pitfalls"). Tests therefore drive the FMUs in a subprocess
(``run_python``) and compare with mkctl in the test process.
"""
from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]


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
