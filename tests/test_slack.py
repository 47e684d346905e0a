"""The slack effect (model-spec section 4): f = max(f, 0), applied last, everywhere tensions are computed."""
import numpy as np
import pytest

from mkctl import Params, ParameterError
from mkctl.physics import actuator, knee, stability

SLACK = Params(slack=1)


def test_slack_clamps_the_spec_table_row_that_pushes():
    # spec section 2 table: f2(0.16 m, 200 kPa) = -1.807147 N, a shortened muscle that would push
    assert actuator.tension(0.16, 200e3) == pytest.approx(-1.807147, abs=1e-6)
    assert actuator.tension(0.16, 200e3, params=SLACK) == 0.0
    # where the muscle pulls, slack changes nothing (spec table: f2(0.18, 300 kPa) = 75.248131 N)
    assert actuator.tension(0.18, 300e3, params=SLACK) == pytest.approx(75.248131, abs=1e-6)


def test_slack_applies_to_the_whole_tension_including_damping():
    p = Params(slack=1, c=100.0)
    # static tension -1.807 N; shortening at 0.01 m/s adds c Ldot = -1 N: still slack
    assert actuator.tension(0.16, 200e3, -0.01, p) == 0.0
    # lengthening at 0.05 m/s adds +5 N: the total 3.19 N pulls
    assert actuator.tension(0.16, 200e3, 0.05, p) == pytest.approx(-1.807147 + 5.0, abs=1e-6)
    arr = actuator.tension(np.array([0.16, 0.18]), np.array([200e3, 300e3]), 0.0, SLACK)
    assert arr[0] == 0.0 and arr[1] == pytest.approx(75.248131, abs=1e-6)


def test_slack_is_a_switch():
    assert "slack" in SLACK.effects and "slack" not in Params().effects
    for bad in (2, -1, 0.5):
        with pytest.raises(ParameterError):
            Params(slack=bad)
    assert isinstance(Params(slack=1.0).slack, int)


def _finite_difference(fun, x, h):
    return (fun(x + h) - fun(x - h)) / (2 * h)


@pytest.mark.parametrize("Pf", [0.0, 300e3])
def test_a_slack_muscle_contributes_nothing_to_the_jacobian(Pf):
    # at a deeply bent posture with no flexor pressure the flexor's model tension is negative: slack
    p = Params(slack=1, c=50.0)
    X = float(knee.X_from_alpha(np.radians(40), p))
    geo = knee.geometry_at_X(X, p)
    raw = knee.knee_force_partials(geo, 0.0, 1.0e6, Pf, Params(c=50.0))
    part = knee.knee_force_partials(geo, 0.0, 1.0e6, Pf, p)
    if raw.ff < 0:
        assert part.ff == 0.0 and part.dF_dPf == 0.0
    else:
        assert part.ff == pytest.approx(raw.ff)
    for name, h, fun in (
        ("dF_dX", 1e-7, lambda x: knee.knee_force(knee.geometry_at_X(x, p), 0.0, 1.0e6, Pf, p).F),
        ("dF_dV", 1e-7, lambda v: knee.knee_force(geo, v, 1.0e6, Pf, p).F),
    ):
        x0 = X if name == "dF_dX" else 0.0
        assert getattr(part, name) == pytest.approx(_finite_difference(fun, x0, h), rel=1e-5, abs=1e-6)


def test_equilibrium_pressure_with_a_slack_flexor_balances_the_weight():
    p = Params(slack=1, m=3.0)
    alpha = np.radians(35)
    pe = float(stability.equilibrium_pressure(alpha, 0.0, p))
    X = float(knee.X_from_alpha(alpha, p))
    force = knee.knee_force(knee.geometry_at_X(X, p), 0.0, pe, 0.0, p)
    assert force.F == pytest.approx(p.m * p.g, rel=1e-9)
    assert force.fe > 0
