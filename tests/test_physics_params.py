"""Every physics function honours the parameters it is given, and the thresholds sit where the equations put them.

Written against the survivors of ``python bench/mutation.py``: most were a function that silently fell back to
the default parameters (``f(x, )`` for ``f(x, params)``) or a comparison moved across its boundary, and the other
tests, which use the defaults, could not tell. Here the parameters differ from the defaults in the geometry, the
muscle, the mass and the effects, and each result is checked against an independent relation: a finite
difference of Eq. 17's right-hand side, a round trip, a force balance, the documented formula of the end stops.
"""
import math

import numpy as np
import pytest

from mkctl.physics import actuator, knee, stability
from mkctl.physics.params import DEFAULT, Params

#: Other geometry, muscle, mass and damping than the defaults: a function that ignores its params differs here.
OTHER = Params(Lo=0.46, Lu=0.45, r=0.062, C1=170e3, C2=1500.0, m=8.0, c=30.0)
#: Another muscle (braid, turns, rest length, rubber) for the actuator's own functions.
MUSCLE = Params(b=0.25, n=3.1, L0=0.215, C1=150e3, C2=2000.0, c=30.0)


def accel(params, X, V, Pe, Pf):
    """dV/dt of Eq. 17 (no stops): the library's right-hand side, the reference the others are checked against."""
    return float(knee.knee_derivatives([X, V], Pe, Pf, params)[1])


@pytest.fixture  # per test, not per module: mutmut must see each test compute it (its test selection)
def posture():
    alpha = math.radians(62.0)
    X = float(knee.X_from_alpha(alpha, OTHER))
    Pf = 1.2e5
    Pe = float(stability.equilibrium_pressure(alpha, Pf, OTHER))
    return alpha, X, Pe, Pf


def test_the_other_parameters_do_change_the_geometry_and_the_equilibrium(posture):
    alpha, X, Pe, Pf = posture
    assert abs(X - float(knee.X_from_alpha(alpha))) > 1e-3
    assert abs(Pe - float(stability.equilibrium_pressure(alpha, Pf))) > 1e4


def test_geometry_round_trips_with_other_parameters():
    alpha = np.radians([10.0, 40.0, 70.0])
    X = knee.X_from_alpha(alpha, OTHER)
    np.testing.assert_allclose(knee.alpha_from_X(X, OTHER), alpha, rtol=1e-12)
    beta = knee.beta_from_alpha(alpha, OTHER)
    np.testing.assert_allclose(knee.alpha_from_beta(beta, OTHER), alpha, rtol=1e-12)
    np.testing.assert_allclose(knee.hip_height(beta, OTHER), X, rtol=1e-12)
    np.testing.assert_allclose(knee.beta_from_X(X, OTHER), beta, rtol=1e-12)
    for which in (knee.geometry_at_alpha(alpha, OTHER), knee.geometry_at_X(X, OTHER)):
        np.testing.assert_allclose(which.X, X, rtol=1e-12)
        np.testing.assert_allclose(which.alpha, alpha, rtol=1e-12)
        np.testing.assert_allclose(which.beta, beta, rtol=1e-12)
    a, x = knee.posture(X=float(X[1]), params=OTHER)
    assert a == pytest.approx(alpha[1], rel=1e-12) and x == pytest.approx(X[1], rel=1e-12)
    a, x = knee.posture(float(alpha[2]), params=OTHER)
    assert x == pytest.approx(X[2], rel=1e-12)


