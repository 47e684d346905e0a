"""simulate_knee's outputs beyond X, V, Pe, Pf are computed when the first of them is read, in one pass over the
samples (compiled: mk_knee_outputs_many; Python: knee_outputs on numpy arrays): the values are those of
state_outputs at each sample's state, on both paths, with a lag and with a dead time."""
import copy
import pickle

import numpy as np
import pytest

from mkctl.native import build
from mkctl.physics.params import Params
from mkctl.physics.simulate import KNEE_OUTPUTS, knee_states, simulate_knee, state_outputs

DEFERRED = [name for name in KNEE_OUTPUTS if name not in ("X", "V", "Pe", "Pf")]
CASES = {"damped": Params(c=40.0), "lag": Params(c=20.0, tau=0.03), "dead time": Params(c=30.0, delay=0.012)}


def record():
    t = np.linspace(0.0, 0.4, 401)
    return t, np.where(t < 0.1, 1.75e6, np.where(t < 0.25, 1.8e6, 1.7e6)), np.full(t.size, 1e5)


def seen_commands(t, pe, pf, params):
    """The commands the actuators see at each sample (a dead time late), computed here from the definition."""
    given = np.searchsorted(t, t - params.delay + 1e-12, side="right") - 1
    given = np.clip(given, 0, t.size - 1)
    return pe[given], pf[given]


@pytest.mark.parametrize("path", ["compiled", "python"])
@pytest.mark.parametrize("case", list(CASES))
def test_deferred_outputs_are_state_outputs_at_every_sample(case, path, monkeypatch):
    if path == "python":
        monkeypatch.setenv(build.ENV_SWITCH, "0")
    params = CASES[case]
    t, pe, pf = record()
    run = simulate_knee(t, pe, pf, params)
    assert not any(name in vars(run) for name in DEFERRED)  # nothing computed yet
    X, V = knee_states(t, pe, pf, params)
    np.testing.assert_array_equal(run.X, X)  # the same run as the states alone
    np.testing.assert_array_equal(run.V, V)
    a1 = run.a1  # the first read computes every deferred output
    assert all(name in vars(run) for name in DEFERRED) and run.a1 is a1
    pe_seen, pf_seen = seen_commands(t, pe, pf, params)
    lag = params.tau > 0
    for k in range(0, t.size, 7):
        state = [run.X[k], run.V[k]] + ([run.Pe[k], run.Pf[k]] if lag else [])
        expected = state_outputs(state, pe_seen[k], pf_seen[k], params)
        for name in KNEE_OUTPUTS:
            assert float(run[name][k]) == pytest.approx(float(expected[name]), rel=1e-12, abs=1e-12), (name, k)
    if not lag:
        np.testing.assert_array_equal(run.Pe, pe_seen)
        np.testing.assert_array_equal(run.Pf, pf_seen)


def test_a_pickled_or_copied_result_carries_every_output():
    t, pe, pf = record()
    for clone in (lambda r: pickle.loads(pickle.dumps(r)), copy.deepcopy, copy.copy):
        original = simulate_knee(t, pe, pf, CASES["damped"])
        twin = clone(original)
        assert "_compute" not in vars(twin)
        for name in ("time", *KNEE_OUTPUTS):
            np.testing.assert_array_equal(twin[name], original[name])


def test_an_unknown_attribute_is_an_attribute_error():
    t, pe, pf = record()
    run = simulate_knee(t, pe, pf)
    with pytest.raises(AttributeError, match="nope"):
        run.nope
    assert not hasattr(run, "nope") and hasattr(run, "alpha")
