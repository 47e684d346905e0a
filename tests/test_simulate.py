"""Time simulation: the integrator against scipy, step-size independence, state save/restore, isotonic."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from mkctl.physics import isotonic, knee, stability
from mkctl.errors import DomainError
from mkctl.physics.params import DEFAULT, Params
from mkctl.physics.simulate import ActuatorSimulator, KneeSimulator, default_commands, simulate_knee


def test_default_commands_hold_the_default_posture_at_rest():
    pe, pf = default_commands()
    sim = KneeSimulator(DEFAULT, None, pe, pf)
    X0 = sim.state[0]
    for _ in range(100):
        sim.step(0.01, pe, pf)
    assert abs(sim.state[0] - X0) < 1e-9


@pytest.mark.parametrize("params", [Params(), Params(c=40.0, tau=0.05), Params(c=20.0, Fc=2.0)])
def test_knee_simulation_matches_scipy_and_does_not_depend_on_the_step(params):
    pe, pf = default_commands(params)
    pe_step = pe * 1.05
    runs = {}
    for dt in (1e-3, 20e-3):
        sim = KneeSimulator(params, None, pe, pf)
        samples = []
        for k in range(int(round(1.0 / dt))):
            sim.step(dt, pe_step, pf)
            if (k + 1) % int(round(0.02 / dt)) == 0:
                samples.append(sim.state[0])
        runs[dt] = np.array(samples)
    assert np.max(np.abs(runs[1e-3] - runs[20e-3])) < 1e-6  # 1 micrometre (issue 3)
    stops = knee.stop_positions(params)
    y0 = [knee.X_from_alpha(np.radians(60), params), 0.0] + ([pe, pf] if params.tau else [])
    ref = solve_ivp(lambda t, y: knee.knee_derivatives(y, pe_step, pf, params, stops), (0, 1.0), y0,
                    method="DOP853", rtol=1e-12, atol=1e-12, t_eval=np.arange(1, 51) * 0.02)
    assert np.max(np.abs(ref.y[0] - runs[20e-3])) < 1e-7


def test_state_can_be_saved_and_restored():
    pe, pf = default_commands()
    sim = KneeSimulator(Params(tau=0.05), None, pe, pf)
    sim.step(0.1, pe * 1.1, pf)
    snapshot = sim.get_state()
    first = [sim.step(0.01, pe * 0.9, pf).copy() for _ in range(20)]
    sim.set_state(snapshot)
    again = [sim.step(0.01, pe * 0.9, pf).copy() for _ in range(20)]
    np.testing.assert_array_equal(first, again)


def test_saturated_flexor_drives_the_leg_onto_the_lower_stop_not_out_of_the_domain():
    pe, pf = default_commands()
    t = np.linspace(0, 2, 201)
    run = simulate_knee(t, np.zeros_like(t), np.full_like(t, 1e6), X0=knee.X_from_alpha(np.radians(60)))
    low, _ = knee.stop_positions()
    assert run["X"][-1] == pytest.approx(low, abs=2e-3)
    assert np.all(np.isfinite(run["X"]))


def test_simulate_knee_starts_at_rest_in_equilibrium_and_reports_outputs():
    t = np.linspace(0, 0.5, 51)
    run = simulate_knee(t, 1.75e6, 1e5, Params(c=40.0))
    assert run["X"][0] == pytest.approx(stability.equilibrium_hip_height(1.75e6, 1e5), abs=1e-12)
    assert np.ptp(run["X"]) < 1e-9
    assert run["stable"].all() and set(run) >= {"alpha", "beta", "Le", "Lf", "fe", "ff", "F", "a1", "a2"}


def test_impossible_start_raises_a_clear_error():
    with pytest.raises(DomainError, match="hip height"):
        KneeSimulator(DEFAULT, X0=0.95)


def test_actuator_simulator_lags_and_computes_tension():
    act = ActuatorSimulator(Params(tau=0.1), p0=0.0)
    act.step(0.1, 1e5)
    assert act.pressure == pytest.approx(1e5 * (1 - np.exp(-1)))
    from mkctl.physics.actuator import tension_model2
    assert act.outputs(1e5, 0.2, 0.0)["f"] == pytest.approx(tension_model2(0.2, act.pressure))
    with pytest.raises(DomainError):
        act.outputs(1e5, 0.25, 0.0)
    with pytest.raises(DomainError, match="Ldot"):
        act.outputs(1e5, 0.2, float("nan"))


def test_static_isotonic_length_carries_the_load():
    P = np.array([1e5, 3e5, 5e5])
    L = isotonic.static_length(P, 60.0)
    from mkctl.physics.actuator import static_tension
    np.testing.assert_allclose(static_tension(L, P), 60.0, rtol=1e-9)
    with pytest.raises(DomainError, match="no actuator length"):
        isotonic.static_length(0.0, 50.0, Params(model=1))


def test_friction_draws_a_hysteresis_loop_in_the_isotonic_test():
    t = np.linspace(0, 20, 801)
    P = 50e3 + 250e3 * np.sin(np.pi * t / 20) ** 2
    load = np.full_like(t, 50.0)
    L0 = isotonic.simulate_isotonic(t, P, load)
    L1 = isotonic.simulate_isotonic(t, P, load, Params(Fc=3.0))
    # pressure rises over the first half (the muscle shortens), falls over the second (it lengthens)
    up = np.interp(150e3, P[:401], L1[:401])
    down = np.interp(150e3, P[400:][::-1], L1[400:][::-1])
    # friction resists the motion, so the length lags: longer on the way up than on the way down
    assert up - down > 1e-4, "the loop must open"
    assert abs(np.interp(150e3, P[:401], L0[:401]) - np.interp(150e3, P[400:][::-1], L0[400:][::-1])) < 1e-8


def test_a_tiny_communication_step_is_fine_and_keeps_the_step_hint():
    pe, pf = default_commands()
    t = np.array([0.0, 1e-3, 1e-3 + 1e-15, 2e-3])
    run = simulate_knee(t, pe * 1.05, pf, X0=knee.X_from_alpha(np.radians(60)))
    reference = simulate_knee(np.array([0.0, 1e-3, 2e-3]), pe * 1.05, pf, X0=knee.X_from_alpha(np.radians(60)))
    assert run["X"][-1] == pytest.approx(reference["X"][-1], abs=1e-12)
    sim = KneeSimulator(DEFAULT, None, pe, pf)
    sim.step(1e-3, pe, pf)
    hint = sim.step_hint
    sim.step(1e-15, pe, pf)
    assert sim.step_hint >= hint


def test_knee_states_is_simulate_knee_at_the_asked_samples():
    pe, pf = default_commands()
    t = np.arange(0, 0.3, 1e-3)
    pe_cmd = np.where(t < 0.05, pe, 1.04 * pe)
    from mkctl.physics.simulate import knee_states
    full = simulate_knee(t, pe_cmd, pf, Params(c=30.0))
    at = np.array([0, 17, 120, 299])
    X, V = knee_states(t, pe_cmd, pf, Params(c=30.0), at=at)
    # the integrator's steps do not depend on the samples asked for (they are read off its dense output)
    np.testing.assert_allclose(X, full["X"][at], rtol=0, atol=1e-14)
    np.testing.assert_allclose(V, full["V"][at], rtol=0, atol=1e-13)


def test_dense_output_is_the_quartic_of_the_step():
    """Against a closed form: y' = A y (a lightly damped oscillator), read off the continuous extension at 2000
    times, several inside each step. The quartic ends where the step ends (theta = 1), and between the ends it
    is as accurate as the steps themselves (error far below 1e-6 at rtol 1e-8)."""
    from mkctl.physics.integrate import DENSE, _A, integrate
    np.testing.assert_allclose(np.sum(DENSE, axis=1), list(_A[6]) + [0.0], rtol=1e-13, atol=1e-15)
    A = np.array([[0.0, 1.0], [-400.0, -2.0]])
    eigenvalues, vectors = np.linalg.eig(A)
    y0 = np.array([1.0, 0.0])

    def exact(t):
        return np.real(vectors @ (np.exp(eigenvalues * t) * np.linalg.solve(vectors, y0)))

    times = np.linspace(0.0, 1.0, 2001)[1:]
    out = np.empty((times.size, 2))
    y_end, _, steps = integrate(lambda y: A @ y, y0, 1.0, 1e-3, 1e-12, 1e-8, dense_times=times, dense_out=out)
    assert steps < times.size / 4  # far fewer steps than samples: the samples did not cut them
    errors = np.abs(out - np.array([exact(t) for t in times]))
    assert errors.max() < 1e-6
    np.testing.assert_array_equal(out[-1], y_end)


def test_a_trial_step_leaving_the_domain_is_shrunk_not_fatal():
    """y' = 1 - y from 0 approaches 1 and never reaches it; the model raises a DomainError for y > 1. A first
    trial step of 10 s overshoots in its stages: it must be rejected and shrunk, not end the run."""
    from mkctl.physics.integrate import integrate

    def rhs(y):
        if y[0] > 1.0:
            raise DomainError("y past 1")
        return 1.0 - y

    y, _, _ = integrate(rhs, [0.0], 3.0, 10.0, 1e-12, 1e-10)
    assert y[0] == pytest.approx(1 - np.exp(-3.0), rel=1e-9)

    def leaves(y):  # a solution that does leave the domain: the last domain error is raised, not swallowed
        if y[0] > 1.0:
            raise DomainError("y past 1")
        return np.array([1.0])

    with pytest.raises(DomainError, match="y past 1"):
        integrate(leaves, [0.0], 3.0, 1e-3, 1e-12, 1e-10)
