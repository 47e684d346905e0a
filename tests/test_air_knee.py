"""The knee (and any mechanism) with the air: the pressures as states of the muscles' mass balance
(model-spec 4d), the linearization with them, sealed muscles, the lag as the small-signal limit.

The references are independent of mkctl's air path: the knee's geometry and tension of
tests/independent_rig.py, the ISO 6358 flow, volume and regulator of
tests/independent_pneumatics.py, and the mass balance written here, ``dp/dt = (k / V) (R T q - p
dV/dt)`` with ``dV/dt = (dV_b/dL) Ldot``, integrated by scipy's solve_ivp (Radau); the sealed
muscle's pressure from ``p V^k`` constant written here; finite differences of the right-hand side.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import independent_mechanisms as im
import independent_pneumatics as ip
import independent_rig as rig
from mkctl.errors import MkctlError
from mkctl.analysis import air_poles
from mkctl.physics import actuator, knee, mechanism, pneumatics, simulate, stability
from mkctl.physics.params import Params

#: The air's values every test here uses (the spec's typical valve; a smaller valve where it says).
AIR = {"C_fill": 5e-9, "C_exhaust": 0.0, "P_supply": 2e6, "band": 2e4, "b_cr": 0.3, "m_sub": 0.5,
       "k_poly": 1.2, "V_dead": 5e-6, "T_air": 293.15, "C_leak": 0.0}


def air_params(**values) -> Params:
    return Params(valve_flow=1, c=45.0, **{**{k: v for k, v in AIR.items() if k != "C_leak"},
                                           **values})


def _air_rate(P, command, L, Ldot, a, n, b):
    """The test's own mass balance of one muscle (regulator, ISO flow, leak from
    independent_pneumatics)."""
    u = ip.opening("command", command, P, a)
    q = ip.net_flow(u, P, a, a["T_air"])
    V = ip.volume(L, b, n, a["V_dead"])
    dV_dt = ip.volume_slope(L, b, n) * Ldot
    return a["k_poly"] / V * (ip.R * a["T_air"] * q - (P + ip.P_ATM) * dV_dt)


def independent_knee(time, pe_cmd, pf_cmd, p: Params, a: dict):
    """The knee with the air, from the spec's equations written in the tests: (X, V, Pe, Pf)."""
    n = rig.turns(p)
    hidden = {"c": p.c}
    X0 = rig.rest_height(pe_cmd[0], pf_cmd[0], p)
    y = np.array([X0, 0.0, pe_cmd[0], pf_cmd[0]])
    out = np.empty((time.size, 4))
    out[0] = y
    for k in range(time.size - 1):
        def rhs(t, s, pe=pe_cmd[k], pf=pf_cmd[k]):
            Le, Lf, Ge, Gf = (float(v) for v in rig.knee_geometry(s[0], p))
            F = (Ge * float(rig.tension(Le, s[2], -Ge * s[1], p, hidden))
                 - Gf * float(rig.tension(Lf, s[3], Gf * s[1], p, hidden)))
            return [s[1], F / p.m - p.g, _air_rate(s[2], pe, Le, -Ge * s[1], a, n, p.b),
                    _air_rate(s[3], pf, Lf, Gf * s[1], a, n, p.b)]
        sol = solve_ivp(rhs, (time[k], time[k + 1]), y, method="Radau", rtol=1e-11,
                        atol=[1e-12, 1e-12, 1e-5, 1e-5])
        y = sol.y[:, -1]
        out[k + 1] = y
    return out