def test_geometry_derivatives_are_those_of_the_geometry():
    beta, h = 2.5, 1e-6
    geo = knee.knee_geometry(beta, OTHER)
    up, down = knee.knee_geometry(beta + h, OTHER), knee.knee_geometry(beta - h, OTHER)
    for name in ("X", "Le", "Lf"):
        assert getattr(geo, f"d{name}_dbeta") == pytest.approx((getattr(up, name) - getattr(down, name)) / (2 * h),
                                                                 rel=1e-6)
    assert geo.beta == beta and geo.alpha == pytest.approx(float(knee.alpha_from_beta(beta, OTHER)), rel=1e-12)
    fast = knee.geometry_at_X(geo.X, OTHER, derivatives=False)
    assert (fast.X, fast.Le, fast.Lf, fast.G_e, fast.G_f) == pytest.approx((geo.X, geo.Le, geo.Lf, geo.G_e, geo.G_f))
    assert fast.dX_dbeta == pytest.approx(geo.dX_dbeta) and fast.dLe_dbeta == pytest.approx(geo.dLe_dbeta)


def test_the_stops_sit_at_the_same_angles_for_any_geometry():
    low, high = knee.stop_positions(OTHER)
    assert float(knee.alpha_from_X(low, OTHER)) == pytest.approx(knee.ALPHA_STOP_LOW, rel=1e-12)
    assert float(knee.alpha_from_X(high, OTHER)) == pytest.approx(knee.ALPHA_STOP_HIGH, rel=1e-12)


def test_ground_force_and_its_partials_with_other_parameters(posture):
    _, X, Pe, Pf = posture
    V = 0.02
    F = float(knee.ground_force(X, Pe, Pf, V, OTHER))
    assert F == pytest.approx(OTHER.m * (accel(OTHER, X, V, Pe, Pf) + OTHER.g), rel=1e-12)
    d = knee.knee_force_partials(knee.geometry_at_X(X, OTHER), V, Pe, Pf, OTHER)
    hP = 10.0
    assert d.dF_dPe == pytest.approx((knee.ground_force(X, Pe + hP, Pf, V, OTHER)
                                      - knee.ground_force(X, Pe - hP, Pf, V, OTHER)) / (2 * hP), rel=1e-6)
    assert d.dF_dPf == pytest.approx((knee.ground_force(X, Pe, Pf + hP, V, OTHER)
                                      - knee.ground_force(X, Pe, Pf - hP, V, OTHER)) / (2 * hP), rel=1e-6)


def test_the_stability_coefficients_are_eq17s_jacobian_with_other_parameters(posture):
    _, X, Pe, Pf = posture
    for V in (0.0, 0.05):
        a1, a2 = stability.routh_hurwitz_coefficients(X, Pe, Pf, V, OTHER)
        assert a2 == pytest.approx((accel(OTHER, X + 1e-7, V, Pe, Pf) - accel(OTHER, X - 1e-7, V, Pe, Pf)) / 2e-7,
                                   rel=1e-6)
        assert a1 == pytest.approx((accel(OTHER, X, V + 1e-6, Pe, Pf) - accel(OTHER, X, V - 1e-6, Pe, Pf)) / 2e-6,
                                   rel=1e-6)


def test_h_and_the_two_surfaces_with_other_parameters(posture):
    alpha, X, Pe, Pf = posture
    F = lambda a, pe: float(knee.ground_force(knee.X_from_alpha(a, OTHER), pe, Pf, 0.0, OTHER))  # noqa: E731
    h = float(stability.h_function(alpha, Pe, Pf, OTHER))
    assert h == pytest.approx((F(alpha + 1e-7, Pe) - F(alpha - 1e-7, Pe)) / 2e-7, rel=1e-6)  # at rest, V = 0
    assert F(alpha, Pe) == pytest.approx(OTHER.m * OTHER.g, rel=1e-10)  # equilibrium_pressure holds the hip
    pe0 = float(stability.h_zero_pressure(alpha, Pf, OTHER))
    assert abs(float(stability.h_function(alpha, pe0, Pf, OTHER))) < 1e-6 * abs(h)
    slope = float(stability.h_slope(alpha, Pe, Pf, OTHER))
    assert slope == pytest.approx((float(stability.h_function(alpha + 1e-4, Pe, Pf, OTHER))
                                   - float(stability.h_function(alpha - 1e-4, Pe, Pf, OTHER))) / 2e-4, rel=1e-4)


