"""The air in the muscle (model-spec section 4d, mkctl.physics.pneumatics) against independent
references: the independent simulator of tests/independent_pneumatics.py (its own ISO 6358, volume,
mass and energy balance, solve_ivp), finite differences, closed-form limits (the lag, the choked
rise, the leak's exponential, p V^k constant) and the spec's own text."""

from __future__ import annotations

import math
import re
from pathlib import Path

import numpy as np
import pytest
import sympy

import independent_pneumatics as ind
from mkctl.errors import MkctlError
from mkctl.physics import actuator
from mkctl.physics import pneumatics as pn
from mkctl.physics.params import DEFAULT, PARAMETER_NAMES, Params

ROOT = Path(__file__).resolve().parents[1]
B, N, L0 = DEFAULT.b, DEFAULT.n, DEFAULT.L0
AIR = pn.AirParams()


def air_dict(air: pn.AirParams) -> dict:
    return {
        name: getattr(air, name)
        for name in (
            "C_fill",
            "C_exhaust",
            "P_supply",
            "band",
            "b_cr",
            "m_sub",
            "k_poly",
            "V_dead",
            "T_air",
            "C_leak",
            "tau_heat",
        )
    }


# --- the pure functions ---------------------------------------------------------------------------


def test_volume_and_its_slope_against_eq6_and_eq7():
    L = np.linspace(0.15, 0.235, 9)
    assert np.allclose(
        pn.air_volume(L, B, N, 5e-6), [ind.volume(x, B, N, 5e-6) for x in L], rtol=1e-14
    )
    h = 1e-6
    fd = (pn.air_volume(L + h, B, N, 0.0) - pn.air_volume(L - h, B, N, 0.0)) / (2 * h)
    assert np.allclose(pn.air_volume_slope(L, B, N), fd, rtol=1e-8)
    # spec 4d: dV_b/dL = -f1 / P (Eq. 4 and 7), f1 from the library's model 1
    P = 3e5
    assert np.allclose(pn.air_volume_slope(L, B, N), -actuator.tension_model1(L, P) / P, rtol=1e-13)
    assert np.all(pn.air_volume_slope(L[L > B / math.sqrt(3)], B, N) < 0)


@pytest.mark.parametrize(
    "b_cr, m_sub", [(0.3, 0.5), (0.0, 0.5), (0.528, 1.0), (0.9, 0.3), (0.2, 1.5)]
)
def test_flow_function_matches_the_independent_one_exactly(b_cr, m_sub):
    r = np.concatenate([np.linspace(-0.1, 1.1, 241), [b_cr, 0.995, 0.9951, 0.99999, 1.0]])
    expected = [ind.phi(x, b_cr, m_sub) for x in r]
    assert np.allclose(pn.flow_function(r, b_cr, m_sub), expected, rtol=1e-12, atol=1e-14)
    assert all(
        pn.flow_function(float(x), b_cr, m_sub) == pytest.approx(e, rel=1e-12, abs=1e-14)
        for x, e in zip(r, expected)
    )
    assert np.all(np.diff(pn.flow_function(np.linspace(0, 1, 2001), b_cr, m_sub)) <= 1e-15)  # falls


@pytest.mark.parametrize("b_cr, m_sub", [(0.3, 0.5), (0.5, 1.2), (0.0, 0.3)])
def test_the_laminar_branch_meets_iso_in_value_and_slope(b_cr, m_sub):
    r_l, h = pn.LAMINAR_RATIO, 1e-7
    below = pn.flow_function(r_l - h, b_cr, m_sub)
    above = pn.flow_function(r_l + h, b_cr, m_sub)
    at = pn.flow_function(r_l, b_cr, m_sub)
    assert abs(above - below) < 1e-4 * at  # continuous (the step is two slopes times h)
    slope_below = (at - pn.flow_function(r_l - 1e-6, b_cr, m_sub)) / 1e-6
    slope_above = (pn.flow_function(r_l + 1e-6, b_cr, m_sub) - at) / 1e-6
    assert slope_above == pytest.approx(slope_below, rel=1e-3)
    # the slope at r = 1 is finite (ISO's would be infinite for m_sub < 1)
    slope_end = (
        pn.flow_function(1.0, b_cr, m_sub) - pn.flow_function(1 - 1e-7, b_cr, m_sub)
    ) / 1e-7
    assert np.isfinite(slope_end) and slope_end < 0


