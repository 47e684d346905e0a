"""Typed results (python-control's manner): named arrays, a readable repr, to_dataframe, and the old dict access."""
import math
from dataclasses import fields

import numpy as np
import pytest

from mkctl.physics.params import Params
from mkctl.physics.results import SimulationResult
from mkctl.physics.simulate import KNEE_OUTPUTS, KneeSimulator, simulate_knee


@pytest.fixture(scope="module")
def run():
    t = np.linspace(0.0, 0.3, 31)
    return simulate_knee(t, np.where(t < 0.1, 1.75e6, 1.8e6), 1e5, Params(c=40.0))


def test_simulation_result_has_one_named_array_per_spec_output(run):
    assert isinstance(run, SimulationResult)
    assert [f.name for f in fields(SimulationResult)] == ["time", *KNEE_OUTPUTS]  # a new output needs a field
    assert run.keys() == ["time", *KNEE_OUTPUTS] and list(run) == run.keys() and len(run) == len(KNEE_OUTPUTS) + 1
    for name in run.keys():
        assert run[name] is getattr(run, name) and run[name].shape == run.time.shape and name in run
    assert "nope" not in run and run.get("nope") is None
    with pytest.raises(KeyError):
        run["nope"]


def test_simulation_result_holds_what_the_simulator_reports(run):
    """The same run stepped by hand through KneeSimulator (the FMU's core) gives the same numbers. Stepping
    sample by sample cuts the integrator's steps at every sample, where simulate_knee steps through each run of
    held commands and reads the samples off its dense output: the two agree to the integrator's tolerance
    (rtol 1e-10 per step, accumulated over the record), not to rounding."""
    sim = KneeSimulator(Params(c=40.0), X0=run.X[0], pe0=1.75e6, pf0=1e5)
    for k in range(1, run.time.size):
        sim.step(run.time[k] - run.time[k - 1], 1.75e6 if run.time[k - 1] < 0.1 else 1.8e6, 1e5)
    last = sim.outputs(1.8e6, 1e5)
    for name in KNEE_OUTPUTS:
        assert run[name][-1] == pytest.approx(last[name], rel=1e-7, abs=1e-9), name


def test_simulation_result_reads_as_a_table_and_a_summary(run):
    frame = run.to_dataframe()
    assert list(frame.columns) == run.keys() and len(frame) == run.time.size
    np.testing.assert_array_equal(frame["X"].to_numpy(), run.X)
    text = repr(run)
    assert text.startswith("SimulationResult:") and f"{run.time.size} samples" in text
    assert f"{run.X[-1]:.6g} m" in text and f"at the end: {bool(run.stable[-1])}" in text


def test_step_responses_are_typed_and_keep_the_dict_access():
    from mkctl.analysis import control as mc

    op = mc.operating_point(math.radians(60), Pf=100e3)
    op = op.with_params(c=mc.damping_for_zeta(0.3, op))
    result = mc.step_responses(op, 1e3, duration=1.5, fmu=None)
    assert isinstance(result, mc.StepResponses)
    assert result["info"] is result.info and result["nonlinear"] is result.nonlinear and result["fmu"] is None
    frame = result.to_dataframe()
    assert list(frame.columns) == ["time", "linear", "nonlinear"]
    np.testing.assert_array_equal(frame["linear"].to_numpy(), result.linear)
    text = repr(result)
    info = result.info["nonlinear"]
    assert f"overshoot {info['Overshoot']:.4g} %" in text and "FMU response not asked for" in text
    # the overshoot is the peak over the final value, read off the arrays themselves
    final = info["SteadyStateValue"]
    assert info["Overshoot"] == pytest.approx(100 * (result.nonlinear.max() - final) / final, rel=1e-9)
