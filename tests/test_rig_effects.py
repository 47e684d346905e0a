"""The effects a real rig has (model-spec section 4b), each against a hand computation independent of the
library's composition, the compiled core (1e-10 against Python) and ``synth --hidden``."""
from __future__ import annotations

import math

import numpy as np
import pytest

from mkctl.physics import actuator, knee
from mkctl.physics.isometric import isometric_tension
from mkctl.physics.isotonic import simulate_isotonic, static_length
from mkctl.physics.params import Params

#: Model 2 at (0.18 m, 300 kPa), model-spec section 2's reference table [N].
F2_REFERENCE = 75.248131


def _core(params):
    from mkctl.native import build, compiled
    if build.find_compiler() is None:
        pytest.skip("no C compiler here")
    core = compiled.core_for(params)
    assert core is not None
    return core


def _core_agrees(params, rng, lag_states=False):
    """The compiled right-hand side, outputs and tension agree with Python at random states (1e-10)."""
    from mkctl.physics.simulate import default_commands, knee_outputs
    core = _core(params)
    low, high = knee.stop_positions(params)
    pe, pf = default_commands(params)
    for _ in range(20):
        X, V = rng.uniform(low, high), rng.normal(0, 0.2)
        state = [X, V] + ([pe * rng.uniform(0.8, 1.2), pf * rng.uniform(0.5, 2)] if lag_states else [])
        pe_cmd, pf_cmd = pe * rng.uniform(0.8, 1.2), pf * rng.uniform(0.5, 2)
        np.testing.assert_allclose(core.knee_rhs(params, state, pe_cmd, pf_cmd),
                                   knee.knee_derivatives(state, pe_cmd, pf_cmd, params), rtol=1e-10, atol=1e-9)
        P = (state[2], state[3]) if lag_states else (pe_cmd, pf_cmd)
        expected = knee_outputs(X, V, *P, params)
        got = core.knee_outputs(params, state, pe_cmd, pf_cmd)
        for i, name in enumerate(expected):
            assert got[i] == pytest.approx(float(expected[name]), rel=1e-10, abs=1e-9), name
        L, Ldot, P = rng.uniform(0.16, 0.22), rng.normal(0, 0.01), rng.uniform(0, 6e5)
        assert core.actuator("tension", params, L, P, Ldot) == pytest.approx(
            float(actuator.tension(L, P, Ldot, params)), rel=1e-10, abs=1e-9)


def _synth_hides(item, parameter, value, effect):
    from mkctl.analysis.synth import synthesize
    record = synthesize("knee", hidden=[item], samples=200, seed=1)
    assert getattr(record.truth, parameter) == pytest.approx(value)
    assert effect in record.hidden_effects


# --- pressure_friction: f += Fc_p P tanh(Ldot / vs) -------------------------------------------------------------

def test_pressure_friction_by_hand():
    p = Params(Fc=1.5, Fc_p=4e-6, vs=2e-3)
    L, P, Ldot = 0.18, 300e3, 1.3e-3
    by_hand = F2_REFERENCE + (1.5 + 4e-6 * 300e3) * math.tanh(Ldot / 2e-3)
    assert float(actuator.tension(L, P, Ldot, p)) == pytest.approx(by_hand, abs=1e-6)
    assert p.effects == ("elasticity", "coulomb_friction", "pressure_friction")
    # a clamped muscle: the branches differ by 2 (Fc + Fc_p P)
    up, down = isometric_tension(L, P, +1, p), isometric_tension(L, P, -1, p)
    assert float(down - up) == pytest.approx(2 * (1.5 + 4e-6 * 300e3), rel=1e-12)
    assert float(up) == pytest.approx(F2_REFERENCE - 2.7, abs=1e-6)
    # at rest the knee's damping is the friction's slope: a1 = -(Fc + Fc_p P)/vs (G_e^2 + G_f^2) / m, per muscle
    geo = knee.geometry_at_X(0.8, p)
    Pe, Pf = 1.2e6, 1e5
    d = knee.knee_force_partials(geo, 0.0, Pe, Pf, p)
    slope_e, slope_f = (1.5 + 4e-6 * Pe) / 2e-3, (1.5 + 4e-6 * Pf) / 2e-3
    assert float(d.dF_dV) == pytest.approx(-(slope_e * geo.G_e**2 + slope_f * geo.G_f**2), rel=1e-10)