def test_the_orifice_flow_reverses_and_is_c1_where_the_pressures_meet():
    p = 4e5
    dp = np.array([-1e-2, -1e-3, 1e-3, 1e-2])
    q = pn.orifice_mass_flow(p + dp, p, 5e-9, 0.3, 0.5)
    slopes = q / dp
    assert np.allclose(slopes, slopes[0], rtol=1e-3)  # one slope from both sides: C1 at p_u = p_d
    assert pn.orifice_mass_flow(p, p, 5e-9, 0.3, 0.5) == 0.0
    assert pn.orifice_mass_flow(2e5, 6e5, 5e-9, 0.3, 0.5) == pytest.approx(
        -pn.orifice_mass_flow(6e5, 2e5, 5e-9, 0.3, 0.5), rel=1e-15
    )
    # choked: q = C rho0 p_u sqrt(T0 / T_u), whatever the downstream pressure
    assert pn.orifice_mass_flow(1e6, 1e5, 5e-9, 0.3, 0.5, 330.0) == pytest.approx(
        5e-9 * 1.185 * 1e6 * math.sqrt(293.15 / 330.0), rel=1e-15
    )
    for pu, pd in [(7e5, 1e5), (3e5, 2.9e5), (2e5, 6e5), (4e5, 4.0001e5)]:
        assert pn.orifice_mass_flow(pu, pd, 5e-9, 0.3, 0.5, 300.0, 310.0) == pytest.approx(
            ind.orifice(pu, pd, 5e-9, 0.3, 0.5, 300.0, 310.0), rel=1e-12
        )


def test_the_valve_fills_exhausts_and_closes():
    a = air_dict(AIR)
    for u in (1.0, 0.4, 0.0, -0.3, -1.0):
        for P in (0.0, 2e5, 2.5e6):
            assert pn.valve_mass_flow(
                u, P, AIR.P_supply, AIR.C_fill, 0.0, 0.3, 0.5
            ) == pytest.approx(ind.valve(u, P, a, AIR.T_air), rel=1e-12, abs=1e-18)
    # C_exhaust 0 is the same as C_fill; another value is used as given
    same = pn.valve_mass_flow(-1.0, 3e5, 2e6, 5e-9, 0.0, 0.3, 0.5)
    assert same == pn.valve_mass_flow(-1.0, 3e5, 2e6, 5e-9, 5e-9, 0.3, 0.5)
    assert pn.valve_mass_flow(-1.0, 3e5, 2e6, 5e-9, 2e-9, 0.3, 0.5) == pytest.approx(
        0.4 * same, rel=1e-14
    )
    assert (
        pn.valve_mass_flow(1.0, 2.5e6, 2e6, 5e-9, 0.0, 0.3, 0.5) < 0
    )  # above the supply: flows back
    assert pn.regulator_opening(np.array([0.0, 1e4, 1e6]), 1e4, 2e4).tolist() == [-0.5, 0.0, 1.0]