def test_posture_stability_reports_the_posture_it_was_given(posture):
    alpha, X, Pe, Pf = posture
    s = stability.posture_stability(X=X, Pf=Pf, params=OTHER)
    assert (s.alpha, s.X, s.Pe, s.Pf) == pytest.approx((alpha, X, Pe, Pf), rel=1e-10)
    a1, a2 = stability.routh_hurwitz_coefficients(X, Pe, Pf, 0.0, OTHER)
    assert (s.a1, s.a2) == pytest.approx((float(a1), float(a2)), rel=1e-12)
    assert s.h == pytest.approx(float(stability.h_function(alpha, Pe, Pf, OTHER)), rel=1e-12)
    assert s.verdict == "stable" and s.in_equilibrium


def test_the_stable_equilibrium_height_with_other_parameters_and_ranges(posture):
    alpha, X, Pe, Pf = posture
    found = stability.equilibrium_hip_height(Pe, Pf, OTHER)
    assert found == pytest.approx(X, abs=1e-9)  # the posture we started from, of the other geometry
    low, high = knee.stop_positions(OTHER)
    assert stability.equilibrium_hip_height(Pe, Pf, OTHER, X_range=(X - 0.01, X + 0.01), samples=7) == \
        pytest.approx(X, abs=1e-9)
    with pytest.raises(Exception, match="no stable equilibrium"):
        stability.equilibrium_hip_height(Pe, Pf, OTHER, X_range=(X + 0.002, high))  # the root is outside


@pytest.mark.parametrize("a1, a2, expected", [
    (-1.0, -1.0, "stable"), (-1.0, 0.0, "unstable"), (-1.0, 0.5, "unstable"),
    (0.0, -1.0, "marginal"), (0.0, 0.0, "unstable"), (0.0, 0.5, "unstable"), (0.5, -1.0, "unstable"),
])
def test_the_verdict_at_and_near_its_boundaries(a1, a2, expected):
    assert str(stability.verdict(a1, a2)) == expected
    s = np.sort_complex(stability.poles(a1, a2))
    np.testing.assert_allclose(s, np.sort_complex(np.roots([1.0, -a1, -a2]).astype(complex)), atol=1e-12)


def test_poles_of_many_postures_come_in_pairs():
    a1, a2 = np.array([-1.0, 0.0, -3.0]), np.array([-4.0, -9.0, 2.0])
    s = stability.poles(a1, a2)
    assert s.shape == (3, 2)
    for row, x, y in zip(s, a1, a2):
        np.testing.assert_allclose(np.sort_complex(row), np.sort_complex(np.roots([1.0, -x, -y]).astype(complex)),
                                   atol=1e-12)


def test_end_stop_force_is_the_documented_spring_damper():
    """docs/fmu.md: contact stiffness STOP_STIFFNESS, damping 2 sqrt(k m), one-sided; scalar and array alike."""
    low, high = knee.stop_positions(OTHER)
    k, d = knee.STOP_STIFFNESS, 2 * math.sqrt(knee.STOP_STIFFNESS * OTHER.m)
    cases = [  # (X, V, expected force)
        (high + 1e-3, 0.0, -k * 1e-3), (high + 1e-3, 0.01, -(k * 1e-3 + d * 0.01)),
        (high + 1e-3, -0.01, -(k * 1e-3 - d * 0.01)), (high + 1e-3, -1.0, 0.0),  # leaving fast: never pulls
        (low - 1e-3, 0.0, k * 1e-3), (low - 1e-3, -0.01, k * 1e-3 + d * 0.01),
        (low - 1e-3, 0.01, k * 1e-3 - d * 0.01), (low - 1e-3, 1.0, 0.0),
        (0.5 * (low + high), 0.3, 0.0), (high, 0.5, 0.0), (low, -0.5, 0.0),
    ]
    for X, V, expected in cases:
        assert knee.end_stop_force(X, V, OTHER) == pytest.approx(expected, rel=1e-12, abs=1e-12), (X, V)
    X = np.array([c[0] for c in cases])
    V = np.array([c[1] for c in cases])
    np.testing.assert_allclose(knee.end_stop_force(X, V, OTHER), [c[2] for c in cases], rtol=1e-12, atol=1e-12)
    # the stops given explicitly are the ones used
    assert knee.end_stop_force(0.7, 0.0, OTHER, stops=(0.71, 0.9)) == pytest.approx(k * 0.01, rel=1e-12)
    # and the state equations add them: the hip beyond the upper stop is pushed down by exactly that force
    pe, pf = 1.5e6, 1e5
    X0 = high + 2e-3
    with_stops = knee.knee_derivatives([X0, 0.0], pe, pf, OTHER, (low, high))[1]
    assert (with_stops - accel(OTHER, X0, 0.0, pe, pf)) * OTHER.m == pytest.approx(-k * 2e-3, rel=1e-9)