def test_pressure_friction_in_the_isotonic_test_is_a_play_band_that_widens_with_pressure():
    p = Params(Fc_p=5e-6)
    t = np.linspace(0, 10, 201)
    P = np.concatenate([np.linspace(150e3, 600e3, 101), np.linspace(600e3, 150e3, 101)[1:]])
    F = np.full(t.size, 50.0)
    L = simulate_isotonic(t, P, F, p)
    rising, falling = slice(5, 101), slice(110, 201)  # the muscle shortens while P rises, lengthens while it falls
    np.testing.assert_allclose(L[rising], static_length(P[rising], F[rising] + 5e-6 * P[rising], p), rtol=1e-9)
    np.testing.assert_allclose(L[falling], static_length(P[falling], F[falling] - 5e-6 * P[falling], p), rtol=1e-9)


def test_pressure_friction_in_the_compiled_core():
    _core_agrees(Params(Fc=0.8, Fc_p=3e-6, vs=5e-3, c=10.0), np.random.default_rng(11))
    # the damped isotonic test in C: the band's half-width Fc + Fc_p P comes from the generated code
    from mkctl.physics import backend
    p = Params(Fc_p=5e-6, c=30.0)
    t = np.linspace(0, 4, 401)
    P = 375e3 + 225e3 * np.sin(2 * np.pi * t / 4)
    fast = simulate_isotonic(t, P, np.full(t.size, 50.0), p)
    previous = backend.install(None)
    try:
        slow = simulate_isotonic(t, P, np.full(t.size, 50.0), p)
    finally:
        backend.install(previous)
    np.testing.assert_allclose(fast, slow, rtol=1e-10)


def test_synth_hides_pressure_friction():
    _synth_hides("Fc_p=5e-6", "Fc_p", 5e-6, "pressure_friction")
    _synth_hides("pressure_friction", "Fc_p", 5e-6, "pressure_friction")


# --- pressure_threshold: P_eff = P - P0 (1 - exp(-P / P0)) in Eq. 7 ---------------------------------------------

def test_pressure_threshold_by_hand():
    from mkctl.physics.params import DEFAULT
    p = Params(P0=1e5)
    L, P = 0.18, 300e3
    P_eff = P - 1e5 * (1 - math.exp(-3.0))
    # model 2 is affine in P at a fixed length: the threshold is model 2 at P_eff, the rubber unchanged
    assert float(actuator.tension(L, P, 0.0, p)) == pytest.approx(float(actuator.tension_model2(L, P_eff)), rel=1e-13)
    n = math.sqrt(0.241**2 - 0.208**2) / (math.pi * 0.013)
    gain = (3 * L * L - 0.241**2) / (4 * math.pi * n * n)
    assert float(actuator.tension(L, P, 0.0, p)) == pytest.approx(F2_REFERENCE - (P - P_eff) * gain, abs=1e-6)
    # no pressure, a negative one, or P0 = 0: the paper's model
    for pressure in (0.0, -2e4):
        assert float(actuator.tension(L, pressure, 0.0, p)) == float(actuator.tension(L, pressure, 0.0, DEFAULT))
    # the asymptotes of spec 4b: P^2 / (2 P0) at low pressure, P - P0 at high pressure
    low = float(actuator.tension_model1(L, 1e3, p.replace(model=1))) / 1e3  # the gain
    assert float(actuator.tension(L, 1e3, 0.0, p.replace(model=1))) / low == pytest.approx(1e3**2 / 2e5, rel=1e-2)
    assert float(actuator.tension(L, 4e6, 0.0, p.replace(model=1))) / low == pytest.approx(4e6 - 1e5, rel=1e-9)
    # the slope in P is (1 - exp(-P/P0)) times the paper's, in the knee's partials
    geo = knee.geometry_at_X(0.8, p)
    d = knee.knee_force_partials(geo, 0.0, 1.2e6, 1e5, p)
    d0 = knee.knee_force_partials(geo, 0.0, 1.2e6, 1e5, DEFAULT)
    assert float(d.dF_dPe) == pytest.approx(float(d0.dF_dPe) * (1 - math.exp(-12.0)), rel=1e-12)
    assert float(d.dF_dPf) == pytest.approx(float(d0.dF_dPf) * (1 - math.exp(-1.0)), rel=1e-12)
    assert float(isometric_tension(L, P, 1, p)) == pytest.approx(float(actuator.tension_model2(L, P_eff)), rel=1e-13)
    with pytest.raises(Exception, match=r"P0 = 500000 Pa is outside the model's domain \[0, 400000\] Pa"):
        Params(P0=5e5)


