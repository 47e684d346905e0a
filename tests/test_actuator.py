"""Actuator models against spec section 2's reference table, finite differences and the domain."""
import numpy as np
import pytest

from mkctl.physics import actuator
from mkctl.errors import DomainError
from mkctl.physics.params import DEFAULT, Params

# model-spec section 2, reference values (Table I defaults)
REFERENCE = [  # L [m], P [Pa], f1 [N], f2 [N]
    (0.208, 300000, 192.718470, 192.718470),
    (0.18, 300000, 105.129671, 75.248131),
    (0.16, 200000, 33.537366, -1.807147),
    (0.22, 0, 0.0, 65.908613),
]


@pytest.mark.parametrize("L, P, f1, f2", REFERENCE)
def test_models_match_spec_reference_table(L, P, f1, f2):
    assert actuator.tension_model1(L, P) == pytest.approx(f1, rel=1e-6, abs=1e-9)
    assert actuator.tension_model2(L, P) == pytest.approx(f2, rel=1e-6)


def test_models_work_on_arrays():
    L = np.array([row[0] for row in REFERENCE])
    P = np.array([row[1] for row in REFERENCE])
    np.testing.assert_allclose(actuator.tension_model2(L, P), [row[3] for row in REFERENCE], rtol=1e-6)
    assert actuator.tension_model1([[0.2, 0.21]], 1e5).shape == (1, 2)


def test_rubber_is_relaxed_at_rest():
    # lambda_1 = lambda_2 = 1 at L0, so the Mooney-Rivlin term exerts no force there
    assert actuator.strain_energy_gradient(DEFAULT.L0) == pytest.approx(0.0, abs=1e-6)
    assert actuator.strain_energy_density(DEFAULT.L0) == pytest.approx(0.0, abs=1e-9)


def test_bladder_volume_derivative_is_the_pressure_gain():
    L, h = np.linspace(0.1, 0.23, 9), 1e-7
    dV = (actuator.bladder_volume(L + h, DEFAULT.b, DEFAULT.n) - actuator.bladder_volume(L - h, DEFAULT.b, DEFAULT.n)) / (2 * h)
    np.testing.assert_allclose(-dV, actuator.pressure_gain(L, DEFAULT.b, DEFAULT.n), rtol=1e-6)


L_GRID = np.linspace(0.12, 0.235, 13)


def central(fun, x, h):
    return (fun(x + h) - fun(x - h)) / (2 * h)


def test_strain_energy_gradient_matches_finite_difference():
    fd = central(actuator.strain_energy_density, L_GRID, 1e-6)
    np.testing.assert_allclose(actuator.strain_energy_gradient(L_GRID), fd, rtol=1e-6, atol=1e-2)


def test_strain_energy_curvature_matches_finite_difference():
    fd = central(actuator.strain_energy_gradient, L_GRID, 1e-7)
    np.testing.assert_allclose(actuator.strain_energy_curvature(L_GRID), fd, rtol=1e-6)


@pytest.mark.parametrize("model", [1, 2])
def test_static_tension_derivatives_match_finite_differences(model):
    p = Params(model=model)
    for P in (0.0, 150e3, 600e3):
        fd_L = central(lambda L: actuator.static_tension(L, P, p), L_GRID, 1e-7)
        np.testing.assert_allclose(actuator.static_tension_dL(L_GRID, P, p), fd_L, rtol=1e-6, atol=1e-6)
    fd_P = central(lambda P: actuator.static_tension(L_GRID, P, p), 2e5, 10.0)
    np.testing.assert_allclose(actuator.static_tension_dP(L_GRID, p), fd_P, rtol=1e-6, atol=1e-12)


def test_effects_add_their_terms():
    p = Params(c=40.0, Fc=3.0, vs=1e-3)
    base = actuator.tension(0.19, 2e5, 0.0, p)
    assert base == pytest.approx(actuator.tension_model2(0.19, 2e5))
    assert actuator.tension(0.19, 2e5, 0.01, p) - base == pytest.approx(40.0 * 0.01 + 3.0 * np.tanh(10.0))
    assert actuator.tension(0.19, 2e5, -0.01, p) - base == pytest.approx(-(40.0 * 0.01 + 3.0 * np.tanh(10.0)))
    v = np.array([-2e-3, 0.0, 5e-4, 1.0])
    fd = central(lambda x: actuator.tension(0.19, 2e5, x, p), v, 1e-8)
    np.testing.assert_allclose(actuator.tension_partials(0.19, 2e5, v, p)[2], fd, rtol=1e-5, atol=1e-6)


def test_pressure_lag_exact_solution_matches_the_rate():
    P, cmd, tau, dt = 1e5, 4e5, 0.05, 1e-6
    stepped = actuator.lagged_pressure(P, cmd, tau, dt)
    assert (stepped - P) / dt == pytest.approx(actuator.pressure_rate(P, cmd, tau), rel=1e-4)
    assert actuator.lagged_pressure(P, cmd, tau, 10.0) == pytest.approx(cmd)
    assert actuator.lagged_pressure(P, cmd, 0.0, 1e-3) == cmd  # no lag


@pytest.mark.parametrize("L", [0.0, -0.1, 0.241, 0.3, float("nan")])
def test_lengths_outside_the_domain_raise_not_nan(L):
    for model in (actuator.tension_model1, actuator.tension_model2):
        with pytest.raises(DomainError, match="outside the model's domain"):
            model(L, 1e5)
    with pytest.raises(DomainError):
        actuator.tension_model2(np.array([0.2, L]), 1e5)


@pytest.mark.parametrize("model", [actuator.tension_model1, actuator.tension_model2, actuator.static_tension])
def test_nan_pressure_raises_not_nan(model):
    with pytest.raises(DomainError, match="pressure"):
        model(0.2, float("nan"))
    with pytest.raises(DomainError, match="pressure"):
        model(np.array([0.2, 0.21]), np.array([1e5, np.inf]))


def test_nan_rate_raises():
    with pytest.raises(DomainError, match="Ldot"):
        actuator.tension(0.2, 1e5, float("nan"), Params(c=10.0))
