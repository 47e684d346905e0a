"""The control analysis against the packed knee FMU: its own linearization, and its step responses.

The FMU runs in a fresh interpreter (``run_python`` of conftest.py) so that it uses its packed copy of mkctl.
That interpreter loads :mod:`mkctl.analysis.fmu_probe` by file path (the module imports nothing from mkctl), so no
mkctl of this checkout is imported there before the FMU brings its own. The references (the analytic
linearization, the linear and nonlinear step responses) are computed here with mkctl.
"""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from mkctl.analysis import control as mc
from mkctl.physics.params import Params

ROOT = Path(__file__).resolve().parents[1]

PROBE = r"""
import importlib.util, json, sys
spec = importlib.util.spec_from_file_location("fmu_linear_standalone", sys.argv[1])
fl = importlib.util.module_from_spec(spec)
spec.loader.exec_module(fl)
fmu, job = sys.argv[2], json.loads(sys.argv[3])
assert "mkctl" not in sys.modules
out = {"linear": [], "steps": []}
for case in job["linear"]:
    A, B, dt = fl.linearize_fmu(fmu, case["start"], case["X0"], case["inputs"], case["lag"])
    x0 = fl.flow_map_jacobian(fmu, case["start"], case["X0"], case["inputs"], case["lag"], dt)[2]
    out["linear"].append({"A": A.tolist(), "B": B.tolist(), "x0": x0.tolist(), "dt": dt})
for case in job["steps"]:
    run = fl.fmu_step_response(fmu, case["start"], case["inputs0"], case["inputs1"], case["t_step"],
                               case["duration"], case["dt"])
    out["steps"].append({"time": run["time"].tolist(), "X": run["X"].tolist()})
out["mkctl"] = sys.modules["mkctl"].__file__
print(json.dumps(out))
"""

DURATION, T_STEP, DT = 1.6, 0.1, 1e-3


@pytest.fixture(scope="module")
def cases():
    op = mc.operating_point(math.radians(60), pf=100e3)
    damped = op.with_params(c=mc.damping_for_zeta(0.3, op))
    model1 = mc.operating_point(math.radians(65), pf=150e3, params=Params().replace(model=1, c=20.0))
    fast = mc.operating_point(math.radians(60), pf=100e3, params=Params().replace(m=0.01, c=0.2))  # w_n ~ 340/s
    return {"linear": [op, damped, damped.with_params(tau=0.05), model1, fast],
            "steps": [(damped, 1e3), (damped.with_params(tau=0.05), 1e3), (damped, 100e3)]}


@pytest.fixture(scope="module")
def probe(built_fmus, run_python, cases):
    job = {
        "linear": [{"start": op.params.as_dict(), "X0": op.X, "inputs": op.inputs.tolist(), "lag": op.params.tau > 0}
                   for op in cases["linear"]],
        "steps": [{"start": {**op.params.as_dict(), "X0": op.X}, "inputs0": op.inputs.tolist(),
                   "inputs1": [op.pe + dpe, op.pf], "t_step": T_STEP, "duration": DURATION, "dt": DT}
                  for op, dpe in cases["steps"]],
    }
    import json
    return run_python(PROBE, ROOT / "mkctl" / "analysis" / "fmu_probe.py", built_fmus["knee"], json.dumps(job), timeout=300)


def test_the_fmu_used_its_packed_mkctl(probe):
    assert not Path(probe["mkctl"]).resolve().is_relative_to(ROOT)


def test_fmu_linearization_agrees_with_the_analytic_one(probe, cases):
    for op, found in zip(cases["linear"], probe["linear"]):
        analytic = mc.analytic_linearization(op)
        A, B = np.array(found["A"]), np.array(found["B"])
        assert np.array(found["x0"]) == pytest.approx(op.states, rel=1e-9, abs=1e-9)  # it rests at op
        sx = np.array([mc.LINEARIZE_SCALE[s] for s in op.state_names])
        scaled = lambda A_, B_: np.hstack([A_ * sx[None, :] / sx[:, None], B_ * 1e6 / sx[:, None]])  # noqa: E731
        ref = scaled(analytic.A, analytic.B)
        assert np.abs(scaled(A, B) - ref).max() / np.abs(ref).max() < 1e-3
        assert A[1, 0] == pytest.approx(analytic.A[1, 0], rel=1e-3)  # a2
        w_n = math.sqrt(-analytic.A[1, 0])
        assert A[1, 1] == pytest.approx(analytic.A[1, 1], abs=1e-3 * w_n)  # a1 (0 for model 2 alone)
        eig, ref_eig = np.sort_complex(np.linalg.eigvals(A)), np.sort_complex(analytic.poles())
        np.testing.assert_allclose(eig, ref_eig, rtol=1e-3, atol=1e-3 * w_n)
        assert found["dt"] * np.abs(ref_eig).max() < math.pi  # dt was shortened where the knee is fast


