"""The compiled core of mechanism simulations (mkctl/native/mechanism_compiled.py) against the
Python loop of simulate_mechanism, which tests/test_mechanism.py and tests/test_air_knee.py check
against independent simulators: the built-ins and the cam lever file, with damping, friction, a
lag and a dead time, and with the air (valve_flow, a leak: the pressures states of the muscles'
mass balance, in a library of their own); the fallback (MKCTL_NATIVE=0, the air's temperature as
a state); the cache."""
from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from mkctl.analysis.mechanism_files import mechanism
from mkctl.native import build
from mkctl.native import mechanism_compiled as mc
from mkctl.physics import backend
from mkctl.physics import mechanism as mm
from mkctl.physics.params import DEFAULT

CAM_FILE = Path(__file__).resolve().parent.parent / "docs" / "examples" / "cam_lever.py"
PARAMS = {"damping": DEFAULT.replace(c=20.0),
          "damping+friction": DEFAULT.replace(c=20.0, Fc=2.0),
          "lag": DEFAULT.replace(tau=0.03),
          "friction+lag+dead-time": DEFAULT.replace(Fc=1.0, tau=0.03, delay=0.02)}
#: The air (model-spec 4d), on records whose command steps stay near the regulator's band
#: (:func:`_small_record`): a smaller valve with a leak and damping; the default valve with a
#: leak, friction, slack, model 1 and a dead time. The leak keeps each regulator a little open at
#: rest (filling what leaks), so that its opening does not switch between filling and exhausting
#: while the arm settles: see the kinks' test below for what that switch costs.
AIR_PARAMS = {"air+leak+damping": DEFAULT.replace(valve_flow=1, C_fill=1e-9, C_leak=1e-10, c=20.0),
              "air+leak+friction+slack+model1+dead-time": DEFAULT.replace(
                  valve_flow=1, C_leak=1e-10, c=20.0, Fc=1.0, slack=1, model=1, delay=0.02)}


def _record(name):
    """(mechanism, time, commands) of a 1 s record at 1 kHz with steps in its commands."""
    t = np.linspace(0.0, 1.0, 1001)
    if name == "pulley_joint":
        return mm.PULLEY_JOINT, t, (np.where(t < 0.2, 3e5, 4e5), np.where(t < 0.6, 2e5, 3.5e5))
    if name == "hanging_mass":
        return mm.HANGING_MASS, t, np.where(t < 0.2, 3e5, np.where(t < 0.6, 4.5e5, 2.5e5))
    return mechanism(str(CAM_FILE)), t, np.where(t < 0.3, 3e5, np.where(t < 0.7, 4e5, 2.5e5))


def _small_record(name):
    """_record's with command steps of 15 % of its: 15-30 kPa, the size of the regulator's band
    (20 kPa): the valve saturates briefly, then works in its band."""
    mech, t, commands = _record(name)
    columns = commands if isinstance(commands, tuple) else [commands]
    small = [3e5 + 0.15 * (c - 3e5) for c in columns]
    return mech, t, tuple(small) if isinstance(commands, tuple) else small[0]


class _Counted:
    """Counts the compiled record runs that gave states (not None)."""

    def __init__(self, monkeypatch):
        self.runs = 0
        original = mc.MechanismCore.run

        def run(core, *args, **kwargs):
            states = original(core, *args, **kwargs)
            self.runs += states is not None
            return states
        monkeypatch.setattr(mc.MechanismCore, "run", run)


def _python(time, commands, mech, params):
    previous = backend.install_mechanism(None)
    try:
        return mm.simulate_mechanism(time, commands, mech, params)
    finally:
        backend.install_mechanism(previous)


@pytest.mark.parametrize("effects", list(PARAMS))
@pytest.mark.parametrize("name", ["hanging_mass", "pulley_joint", "cam_lever"])
def test_the_compiled_core_runs_the_record_as_python(name, effects, monkeypatch):
    mech, t, commands = _record(name)
    params = PARAMS[effects]
    counted = _Counted(monkeypatch)
    compiled = mm.simulate_mechanism(t, commands, mech, params)
    assert counted.runs == 1, "the compiled core did not run the record"
    python = _python(t, commands, mech, params)
    assert counted.runs == 1
    span = np.ptp(python.q)
    assert span > 1e-3  # the record moves
    assert np.max(np.abs(compiled.q - python.q)) <= 1e-9 * span
    assert np.max(np.abs(compiled.qdot - python.qdot)) <= 1e-9 * np.ptp(python.qdot)
    np.testing.assert_allclose(compiled.P, python.P, rtol=0, atol=1e-9 * np.ptp(python.P) + 1e-9)
    np.testing.assert_allclose(compiled.f, python.f, rtol=1e-8, atol=1e-9 * np.ptp(python.f))


def test_the_compiled_core_lands_on_the_end_stop_as_python(monkeypatch):
    """Pressure off under 20 kg: the hanging mass falls onto its upper stop (the contact law).
    The stiff contact turns round-off into step choices: compiled and Python differ by the
    integrator's own error there (about 1e-7 of the range, as Python at rtol 1e-10 against 1e-11),
    so the bound is 1e-6 of the range, not the 1e-9 of the smooth records."""
    params = DEFAULT.replace(m=20.0, c=5.0)
    t = np.linspace(0.0, 0.8, 801)
    p = np.where(t < 0.2, 3e5, 0.0)
    counted = _Counted(monkeypatch)
    compiled = mm.simulate_mechanism(t, p, mm.HANGING_MASS, params)
    python = _python(t, p, mm.HANGING_MASS, params)
    assert counted.runs == 1
    assert python.q.max() > 0.97 * params.b
    assert np.max(np.abs(compiled.q - python.q)) <= 1e-6 * np.ptp(python.q)