def test_floats_and_arrays_agree():
    class Column(np.ndarray):  # a column whose single items are Python floats
        def __getitem__(self, i):
            item = np.ndarray.__getitem__(self, i)
            return float(item) if isinstance(i, int) else np.asarray(item)

    L, P, T, u, q = (
        np.array(v).view(Column)
        for v in (
            [0.17, 0.2, 0.22],
            [1e3, 2e5, 6e5],
            [280.0, 293.15, 340.0],
            [-0.7, 0.2, 1.0],
            [-1e-4, 2e-4, 0.0],
        )
    )
    calls = [
        lambda i: pn.air_volume(L[i], B, N, 5e-6),
        lambda i: pn.sealed_stiffness(L[i], P[i], B, N, 5e-6, 1.2),
        lambda i: pn.valve_mass_flow(u[i], P[i], 2e6, 5e-9, 3e-9, 0.3, 0.5, 293.15, T[i]),
        lambda i: pn.polytropic_pressure_rate(P[i], 3e-5, 1e-6, q[i], 1.2),
        lambda i: pn.air_heat_rates(P[i], T[i], 3e-5, 1e-6, q[i], 293.15, 2.0)[1],
        lambda i: pn.leak_mass_flow(P[i], 1e-12),
        lambda i: pn.regulator_time_constant(P[i], 3e-5, 2e4, 5e-9, 0.0, 2e6, 0.3, 0.5, 1.2)[0],
    ]
    for call in calls:
        vector = call(slice(None))
        scalars = [call(i) for i in range(3)]
        assert all(type(s) is float for s in scalars)
        assert np.allclose(vector, scalars, rtol=1e-14, atol=0)


def test_every_function_traces_on_sympy_and_its_derivative_matches_finite_differences():
    p_u, p_d, u, P, T, Ld = sympy.symbols("p_u p_d u P T Ldot", real=True)
    C, b_cr, m_sub = sympy.symbols("C b_cr m_sub", positive=True)
    flow = pn.orifice_mass_flow(p_u, p_d, C, b_cr, m_sub, T)
    values = {C: 5e-9, b_cr: 0.3, m_sub: 0.5, T: 300.0}
    d_flow = sympy.lambdify((p_u, p_d), sympy.diff(flow, p_d).subs(values), "math")
    f = sympy.lambdify((p_u, p_d), flow.subs(values), "math")
    for pu, pd in [(7e5, 1.5e5), (7e5, 5e5), (7e5, 6.99e5), (3e5, 4e5), (7e5, 6.999e5)]:
        h = pd * 1e-7
        fd = (
            pn.orifice_mass_flow(pu, pd + h, 5e-9, 0.3, 0.5, 300.0)
            - pn.orifice_mass_flow(pu, pd - h, 5e-9, 0.3, 0.5, 300.0)
        ) / (2 * h)
        assert float(d_flow(pu, pd)) == pytest.approx(fd, rel=1e-5, abs=1e-18)
        assert float(f(pu, pd)) == pytest.approx(
            pn.orifice_mass_flow(pu, pd, 5e-9, 0.3, 0.5, 300.0), rel=1e-13
        )
    # the rest trace too (no Python branch on a symbol)
    L = sympy.Symbol("L", positive=True)
    q = pn.valve_mass_flow(pn.regulator_opening(u, P, 2e4), P, 2e6, C, 0.0, b_cr, m_sub, 293.15, T)
    rate = pn.polytropic_pressure_rate(
        P,
        pn.air_volume(L, B, N, 5e-6),
        pn.air_volume_slope(L, B, N) * Ld,
        q + pn.leak_mass_flow(P, 1e-12),
        1.2,
    )
    heat = pn.air_heat_rates(P, T, pn.air_volume(L, B, N, 5e-6), Ld, q, 293.15, 2.0)
    stiff = pn.sealed_stiffness(L, P, B, N, 5e-6, 1.2)
    taus = pn.regulator_time_constant(P, 3e-5, 2e4, C, 0.0, 2e6, b_cr, m_sub, 1.2)
    point = {u: 2e5, P: 1e5, T: 300.0, L: 0.2, Ld: 0.01, C: 5e-9, b_cr: 0.3, m_sub: 0.5}
    expected_q = pn.valve_mass_flow(
        pn.regulator_opening(2e5, 1e5, 2e4), 1e5, 2e6, 5e-9, 0.0, 0.3, 0.5, 293.15, 300.0
    )
    assert float(q.subs(point)) == pytest.approx(expected_q, rel=1e-12)
    assert float(rate.subs(point)) == pytest.approx(
        pn.polytropic_pressure_rate(
            1e5,
            pn.air_volume(0.2, B, N, 5e-6),
            pn.air_volume_slope(0.2, B, N) * 0.01,
            expected_q + pn.leak_mass_flow(1e5, 1e-12),
            1.2,
        ),
        rel=1e-12,
    )
    assert float(heat[1].subs(point)) == pytest.approx(
        pn.air_heat_rates(
            1e5, 300.0, pn.air_volume(0.2, B, N, 5e-6), 0.01, expected_q, 293.15, 2.0
        )[1],
        rel=1e-12,
    )
    assert float(stiff.subs(point)) == pytest.approx(
        pn.sealed_stiffness(0.2, 1e5, B, N, 5e-6, 1.2), rel=1e-12
    )
    assert float(taus[0].subs(point)) == pytest.approx(
        pn.regulator_time_constant(1e5, 3e-5, 2e4, 5e-9, 0.0, 2e6, 0.3, 0.5, 1.2)[0], rel=1e-12
    )