def test_actuator_functions_with_other_parameters():
    L, P, h = 0.19, 3e5, 1e-7
    f = lambda x: actuator.static_tension(x, P, MUSCLE)  # noqa: E731
    assert actuator.static_tension_dL(L, P, MUSCLE) == pytest.approx((f(L + h) - f(L - h)) / (2 * h), rel=1e-6)
    assert actuator.static_tension_dP(L, MUSCLE) == pytest.approx(
        (actuator.static_tension(L, P + 10, MUSCLE) - actuator.static_tension(L, P - 10, MUSCLE)) / 20, rel=1e-6)
    # model 2 (Eq. 13) is model 1 (Eq. 7) plus the rubber's V_r dW/dL; the rubber term is the energy's derivative
    W = lambda x: actuator.strain_energy_density(x, MUSCLE)  # noqa: E731
    rubber = MUSCLE.V_r * (W(L + h) - W(L - h)) / (2 * h)
    assert actuator.tension_model2(L, P, MUSCLE) == pytest.approx(actuator.tension_model1(L, P, MUSCLE) + rubber,
                                                                 rel=1e-6)
    assert actuator.elastic_tension(L, MUSCLE) == pytest.approx(rubber, rel=1e-6)
    assert actuator.tension(L, P, 0.0, MUSCLE) == pytest.approx(actuator.tension_model2(L, P, MUSCLE), rel=1e-12)
    # the default Ldot is 0: no damping force
    assert actuator.tension(L, P, params=MUSCLE) == actuator.tension(L, P, 0.0, MUSCLE)
    assert actuator.tension(L, P, 0.01, MUSCLE) == pytest.approx(actuator.tension(L, P, 0.0, MUSCLE) + 30.0 * 0.01,
                                                                rel=1e-12)


def test_friction_and_its_slope_with_and_without_friction():
    """The registry's damping and friction terms, and their exact slope (tension_partials) against differences."""
    L, P = 0.19, 2e5
    for Fc in (0.0, 1.0, 4.0):
        p = DEFAULT.replace(c=20.0, Fc=Fc, vs=0.01)
        for Ldot in (0.0, 0.004, np.array([-0.02, 0.0, 0.03])):
            expected = 20.0 * np.asarray(Ldot) + Fc * np.tanh(np.asarray(Ldot) / 0.01)
            moving = actuator.compose_tension(L, P, Ldot, p) - actuator.compose_tension(L, P, 0.0 * np.asarray(Ldot), p)
            np.testing.assert_allclose(moving, expected, rtol=1e-12, atol=1e-9)
            slope = (actuator.compose_tension(L, P, np.asarray(Ldot) + 1e-7, p)
                     - actuator.compose_tension(L, P, np.asarray(Ldot) - 1e-7, p)) / 2e-7
            np.testing.assert_allclose(actuator.tension_partials(L, P, Ldot, p)[2], slope, rtol=1e-6)