def test_knee_with_air_matches_an_independent_simulator():
    p = air_params()
    Pf = 1e5
    Pe = float(stability.equilibrium_pressure(math.radians(60.0), Pf, p))
    time = np.linspace(0.0, 0.3, 61)
    pe_cmd = np.where(time < 0.05, Pe, 1.03 * Pe)  # a 3 % step: the valve saturates and chokes
    pf_cmd = np.where(time < 0.15, Pf, 1.5 * Pf)
    ours = simulate.simulate_knee(time, pe_cmd, pf_cmd, p, stops=False, rtol=1e-11)
    theirs = independent_knee(time, pe_cmd, pf_cmd, p, AIR)
    assert np.ptp(theirs[:, 0]) > 1e-3  # the leg moves (a millimetre and more)
    # measured: 1.4e-10 m, 2e-9 m/s, 0.009 and 0.044 Pa (of 1.7 MPa and 150 kPa)
    assert np.max(np.abs(ours.X - theirs[:, 0])) < 1e-8
    assert np.max(np.abs(ours.V - theirs[:, 1])) < 1e-7
    assert np.max(np.abs(ours.Pe - theirs[:, 2])) < 0.2
    assert np.max(np.abs(ours.Pf - theirs[:, 3])) < 0.2
    # the air moves with the leg: the flexor's pressure is not held at its command while it moves
    moving = (time > 0.05) & (time < 0.15)
    assert np.max(np.abs(ours.Pf[moving] - Pf)) > 1.0


def _rest(p, Pf=1e5, alpha=math.radians(60.0)):
    Pe = float(stability.equilibrium_pressure(alpha, Pf, p))
    return float(knee.X_from_alpha(alpha, p)), Pe, Pf


def _jacobian(y0, pe_cmd, pf_cmd, p, steps=(1e-7, 1e-6, 1.0, 1.0)):
    J = np.zeros((4, 4))
    for j, h in enumerate(steps):
        up, down = y0.copy(), y0.copy()
        up[j] += h
        down[j] -= h
        J[:, j] = (knee.knee_derivatives(up, pe_cmd, pf_cmd, p)
                   - knee.knee_derivatives(down, pe_cmd, pf_cmd, p)) / (2 * h)
    return J


def test_linearization_matches_finite_differences_of_the_right_hand_side():
    p = air_params()
    X, Pe, Pf = _rest(p)
    # away from the regulator's kink (u = 0): central differences hold on both sides
    y0 = np.array([X, 0.0, Pe - 5e3, Pf - 3e3])
    A, B = knee.linearization(X, y0[2], y0[3], Pe, Pf, p)
    J = _jacobian(y0, Pe, Pf, p)
    assert np.abs(J[0] - A[0]).max() == 0.0
    assert np.all(np.abs(J[1:] - A[1:]) <= 1e-6 * np.abs(A[1:]) + 1e-9)
    assert A[2, 1] != 0.0 and A[3, 1] != 0.0  # the motion moves the air (dV/dt)
    # the command's column: a central difference of the set-point
    h = 1.0
    up = knee.knee_derivatives(y0, Pe + h, Pf + h, p)
    down = knee.knee_derivatives(y0, Pe - h, Pf - h, p)
    assert np.allclose((up - down)[2:] / (2 * h), np.diag(B[2:]), rtol=1e-6)


def test_rest_linearization_is_the_filling_side_and_the_regulators_lag():
    p = air_params()
    X, Pe, Pf = _rest(p)
    A, _ = knee.linearization(X, Pe, Pf, Pe, Pf, p)
    y0 = np.array([X, 0.0, Pe, Pf])
    # one-sided difference below the set-point (the valve fills): the pressure rows' diagonal
    h = 1e-3
    geo = knee.geometry_at_X(X, p)
    for i, (P, L) in enumerate(((Pe, geo.Le), (Pf, geo.Lf))):
        low = y0.copy()
        low[2 + i] -= h
        slope = (knee.knee_derivatives(y0, Pe, Pf, p)[2 + i]
                 - knee.knee_derivatives(low, Pe, Pf, p)[2 + i]) / h
        assert A[2 + i, 2 + i] == pytest.approx(slope, rel=1e-5)
        V = ip.volume(float(L), p.b, rig.turns(p), p.V_dead)
        tau_fill, _ = pneumatics.regulator_time_constant(P, V, p.band, p.C_fill, p.C_exhaust,
                                                         p.P_supply, p.b_cr, p.m_sub, p.k_poly)
        assert A[2 + i, 2 + i] == pytest.approx(-1.0 / tau_fill, rel=1e-9)


