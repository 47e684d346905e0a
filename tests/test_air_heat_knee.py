"""air_heat in the knee and in mechanisms: each muscle's air temperature a state beside its pressure
(model-spec 4d), in the simulation and in the linearization.

The reference is independent of mkctl's air path: an ISO 6358-1 orifice with the smooth laminar
branch of docs/pneumatics.md section 2, the volume of Eq. 6 plus V_dead and the regulator, all
written here; the open chamber's energy balance from the spec's text with another state than the
library's (each muscle's air mass m and internal energy U = m c_v T, where mkctl integrates p and
T); the knee's geometry and tension of tests/independent_rig.py, the pulley joint's of
tests/independent_mechanisms.py; scipy's solve_ivp (Radau) at tight tolerances.
"""
from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import independent_mechanisms as im
import independent_rig as rig
from mkctl.physics import actuator, knee, mechanism, pneumatics, simulate, stability
from mkctl.physics.params import Params

R, P_ATM, RHO0, T0, GAMMA = 287.05, 101325.0, 1.185, 293.15, 1.4
CV = R / (GAMMA - 1.0)
CP = CV + R
LAMINAR = 0.995  # docs/pneumatics.md section 2: above this pressure ratio the flow is laminar

#: The spec's typical valve with a smaller conductance (a fill of a few tens of ms: the air heats).
AIR = {"C_fill": 2e-9, "C_exhaust": 0.0, "P_supply": 2e6, "band": 2e4, "b_cr": 0.3,
       "m_sub": 0.5, "V_dead": 5e-6, "T_air": 293.15}


def heat_params(tau_heat=0.2, **values) -> Params:
    return Params(valve_flow=1, c=45.0, tau_heat=tau_heat, **{**AIR, **values})


# --- the test's own air: orifice, valve, volume, energy balance -----------------------------------

def _phi(r, b_cr, m):
    """ISO 6358-1's flow function, with the quadratic laminar branch x (A + B x), x = 1 - r, above
    LAMINAR meeting ISO's value and slope there (docs/pneumatics.md section 2)."""
    r = min(max(r, 0.0), 1.0)
    if r <= b_cr:
        return 1.0

    def iso(r):
        return (1.0 - ((r - b_cr) / (1.0 - b_cr)) ** 2) ** m

    if r <= LAMINAR:
        return iso(r)
    s = (LAMINAR - b_cr) / (1.0 - b_cr)
    value = iso(LAMINAR)
    slope = m * (1.0 - s * s) ** (m - 1.0) * (-2.0 * s / (1.0 - b_cr))
    delta = 1.0 - LAMINAR
    A = 2.0 * value / delta + slope
    B = -(slope + value / delta) / delta
    x = 1.0 - r
    return x * (A + B * x)


def _mass_flow(p_up, T_up, p_down, C, a):
    """Mass flow [kg/s] from p_up to p_down (absolute), the upstream air at T_up."""
    return C * RHO0 * p_up * math.sqrt(T0 / T_up) * _phi(p_down / p_up, a["b_cr"], a["m_sub"])


def _valve(P_cmd, p, T, a):
    """Net mass flow into a muscle (absolute pressure p, air at T) from its regulator."""
    u = min(max((P_cmd - (p - P_ATM)) / a["band"], -1.0), 1.0)
    if u > 0:
        supply = a["P_supply"] + P_ATM
        if supply >= p:
            return u * _mass_flow(supply, a["T_air"], p, a["C_fill"], a)
        return -u * _mass_flow(p, T, supply, a["C_fill"], a)
    if u < 0:
        exhaust = a["C_exhaust"] or a["C_fill"]
        return u * _mass_flow(p, T, P_ATM, exhaust, a)
    return 0.0


def _volume(L, p: Params):
    n = rig.turns(p)
    return (p.b ** 2 * L - L ** 3) / (4 * math.pi * n * n) + p.V_dead


def _volume_slope(L, p: Params):
    n = rig.turns(p)
    return (p.b ** 2 - 3 * L * L) / (4 * math.pi * n * n)