def test_the_sealed_stiffness_is_the_slope_of_p_v_to_the_k_constant():
    for L, P, k in [(0.2, 3e5, 1.2), (0.18, 5e5, 1.4), (0.22, 1e5, 1.0)]:
        const = (P + pn.P_ATM) * pn.air_volume(L, B, N, 5e-6) ** k

        def pressure(x):
            return const / pn.air_volume(x, B, N, 5e-6) ** k - pn.P_ATM

        h = 1e-6
        fd = (pressure(L + h) - pressure(L - h)) / (2 * h)
        assert pn.sealed_stiffness(L, P, B, N, 5e-6, k) == pytest.approx(fd, rel=1e-7)
        assert pn.sealed_stiffness(L, P, B, N, 5e-6, k) > 0  # pulled longer, the air is squeezed


def test_a_sealed_moving_muscle_keeps_p_v_to_the_k():
    t = np.linspace(0, 0.5, 51)
    L = 0.2 + 0.01 * np.sin(2 * np.pi * t)
    Ld = 0.01 * 2 * np.pi * np.cos(2 * np.pi * t)
    run = pn.simulate_muscle_pressure(
        t, opening=0.0, length=L, length_rate=Ld, P_start=3e5, rtol=1e-11
    )
    invariant = (run.P + pn.P_ATM) * run.V**AIR.k_poly
    assert np.allclose(invariant, invariant[0], rtol=1e-8)
    assert run.mass_flow.tolist() == [0.0] * t.size


# --- the small-signal and large-signal limits -----------------------------------------------------


def test_small_steps_follow_a_first_order_lag_with_the_derived_time_constant():
    V = pn.air_volume(L0, B, N, AIR.V_dead)
    for P_op, step in [(3e5, 20.0), (3e5, -20.0), (8e5, 20.0)]:
        tau_fill, tau_exhaust = pn.regulator_time_constant(
            P_op,
            V,
            AIR.band,
            AIR.C_fill,
            AIR.C_exhaust,
            AIR.P_supply,
            AIR.b_cr,
            AIR.m_sub,
            AIR.k_poly,
        )
        tau = tau_fill if step > 0 else tau_exhaust
        t = np.linspace(0, 8 * tau, 161)
        run = pn.simulate_muscle_pressure(t, np.full(t.size, P_op + step), P_start=P_op)
        # mkctl's pressure_lag (tau dP/dt = P_cmd - P), solved exactly by the library
        lag = np.array([actuator.lagged_pressure(P_op, P_op + step, tau, float(x)) for x in t])
        assert np.max(np.abs(run.P - lag)) < 1e-4 * abs(step), (P_op, step)
    assert tau_exhaust != tau_fill  # the asymmetric lag in the small


