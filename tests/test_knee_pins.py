"""Pins of the knee's linearization without pressure states, its end stops at their boundary and the posture's
bounds (issue 18's mutation run): each against an independent reference (finite differences of Eq. 17's
right-hand side, the float path against the array path, the documented open interval)."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mkctl.errors import DomainError
from mkctl.physics import knee
from mkctl.physics.params import Params

#: Other geometry, muscle and mass than the defaults (a function that falls back to the defaults differs here).
OTHER = Params(Lo=0.46, Lu=0.45, r=0.062, C1=170e3, C2=1500.0, m=8.0, c=30.0)


def test_the_linearization_without_pressure_states_is_the_jacobian_of_eq_17():
    X, Pe, Pf = 0.8, 3.2e5, 1.1e5
    A, B = knee.linearization(X, Pe, Pf, Pe, Pf, OTHER)
    assert A.shape == (2, 2) and B.shape == (2, 2)
    rhs = lambda y, u: knee.knee_derivatives(y, *u, OTHER)  # noqa: E731
    y0, u0 = np.array([X, 0.0]), np.array([Pe, Pf])
    for j, h in enumerate((1e-6, 1e-5)):
        e = np.zeros(2)
        e[j] = h
        np.testing.assert_allclose(A[:, j], (rhs(y0 + e, u0) - rhs(y0 - e, u0)) / (2 * h), rtol=1e-6, atol=1e-9)
    for j in range(2):
        e = np.zeros(2)
        e[j] = 1.0
        np.testing.assert_allclose(B[:, j], (rhs(y0, u0 + e) - rhs(y0, u0 - e)) / 2.0, rtol=1e-6, atol=1e-15)
    assert A[0, 0] == 0.0 and A[0, 1] == 1.0 and (B[0] == 0.0).all()


def test_the_end_stops_engage_strictly_beyond_their_positions_on_both_paths():
    low, high = knee.stop_positions(OTHER)
    d = 2 * math.sqrt(knee.STOP_STIFFNESS * OTHER.m)
    for X, V, want in ((low, -0.1, 0.0), (high, 0.1, 0.0), (low - 1e-3, -0.1, knee.STOP_STIFFNESS * 1e-3 + d * 0.1),
                       (high + 1e-3, 0.1, -(knee.STOP_STIFFNESS * 1e-3 + d * 0.1)), (0.5 * (low + high), 5.0, 0.0)):
        scalar = knee.end_stop_force(X, V, OTHER)
        assert type(scalar) is float and scalar == pytest.approx(want, rel=1e-12, abs=0.0)
        array = knee.end_stop_force(np.array([X, X]), np.array([V, V]), OTHER)
        np.testing.assert_allclose(array, [want, want], rtol=1e-12, atol=0.0)


def test_the_posture_takes_alpha_in_the_open_quarter_turn():
    for alpha in (0.0, math.pi / 2, -0.1, 2.0):
        with pytest.raises(DomainError, match="outside \\(0, 90\\) deg"):
            knee.posture(alpha, params=OTHER)
    a, X = knee.posture(1.2, params=OTHER)
    assert a == 1.2 and X == pytest.approx(float(knee.X_from_alpha(1.2, OTHER)), rel=1e-15)


def test_the_knee_domain_checks_say_what_and_where_in_one_line():
    for beta in (0.0, math.pi, 3.3, -0.2):
        for given in (beta, np.array([1.5, beta])):
            with pytest.raises(DomainError) as error:
                knee.knee_geometry(given, OTHER)
            assert str(error.value) == f"knee angle beta = {beta!r} rad is outside (0, 3.14159) rad"
    for X in (0.01, 0.91, 0.95):
        with pytest.raises(DomainError) as error:
            knee.beta_from_X(X, OTHER)
        assert str(error.value) == (f"hip height X = {X!r} m is outside (0.01, 0.91) m (the leg cannot fold flat or "
                                    "stretch past straight)")


def test_the_knee_on_symbols_records_its_checks_and_computes_what_the_floats_do():
    import sympy

    from mkctl.physics import actuator
    beta, X, V = sympy.symbols("beta X V", real=True)
    with actuator.tracing_domain_checks() as trace:
        knee.knee_geometry(beta, OTHER, derivatives=False)
        knee.beta_from_X(X, OTHER)
    assert [(entry[0], entry[1], entry[4]) for entry in trace] == [(beta, 0.0, "knee angle beta [rad]"),
                                                                  (X, abs(0.46 - 0.45), "hip height X [m]")]
    assert trace[0][3](3.3, 0.0, math.pi) == "knee angle beta = 3.3 rad is outside (0, 3.14159) rad"
    assert trace[1][3](0.95, 0.01, 0.91).endswith("m (the leg cannot fold flat or stretch past straight)")
    numeric = knee.knee_derivatives([0.8, 0.05], 3.2e5, 1.1e5, OTHER)
    with actuator.tracing_domain_checks():
        symbolic = knee.knee_derivatives([X, V], 3.2e5, 1.1e5, OTHER)
    assert isinstance(symbolic, list)
    np.testing.assert_allclose([float(e.subs({X: 0.8, V: 0.05})) for e in symbolic], numeric, rtol=1e-12)


def test_the_geometry_of_one_float_is_floats():
    geo = knee.knee_geometry(1.5, OTHER)
    assert all(type(value) is float for value in geo)
    assert type(knee.beta_from_alpha(0.5, OTHER)) is float and type(knee.beta_from_X(0.8, OTHER)) is float


def test_the_geometry_without_derivatives_leaves_out_only_the_three_it_says():
    full, lean = knee.knee_geometry(1.5, OTHER), knee.knee_geometry(1.5, OTHER, derivatives=False)
    for name in knee.KneeGeometry._fields:
        if name in ("dalpha_dbeta", "dGe_dbeta", "dGf_dbeta"):
            assert getattr(lean, name) is None and getattr(full, name) is not None
        else:
            assert getattr(lean, name) == getattr(full, name), name
    lean_X = knee.geometry_at_X(0.8, OTHER, derivatives=False)
    assert lean_X.dGe_dbeta is None and lean_X.X == pytest.approx(0.8, rel=1e-13)


def test_the_knee_rest_of_a_full_run():
    from mkctl.errors import ParameterError
    for given in ({}, {"alpha": 1.0, "X": 0.8}):
        with pytest.raises(ParameterError) as error:
            knee.posture(params=OTHER, **given)
        assert str(error.value) == "give exactly one of the kneecap angle alpha and the hip height X"
    low, high = knee.stop_positions(OTHER)
    assert knee.end_stop_force(low, 30.0, OTHER) == 0.0 and knee.end_stop_force(high, -30.0, OTHER) == 0.0
    X = np.array([low - 1e-3, 0.5 * (low + high), high + 1e-3])
    d = 2 * math.sqrt(knee.STOP_STIFFNESS * OTHER.m)
    np.testing.assert_allclose(knee.end_stop_force(X, 0.0, OTHER), [200.0, 0.0, -200.0], rtol=1e-12)
    np.testing.assert_allclose(knee.end_stop_force(X, np.full(3, -0.1), OTHER), [200.0 + 0.1 * d, 0.0, 0.0])  # never pulling
    assert knee.linearization_state_names(OTHER) == ("X", "V")
    assert knee.linearization_state_names(Params(tau=0.05)) == ("X", "V", "Pe", "Pf")
    assert knee.linearization_state_names(Params(delay=0.03)) == ("X", "V", "pe_pade", "pf_pade")
    import sympy

    from mkctl.physics import actuator
    beta = sympy.Symbol("beta", real=True)
    with actuator.tracing_domain_checks() as trace:
        knee.knee_geometry(beta, OTHER, derivatives=False)
    assert trace[0][1:3] == (0.0, math.pi)