def _sealed_force(X, X0, Pe0, Pf0, p):
    """The ground force along a sealed path: each muscle's p V^k constant (written here)."""
    n, k = rig.turns(p), p.k_poly
    Le0, Lf0, _, _ = rig.knee_geometry(X0, p)
    Le, Lf, Ge, Gf = rig.knee_geometry(X, p)
    pressures = []
    for L, L0, P0 in ((Le, Le0, Pe0), (Lf, Lf0, Pf0)):
        ratio = ip.volume(float(L0), p.b, n, p.V_dead) / ip.volume(float(L), p.b, n, p.V_dead)
        pressures.append((P0 + ip.P_ATM) * ratio ** k - ip.P_ATM)
    return float(rig.ground_force(X, 0.0, pressures[0], pressures[1], p, {}))


def test_sealed_knee_is_stiffer_by_the_air_spring():
    p = air_params()
    X, Pe, Pf = _rest(p)
    a1, a2 = stability.routh_hurwitz_coefficients(X, Pe, Pf, 0.0, p)
    s1, s2 = stability.sealed_coefficients(X, Pe, Pf, p)
    h = 1e-6
    fd = (_sealed_force(X + h, X, Pe, Pf, p) - _sealed_force(X - h, X, Pe, Pf, p)) / (2 * h * p.m)
    assert s2 == pytest.approx(fd, rel=1e-6)
    assert s1 == pytest.approx(float(a1), rel=1e-12)
    assert s2 < float(a2) * 1.2  # measured: -150.8 against -117.5 1/s^2 held (28 % stiffer)
    # the sealed linearization (valves closed, u = 0): the poles of s^2 - a1 s - a2_sealed, and 0
    # twice (each muscle's air mass is conserved)
    A, B = knee.linearization(X, Pe, Pf, Pe, Pf, p, sealed=True)
    eig = np.sort_complex(np.linalg.eigvals(A))
    expected = np.sort_complex(np.concatenate([np.roots([1.0, -s1, -s2]), [0.0, 0.0]]))
    assert np.allclose(eig, expected, atol=1e-9 * abs(s2))
    assert B[2, 0] > 0 and B[3, 1] > 0  # an opening fills


def test_sealed_stiffness_matches_finite_differences_of_p_V_k():
    p = air_params()
    n = rig.turns(p)
    for L, P in ((0.208, 3e5), (0.19, 1.2e6), (0.17, 5e4)):
        h = 1e-7

        def sealed(Lx):
            ratio = ip.volume(L, p.b, n, p.V_dead) / ip.volume(Lx, p.b, n, p.V_dead)
            return (P + ip.P_ATM) * ratio ** p.k_poly - ip.P_ATM

        fd = (sealed(L + h) - sealed(L - h)) / (2 * h)
        ours = pneumatics.sealed_stiffness(L, P, p.b, p.n, p.V_dead, p.k_poly)
        assert ours == pytest.approx(fd, rel=1e-7)
        # the linearization's Ldot column is the same spring per unit rate
        _, _, _, dLdot = actuator.air_pressure_partials(P, 0.0, L, 0.0, p, opening=True)
        assert dLdot == pytest.approx(ours, rel=1e-12)


def test_poles_move_with_the_valve_the_dead_volume_and_the_band():
    X, Pe, Pf = _rest(air_params())

    def pressure_poles(**values):
        p = air_params(**values)
        A, _ = knee.linearization(X, Pe, Pf, Pe, Pf, p)
        eig = np.linalg.eigvals(A)
        return np.sort(eig[np.abs(eig.imag) == 0].real)

    base = pressure_poles()
    assert np.all(pressure_poles(C_fill=1e-9) > base)  # a smaller valve: slower air
    assert np.all(pressure_poles(V_dead=5e-5) > base)  # more tubing: slower
    assert np.all(pressure_poles(band=1e5) > base)  # a wider band: slower
    assert np.all(pressure_poles(C_fill=1e-9) / base == pytest.approx(0.2, rel=0.05))