def test_pressure_threshold_in_the_compiled_core():
    _core_agrees(Params(P0=8e4, Fc=0.5), np.random.default_rng(12))
    _core_agrees(Params(P0=8e4, tau=0.04, slack=1), np.random.default_rng(13), lag_states=True)


def test_synth_hides_pressure_threshold():
    _synth_hides("P0=5e4", "P0", 5e4, "pressure_threshold")


# --- asymmetric_lag: tau fills, tau_exhaust exhausts -------------------------------------------------------------

def test_asymmetric_lag_by_hand():
    from mkctl.errors import ParameterError
    from mkctl.physics.simulate import ActuatorSimulator
    p = Params(tau=0.05, tau_exhaust=0.15)
    # the rates: (P_cmd - P) / tau filling, / tau_exhaust exhausting
    assert float(actuator.pressure_derivative(1e5, 3e5, p)) == pytest.approx(2e5 / 0.05, rel=1e-13)
    assert float(actuator.pressure_derivative(3e5, 1e5, p)) == pytest.approx(-2e5 / 0.15, rel=1e-13)
    # the actuator's exact step, against the closed form of each branch
    sim = ActuatorSimulator(p, 1e5)
    assert sim.step(0.02, 3e5) == pytest.approx(3e5 - 2e5 * math.exp(-0.02 / 0.05), rel=1e-14)
    start = sim.pressure
    assert sim.step(0.07, 0.0) == pytest.approx(start * math.exp(-0.07 / 0.15), rel=1e-14)
    # the knee: a command step down then up, integrated by the library, against solve_ivp of the pressure alone
    from scipy.integrate import solve_ivp
    from mkctl.physics.simulate import simulate_knee, default_commands
    pe, pf = default_commands(p)
    t = np.linspace(0, 0.6, 601)
    pe_cmd = np.where(t < 0.3, pe * 0.95, pe)

    def rate(time, y):
        command = pe * 0.95 if time < 0.3 else pe
        return [(command - y[0]) / (0.15 if command < y[0] else 0.05)]
    expected = np.concatenate([solve_ivp(rate, (0, 0.3), [pe * 0.95], t_eval=t[t <= 0.3], rtol=1e-11,
                                         atol=1e-6).y[0],
                               solve_ivp(rate, (0.3, 0.6), [pe * 0.95], t_eval=t[t > 0.3], rtol=1e-11,
                                         atol=1e-6).y[0]])
    run = simulate_knee(t, pe_cmd, pf, p)
    np.testing.assert_allclose(run["Pe"], expected, rtol=1e-7)
    down = simulate_knee(t, np.where(t < 0.3, pe, pe * 0.95), pf, p)
    after = t > 0.3
    expected_down = pe * 0.95 + pe * 0.05 * np.exp(-(t[after] - 0.3) / 0.15)
    np.testing.assert_allclose(down["Pe"][after], expected_down, rtol=1e-7)
    # it needs the lag
    with pytest.raises(ParameterError, match="needs the effect pressure_lag"):
        Params(tau_exhaust=0.1)
    assert p.effects == ("elasticity", "pressure_lag", "asymmetric_lag")