def test_a_large_step_chokes_rises_nearly_linearly_then_bends():
    V = pn.air_volume(L0, B, N, AIR.V_dead)
    rate = pn.choked_fill_rate(V, AIR.C_fill, AIR.P_supply, AIR.k_poly)
    target = 4e5
    t = np.linspace(0, 1.5 * target / rate, 301)
    run = pn.simulate_muscle_pressure(t, np.full(t.size, target), P_start=0.0)
    choked = run.P < target - AIR.band  # u = 1, p / p_s < b_cr: a straight line of slope `rate`
    assert np.allclose(run.P[choked], rate * t[choked], rtol=1e-7, atol=1e-3)
    slope = np.gradient(run.P, t)
    near = (run.P > target - 0.2 * AIR.band) & (run.P < target - 1.0)
    assert near.any() and np.all(slope[near] < 0.25 * rate)  # it bends over near the target
    assert abs(run.P[-1] - target) < 1.0


def test_the_leak_decays_exponentially_with_its_time_constant():
    air = AIR.replace(C_leak=1e-12)
    V = pn.air_volume(L0, B, N, air.V_dead)
    tau = pn.leak_time_constant(V, 1e-12, air.k_poly)
    assert 200 < tau < 350  # the 190-240 s leak-down records
    t = np.linspace(0, 600, 61)
    run = pn.simulate_muscle_pressure(t, opening=0.0, air=air, P_start=4e5)
    assert np.allclose(run.P, 4e5 * np.exp(-t / tau), rtol=1e-7)


def test_the_air_sags_after_a_fast_fill_as_it_cools():
    # a rig like the issue's: a 620 kPa (absolute) supply, a switching valve open 2 s, then closed
    # for 10 s
    air = AIR.replace(P_supply=5.2e5, C_fill=1e-9, tau_heat=1.0)
    t = np.linspace(0, 12.0, 1201)
    u = np.where(t < 2.0, 1.0, 0.0)
    run = pn.simulate_muscle_pressure(t, opening=u, air=air)
    close = np.searchsorted(t, 2.0)
    assert run.T.max() > air.T_air + 50  # the fill heated the air
    sag = run.P[close] - run.P[close + 500]
    assert 3e3 < sag < 6e4, sag  # a few kPa to tens of kPa within 5 s of the valve closing
    # sealed, the mass is constant: cooled back to T_air the pressure is p (T_air / T) of the
    # closing moment
    assert run.T[-1] == pytest.approx(air.T_air, abs=0.01)
    cooled = (run.P[close] + pn.P_ATM) * air.T_air / run.T[close] - pn.P_ATM
    assert run.P[-1] == pytest.approx(cooled, rel=1e-4)


def test_a_fast_heat_exchange_is_the_isothermal_law():
    t = np.linspace(0, 0.05, 51)
    cmd = np.full(t.size, 3e5)
    hot = pn.simulate_muscle_pressure(t, cmd, air=AIR.replace(tau_heat=1e-5), P_start=0.0)
    cold = pn.simulate_muscle_pressure(t, cmd, air=AIR.replace(k_poly=1.0), P_start=0.0)
    assert np.max(np.abs(hot.P - cold.P)) < 1e-3 * 3e5


# --- the simulation against the independent simulator ---------------------------------------------


def _compare(t, mode, values, air, P_start, **muscle):
    kwargs = {"command": values} if mode == "command" else {"opening": values}
    params = muscle.pop("params", DEFAULT)
    run = pn.simulate_muscle_pressure(
        t, **kwargs, air=air, P_start=P_start, muscle=params, **muscle
    )
    length = muscle.get("length", params.L0 if "load" not in muscle else None)
    P, T, q = ind.simulate(
        t,
        mode,
        np.broadcast_to(values, t.shape),
        air_dict(air),
        params.b,
        params.n,
        P_start,
        length=length,
        length_rate=muscle.get("length_rate"),
        load=muscle.get("load"),
    )
    scale = np.max(np.abs(P))
    assert np.max(np.abs(run.P - P)) < 1e-6 * scale
    assert np.allclose(run.T, T, rtol=1e-7)
    assert np.allclose(run.mass_flow, q, rtol=1e-5, atol=1e-6 * np.max(np.abs(q)))
    return run


def test_a_regulator_record_at_a_held_length():
    t = np.arange(0, 0.12, 0.001)
    cmd = np.select([t < 0.01, t < 0.06], [0.0, 4.5e5], 1.5e5)
    _compare(t, "command", cmd, AIR.replace(C_exhaust=2e-9), 0.0, length=0.2)