def test_small_steps_behave_like_the_lag_of_the_regulators_time_constant():
    p = air_params()
    X, Pe, Pf = _rest(p)
    Le = float(knee.geometry_at_X(X, p).Le)
    V = float(pneumatics.air_volume(Le, p.b, p.n, p.V_dead))
    tau, _ = pneumatics.regulator_time_constant(Pe, V, p.band, p.C_fill, p.C_exhaust, p.P_supply,
                                                p.b_cr, p.m_sub, p.k_poly)
    lagged = Params(c=45.0, tau=float(tau))
    time = np.linspace(0.0, 20 * tau, 401)
    pe_cmd = np.where(time < 2 * tau, Pe, Pe + 200.0)  # 200 Pa: far inside the 20 kPa band
    air = simulate.simulate_knee(time, pe_cmd, Pf, p, X0=X, stops=False)
    lag = simulate.simulate_knee(time, pe_cmd, Pf, lagged, X0=X, stops=False)
    step = lag.Pe - Pe
    assert np.max(np.abs(air.Pe - lag.Pe)) < 2e-3 * 200.0  # the lag's path, to 0.2 % of the step
    # a large step is no lag: the valve saturates and chokes
    pe_big = np.where(time < 2 * tau, Pe, Pe + 2e5)
    big = simulate.simulate_knee(time, pe_big, Pf, p, X0=X, stops=False)
    big_lag = simulate.simulate_knee(time, pe_big, Pf, lagged, X0=X, stops=False)
    assert np.max(np.abs(big.Pe - big_lag.Pe)) > 0.2 * 2e5
    assert step[-1] == pytest.approx(200.0, rel=1e-3)


def independent_hanging(time, commands, p, a, mech):
    n = rig.turns(p)
    y = np.array([im.rest(mech, [commands[0]], p), 0.0, commands[0]])
    out = np.empty((time.size, 3))
    out[0] = y
    for k in range(time.size - 1):
        def rhs(t, s, cmd=commands[k]):
            F = im.generalized_force(mech, s[0], s[1], [s[2]], p) + im.stop_force(mech, s[0], s[1])
            return [s[1], F / p.m, _air_rate(s[2], cmd, s[0], s[1], a, n, p.b)]
        sol = solve_ivp(rhs, (time[k], time[k + 1]), y, method="Radau", rtol=1e-11,
                        atol=[1e-12, 1e-12, 1e-5])
        y = sol.y[:, -1]
        out[k + 1] = y
    return out


def test_a_hanging_mass_with_the_air():
    p = air_params(m=5.0)
    hanging = mechanism.builtin_mechanism("hanging_mass")
    time = np.linspace(0.0, 0.2, 41)
    commands = np.where(time < 0.05, 3e5, 4e5)
    run = mechanism.simulate_mechanism(time, commands, hanging, p, rtol=1e-11)
    theirs = independent_hanging(time, commands, p, AIR, im.hanging_mass(p))
    assert np.ptp(theirs[:, 0]) > 1e-3  # it lifts the mass by millimetres
    assert np.max(np.abs(run.q - theirs[:, 0])) < 1e-8
    assert np.max(np.abs(run.P[:, 0] - theirs[:, 2])) < 0.2
    # held pressures move as the muscle contracts: the linearization sees the volume's change
    A, _ = mechanism.linearization(hanging, float(theirs[-1, 0]), [4e5], params=p)
    assert A[2, 1] > 0  # Ldot = qdot > 0 squeezes the air: its pressure rises


def test_the_airs_temperature_is_carried_by_the_knee():
    # no longer refused: each muscle's air temperature is a state (tests/test_air_heat_knee.py
    # checks it against an independent simulator)
    p = air_params(tau_heat=2.0)
    run = simulate.simulate_knee(np.linspace(0, 0.01, 3), 1.7e6, 1e5, p)
    assert np.all(np.isfinite(run.Pe)) and knee.state_names(p)[-2:] == ("Te", "Tf")


def test_pole_sweep_runs_from_sealed_to_held():
    from mkctl.analysis import control as mc

    held = mc.operating_point(math.radians(60.0), Pf=100e3)
    sweep = air_poles.air_pole_sweep(held, "C_fill", np.geomspace(1e-11, 1e-6, 40))
    motion = sweep.poles[:, 2:]  # sorted by real part: the air's two first
    assert np.all(np.abs(motion.imag) > 0)
    # the largest valve: the pressures held; the smallest: near the sealed knee
    assert np.allclose(np.sort_complex(motion[-1]), np.sort_complex(sweep.held), atol=1e-3)
    assert abs(abs(motion[0, 0].imag) - abs(sweep.sealed[0].imag)) < 0.5
    assert sweep.a2_sealed < sweep.a2_held < 0
    assert np.all(motion.real < 0)  # c = 0: the valve alone damps (the held knee is marginal)
    with pytest.raises(MkctlError, match="C_fill, V_dead, band"):
        air_poles.air_pole_sweep(held, "tau", [0.1])