def test_asymmetric_lag_linearizes_on_the_filling_branch_at_rest():
    p = Params(tau=0.05, tau_exhaust=0.15)
    X = float(knee.X_from_alpha(1.0, p))
    from mkctl.physics import stability
    Pe = float(stability.equilibrium_pressure(1.0, 1e5, p))
    A, B = knee.linearization(X, Pe, 1e5, Pe, 1e5, p)
    assert A[2, 2] == pytest.approx(-1 / 0.05) and B[2, 0] == pytest.approx(1 / 0.05)


def test_asymmetric_lag_in_the_compiled_core():
    _core_agrees(Params(tau=0.04, tau_exhaust=0.11), np.random.default_rng(14), lag_states=True)
    core = _core(Params(tau=0.04, tau_exhaust=0.11))
    p = Params(tau=0.04, tau_exhaust=0.11)
    for P, command in ((1e5, 3e5), (3e5, 1e5)):
        assert core.actuator("lagged_pressure", p, P, command, 0.03) == pytest.approx(
            float(actuator.pressure_after(P, command, 0.03, p)), rel=1e-13)


def test_synth_hides_asymmetric_lag():
    from mkctl.analysis.synth import synthesize
    record = synthesize("knee", hidden=["tau=0.05", "tau_exhaust=0.12"], samples=200, seed=1)
    assert record.truth.tau_exhaust == 0.12 and "asymmetric_lag" in record.hidden_effects


# --- dead_time: P_cmd(t - delay) ---------------------------------------------------------------------------------

def _step_record(p, delay_samples=0, dt=1e-3, n=801):
    from mkctl.physics.simulate import default_commands
    pe, pf = default_commands(p)
    t = np.arange(n) * dt
    pe_cmd = np.where(np.arange(n) < 100 + delay_samples, pe, pe * 1.04)
    pf_cmd = np.where(np.arange(n) < 300 + delay_samples, pf, pf * 1.3)
    return t, pe_cmd, pf_cmd


def test_dead_time_is_the_record_shifted_by_the_delay():
    from mkctl.physics.simulate import simulate_knee
    p = Params(delay=0.03, tau=0.02)
    t, pe_cmd, pf_cmd = _step_record(p)
    delayed = simulate_knee(t, pe_cmd, pf_cmd, p)
    # by hand: the same commands given 30 samples (= 0.03 s) later, to the model without a dead time
    _, pe_late, pf_late = _step_record(p, delay_samples=30)
    shifted = simulate_knee(t, pe_late, pf_late, p.replace(delay=0.0))
    for name in ("X", "V", "Pe", "Pf", "F"):
        span = np.ptp(shifted[name]) + np.abs(shifted[name]).max()
        np.testing.assert_allclose(delayed[name], shifted[name], rtol=0, atol=1e-10 * span, err_msg=name)
    assert np.ptp(delayed["X"]) > 1e-3
    # a delay between samples: the command arrives between them, the step is cut there; knee_states agrees
    from mkctl.physics.simulate import knee_states
    p2 = p.replace(delay=0.0315)
    run = simulate_knee(t, pe_cmd, pf_cmd, p2)
    X, V = knee_states(t, pe_cmd, pf_cmd, p2, at=[0, 200, 500, 800])
    np.testing.assert_allclose(X, run["X"][[0, 200, 500, 800]], rtol=1e-12)
    assert run["Pe"][130] == pytest.approx(run["Pe"][0], rel=1e-12)  # before 0.1315 s nothing has arrived
    assert run["Pe"][132] > run["Pe"][0]


