"""The knee FMU in libcosimpy (the Open Simulation Platform's engine, an independent FMI importer).

The same run (c = 40 N s/m, the extensor command stepped by 5 % at t = 0.1 s, 1 ms steps) goes through
libcosimpy and through fmpy, each in its own fresh process; the hip heights must agree with each other and
with mkctl.
"""
from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("libcosimpy")

from hosts import LIBCOSIM_KNEE_STEP  # noqa: E402
from mkctl.physics.params import Params  # noqa: E402
from mkctl.physics.simulate import KneeSimulator, default_commands, default_hip_height  # noqa: E402

PE0, PF0 = default_commands()
PE1 = PE0 * 1.05

FMPY = r"""
import json, sys
import numpy as np
from fmpy import simulate_fmu
fmu, pe0, pe1, pf = sys.argv[1], *map(float, sys.argv[2:5])
signal = np.array([(0.0, pe0, pf), (0.1, pe0, pf), (0.1, pe1, pf), (1.0, pe1, pf)],
                  dtype=[("time", float), ("pe_cmd", float), ("pf_cmd", float)])
result = simulate_fmu(fmu, stop_time=1.0, output_interval=1e-3, input=signal, start_values={"c": 40.0})
print(json.dumps({"time": result["time"].tolist(), "X": result["X"].tolist()}))
"""


def test_knee_fmu_runs_in_libcosimpy_with_the_same_results_as_in_fmpy(built_fmus, run_python):
    cosim = run_python(LIBCOSIM_KNEE_STEP, built_fmus["knee"], repr(PE1), "1.0")
    fmpy_run = run_python(FMPY, built_fmus["knee"], repr(PE0), repr(PE1), repr(PF0))
    assert cosim["ok"] == [True, True]
    assert cosim["time"][-1] == pytest.approx(1.0) and fmpy_run["time"][-1] == pytest.approx(1.0)
    cosim_X = dict(zip(np.round(cosim["time"], 9), cosim["X"]))
    shared = [(x, cosim_X[t]) for t, x in zip(np.round(fmpy_run["time"], 9), fmpy_run["X"]) if t in cosim_X]
    assert len(shared) == 1000
    fmpy_X, libcosim_X = np.array(shared).T
    assert np.ptp(libcosim_X) > 1e-3, "the step must move the leg"
    np.testing.assert_allclose(libcosim_X, fmpy_X, rtol=0, atol=1e-12)
    # and both equal mkctl run directly
    sim = KneeSimulator(Params(c=40.0), default_hip_height(), PE0, PF0)
    direct = [sim.state[0]] + [sim.step(1e-3, PE0 if k < 100 else PE1, PF0)[0] for k in range(1000)]
    np.testing.assert_allclose(fmpy_run["X"], direct, rtol=0, atol=1e-12)