def _chamber(m, U, P_cmd, L, Ldot, p: Params, a):
    """Gauge pressure and (dm/dt, dU/dt) of one muscle: the open chamber's energy balance,
    dU/dt = c_p T_in q - p dV/dt + m c_v (T_air - T) / tau_heat, T_in the supply's for inflow and
    the muscle's own for outflow; p V = (gamma - 1) U, T = U / (m c_v)."""
    V = _volume(L, p)
    pressure = (GAMMA - 1.0) * U / V
    T = U / (m * CV)
    q = _valve(P_cmd, pressure, T, a)
    T_in = a["T_air"] if q > 0 else T
    dV = _volume_slope(L, p) * Ldot
    dU = CP * T_in * q - pressure * dV + m * CV * (a["T_air"] - T) / p.tau_heat
    return pressure - P_ATM, T, q, dU


def _filled(P, L, p: Params):
    """(m, U) of a muscle at gauge pressure P, length L, the air at T_air."""
    V = _volume(L, p)
    return (P + P_ATM) * V / (R * p.T_air), (P + P_ATM) * V / (GAMMA - 1.0)


def _integrate(rhs, time, y, commands, atol):
    out = np.empty((time.size, len(y)))
    out[0] = y
    for k in range(time.size - 1):
        sol = solve_ivp(rhs, (time[k], time[k + 1]), y, method="Radau", rtol=1e-11, atol=atol,
                        args=(commands[k],))
        assert sol.success, sol.message
        y = sol.y[:, -1]
        out[k + 1] = y
    return out


def independent_knee(time, pe_cmd, pf_cmd, p: Params, X0: float):
    """(X, V, Pe, Pf, Te, Tf) at the samples: the knee of tests/independent_rig.py, each muscle's
    air the chamber above (states X, V, m_e, U_e, m_f, U_f)."""
    hidden = {"c": p.c}
    Le, Lf, _, _ = rig.knee_geometry(X0, p)
    y = np.array([X0, 0.0, *_filled(pe_cmd[0], float(Le), p), *_filled(pf_cmd[0], float(Lf), p)])

    def rhs(t, s, commands):
        Le, Lf, Ge, Gf = (float(v) for v in rig.knee_geometry(s[0], p))
        Pe, _, qe, dUe = _chamber(s[2], s[3], commands[0], Le, -Ge * s[1], p, AIR)
        Pf, _, qf, dUf = _chamber(s[4], s[5], commands[1], Lf, Gf * s[1], p, AIR)
        F = (Ge * float(rig.tension(Le, Pe, -Ge * s[1], p, hidden))
             - Gf * float(rig.tension(Lf, Pf, Gf * s[1], p, hidden)))
        return [s[1], F / p.m - p.g, qe, dUe, qf, dUf]

    scale = y[2:].copy()
    out = _integrate(rhs, time, y, np.stack([pe_cmd, pf_cmd], axis=1),
                     [1e-12, 1e-12, *(1e-12 * scale)])
    states = np.empty_like(out)
    states[:, :2] = out[:, :2]
    for k, X in enumerate(out[:, 0]):
        Le, Lf, Ge, Gf = (float(v) for v in rig.knee_geometry(X, p))
        for i, L in enumerate((Le, Lf)):
            m, U = out[k, 2 + 2 * i], out[k, 3 + 2 * i]
            states[k, 2 + i] = (GAMMA - 1.0) * U / _volume(L, p) - P_ATM
            states[k, 4 + i] = U / (m * CV)
    return states


def independent_pulley(time, commands, p: Params, mech, q0: float):
    """(q, qdot, P_1, P_2, T_1, T_2) at the samples for a mechanism of
    tests/independent_mechanisms.py with two muscles."""
    lengths, _ = mech.geometry(q0)
    y = np.array([q0, 0.0, *_filled(commands[0, 0], lengths[0], p),
                  *_filled(commands[0, 1], lengths[1], p)])

    def pressures(s):
        lengths, _ = mech.geometry(s[0])
        return [(GAMMA - 1.0) * s[3 + 2 * i] / _volume(lengths[i], p) - P_ATM for i in range(2)]

    def rhs(t, s, held):
        lengths, arms = mech.geometry(s[0])
        rates = []
        for i in range(2):
            _, _, q, dU = _chamber(s[2 + 2 * i], s[3 + 2 * i], held[i], lengths[i],
                                   arms[i] * s[1], p, AIR)
            rates += [q, dU]
        F = im.generalized_force(mech, s[0], s[1], pressures(s), p) + im.stop_force(mech, s[0],
                                                                                    s[1])
        return [s[1], F / mech.inertia(s[0]), *rates]

    scale = y[2:].copy()
    out = _integrate(rhs, time, y, commands, [1e-12, 1e-12, *(1e-12 * scale)])
    P = np.array([pressures(s) for s in out])
    return out[:, 0], out[:, 1], P


