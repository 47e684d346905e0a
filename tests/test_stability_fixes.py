"""equilibrium_pressure and h_zero_pressure where F and h are not affine in Pe.

The pressure threshold (model-spec section 4b, P0 > 0) bends F and h in Pe, and a slack extensor
(slack = 1, model 2) makes h flat in Pe while it is slack. The references here are independent of
the closed forms in mkctl.physics.stability: scipy's brentq on the exact ground force
(:func:`mkctl.physics.knee.ground_force`) and on :func:`mkctl.physics.stability.h_function`, and
h sampled on a grid of Pe.
"""
import numpy as np
import pytest
from scipy.optimize import brentq

from mkctl.errors import DomainError, MkctlError
from mkctl.physics import knee, simulate, stability
from mkctl.physics.params import DEFAULT

ALPHA60, PF = float(np.radians(60.0)), 100e3
THRESHOLD = DEFAULT.replace(P0=100e3)
SLACK = DEFAULT.replace(slack=1)


def ground_excess(alpha, Pe, Pf, params):
    """F - m g [N] at rest, on the exact force of Eq. 14."""
    X = knee.X_from_alpha(alpha, params)
    return float(knee.ground_force(X, Pe, Pf, 0.0, params)) - params.m * params.g


def brentq_equilibrium(alpha, Pf, params, low=-5e6, high=2e7):
    return brentq(lambda pe: ground_excess(alpha, pe, Pf, params), low, high, xtol=1e-6,
                  rtol=1e-14)


def brentq_h_zero(alpha, Pf, params, low=-2e7, high=2e7):
    return brentq(lambda pe: float(stability.h_function(alpha, pe, Pf, params)), low, high,
                  xtol=1e-6, rtol=1e-14)


def test_equilibrium_pressure_holds_the_hip_with_the_threshold():
    """The brief's case: the affine step gave 1.598 MPa and F - m g = -7.6 N."""
    Pe = stability.equilibrium_pressure(ALPHA60, PF, THRESHOLD)
    assert isinstance(Pe, float)
    assert abs(ground_excess(ALPHA60, Pe, PF, THRESHOLD)) < 1e-8
    assert Pe == pytest.approx(brentq_equilibrium(ALPHA60, PF, THRESHOLD), rel=1e-10)
    assert Pe == pytest.approx(1.698e6, rel=1e-3)  # measured; the affine step gave 1.598e6


@pytest.mark.parametrize("P0", [20e3, 100e3, 300e3])
def test_equilibrium_pressure_on_arrays_with_the_threshold(P0):
    params = DEFAULT.replace(P0=P0)
    alpha = np.radians(np.linspace(20, 75, 6))
    Pe = stability.equilibrium_pressure(alpha, PF, params)
    reference = [brentq_equilibrium(a, PF, params) for a in alpha]
    np.testing.assert_allclose(Pe, reference, rtol=1e-10)
    F = knee.ground_force(knee.X_from_alpha(alpha, params), Pe, PF, 0.0, params)
    np.testing.assert_allclose(F, params.m * params.g, rtol=1e-10)


def test_equilibrium_pressure_with_threshold_and_slack():
    params = DEFAULT.replace(P0=100e3, slack=1)
    alpha = np.radians([30.0, 60.0])
    Pe = stability.equilibrium_pressure(alpha, 300e3, params)
    np.testing.assert_allclose(Pe, [brentq_equilibrium(a, 300e3, params) for a in alpha],
                               rtol=1e-10)


def test_without_threshold_the_closed_form_is_kept_bit_for_bit():
    """P0 = 0: the result is the affine step itself (the numbers the suite pins do not move)."""
    alpha, Pf = np.radians(np.linspace(15, 75, 9)), np.array(150e3)
    for params in (DEFAULT, DEFAULT.replace(model=1), DEFAULT.replace(c=45.0)):
        geo = knee.geometry_at_alpha(alpha, params)
        partials = knee.knee_force_partials(geo, 0.0, 0.0, Pf, params)
        affine = (params.m * params.g - partials.F) / partials.dF_dPe
        assert np.array_equal(stability.equilibrium_pressure(alpha, Pf, params), affine)
        h0 = stability.h_function(alpha, 0.0, Pf, params)
        h1 = stability.h_function(alpha, 1.0, Pf, params)
        assert np.array_equal(stability.h_zero_pressure(alpha, Pf, params), -h0 / (h1 - h0))


def test_posture_stability_in_equilibrium_is_checked_on_the_force():
    found = stability.posture_stability(ALPHA60, Pf=PF, params=THRESHOLD)
    assert found.in_equilibrium
    assert abs(ground_excess(ALPHA60, found.Pe, PF, THRESHOLD)) < 1e-8
    # the affine step's old answer does not hold the hip: not an equilibrium
    assert not stability.posture_stability(ALPHA60, Pf=PF, Pe=1.598e6,
                                           params=THRESHOLD).in_equilibrium
    # a given Pe that holds the hip is an equilibrium too
    assert stability.posture_stability(ALPHA60, Pf=PF, Pe=found.Pe,
                                       params=THRESHOLD).in_equilibrium


