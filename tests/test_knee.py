"""Knee geometry and forces against spec section 3's table, virtual work and finite differences."""
import numpy as np
import pytest

from mkctl.physics import knee
from mkctl.errors import DomainError
from mkctl.physics.params import DEFAULT, Params

# model-spec section 3, reference values (Table I and II defaults)
REFERENCE = [  # alpha, X, beta, Le, Lf, G_e, G_f, F(Pe=500 kPa, Pf=100 kPa)
    (30, 0.764856, 123.0746, 0.179707, 0.190957, 0.142317, 0.176160, 16.62307),
    (60, 0.849920, 155.3305, 0.156525, 0.206288, 0.549926, 0.184043, 7.43166),
]


@pytest.mark.parametrize("row", REFERENCE)
def test_geometry_matches_spec_reference_table(row):
    alpha, X, beta, Le, Lf, Ge, Gf, F = row
    geo = knee.geometry_at_alpha(np.radians(alpha))
    assert geo.X == pytest.approx(X, rel=1e-6)
    assert np.degrees(geo.beta) == pytest.approx(beta, rel=1e-6)
    for value, ref in ((geo.Le, Le), (geo.Lf, Lf), (geo.G_e, Ge), (geo.G_f, Gf)):
        assert value == pytest.approx(ref, rel=1e-5)  # the table gives 6 significant digits
    # F at the exact posture: the table rounds X to 1 um, and F is steep in X
    assert knee.ground_force(geo.X, 500e3, 100e3) == pytest.approx(F, rel=1e-6)


def test_conversions_go_both_ways():
    alpha = np.radians(np.linspace(1, 83, 50))
    beta = knee.beta_from_alpha(alpha)
    np.testing.assert_allclose(knee.alpha_from_beta(beta), alpha, rtol=1e-12)
    X = knee.hip_height(beta)
    np.testing.assert_allclose(knee.beta_from_X(X), beta, rtol=1e-10)
    np.testing.assert_allclose(knee.alpha_from_X(knee.X_from_alpha(alpha)), alpha, rtol=1e-9)
    assert np.all(np.diff(X) > 0), "X must increase monotonically with alpha"


def test_alpha_range_and_moment_arm():
    assert np.degrees(knee.alpha_from_beta(np.pi - 1e-9)) == pytest.approx(83.88, abs=0.01)
    assert knee.alpha_from_beta(np.pi / 2) == pytest.approx(0.0, abs=1e-12)


BETAS = np.radians(np.linspace(95, 178, 30))


def test_gains_equal_virtual_work_jacobians():
    """Eq. 15 and 16 against -dLe/dX and +dLf/dX by finite differences of the lengths."""
    h = 1e-7
    up, down, geo = knee.knee_geometry(BETAS + h), knee.knee_geometry(BETAS - h), knee.knee_geometry(BETAS)
    dX = up.X - down.X
    np.testing.assert_allclose(geo.G_e, -(up.Le - down.Le) / dX, rtol=1e-6)
    np.testing.assert_allclose(geo.G_f, (up.Lf - down.Lf) / dX, rtol=1e-6)


@pytest.mark.parametrize("name", ["alpha", "X", "Le", "Lf", "G_e", "G_f"])
def test_geometry_derivatives_match_finite_differences(name):
    h = 1e-6
    fd = (getattr(knee.knee_geometry(BETAS + h), name) - getattr(knee.knee_geometry(BETAS - h), name)) / (2 * h)
    derivative = {"alpha": "dalpha_dbeta", "X": "dX_dbeta", "Le": "dLe_dbeta", "Lf": "dLf_dbeta",
                  "G_e": "dGe_dbeta", "G_f": "dGf_dbeta"}[name]
    np.testing.assert_allclose(getattr(knee.knee_geometry(BETAS), derivative), fd, rtol=1e-6, atol=1e-9)


@pytest.mark.parametrize("params", [Params(), Params(model=1), Params(c=45.0, Fc=4.0, vs=0.01)])
@pytest.mark.parametrize("V", [0.0, 0.02, -0.05])
def test_force_partials_match_finite_differences(params, V):
    X, Pe, Pf = np.linspace(0.70, 0.86, 7), 1.6e6, 2e5
    part = knee.knee_force_partials(knee.geometry_at_X(X, params), V, Pe, Pf, params)

    def F(X=X, V=V, Pe=Pe, Pf=Pf):
        return knee.ground_force(X, Pe, Pf, V, params)

    np.testing.assert_allclose(part.F, F(), rtol=1e-12)
    np.testing.assert_allclose(part.dF_dX, (F(X=X + 1e-7) - F(X=X - 1e-7)) / 2e-7, rtol=1e-5, atol=1e-3)
    np.testing.assert_allclose(part.dF_dV, (F(V=V + 1e-7) - F(V=V - 1e-7)) / 2e-7, rtol=1e-5, atol=1e-6)
    np.testing.assert_allclose(part.dF_dPe, (F(Pe=Pe + 10) - F(Pe=Pe - 10)) / 20, rtol=1e-6)
    np.testing.assert_allclose(part.dF_dPf, (F(Pf=Pf + 10) - F(Pf=Pf - 10)) / 20, rtol=1e-6)


def test_damping_gives_the_spec_velocity_derivative():
    p = Params(c=45.0)
    geo = knee.geometry_at_alpha(np.radians(40), p)
    part = knee.knee_force_partials(geo, 0.0, 1.5e6, 1e5, p)
    assert part.dF_dV == pytest.approx(-45.0 * (geo.G_e**2 + geo.G_f**2), rel=1e-12)


def test_state_equations_follow_eq_17():
    p = Params(tau=0.05)
    X, V, Pe, Pf = 0.84, 0.01, 1.6e6, 1.2e5
    d = knee.knee_derivatives([X, V, Pe, Pf], 1.7e6, 1e5, p)
    assert d[0] == V
    assert d[1] == pytest.approx(knee.ground_force(X, Pe, Pf, V, p) / p.m - p.g)
    assert d[2:] == pytest.approx([(1.7e6 - Pe) / 0.05, (1e5 - Pf) / 0.05])
    assert knee.state_names(p) == ("X", "V", "Pe", "Pf") and knee.state_names(DEFAULT) == ("X", "V")


def test_end_stops_push_back_only_beyond_them():
    low, high = knee.stop_positions()
    assert knee.end_stop_force((low + high) / 2, 0.3) == 0.0
    assert knee.end_stop_force(high + 1e-3, 0.0) == pytest.approx(-knee.STOP_STIFFNESS * 1e-3)
    assert knee.end_stop_force(low - 1e-3, 0.0) == pytest.approx(knee.STOP_STIFFNESS * 1e-3)
    assert knee.end_stop_force(high + 1e-4, -10.0) == 0.0  # leaving the stop: it never pulls


@pytest.mark.parametrize("X", [0.0, 0.005, 0.87, 1.0, float("nan")])
def test_impossible_hip_heights_raise(X):
    with pytest.raises(DomainError, match="hip height"):
        knee.geometry_at_X(X)


def test_posture_takes_exactly_one_of_alpha_and_X():
    from mkctl.errors import ParameterError
    alpha, X = knee.posture(np.radians(60))
    assert knee.posture(X=X) == pytest.approx((alpha, X))
    for bad in ({}, {"alpha": 1.0, "X": 0.8}):
        with pytest.raises(ParameterError, match="exactly one"):
            knee.posture(**bad)
    with pytest.raises(DomainError, match="outside"):
        knee.posture(np.radians(100))