def test_slack_clips_at_zero_tension_exactly():
    """Model-spec section 4: a slack muscle carries no compression; any pull, however small, is carried."""
    values = [-1.0, -1e-9, 0.0, 1e-9, 0.5, 2.0]
    on, off = DEFAULT.replace(slack=1), DEFAULT.replace(slack=0)
    for f in values:
        assert actuator.apply_limits(f, on) == max(f, 0.0)
        assert actuator.apply_limits(f, off) == f
    np.testing.assert_array_equal(actuator.apply_limits(np.array(values), on), np.maximum(values, 0.0))
    # the limit's slope (tension_partials' last value): 0 where a slack muscle carries nothing, else 1
    model1 = DEFAULT.replace(model=1)
    for L, carries in ((0.1, 0.0), (0.2, 1.0)):  # model 1 pushes below b / sqrt(3) = 0.139 m
        assert actuator.tension_partials(L, 2e5, 0.0, model1.replace(slack=1))[4] == carries
        assert actuator.tension_partials(L, 2e5, 0.0, model1)[4] == 1.0


def test_the_slack_equilibrium_equals_the_taut_one_while_both_muscles_pull(posture):
    alpha, _, Pe, Pf = posture
    slack = OTHER.replace(slack=1)
    geo = knee.geometry_at_alpha(alpha, OTHER)
    assert float(knee.knee_force(geo, 0.0, Pe, Pf, OTHER).ff) > 1.0  # the flexor pulls more than 1 N here
    assert float(stability.equilibrium_pressure(alpha, Pf, slack)) == pytest.approx(Pe, rel=1e-12)


def test_defaults_of_the_velocity_are_rest(posture):
    _, X, Pe, Pf = posture
    assert knee.ground_force(X, Pe, Pf, params=OTHER) == knee.ground_force(X, Pe, Pf, 0.0, OTHER)
    assert stability.routh_hurwitz_coefficients(X, Pe, Pf, params=OTHER) == \
        stability.routh_hurwitz_coefficients(X, Pe, Pf, 0.0, OTHER)


def test_the_stops_given_to_the_state_equations_are_the_ones_used():
    stops = (0.70, 0.80)
    X, pe, pf = 0.81, 1.5e6, 1e5  # 1 cm beyond the given upper stop, inside the default ones
    assert knee.end_stop_force(X, 0.0, OTHER) == 0.0
    free = knee.knee_derivatives([X, 0.0], pe, pf, OTHER)[1]
    pushed = knee.knee_derivatives([X, 0.0], pe, pf, OTHER, stops)[1]
    assert (pushed - free) * OTHER.m == pytest.approx(-knee.STOP_STIFFNESS * 0.01, rel=1e-9)


def test_a_slack_muscle_neither_pushes_nor_responds_to_its_pressure():
    """Model-spec section 4 (slack): at alpha = 60 deg the unpressurized extensor is shorter than its rest length,
    its rubber would push (negative tension); with slack on it carries nothing and dF/dPe = 0 there."""
    slack = OTHER.replace(slack=1)
    geo = knee.geometry_at_alpha(math.radians(60.0), slack)
    fe = float(actuator.static_tension(geo.Le, 0.0, slack))
    ff = float(actuator.static_tension(geo.Lf, 2e5, slack))
    assert fe < 0 < ff  # the extensor would push, the flexor pulls
    F = float(knee.ground_force(geo.X, 0.0, 2e5, 0.0, slack))
    assert F == pytest.approx(-geo.G_f * ff, rel=1e-12)  # no push from the slack extensor
    assert float(knee.ground_force(geo.X, 0.0, 2e5, 0.0, OTHER)) == pytest.approx(geo.G_e * fe - geo.G_f * ff,
                                                                                 rel=1e-12)
    d = knee.knee_force_partials(geo, 0.0, 0.0, 2e5, slack)
    assert float(d.dF_dPe) == 0.0
    assert float(d.dF_dPf) == pytest.approx(-geo.G_f * float(actuator.static_tension_dP(geo.Lf, slack)), rel=1e-12)