def test_switched_off_it_falls_back_to_python(monkeypatch):
    mech, t, commands = _record("pulley_joint")
    compiled = mm.simulate_mechanism(t, commands, mech, PARAMS["damping"])
    monkeypatch.setenv(build.ENV_SWITCH, "0")
    counted = _Counted(monkeypatch)
    assert backend.mechanism_core(mech, mech.bind(PARAMS["damping"])) is None
    assert mc.status(mech).startswith("python (switched off")
    python = mm.simulate_mechanism(t, commands, mech, PARAMS["damping"])
    assert counted.runs == 0
    assert np.max(np.abs(compiled.q - python.q)) <= 1e-9 * np.ptp(python.q)


@pytest.mark.parametrize("effects", list(AIR_PARAMS))
@pytest.mark.parametrize("name", ["pulley_joint", "cam_lever"])
def test_the_compiled_core_runs_the_record_with_the_air_as_python(name, effects, monkeypatch):
    mech, t, commands = _small_record(name)
    params = AIR_PARAMS[effects]
    counted = _Counted(monkeypatch)
    compiled = mm.simulate_mechanism(t, commands, mech, params)
    assert counted.runs == 1, "the compiled core did not run the record"
    python = _python(t, commands, mech, params)
    held = np.array(commands if isinstance(commands, tuple) else [commands]).T
    assert np.abs(python.P - held).max() > 1e4  # the pressures: the air's states, not the commands
    assert np.max(np.abs(compiled.q - python.q)) <= 1e-9 * np.ptp(python.q)
    assert np.max(np.abs(compiled.qdot - python.qdot)) <= 1e-9 * np.ptp(python.qdot)
    for i in range(held.shape[1]):
        assert np.max(np.abs(compiled.P[:, i] - python.P[:, i])) <= 1e-9 * np.ptp(python.P[:, i])


@pytest.mark.parametrize("values", [dict(valve_flow=1, C_fill=1e-9), dict(valve_flow=1)],
                         ids=["small_valve", "default_valve"])
def test_where_the_air_has_kinks_compiled_and_python_differ_by_their_own_error(values):
    """The hanging mass with the air and no leak: a mass on an air spring, its regulator's opening
    crossing the kinks at the band's edges and at its switch from filling to exhausting. A step
    across a kink amplifies the rounding-level differences of the generated right-hand side (as in
    the knee, tests/test_air_core.py): compiled and Python differ by up to 2e-6 of P's range
    (measured, default valve), not 1e-9. The Python loop's own result moves more than that with its
    tolerance (rtol 1e-10 against 1e-12: 7e-6 of P's range), so the bound is the loop's own
    tolerance dependence (a finding: docs/fmu.md)."""
    mech, t, commands = _small_record("hanging_mass")
    params = DEFAULT.replace(**values)
    compiled = mm.simulate_mechanism(t, commands, mech, params)
    assert mc.status(mech, params).startswith("compiled")
    previous = backend.install_mechanism(None)
    try:
        python = mm.simulate_mechanism(t, commands, mech, params)
        tighter = mm.simulate_mechanism(t, commands, mech, params, rtol=1e-12)
    finally:
        backend.install_mechanism(previous)
    for name in ("q", "qdot", "P"):
        own = np.abs(getattr(python, name) - getattr(tighter, name)).max()
        difference = np.abs(getattr(compiled, name) - getattr(python, name)).max()
        span = np.ptp(getattr(python, name))
        assert own > 1e-9 * span  # the loop does not resolve it better than this itself
        assert difference <= 3.0 * own + 1e-9 * span, (name, difference / span, own / span)


def test_the_air_gets_a_library_of_its_own_and_its_temperature_the_python_path():
    air = mm.PULLEY_JOINT.bind(DEFAULT.replace(valve_flow=1))
    with_air = mc.core_for(mm.PULLEY_JOINT, air)
    without = mc.core_for(mm.PULLEY_JOINT, mm.PULLEY_JOINT.bind(DEFAULT))
    assert with_air is not None and without is not None and with_air.path != without.path
    assert with_air.air and not without.air
    assert mc.status(mm.PULLEY_JOINT, air).startswith("compiled")
    assert "mech_air_flows_" in mc.generated_source(mm.PULLEY_JOINT, air=True).read_text()
    assert "mech_air_flows_" not in mc.generated_source(mm.PULLEY_JOINT).read_text()
    hot = mm.PULLEY_JOINT.bind(DEFAULT.replace(valve_flow=1, tau_heat=0.5))
    assert mc.core_for(mm.PULLEY_JOINT, hot) is None
    assert "temperature" in mc.status(mm.PULLEY_JOINT, hot)


def test_the_second_build_is_a_cache_hit(monkeypatch):
    mech = mechanism(str(CAM_FILE))  # a user's file: its C from its own traced functions
    first = mc.build_library(mech)
    source = mc.generated_source(mech).read_text()
    assert "mech_rhs_" in source and "mk_mech_record" in source

    def refuse(*args, **kwargs):
        raise AssertionError("made again")
    monkeypatch.setattr(mc, "generate_source", refuse)
    monkeypatch.setattr(build, "_compile_library", refuse)
    monkeypatch.setattr(mc, "_cores", {})
    again = mechanism(str(CAM_FILE))
    assert mc.build_library(again) == first
    assert mc.core_for(again, again.bind()).path == first


def test_another_mechanism_gets_another_library():
    """The key follows the traced functions: the pulley and the cam lever do not share C."""
    assert mc.source_key(mm.PULLEY_JOINT) != mc.source_key(mechanism(str(CAM_FILE)))
    assert mc.source_key(mm.PULLEY_JOINT) == mc.source_key(mm.PULLEY_JOINT)