def _rest(p, Pf=1e5, alpha=math.radians(60.0)):
    Pe = float(stability.equilibrium_pressure(alpha, Pf, p))
    return float(knee.X_from_alpha(alpha, p)), Pe, Pf


# --- the knee -------------------------------------------------------------------------------------

def test_knee_with_air_heat_matches_an_independent_simulator():
    p = heat_params()
    X, Pe, Pf = _rest(p)
    time = np.linspace(0.0, 0.3, 61)
    pe_cmd = np.where(time < 0.05, Pe, 1.05 * Pe)  # the valve saturates and chokes: the air heats
    pf_cmd = np.where(time < 0.15, Pf, 2.0 * Pf)
    sim = simulate.KneeSimulator(p, X, pe_cmd[0], pf_cmd[0], stops=False, rtol=1e-12)
    ours = np.empty((time.size, 6))
    ours[0] = sim.state
    for k in range(time.size - 1):
        ours[k + 1] = sim.step(time[k + 1] - time[k], pe_cmd[k], pf_cmd[k])
    theirs = independent_knee(time, pe_cmd, pf_cmd, p, X)
    assert knee.state_names(p) == ("X", "V", "Pe", "Pf", "Te", "Tf")
    assert np.ptp(theirs[:, 0]) > 1e-3  # the leg moves by millimetres
    assert np.ptp(theirs[:, 4]) > 1.0  # the air's temperature moves by kelvins
    # measured (of each state's largest value): X 1.5e-10, V 2.9e-8, Pe 4e-9, Pf 5.6e-7 (the
    # flexor's doubled command: a choked fill of 100 kPa in ms), Te 1.2e-9, Tf 8e-8
    scale = np.max(np.abs(theirs), axis=0)
    scale[1] = np.max(np.abs(theirs[:, 1]))
    assert np.all(np.max(np.abs(ours - theirs), axis=0) < 1e-6 * scale)
    # simulate_knee runs the same (the Python loop: the compiled core does not carry T)
    run = simulate.simulate_knee(time, pe_cmd, pf_cmd, p, X0=X, stops=False, rtol=1e-12)
    assert np.max(np.abs(run.Pe - theirs[:, 2])) < 1e-6 * scale[2]
    assert np.max(np.abs(run.X - theirs[:, 0])) < 1e-6 * scale[0]
    # the heat is no detail here: the polytropic knee (k_poly 1.2) departs by far more
    poly = simulate.simulate_knee(time, pe_cmd, pf_cmd, p.replace(tau_heat=0.0), X0=X,
                                  stops=False)
    assert np.max(np.abs(poly.Pe - theirs[:, 2])) > 1e3 * np.max(np.abs(run.Pe - theirs[:, 2]))


def test_the_pulley_joint_with_air_heat_matches_an_independent_simulator():
    p = heat_params(tau_heat=0.1)
    pulley = mechanism.builtin_mechanism("pulley_joint")
    bound = pulley.bind(p)
    time = np.linspace(0.0, 0.25, 51)
    commands = np.stack([np.where(time < 0.05, 3e5, 3.6e5), np.where(time < 0.12, 3e5, 2.4e5)],
                        axis=1)
    q0 = mechanism.equilibrium(pulley, tuple(commands[0]), bound)
    run = mechanism.simulate_mechanism(time, (commands[:, 0], commands[:, 1]), pulley, p,
                                       q0=q0, rtol=1e-11)
    q, qdot, P = independent_pulley(time, commands, p, im.pulley_joint(p), q0)
    assert mechanism.state_names(pulley, p)[2:] == (*(f"P_{m}" for m in pulley.muscles),
                                                     *(f"T_{m}" for m in pulley.muscles))
    assert np.ptp(q) > 0.2  # the arm turns by 23 degrees (inside its stops)
    # measured: q 6e-8, qdot 1.4e-7, the pressures 2.2e-7 of their largest values
    assert np.max(np.abs(run.q - q)) < 1e-6 * np.max(np.abs(q))
    assert np.max(np.abs(run.qdot - qdot)) < 1e-6 * np.max(np.abs(qdot))
    assert np.max(np.abs(run.P - P)) < 1e-6 * np.max(np.abs(P))