def test_default_commands_hold_the_leg_with_the_threshold():
    pe_cmd, pf_cmd = simulate.default_commands(THRESHOLD)
    assert abs(ground_excess(simulate.DEFAULT_ALPHA, pe_cmd, pf_cmd, THRESHOLD)) < 1e-8


def test_h_zero_pressure_is_on_the_surface_with_the_threshold():
    """The brief's case: h was 1.5e7 N/rad at the secant's result."""
    Pe = stability.h_zero_pressure(ALPHA60, PF, THRESHOLD)
    assert isinstance(Pe, float)
    assert Pe == pytest.approx(brentq_h_zero(ALPHA60, PF, THRESHOLD), rel=1e-10)
    alpha = np.radians(np.linspace(20, 55, 5))
    Pe = stability.h_zero_pressure(alpha, 200e3, THRESHOLD)
    np.testing.assert_allclose(Pe, [brentq_h_zero(a, 200e3, THRESHOLD) for a in alpha],
                               rtol=1e-10)
    assert np.all(np.abs(stability.h_function(alpha, Pe, 200e3, THRESHOLD)) < 1e-9)


def test_h_zero_pressure_with_a_slack_extensor_is_a_one_line_error():
    """Slack extensor at 0 and 1 Pa (model 2, alpha = 60 deg, Pf = 100 kPa): was a bare
    ZeroDivisionError for a float and a silent inf for an array. h < 0 at every Pe there (checked on
    a grid), so no pressure puts h at 0."""
    grid = np.concatenate([-np.geomspace(1e3, 1e9, 40), [0.0], np.geomspace(1e3, 1e9, 40)])
    assert np.all(stability.h_function(ALPHA60, grid, PF, SLACK) < 0)
    for alpha in (ALPHA60, np.array([np.radians(40.0), ALPHA60])):
        with pytest.raises(DomainError) as error:
            stability.h_zero_pressure(alpha, PF, SLACK)
        assert isinstance(error.value, MkctlError)
        message = str(error.value)
        assert "\n" not in message and "slack" in message and "alpha = 60 deg" in message


def test_h_zero_pressure_with_slack_where_the_extensor_is_taut_at_the_root():
    """Where the extensor pulls at the h = 0 pressure, slack does not change it."""
    alpha = np.radians(np.linspace(20, 50, 4))
    with_slack = stability.h_zero_pressure(alpha, PF, SLACK)
    np.testing.assert_allclose(with_slack, stability.h_zero_pressure(alpha, PF), rtol=1e-9)
    fe = knee.knee_force(knee.geometry_at_alpha(alpha, SLACK), 0.0, with_slack, PF, SLACK).fe
    assert np.all(fe > 0)


def test_h_zero_pressure_with_slack_where_h_jumps_at_the_taut_pressure():
    """alpha = 30 deg, Pf = 0: both muscles slack at low Pe (h = 0), h < 0 once the extensor pulls;
    the result is the pressure where h changes sign, the extensor's taut pressure."""
    alpha = float(np.radians(30.0))
    Pe = stability.h_zero_pressure(alpha, 0.0, SLACK)
    below, above = Pe * (1 - 1e-9), Pe * (1 + 1e-9)
    assert stability.h_function(alpha, below, 0.0, SLACK) == 0.0
    assert stability.h_function(alpha, above, 0.0, SLACK) < -1.0
    geo = knee.geometry_at_alpha(alpha, SLACK)
    taut = DEFAULT  # the extensor's tension without the slack limit crosses 0 at this pressure
    fe = [float(knee.knee_force(geo, 0.0, pe, 0.0, taut).fe) for pe in (below, above)]
    assert fe[0] < 0 < fe[1]


def test_h_zero_pressure_where_none_marks_only_the_postures_without_a_sign_change():
    """A caller that maps the surface (Fig. 7 with slack) asks for NaN where h has no zero; every
    other posture gets the same pressure as without the option."""
    alpha = np.radians([30.0, 45.0, 60.0, 70.0])
    Pe = stability.h_zero_pressure(alpha, PF, SLACK, where_none=np.nan)
    assert np.array_equal(np.isnan(Pe), [False, False, True, True])
    for a, pe in zip(alpha[:2], Pe[:2]):
        assert pe == pytest.approx(stability.h_zero_pressure(float(a), PF, SLACK), rel=1e-12)
    for a in alpha[2:]:
        with pytest.raises(DomainError):
            stability.h_zero_pressure(float(a), PF, SLACK)
    assert np.isnan(stability.h_zero_pressure(ALPHA60, PF, SLACK, where_none=np.nan))