def test_small_steps_agree_linear_nonlinear_and_fmu(probe, cases):
    for (op, dpe), run in zip(cases["steps"], probe["steps"]):
        ours = mc.step_responses(op, dpe, duration=DURATION, t_step=T_STEP, dt=DT, fmu=None)
        assert np.array(run["time"]) == pytest.approx(ours["time"], abs=1e-9)
        fmu = np.array(run["X"]) - op.X
        peak = np.abs(ours["nonlinear"]).max()
        assert np.abs(fmu - ours["nonlinear"]).max() < 1e-6 * peak + 1e-9  # FMU = library, packed or not
        linear_error = np.abs(fmu - ours["linear"]).max() / peak
        if dpe <= 1e3:
            assert linear_error < 0.01
        else:
            assert linear_error > 0.2  # a large step: the linear model is off


def test_step_responses_api_runs_the_fmu(built_fmus, cases):
    """The API path with an FMU (in this process: the FMU uses this checkout's mkctl, fine for the API)."""
    op, dpe = cases["steps"][0]
    result = mc.step_responses(op, dpe, duration=0.5, t_step=T_STEP, dt=DT, fmu=built_fmus["knee"])
    assert result["fmu"] is not None and result["fmu_note"] is None
    assert set(result["info"]) == {"linear", "nonlinear", "fmu"}
    assert np.abs(result["fmu"] - result["nonlinear"]).max() < 1e-9


#: Two ways the library runs a pythonfmu FMU in the calling process: its own instance (the control analysis's
#: probe) and fmpy's simulate_fmu (the scenarios).
IN_PROCESS_RUNS = {
    "probe": "from mkctl.analysis import control as mc\n"
             "mc.step_responses(mc.operating_point(alpha=1.0472), 1e3, duration=0.3, fmu=FMU)\n",
    "simulate_fmu": "from mkctl.scenarios.common import simulate\nsimulate(FMU, 0.05)\n",
}


@pytest.mark.parametrize("how", list(IN_PROCESS_RUNS))
def test_an_fmu_run_in_process_leaves_no_trace_on_the_import_path(built_fmus, tmp_path, how):
    """After a pythonfmu FMU ran in a process (and its extraction folder was deleted), ``import pythonfmu`` still
    finds the installed package, and no ``sys.path`` entry points into the deleted folder. (It used to find the
    FMU's packed copy in the deleted folder: found by a test that read pythonfmu's binary after such a run.)"""
    import json
    import os
    import subprocess
    import sys

    script = (
        "import json, os, sys\n"
        "before = list(sys.path)\n"
        f"FMU = {str(built_fmus['knee'])!r}\n"
        + IN_PROCESS_RUNS[how] +
        "import pythonfmu\n"
        "print(json.dumps({'pythonfmu': pythonfmu.__file__, 'missing': [p for p in sys.path if p not in before "
        "and not os.path.exists(p)]}))\n")
    done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True, cwd=tmp_path, timeout=300,
                          env={**os.environ, "PYTHONPATH": str(ROOT)})
    assert done.returncode == 0, done.stderr[-2000:]
    seen = json.loads(done.stdout.strip().splitlines()[-1])
    assert Path(seen["pythonfmu"]).exists(), seen
    assert seen["missing"] == [], seen


def test_fmu_linearization_api_refuses_a_missing_fmu(cases):
    with pytest.raises(mc.FMUAnalysisError, match="not found"):
        mc.fmu_linearization(cases["linear"][0], "no/such.fmu")
