"""`mkctl run` from an installed wheel, in a folder that is not the checkout: no checkout file is needed.

The wheel is built from a copy of what the package is made of (pyproject.toml, README.md, mkctl/), so the build
leaves nothing in the checkout; it is installed with ``pip install --no-deps --target`` and run with only that
folder on PYTHONPATH (the dependencies come from this Python's environment). Quick mode keeps it short.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE_FILES = ("pyproject.toml", "README.md")


def run(argv, cwd, env=None, timeout=600) -> subprocess.CompletedProcess:
    done = subprocess.run(argv, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)
    assert done.returncode == 0, f"{' '.join(map(str, argv))} failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"
    return done


@pytest.fixture(scope="module")
def installed(tmp_path_factory) -> Path:
    """The folder the wheel was installed into (``pip install --no-deps --target``)."""
    base = tmp_path_factory.mktemp("wheel")
    source = base / "source"
    source.mkdir()
    for name in PACKAGE_FILES:
        shutil.copy2(ROOT / name, source / name)
    shutil.copytree(ROOT / "mkctl", source / "mkctl", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    # "./source": a bare name would be looked up on the package index
    run([sys.executable, "-m", "pip", "wheel", "--no-deps", "-q", "-w", str(base / "wheels"), "./source"], cwd=base)
    wheels = list((base / "wheels").glob("mkctl-*.whl"))
    assert len(wheels) == 1, wheels
    target = base / "site"
    run([sys.executable, "-m", "pip", "install", "--no-deps", "-q", "--target", str(target), str(wheels[0])], cwd=base)
    return target


def test_mkctl_run_works_from_the_installed_wheel(installed, tmp_path):
    elsewhere = tmp_path / "elsewhere"
    elsewhere.mkdir()
    env = {**os.environ, "PYTHONPATH": str(installed)}
    # the package imported is the installed one, not the checkout
    where = run([sys.executable, "-c", "import mkctl; print(mkctl.__file__)"], elsewhere, env).stdout.strip()
    assert Path(where).resolve().is_relative_to(installed.resolve()), where
    run([sys.executable, "-m", "mkctl", "run", "--quick", "--out", "OUT"], elsewhere, env, timeout=900)
    out = elsewhere / "OUT"
    for name in ("fmu/McKibbenKnee.fmu", "fmu/McKibbenActuator.fmu", "scenario/pressure_step.csv",
                 "paper/claims.md", "control/step_small.png", "diagnosis/diagnosis.json", "index.html"):
        assert (out / name).is_file(), f"mkctl run from the wheel did not write {name}"
    assert not any(elsewhere.glob("*.py")) and not (elsewhere / "scenarios").exists()


def test_the_scenarios_run_as_modules_of_the_installed_package(installed, tmp_path):
    env = {**os.environ, "PYTHONPATH": str(installed)}
    done = run([sys.executable, "-m", "mkctl.scenarios.pressure_step", "--help"], tmp_path, env)
    assert "--fmu-dir" in done.stdout