# --- the limits of the heat model -----------------------------------------------------------------

def test_tau_heat_to_zero_is_isothermal_and_to_infinity_adiabatic():
    p = heat_params()
    X, Pe, Pf = _rest(p)
    time = np.linspace(0.0, 0.3, 61)
    pe_cmd = np.where(time < 0.05, Pe, 1.05 * Pe)
    pf_cmd = np.where(time < 0.15, Pf, 2.0 * Pf)

    def run(**values):
        return simulate.simulate_knee(time, pe_cmd, pf_cmd, p.replace(**values), X0=X,
                                      stops=False, rtol=1e-10)

    def gap(a, b):
        return max(np.max(np.abs(a.Pe - b.Pe)), np.max(np.abs(a.Pf - b.Pf)))

    isothermal, adiabatic = run(tau_heat=0.0, k_poly=1.0), run(tau_heat=0.0, k_poly=1.4)
    apart = gap(isothermal, adiabatic)
    assert apart > 1e4  # measured: 23.6 kPa between the two laws
    # tau_heat -> 0: the polytropic law with k_poly = 1, the gap shrinking in proportion to tau_heat
    # (measured: 5.0 kPa at 1 ms, 0.50 kPa at 0.1 ms)
    slow, fast = gap(run(tau_heat=1e-3), isothermal), gap(run(tau_heat=1e-4), isothermal)
    assert fast < 0.03 * apart and slow / fast == pytest.approx(10.0, rel=0.05)
    # tau_heat -> infinity: the adiabatic law (k_poly = gamma = 1.4); what is left is the air the
    # flexor exhausts at its own temperature (the polytropic law lets it out at T_air): measured
    # 11 Pa of the 23.6 kPa
    assert gap(run(tau_heat=1e4), adiabatic) < 1e-3 * apart


# --- the held knee against one muscle's pressure record -------------------------------------------

def _held_knee(X, p):
    """The knee's two muscles clamped at their lengths at hip height X: a mechanism whose lengths
    do not move with its coordinate (zero moment arms, no load: the coordinate stays put)."""
    geo = knee.geometry_at_X(X, p)
    Le, Lf = float(geo.Le), float(geo.Lf)
    return mechanism.Mechanism(
        "held_knee", "X", "m", ("extensor", "flexor"), (),
        lambda q, p, xp: [Le + 0.0 * q, Lf + 0.0 * q], lambda q, p, xp: 1.0 + 0.0 * q,
        lambda q, qd, p, xp: 0.0 * q, lambda p: (X - 0.1, X + 0.1),
        "the knee's muscles clamped at a posture"), (Le, Lf)


def test_a_fast_fill_on_a_held_knee_matches_one_muscles_pressure_record():
    # the rig: a 520 kPa supply through a small valve, tau_heat 1 s
    p = Params(valve_flow=1, P_supply=5.2e5, C_fill=1e-9, band=2e5, tau_heat=1.0)
    X = float(knee.X_from_alpha(math.radians(60.0), p))
    held, lengths = _held_knee(X, p)
    time = np.linspace(0.0, 6.0, 601)
    commands = (np.where(time < 0.01, 0.0, 4e5), np.where(time < 0.01, 0.0, 2e5))
    run = mechanism.simulate_mechanism(time, commands, held, p, q0=X)
    assert np.ptp(run.q) == 0.0
    for i, L in enumerate(lengths):
        record = pneumatics.simulate_air(time, p, command=commands[i], length=L, rtol=1e-11,
                                         atol=1e-7)
        assert record.T.max() > p.T_air + 30.0  # the fast fill heats the air by tens of kelvins
        # measured: 0.03 Pa of 400 kPa
        assert np.max(np.abs(run.P[:, i] - record.P)) < 1e-6 * np.max(record.P)
    # the heat shows: the polytropic muscle (k_poly 1.2) fills along another curve
    poly = mechanism.simulate_mechanism(time, commands, held, p.replace(tau_heat=0.0), q0=X)
    assert np.max(np.abs(poly.P[:, 0] - run.P[:, 0])) > 1e3