def test_mkctl_rootlocus_vary_C_fill_draws_the_poles(tmp_path, capsys):
    from mkctl.cli import main

    assert main(["rootlocus", "--vary", "C_fill", "--c", "0", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "valves closed" in out and "a2 = -150.806" in out and "a2 = -117.51" in out
    assert (tmp_path / "rootlocus_C_fill.png").stat().st_size > 10_000


def test_sealed_mechanisms_match_their_linearization_and_the_knee():
    p = air_params()
    X, Pe, Pf = _rest(p)
    knee_mechanism = mechanism.builtin_mechanism("knee")
    assert mechanism.sealed_coefficients(knee_mechanism, X, (Pe, Pf), p) == pytest.approx(
        stability.sealed_coefficients(X, Pe, Pf, p), rel=1e-9)
    pulley = mechanism.builtin_mechanism("pulley_joint")
    bound = pulley.bind(p)
    pressures = (4e5, 3e5)
    q = mechanism.equilibrium(pulley, pressures, bound)
    a1, a2 = mechanism.stability_coefficients(pulley, q, pressures, bound)
    s1, s2 = mechanism.sealed_coefficients(pulley, q, pressures, bound)
    assert s2 < float(a2) and s1 == pytest.approx(float(a1))
    A, _ = mechanism.linearization(pulley, q, pressures, params=bound, sealed=True)
    eig = np.sort_complex(np.linalg.eigvals(A))
    expected = np.sort_complex(np.concatenate([np.roots([1.0, -s1, -s2]), [0.0, 0.0]]))
    assert np.allclose(eig, expected, atol=1e-8 * abs(s2))


def test_mkctl_rootlocus_vary_band_for_a_mechanism(tmp_path, capsys):
    from mkctl.cli import main

    assert main(["rootlocus", "--vary", "band", "--mechanism", "pulley_joint", "--c", "0",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    p = air_params()
    pulley = mechanism.builtin_mechanism("pulley_joint")
    bound = pulley.bind(p)
    q = mechanism.equilibrium(pulley, (3e5, 3e5), bound)
    _, s2 = mechanism.sealed_coefficients(pulley, q, (3e5, 3e5), bound)
    assert f"a2 = {s2:.6g} 1/s^2" in out  # the sealed pulley, as the library gives it
    assert (tmp_path / "rootlocus_band.png").stat().st_size > 10_000


def test_a_dead_time_delays_the_command_before_the_valve():
    p = air_params()
    delay = 0.004
    time = np.linspace(0.0, 0.05, 51)  # 1 ms samples: the delay is four of them
    X, Pe, Pf = _rest(p)
    pe_cmd = np.where(time < 0.01, Pe, 1.02 * Pe)
    late = simulate.simulate_knee(time, pe_cmd, Pf, p.replace(delay=delay), X0=X, stops=False)
    shifted = np.where(time < 0.01 + delay, Pe, 1.02 * Pe)
    ours = simulate.simulate_knee(time, shifted, Pf, p, X0=X, stops=False)
    assert np.max(np.abs(late.Pe - ours.Pe)) < 1e-3
    assert np.max(np.abs(late.X - ours.X)) < 1e-10
    A, _ = knee.linearization(X, Pe, Pf, Pe, Pf, p.replace(delay=delay))
    assert A.shape == (6, 6)  # the air's pressures and the dead time's two Pade states


def test_a_mechanism_carries_the_airs_temperature():
    hanging = mechanism.builtin_mechanism("hanging_mass")
    p = air_params(m=5.0, tau_heat=2.0)
    run = mechanism.simulate_mechanism(np.linspace(0, 0.01, 3), 3e5, hanging, p)
    assert np.all(np.isfinite(run.P)) and mechanism.state_names(hanging, p)[-1] == "T_muscle"