def test_dead_time_in_the_step_by_step_simulator_matches_the_record():
    from mkctl.physics.simulate import ActuatorSimulator, KneeSimulator, simulate_knee
    p = Params(delay=0.03)
    t, pe_cmd, pf_cmd = _step_record(p, n=401)
    run = simulate_knee(t, pe_cmd, pf_cmd, p)
    sim = KneeSimulator(p, run["X"][0], pe_cmd[0], pf_cmd[0])
    X = [sim.state[0]]
    for k in range(t.size - 1):
        sim.step(t[k + 1] - t[k], pe_cmd[k], pf_cmd[k])
        X.append(sim.state[0])
    np.testing.assert_allclose(X, run["X"], rtol=0, atol=1e-8)
    # a saved state carries the commands still on their way
    snapshot = sim.get_state()
    sim.step(0.01, pe_cmd[0], pf_cmd[0])
    after = sim.state.copy()
    sim.set_state(snapshot)
    sim.step(0.01, pe_cmd[0], pf_cmd[0])
    np.testing.assert_array_equal(sim.state, after)
    # the actuator: the command seen 0.03 s late, then the exact lag
    act = ActuatorSimulator(Params(delay=0.03, tau=0.05), 1e5)
    act.step(0.02, 3e5)
    assert act.pressure == pytest.approx(1e5)
    act.step(0.02, 3e5)  # 0.01 s of the new command seen
    assert act.pressure == pytest.approx(3e5 - 2e5 * math.exp(-0.01 / 0.05), rel=1e-13)


def test_dead_time_linearizes_by_a_first_order_pade_approximation():
    p = Params(delay=0.03)
    from mkctl.physics import stability
    X = float(knee.X_from_alpha(1.0, p))
    Pe = float(stability.equilibrium_pressure(1.0, 1e5, p))
    A, B = knee.linearization(X, Pe, 1e5, Pe, 1e5, p)
    A0, B0 = knee.linearization(X, Pe, 1e5, Pe, 1e5, p.replace(delay=0.0))
    assert knee.linearization_state_names(p) == ("X", "V", "pe_pade", "pf_pade")
    # the transfer functions: the delayed system is the undelayed one times (1 - s d/2) / (1 + s d/2)
    for w in (0.1, 3.0, 20.0):
        s = 1j * w
        G = np.linalg.solve(s * np.eye(4) - A, B)[:2]
        G0 = np.linalg.solve(s * np.eye(2) - A0, B0)
        np.testing.assert_allclose(G, G0 * (1 - s * 0.015) / (1 + s * 0.015), rtol=1e-10)
    assert np.sort(np.linalg.eigvals(A).real)[0] <= -2 / 0.03 * 0.999


def test_dead_time_in_the_compiled_core():
    from mkctl.physics import backend
    from mkctl.physics.simulate import simulate_knee
    p = Params(delay=0.0315, tau=0.02, Fc=0.5)
    _core(p)
    t, pe_cmd, pf_cmd = _step_record(p)
    fast = simulate_knee(t, pe_cmd, pf_cmd, p)
    previous = backend.install(None)
    try:
        slow = simulate_knee(t, pe_cmd, pf_cmd, p)
    finally:
        backend.install(previous)
    for name in ("X", "V", "Pe", "F", "a1"):
        span = np.ptp(slow[name]) + np.abs(slow[name]).max()
        np.testing.assert_allclose(fast[name], slow[name], rtol=0, atol=1e-10 * span, err_msg=name)
    _core_agrees(p, np.random.default_rng(15), lag_states=True)


def test_synth_hides_a_dead_time():
    _synth_hides("delay=0.03", "delay", 0.03, "dead_time")
    _synth_hides("dead_time", "delay", 0.03, "dead_time")