# --- the linearization with the temperature states ------------------------------------------------

def _jacobian(y0, pe_cmd, pf_cmd, p, steps=(1e-7, 1e-6, 1.0, 1.0, 1e-4, 1e-4)):
    J = np.zeros((6, 6))
    for j, h in enumerate(steps):
        up, down = y0.copy(), y0.copy()
        up[j] += h
        down[j] -= h
        J[:, j] = (knee.knee_derivatives(up, pe_cmd, pf_cmd, p)
                   - knee.knee_derivatives(down, pe_cmd, pf_cmd, p)) / (2 * h)
    return J


def test_the_linearization_has_the_temperatures_and_matches_finite_differences():
    p = heat_params(tau_heat=2.0)
    X, Pe, Pf = _rest(p)
    # away from the regulator's kink (u = 0): central differences hold on both sides
    y0 = np.array([X, 0.0, Pe - 5e3, Pf - 3e3, p.T_air, p.T_air])
    A, B = knee.linearization(X, y0[2], y0[3], Pe, Pf, p)
    assert A.shape == (6, 6) and B.shape == (6, 2)
    assert knee.linearization_state_names(p) == ("X", "V", "Pe", "Pf", "Te", "Tf")
    J = _jacobian(y0, Pe, Pf, p)
    assert np.all(np.abs(J - A) <= 1e-6 * np.abs(A) + 1e-9 * np.abs(A).max(axis=1)[:, None])
    assert A[2, 4] != 0.0 and A[4, 2] != 0.0 and A[4, 1] != 0.0  # heat, flow and motion couple
    h = 1.0
    up = knee.knee_derivatives(y0, Pe + h, Pf + h, p)
    down = knee.knee_derivatives(y0, Pe - h, Pf - h, p)
    assert np.allclose((up - down)[2:] / (2 * h), B[2:].sum(axis=1), rtol=1e-6)


def test_python_control_linearizes_the_knee_with_its_temperatures():
    from mkctl.analysis import control as mc

    held = mc.operating_point(math.radians(60.0), Pf=100e3)
    # the rest with the air on (the regulators hold their set-points at rest)
    op = mc.operating_point(math.radians(60.0), Pf=100e3,
                            params=held.params.replace(valve_flow=1, tau_heat=2.0))
    exact = mc.analytic_linearization(op)
    numeric = mc.numerical_linearization(op)
    assert list(exact.state_labels) == ["X", "V", "Pe", "Pf", "Te", "Tf"]
    assert np.allclose(op.states[4:], op.params.T_air)
    assert np.allclose(op.states[:4], [held.X, 0.0, held.Pe, held.Pf], rtol=1e-9)
    # the columns of X, V, Te, Tf do not cross the regulator's kink at rest (u = 0: no flow on
    # either side), so python-control's one-sided difference finds them too
    row_scale = np.abs(exact.A).max(axis=1)
    for j in (0, 1, 4, 5):
        assert np.all(np.abs(numeric.A[:, j] - exact.A[:, j])
                      <= 1e-5 * np.abs(exact.A[:, j]) + 1e-6 * row_scale)
    # a damping changes nothing at rest: the same states, the temperatures among them
    assert np.array_equal(op.with_params(c=10.0).states, op.states)


def test_the_sealed_air_spring_runs_from_isothermal_to_adiabatic_with_tau_heat():
    base = Params(valve_flow=1)  # c = 0: only the air can damp
    X, Pe, Pf = _rest(base)

    def motion(**values):
        A, _ = knee.linearization(X, Pe, Pf, Pe, Pf, base.replace(**values), sealed=True)
        eig = np.linalg.eigvals(A)
        return eig[eig.imag > 0][0], eig

    def sealed_pole(k):
        s1, s2 = stability.sealed_coefficients(X, Pe, Pf, base.replace(k_poly=k))
        return np.roots([1.0, -s1, -s2]).imag.max()

    isothermal, adiabatic = sealed_pole(1.0), sealed_pole(1.4)
    fast, eig = motion(tau_heat=1e-4)
    assert fast.imag == pytest.approx(isothermal, rel=1e-6)
    assert np.sum(np.abs(eig) < 1e-6) == 2  # each muscle's air mass is conserved
    slow, _ = motion(tau_heat=1e4)
    assert slow.imag == pytest.approx(adiabatic, rel=1e-6)
    # the instantaneous spring is the adiabatic one (gamma, not k_poly)
    geo = knee.geometry_at_X(X, base)
    d = actuator.air_rates_partials(Pe, base.T_air, 0.0, float(geo.Le), 0.0,
                                    base.replace(tau_heat=2.0), opening=True)
    assert d[0, 4] == pytest.approx(
        pneumatics.sealed_stiffness(float(geo.Le), Pe, base.b, base.n, base.V_dead, GAMMA),
        rel=1e-12)
    # in between the heat exchange damps the sealed knee (a1 = 0 without it), most near
    # omega tau_heat ~ 1 (measured: -0.0177 1/s at 2 s, -0.224 at 0.1 s)
    typical, _ = motion(tau_heat=2.0)
    middle, _ = motion(tau_heat=0.1)
    assert isothermal < typical.imag < adiabatic
    assert middle.real < typical.real < 0.0


