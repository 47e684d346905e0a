"""A user effect with a pressure rate and no exact pressure step compiles (model-spec section 4c, issue 21).

The effect, a bladder leak ``dP/dt = -k_leak P``, is defined in an effect file the tests write. No effect's exact
step covers it, so the Python path integrates the pressure over a step (actuator.pressure_after) and the compiled
core integrates the traced rate the same way (codegen's mk_pressure_integrate). The references: the Python path,
and the leak's closed-form solution.
"""
from __future__ import annotations

import contextlib
import math

import numpy as np
import pytest
from compiled_check import assert_core_matches_python

from mkctl.analysis.effect_files import EffectFileError, register_effect_file, unregister_effect_file
from mkctl.physics.params import Params

LEAK = '''
def leak(P, P_cmd, p, xp):
    """A bladder leak [Pa/s]: -k_leak P."""
    return -p.k_leak * P


EFFECTS = [{"name": "bladder_leak", "description": "a bladder leak, -k_leak P",
            "parameters": [{"name": "k_leak", "unit": "1/s", "off": 0.0, "lower": 0.0, "upper": 100.0,
                            "typical": 2.0}],
            "pressure_rate": leak}]
'''

K_LEAK = 0.5  # 1/s: slow enough that the default knee stays off its end stops over the checks' 0.6 s


@pytest.fixture
def leak(tmp_path):
    path = tmp_path / "leak.py"
    path.write_text(LEAK)
    register_effect_file(path)
    try:
        yield path
    finally:
        with contextlib.suppress(EffectFileError):
            unregister_effect_file(path)


def compiled_or_skip():
    from mkctl.native import build
    if build.find_compiler() is None:
        pytest.skip("no C compiler here")


def test_only_a_variant_without_an_exact_step_integrates_its_pressure(leak):
    from mkctl.native.codegen import integrates_pressure
    from mkctl.native.variants import Variant
    assert integrates_pressure(Variant.of(Params(k_leak=K_LEAK)))
    assert integrates_pressure(Variant.of(Params(k_leak=K_LEAK, tau=0.05)))  # the lag's step does not cover it
    assert not integrates_pressure(Variant.of(Params(tau=0.05)))  # the lag's own exact step
    assert not integrates_pressure(Variant.of(Params(tau=0.05, tau_exhaust=0.02)))
    assert not integrates_pressure(Variant.of(Params()))


def _leak_and_lag(P0, P_cmd, dt, k, tau):
    """The closed form of dP/dt = (P_cmd - P)/tau - k P (no lag: -k P) [Pa]."""
    if tau == 0:
        return P0 * math.exp(-k * dt)
    final, rate = P_cmd / (1 + k * tau), 1 / tau + k
    return final + (P0 - final) * math.exp(-rate * dt)


@pytest.mark.parametrize("tau", [0.0, 0.05])
def test_the_compiled_pressure_step_is_the_python_step_and_the_closed_form(leak, tau):
    compiled_or_skip()
    from mkctl.native import compiled
    from mkctl.physics.actuator import pressure_after
    p = Params(k_leak=K_LEAK, tau=tau)
    core = compiled.core_for(p)
    assert core is not None
    for P0, P_cmd, dt in [(3e5, 4e5, 1e-3), (3e5, 0.0, 0.1), (1e5, 2e5, 2.0), (5e5, 5e5, 1e-6), (2e5, 1e5, 0.0)]:
        got = core.actuator("lagged_pressure", p, P0, P_cmd, dt)
        assert got == pytest.approx(pressure_after(P0, P_cmd, dt, p), rel=1e-13, abs=1e-9)
        assert got == pytest.approx(_leak_and_lag(P0, P_cmd, dt, K_LEAK, tau), rel=1e-8)
    assert core.actuator("lagged_pressure", p, 1e5, 2e5, 2.0) < (1e5 if tau == 0 else 2e5 / (1 + K_LEAK * tau))


