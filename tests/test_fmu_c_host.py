"""The knee FMU in a host that is not Python: fmu/fmi2_host.c, compiled with gcc, run with the recipe of
docs/fmu.md (libpython preloaded, PYTHONHOME and PYTHONPATH set), against mkctl."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import numpy as np
import pytest
from fmpy import read_model_description

from mkctl.physics.params import Params
from mkctl.physics.simulate import KneeSimulator, default_commands, default_hip_height

ROOT = Path(__file__).resolve().parents[1]


def python_environment() -> dict[str, str]:
    """The recipe: preload the shared libpython and point the embedded interpreter at this Python's modules."""
    import fmpy
    import numpy
    libpython = Path(sysconfig.get_config_var("LIBDIR")) / sysconfig.get_config_var("INSTSONAME")
    site_packages = str(Path(numpy.__file__).parents[1])
    assert Path(fmpy.__file__).parents[1] == Path(site_packages)
    env = {k: v for k, v in os.environ.items() if not k.startswith("PYTHON")}
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
    subprocess.run(["gcc", "-Wall", "-I", str(Path(fmpy.__file__).parent / "c-code"), "-o", str(binary),
                    str(ROOT / "fmu" / "fmi2_host.c"), "-ldl"], check=True, capture_output=True)
    return binary


def test_knee_fmu_runs_in_a_c_host_with_libpython_preloaded(host, built_fmus, tmp_path):
    # a long path on purpose: it gave a heap layout where the host aborted at exit (numpy's libgfortran exit
    # handler) before fmi2_host.c learned to end with _exit; see docs/fmu.md
    unzipped = tmp_path / ("a_deliberately_long_folder_name_" * 3) / "knee"
    with zipfile.ZipFile(built_fmus["knee"]) as fmu:
        fmu.extractall(unzipped)
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

    # without the recipe the FMU's library cannot even be loaded: the preload is what makes it work
    bare = {k: v for k, v in os.environ.items() if k not in ("LD_PRELOAD", "PYTHONHOME", "PYTHONPATH")}
    failed = subprocess.run(args, capture_output=True, text=True, env=bare, timeout=60)
    assert failed.returncode != 0 and "undefined symbol" in failed.stderr
