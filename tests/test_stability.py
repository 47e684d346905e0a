"""a1, a2 and h (Eq. 18-23) against a numerical Jacobian of the state equations; surfaces; verdicts."""
import numpy as np
import pytest

from mkctl.physics import knee, stability
from mkctl.physics.params import DEFAULT, Params


def numerical_jacobian(params, X, Pe, Pf, V=0.0):
    """Central differences of Eq. 17's right-hand side with respect to (X, V), pressures held."""
    rhs = lambda x, v: knee.knee_derivatives([x, v], Pe, Pf, params)  # noqa: E731
    hX, hV = 1e-7, 1e-6
    col_X = (rhs(X + hX, V) - rhs(X - hX, V)) / (2 * hX)
    col_V = (rhs(X, V + hV) - rhs(X, V - hV)) / (2 * hV)
    return np.column_stack([col_X, col_V])


@pytest.mark.parametrize("params", [Params(), Params(model=1), Params(c=45.0), Params(c=20.0, Fc=3.0, vs=0.01)])
@pytest.mark.parametrize("alpha_deg", [20, 45, 65])
def test_a1_a2_match_the_numerical_jacobian(params, alpha_deg):
    X = float(knee.X_from_alpha(np.radians(alpha_deg), params))
    Pe, Pf = 1.7e6, 1.5e5
    J = numerical_jacobian(params, X, Pe, Pf)
    a1, a2 = stability.routh_hurwitz_coefficients(X, Pe, Pf, 0.0, params)
    assert J[0] == pytest.approx([0.0, 1.0], abs=1e-9)
    assert a2 == pytest.approx(J[1, 0], rel=1e-6)
    assert a1 == pytest.approx(J[1, 1], rel=1e-6, abs=1e-9)


def test_model2_alone_has_a1_zero_and_damping_makes_it_negative():
    a1, _ = stability.routh_hurwitz_coefficients(0.84, 1.7e6, 1e5)
    assert a1 == 0.0
    p = Params(c=45.0)
    geo = knee.geometry_at_X(0.84, p)
    a1, _ = stability.routh_hurwitz_coefficients(0.84, 1.7e6, 1e5, 0.0, p)
    assert a1 == pytest.approx(-45.0 * (geo.G_e**2 + geo.G_f**2) / p.m, rel=1e-12)


def test_h_has_the_sign_of_a2_and_matches_the_alpha_derivative_of_F():
    alpha = np.radians(np.linspace(10, 80, 15))
    Pe, Pf = 1.7e6, 1.5e5
    h = stability.h_function(alpha, Pe, Pf)
    F = lambda a: knee.ground_force(knee.X_from_alpha(a), Pe, Pf)  # noqa: E731
    np.testing.assert_allclose(h, (F(alpha + 1e-7) - F(alpha - 1e-7)) / 2e-7, rtol=1e-6, atol=1e-6)
    _, a2 = stability.routh_hurwitz_coefficients(knee.X_from_alpha(alpha), Pe, Pf)
    assert np.array_equal(np.sign(h), np.sign(a2))


def test_equilibrium_pressure_balances_gravity():
    alpha, Pf = np.radians(np.linspace(15, 75, 9)), 1e5
    Pe = stability.equilibrium_pressure(alpha, Pf)
    np.testing.assert_allclose(knee.ground_force(knee.X_from_alpha(alpha), Pe, Pf), DEFAULT.m * DEFAULT.g, rtol=1e-9)


def test_h_zero_surface_is_where_h_vanishes():
    alpha, Pf = np.radians(np.linspace(15, 75, 9)), 2e5
    Pe = stability.h_zero_pressure(alpha, Pf)
    np.testing.assert_allclose(stability.h_function(alpha, Pe, Pf), 0.0, atol=1e-6)


def test_verdicts_and_poles():
    assert list(stability.verdict([-1.0, 0.0, -1.0, 1.0], [-4.0, -4.0, 2.0, -4.0])) == \
        ["stable", "marginal", "unstable", "unstable"]
    s = stability.poles(-2.0, -10.0)
    np.testing.assert_allclose(np.sort_complex(s), np.sort_complex(np.roots([1, 2.0, 10.0])))


def test_posture_stability_reports_equilibrium_and_verdict():
    bent = stability.posture_stability(np.radians(30), Pf=1e5)
    upright = stability.posture_stability(np.radians(65), Pf=1e5, params=Params(c=45.0))
    assert bent.in_equilibrium and bent.verdict == "unstable" and bent.a2 > 0
    assert upright.verdict == "stable" and upright.a1 < 0 and upright.a2 < 0
    assert all(s.real < 0 for s in upright.poles)
    assert stability.posture_stability(X=upright.X, Pf=1e5).verdict == "marginal"


def test_stable_equilibrium_height_is_a_stable_root():
    Pe, Pf = 1.75e6, 1e5
    X = stability.equilibrium_hip_height(Pe, Pf)
    assert knee.ground_force(X, Pe, Pf) == pytest.approx(DEFAULT.m * DEFAULT.g, rel=1e-9)
    assert stability.routh_hurwitz_coefficients(X, Pe, Pf)[1] < 0