def test_a_switching_valve_record_with_leak_and_heat():
    t = np.arange(0, 0.3, 0.002)
    u = np.select([t < 0.01, t < 0.04, t < 0.2], [0.0, 1.0, 0.0], -0.5)
    _compare(
        t,
        "opening",
        u,
        AIR.replace(C_leak=1e-11, tau_heat=0.5, b_cr=0.45, m_sub=0.8),
        0.0,
        length=0.21,
    )


def test_a_moving_muscle():
    t = np.arange(0, 0.2, 0.002)
    L = 0.2 + 0.01 * np.sin(2 * np.pi * 5 * t)
    Ld = 0.01 * 2 * np.pi * 5 * np.cos(2 * np.pi * 5 * t)
    cmd = np.where(t < 0.05, 1e5, 3e5)
    _compare(t, "command", cmd, AIR, 1e5, length=L, length_rate=Ld)
    _compare(
        t,
        "opening",
        np.where(t < 0.05, 0.5, 0.0),
        AIR.replace(tau_heat=0.3),
        1e5,
        length=L,
        length_rate=Ld,
    )


def test_a_free_muscle_under_a_load():
    model1 = Params(model=1)
    t = np.arange(0, 0.1, 0.001)
    cmd = np.where(t < 0.02, 1e5, 4e5)
    run = _compare(t, "command", cmd, AIR, 1e5, load=60.0, params=model1)
    assert run.L[-1] < run.L[0]  # it contracts as the pressure rises
    assert np.allclose(actuator.static_tension(run.L, run.P, model1), 60.0, rtol=1e-8)
    held = pn.simulate_muscle_pressure(t, cmd, P_start=1e5, length=run.L[0], muscle=model1)
    # the volume grows as it contracts: the free muscle fills more slowly than the held one
    assert np.argmax(run.P > 3.9e5) > np.argmax(held.P > 3.9e5)


# --- the parameters and bad input -----------------------------------------------------------------


def test_the_parameters_are_the_spec_values_and_the_registered_effects_own():
    parameters = {
        q.name: q for q in (*pn.VALVE_FLOW_PARAMETERS, *pn.LEAK_PARAMETERS, *pn.AIR_HEAT_PARAMETERS)
    }
    # registered as the effects valve_flow, leak and air_heat: the same objects, defined once
    from mkctl.physics import effects

    registered = {q.name: q for q in effects.parameters()}
    assert all(registered[name] is q for name, q in parameters.items())
    assert set(parameters) <= set(PARAMETER_NAMES)
    spec = (ROOT / "docs" / "model-spec.md").read_text()
    section = spec[spec.index("### 4d.") : spec.index("## 5.")]
    typical = section[section.index("Typical values") : section.index("bounds:")]
    written = {
        name: float(value) * (1e3 if kilo else 1.0)
        for name, value, kilo in re.findall(r"`(\w+)` ([0-9.e+-]+)( kPa)?", typical)
    }
    assert written.pop("C_exhaust") == 0.0
    for name, value in written.items():
        q = parameters[name]
        assert q.typical == value and q.start == (0.0 if name == "C_leak" else value), name
    bounds = {
        "C_fill": (1e-11, 1e-6),
        "b_cr": (0.0, 0.9),
        "m_sub": (0.3, 1.5),
        "band": (1e3, 1e6),
        "V_dead": (0.0, 1e-3),
        "k_poly": (1.0, 1.4),
    }  # spec 4d's bounds line and its Gas line
    assert "`C` 1e-11..1e-6, `b_cr` 0..0.9, `m_sub` 0.3..1.5, `band` 1 kPa..1 MPa" in section
    for name, (low, high) in bounds.items():
        assert (parameters[name].lower, parameters[name].upper) == (low, high), name
    assert parameters["P_supply"].start == 2e6 and parameters["T_air"].start == 293.15
    assert parameters["valve_flow"].switch and parameters["tau_heat"].off == 0.0
    assert parameters["C_leak"].off == 0.0 and parameters["C_exhaust"].off == 0.0
    for q in parameters.values():  # AirParams' defaults: each parameter's start (leak and heat off)
        assert q.switch or getattr(pn.AirParams(), q.name) == q.start, q.name