@pytest.mark.parametrize("tau", [0.0, 0.05])
def test_the_compiled_knee_with_the_leak_matches_python(leak, tau):
    compiled_or_skip()
    checked = assert_core_matches_python(Params(k_leak=K_LEAK, tau=tau))
    t, command, Pe = checked["t"], checked["pe_cmd"], checked["run"]["Pe"]
    switch = int(np.flatnonzero(command != command[0])[0])  # the step of the command
    at_switch = _leak_and_lag(Pe[0], command[0], t[switch], K_LEAK, tau)
    assert Pe[-1] == pytest.approx(_leak_and_lag(at_switch, command[-1], t[-1] - t[switch], K_LEAK, tau), rel=1e-8)
    assert Pe[-1] < 0.99 * command[-1]  # the leak is really there


def test_native_fmus_built_with_it_agree_with_python(leak, tmp_path):
    """Co-Simulation against the Python path (KneeSimulator, ActuatorSimulator: what the pythonfmu FMUs run) to
    1e-9; the actuator's Model Exchange (its dP/dt the traced rate, through CVode) against its Co-Simulation."""
    compiled_or_skip()
    from fmpy import simulate_fmu
    from mkctl.native.fmu import build_one
    from mkctl.physics.simulate import ActuatorSimulator, KneeSimulator, default_commands
    p = Params(k_leak=K_LEAK)
    # run here only: the Windows binary is the same C cross-compiled (tests/test_win64.py runs it)
    knee_fmu = build_one("McKibbenKnee", tmp_path / "knee.fmu", p, windows=False)
    actuator_fmu = build_one("McKibbenActuator", tmp_path / "actuator.fmu", p, windows=False)
    for start in ({"k_leak": K_LEAK}, {"k_leak": K_LEAK, "tau": 0.05}):
        q = p.replace(**start)
        pe, pf = default_commands(q)
        dt = 2e-3
        signal = np.array([(0.0, pe * 1.04, pf)], dtype=[("time", float), ("pe_cmd", float), ("pf_cmd", float)])
        result = simulate_fmu(str(knee_fmu), stop_time=0.4, output_interval=dt, input=signal, start_values=start,
                              output=["X", "Pe"])
        sim = KneeSimulator(q, None, pe * 1.04, pf)
        X = [sim.state[0]]
        for _ in range(len(result) - 1):
            sim.step(dt, pe * 1.04, pf)
            X.append(sim.state[0])
        np.testing.assert_allclose(result["X"], X, rtol=0, atol=1e-9 * (np.ptp(X) + max(X)), err_msg=str(start))
        assert np.ptp(X) > 1e-3 and result["Pe"][-1] < 0.99 * pe * 1.04  # the leak is really there

        signal = np.array([(0.0, 1e5, 0.18, 0.0), (0.1, 1e5, 0.18, 0.0), (0.1, 4e5, 0.18, 0.01),
                           (0.4, 4e5, 0.18, 0.01)], dtype=[("time", float), ("p_cmd", float), ("L", float),
                                                           ("Ldot", float)])
        cs = simulate_fmu(str(actuator_fmu), stop_time=0.4, output_interval=1e-3, input=signal, start_values=start,
                          output=["P", "f"])
        me = simulate_fmu(str(actuator_fmu), fmi_type="ModelExchange", stop_time=0.4, output_interval=1e-3,
                          input=signal, start_values=start, relative_tolerance=1e-10, output=["P", "f"])
        me = me[[int(np.flatnonzero(np.abs(me["time"] - t) < 1e-12)[0]) for t in cs["time"]]]
        sim = ActuatorSimulator(q, 1e5)
        P = [sim.pressure]
        for before, now in zip(cs["time"][:-1], cs["time"][1:]):
            P.append(sim.step(now - before, 1e5 if before < 0.1 - 1e-12 else 4e5))
        np.testing.assert_allclose(cs["P"], P, rtol=0, atol=1e-9 * max(P), err_msg=str(start))
        assert P[100] == pytest.approx(_leak_and_lag(1e5, 1e5, 0.1, K_LEAK, q.tau), rel=1e-8)
        assert P[100] < 0.98e5  # the leak drains the held 1e5 Pa
        for name in ("P", "f"):
            ref = cs[name].astype(float)
            assert np.abs(me[name] - ref).max() <= 1e-6 * np.abs(ref).max(), (start, name)