def test_a_mechanisms_linear_system_names_the_temperatures():
    p = Params(valve_flow=1, tau_heat=0.1)
    pulley = mechanism.builtin_mechanism("pulley_joint")
    system = mechanism.linear_system(pulley, (4e5, 3e5), pulley.bind(p))
    muscles = pulley.muscles
    assert list(system.state_labels) == [pulley.coordinate, pulley.coordinate + "_dot",
                                         *(f"P_{m}" for m in muscles),
                                         *(f"T_{m}" for m in muscles)]
    assert np.all(system.poles().real < 0)
    # its A against finite differences of the mechanism's right-hand side, off the kink
    bound = pulley.bind(p)
    q = mechanism.equilibrium(pulley, (4e5, 3e5), bound)
    y0 = np.array([q, 0.0, 4e5 - 4e3, 3e5 - 2e3, p.T_air, p.T_air])
    A, _ = mechanism.linearization(pulley, q, (y0[2], y0[3]), (4e5, 3e5), bound)
    J = np.zeros((6, 6))
    for j, h in enumerate((1e-7, 1e-6, 1.0, 1.0, 1e-4, 1e-4)):
        up, down = y0.copy(), y0.copy()
        up[j] += h
        down[j] -= h
        J[:, j] = (mechanism.mechanism_derivatives(up, (4e5, 3e5), pulley, bound)
                   - mechanism.mechanism_derivatives(down, (4e5, 3e5), pulley, bound)) / (2 * h)
    assert np.all(np.abs(J - A) <= 1e-6 * np.abs(A) + 1e-9 * np.abs(A).max(axis=1)[:, None])


def test_the_knees_air_rates_sag_after_a_fast_fill_as_one_muscles_record():
    # the sag needs a closed valve: the rates the knee integrates, driven by an opening (their
    # sealed side, which the sealed linearization takes) at the extensor's length at rest
    p = Params(valve_flow=1, P_supply=5.2e5, C_fill=1e-9, tau_heat=1.0)
    X = float(knee.X_from_alpha(math.radians(60.0), p))
    L = float(knee.geometry_at_X(X, p).Le)
    time = np.linspace(0.0, 7.0, 701)
    opening = np.where(time < 2.0, 1.0, 0.0)  # the valve open 2 s, then closed
    record = pneumatics.simulate_air(time, p, opening=opening, length=L, rtol=1e-11, atol=1e-7)
    ours = np.empty((time.size, 2))
    ours[0] = (0.0, p.T_air)
    for k in range(time.size - 1):
        sol = solve_ivp(lambda t, y, u=opening[k]: actuator.air_rates(y[0], y[1], u, L, 0.0, p,
                                                                      opening=True),
                        (time[k], time[k + 1]), ours[k], method="Radau", rtol=1e-11,
                        atol=[1e-7, 1e-10])
        ours[k + 1] = sol.y[:, -1]
    closed = time >= 2.0
    sag = ours[closed, 0][0] - ours[-1, 0]
    assert 5e3 < sag < 5e4  # measured: 40.4 kPa in the 5 s after the valve closes (real: 5-47)
    assert np.max(np.abs(ours[:, 0] - record.P)) < 1e-6 * np.max(record.P)
    assert np.max(np.abs(ours[:, 1] - record.T)) < 1e-6 * np.max(record.T)