@pytest.mark.parametrize(
    "bad",
    [
        {"C_fill": 1e-3},
        {"b_cr": 0.95},
        {"band": 10.0},
        {"k_poly": 1.6},
        {"V_dead": -1e-6},
        {"tau_heat": math.nan},
        {"P_supply": 0.0},
    ],
)
def test_bad_air_values_are_one_line_errors(bad):
    with pytest.raises(MkctlError, match=next(iter(bad))):
        pn.AirParams(**bad)


@pytest.mark.parametrize(
    "kwargs, words",
    [
        ({"command": [0, 1e5], "opening": [0, 1]}, "either command"),
        ({"opening": [0, 2.0]}, r"\[-1, 1\]"),
        ({"command": [0, 1e5, 2e5]}, "3 values for 2"),
        ({"command": [0, math.nan]}, "finite"),
        ({"command": [0, 1e5], "load": 10.0, "length": 0.2}, "either length"),
        ({"command": [0, 1e5], "method": "Euler"}, "unknown integrator"),
        ({"command": [0, 1e5], "length": 0.5}, "length"),
    ],
)
def test_bad_simulation_input_is_a_one_line_error(kwargs, words):
    with pytest.raises(MkctlError, match=words):
        pn.simulate_muscle_pressure([0.0, 0.01], **kwargs)


def test_a_supply_line_in_series_is_expressed_by_the_valve_s_own_iso_triple():
    """The supply's droop (model-spec 4d): a supply line (an ISO orifice, C_line) in series with the
    valve is solved exactly here (the node pressure where both flows agree, brentq), and the valve's
    own (C_fill, b_cr, m_sub), fitted to that flow, reproduce it within about 1 % of the choked flow
    (ISO 6358-3's way: a series of components has a C, b and m of its own); the valve's values alone
    miss it by some 20 %. While choked, the inlet reads p_s C_fill / C_valve: the drawn-down supply
    an inlet-side sensor sees."""
    from scipy.optimize import brentq, least_squares

    p_s, C_valve, C_line = 6.2e5, 5e-9, 6e-9

    def node(p):
        def mismatch(x):
            return ind.orifice(p_s, x, C_line, 0.3, 0.5, 293.15, 293.15) - ind.orifice(
                x, p, C_valve, 0.3, 0.5, 293.15, 293.15
            )

        return brentq(mismatch, p, p_s, xtol=1e-6)

    p = np.linspace(1.0e5, 6.19e5, 120)
    inlet = np.array([node(x) for x in p])
    exact = np.array(
        [ind.orifice(x, y, C_valve, 0.3, 0.5, 293.15, 293.15) for x, y in zip(inlet, p)]
    )

    def misfit(theta):
        q = pn.valve_mass_flow(
            1.0, p - pn.P_ATM, p_s - pn.P_ATM, theta[0] * 1e-9, 0.0, theta[1], theta[2]
        )
        return (q - exact) / exact.max()

    fit = least_squares(misfit, [5.0, 0.3, 0.5], bounds=([0.01, 0.0, 0.3], [1e3, 0.9, 1.5]))
    assert np.max(np.abs(fit.fun)) < 0.015
    assert np.max(np.abs(misfit([5.0, 0.3, 0.5]))) > 0.15
    C_fill = fit.x[0] * 1e-9
    assert (
        C_fill < C_valve and fit.x[1] < 0.3
    )  # the droop lowers the conductance and the critical ratio
    choked = p < 2e5
    assert np.allclose(inlet[choked], p_s * C_fill / C_valve, rtol=0.01)


def test_the_module_example_runs():
    import doctest

    assert doctest.testmod(pn, optionflags=doctest.ELLIPSIS).failed == 0
