"""A dead time (model-spec section 4b, ``delay``) in the native FMUs, FMI 2.0 and FMI 3.0, both interfaces.

- Co-Simulation keeps the commands on their way and cuts a step where one arrives, as
  mkctl.physics.simulate.KneeSimulator and ActuatorSimulator do (what the pythonfmu FMUs run): driven call by call
  with the same commands, the native knee (FMI 2.0 and 3.0) agrees with KneeSimulator to 1e-9 of each output's
  range on a pressure-step record whose delay falls between the steps, and the native actuator with
  ActuatorSimulator (a delay longer and one shorter than the step); driven by fmpy's simulate_fmu, both agree with
  the pythonfmu FMUs to 1e-9; independently of the Python path, the delayed
  native run equals the native run without a dead time whose commands are given ``delay`` later;
- the commands on their way are part of the FMU state: a replay from a saved state is identical;
- Model Exchange (fmpy's CVode) records the commands as the host gives them and switches what the actuators see
  at a time event (one falls at the arrival, between output points): it agrees with Co-Simulation to 1e-6 of each
  output's range, as the other Model Exchange runs (tests/test_native_me.py), in FMI 2.0 and 3.0, and with the
  Model Exchange run without a dead time whose step is given ``delay`` later;
- more changes on their way than the FMU can hold end the run with a one-line message, no crash: Co-Simulation
  refuses the step (fmi2Discard, the state kept), Model Exchange answers fmi2Error.
The native FMUs carry no Python: they run in this process.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from mkctl.physics.params import Params
from mkctl.physics.simulate import ActuatorSimulator, KneeSimulator, default_commands, default_hip_height

PE0, PF0 = default_commands()
KNEE_OUTPUTS = ("X", "V", "alpha", "beta", "Le", "Lf", "fe", "ff", "Pe", "Pf", "F", "a1", "a2")


def _compiler():
    from mkctl.native.build import find_compiler
    return find_compiler()


pytestmark = pytest.mark.skipif(_compiler() is None, reason="no C compiler: no native FMUs")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, dict]:
    """{"fmi2": {"knee": path, "actuator": path}, "fmi3": {...}} (the core's source and object are cached)."""
    from mkctl.native.fmi3 import build_fmi3
    from mkctl.native.fmu import build_native
    out = tmp_path_factory.mktemp("deadtime")
    short = {"McKibbenKnee": "knee", "McKibbenActuator": "actuator"}
    return {"fmi2": {short[k]: v for k, v in build_native(out).items()},
            "fmi3": {short[k]: v for k, v in build_fmi3(out).items()}}


class Slave:
    """One Co-Simulation instance (FMI 2.0 or 3.0, fmpy's FMU2Slave / FMU3Slave), its log messages kept."""

    def __init__(self, path, folder, **start):
        from fmpy import extract, read_model_description
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.fmi3 = self.md.fmiVersion.startswith("3")
        self.messages = []
        unzipped = extract(str(path), str(folder))
        name = self.md.coSimulation.modelIdentifier
        if self.fmi3:
            from fmpy.fmi3 import FMU3Slave
            self.fmu = FMU3Slave(guid=self.md.guid, unzipDirectory=unzipped, modelIdentifier=name, instanceName="t")
            self.fmu.instantiate(logMessage=lambda env, status, category, message:
                                 self.messages.append(message.decode()))
            self.fmu.enterInitializationMode(startTime=0.0)
        else:
            from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, defaultCallbacks
            self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=unzipped, modelIdentifier=name, instanceName="t")
            self._logger = fmi2CallbackLoggerTYPE(lambda env, instance, status, category, message:
                                                  self.messages.append(message.decode()))
            self.fmu.instantiate(callbacks=fmi2CallbackFunctions(
                logger=self._logger, allocateMemory=defaultCallbacks.allocateMemory,
                freeMemory=defaultCallbacks.freeMemory))
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        self.set(**start)
        self.fmu.exitInitializationMode()

    def set(self, **values):
        vrs, numbers = [self.vr[n] for n in values], [float(v) for v in values.values()]
        (self.fmu.setFloat64 if self.fmi3 else self.fmu.setReal)(vrs, numbers)

    def get(self, *names):
        return (self.fmu.getFloat64 if self.fmi3 else self.fmu.getReal)([self.vr[n] for n in names])

    def step(self, t, dt):
        self.fmu.doStep(t, dt)

    def free(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


def _knee_commands(k: int) -> tuple[float, float]:
    """The record's commands at step k: the extensor steps up 5 % at 0.1 s and back at 0.25 s, the flexor up 30 % at
    0.18 s; from 0.3 s the extensor wobbles (a command that changes every step)."""
    pe = PE0 * (1.05 if 100 <= k < 250 else 1.0) * (1.0 + 0.01 * np.sin(k / 7.0) if k >= 300 else 1.0)
    return pe, PF0 * (1.3 if k >= 180 else 1.0)


def _native_knee(path, folder, start, commands, steps, dt=1e-3) -> np.ndarray:
    fmu = Slave(path, folder, **start)
    rows = []
    try:
        for k in range(steps):
            pe, pf = commands(k)
            fmu.set(pe_cmd=pe, pf_cmd=pf)
            fmu.step(k * dt, dt)
            rows.append(fmu.get(*KNEE_OUTPUTS))
    finally:
        fmu.free()
    return np.array(rows)


def _assert_close(got, ref, tolerance, names):
    for j, name in enumerate(names):
        scale = max(1.0, np.abs(ref[:, j]).max())
        assert np.abs(got[:, j] - ref[:, j]).max() <= tolerance * scale, name


KNEE_START = {"delay": 0.0315, "tau": 0.02, "c": 40.0}  # the arrivals fall between the 1 ms steps


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_co_simulation_knee_with_a_dead_time_agrees_with_the_python_simulator(fmus, tmp_path, version):
    steps = 400
    got = _native_knee(fmus[version]["knee"], tmp_path / "knee", KNEE_START, _knee_commands, steps)
    params = Params(**KNEE_START)
    sim = KneeSimulator(params, default_hip_height(params), PE0, PF0)  # what the pythonfmu knee runs
    ref = []
    for k in range(steps):
        sim.step(1e-3, *_knee_commands(k))
        outputs = sim.outputs(*_knee_commands(k))
        ref.append([outputs[name] for name in KNEE_OUTPUTS])
    ref = np.array(ref)
    _assert_close(got, ref, 1e-9, KNEE_OUTPUTS)
    # the dead time acts: Pe starts to rise only once the step has arrived, 0.1 + 0.0315 s
    Pe = ref[:, KNEE_OUTPUTS.index("Pe")]
    assert np.all(Pe[:131] == Pe[0]) and Pe[133] > Pe[0] + 1e3


def test_a_delayed_co_simulation_is_the_run_without_it_with_the_commands_given_later(fmus, tmp_path):
    """Independent of the Python path: with a delay of 30 steps, the native knee equals the native knee without a
    dead time whose commands are given 30 steps later (the start commands before)."""
    start = {"delay": 0.03, "tau": 0.02, "c": 40.0}
    delayed = _native_knee(fmus["fmi2"]["knee"], tmp_path / "a", start, _knee_commands, 300)
    shifted = _native_knee(fmus["fmi2"]["knee"], tmp_path / "b", {**start, "delay": 0.0},
                           lambda k: _knee_commands(max(k - 30, 0)), 300)
    _assert_close(delayed, shifted, 1e-9, KNEE_OUTPUTS)
    assert np.ptp(delayed[:, 0]) > 1e-3  # the steps moved the leg


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
@pytest.mark.parametrize("delay", [0.0237, 0.0037])  # longer and shorter than the 10 ms step
def test_co_simulation_actuator_with_a_dead_time_agrees_with_the_python_simulator(fmus, tmp_path, version, delay):
    start = {"delay": delay, "tau": 0.05, "c": 10.0, "L": 0.18, "p_cmd": 1e5}
    fmu = Slave(fmus[version]["actuator"], tmp_path / "actuator", **start)
    sim = ActuatorSimulator(Params(delay=delay, tau=0.05, c=10.0), 1e5)
    got, ref = [], []
    try:
        for k in range(60):
            p_cmd, L, Ldot = 1e5 + 3e5 * (k >= 20) - 1e5 * (k >= 40) + 1e3 * (k % 3), 0.18 - 1e-4 * k, -0.01
            fmu.set(p_cmd=p_cmd, L=L, Ldot=Ldot)
            fmu.step(k * 1e-2, 1e-2)
            sim.step(1e-2, p_cmd)
            got.append(fmu.get("P", "f"))
            outputs = sim.outputs(p_cmd, L, Ldot)
            ref.append([outputs["P"], outputs["f"]])
    finally:
        fmu.free()
    _assert_close(np.array(got), np.array(ref), 1e-9, ("P", "f"))
    assert np.ptp(np.array(ref)[:, 0]) > 1e5


def test_co_simulation_agrees_with_the_pythonfmu_fmus_driven_by_fmpy(fmus, built_fmus, run_python):
    """The same record through fmpy's simulate_fmu, the native FMU and the pythonfmu one (each in a fresh process):
    every output to 1e-9 of its range."""
    from test_native_fmu import SIMULATE, _steps
    cases = {
        "knee": {"stop": 0.4, "dt": 1e-3, "start": KNEE_START, "signal": _steps(
            [0.0, 0.1, 0.18, 0.25, 0.4], [{"pe_cmd": PE0, "pf_cmd": PF0}, {"pe_cmd": PE0 * 1.05, "pf_cmd": PF0},
                                          {"pe_cmd": PE0 * 1.05, "pf_cmd": PF0 * 1.3},
                                          {"pe_cmd": PE0, "pf_cmd": PF0 * 1.3}, {"pe_cmd": PE0, "pf_cmd": PF0 * 1.3}])},
        "actuator": {"stop": 0.5, "dt": 1e-2, "start": {"delay": 0.0237, "tau": 0.05, "c": 10.0}, "signal": _steps(
            [0.0, 0.2, 0.35, 0.5], [{"p_cmd": 1e5, "L": 0.18, "Ldot": 0.0}, {"p_cmd": 4e5, "L": 0.17, "Ldot": -0.02},
                                    {"p_cmd": 2e5, "L": 0.19, "Ldot": 0.01}, {"p_cmd": 2e5, "L": 0.19, "Ldot": 0.01}])},
    }
    for model, case in cases.items():
        native = run_python(SIMULATE, fmus["fmi2"][model], json.dumps([case]))[0]
        python = run_python(SIMULATE, built_fmus[model], json.dumps([case]))[0]
        assert native["time"][-1] == pytest.approx(case["stop"]) and native.keys() == python.keys()
        for output in python:
            ref, got = np.array(python[output], float), np.array(native[output], float)
            assert np.abs(got - ref).max() <= 1e-9 * max(1.0, np.abs(ref).max()), f"{model}: {output}"
        pressure = np.array(python["Pe" if model == "knee" else "P"])
        assert np.all(pressure[:131] == pressure[0]) if model == "knee" else np.ptp(pressure) > 1e5


def test_the_commands_on_their_way_are_part_of_the_fmu_state(fmus, tmp_path):
    """Saved at 0.12 s (the step given at 0.1 s not yet arrived), the run replays identically from the state."""
    fmu = Slave(fmus["fmi2"]["knee"], tmp_path / "state", **KNEE_START)
    try:
        def run(first, last):
            rows = []
            for k in range(first, last):
                pe, pf = _knee_commands(k)
                fmu.set(pe_cmd=pe, pf_cmd=pf)
                fmu.step(k * 1e-3, 1e-3)
                rows.append(fmu.get("X", "Pe"))
            return rows

        run(0, 120)
        state = fmu.fmu.getFMUState()
        first = run(120, 200)
        fmu.fmu.setFMUState(state)
        assert run(120, 200) == first
        assert first[-1][1] > first[0][1] + 1e3  # the step arrived during the replay
        fmu.fmu.freeFMUState(state)
    finally:
        fmu.free()


# --- Model Exchange -----------------------------------------------------------------------------------------------

def _signal(name_values: dict, at: float, stop: float):
    """An fmpy input signal: every input at its first value, each stepping to its second at time `at`."""
    names = list(name_values)
    rows = [(0.0, *[v[0] for v in name_values.values()]), (at, *[v[0] for v in name_values.values()]),
            (at, *[v[1] for v in name_values.values()]), (stop, *[v[1] for v in name_values.values()])]
    return np.array(rows, dtype=[("time", float)] + [(n, float) for n in names])


def _me(path, signal, start, stop, **options):
    from fmpy import simulate_fmu
    return simulate_fmu(str(path), fmi_type="ModelExchange", stop_time=stop, output_interval=1e-3, input=signal,
                        start_values=dict(start), relative_tolerance=1e-10, **options)


def _at(run, times):
    """The rows of a Model Exchange run at the given times (the first row at a time, before an event there)."""
    return run[[int(np.flatnonzero(np.abs(run["time"] - t) < 1e-12)[0]) for t in times]]


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_model_exchange_with_a_dead_time_agrees_with_co_simulation(fmus, version):
    from fmpy import simulate_fmu
    path = fmus[version]["knee"]
    signal = _signal({"pe_cmd": (PE0, PE0 * 1.05), "pf_cmd": (PF0, PF0)}, 0.1, 0.4)
    cs = simulate_fmu(str(path), stop_time=0.4, output_interval=1e-3, input=signal, start_values=dict(KNEE_START))
    me_all = _me(path, signal, KNEE_START, 0.4)
    me = _at(me_all, cs["time"])
    names = [n for n in cs.dtype.names[1:] if n != "stable"]
    _assert_close(np.array([me[n] for n in names], float).T, np.array([cs[n] for n in names], float).T, 1e-6, names)
    # the delayed step is a time event, between the output points: CVode stopped at its arrival
    assert np.any(np.abs(me_all["time"] - 0.1315) < 1e-12)
    Pe = cs["Pe"]
    assert Pe[131] == Pe[0] and Pe[140] > Pe[0] + 1e3


def test_model_exchange_with_a_dead_time_is_the_run_without_it_with_the_step_given_later(fmus):
    path = fmus["fmi2"]["knee"]
    delayed = _me(path, _signal({"pe_cmd": (PE0, PE0 * 1.05), "pf_cmd": (PF0, PF0)}, 0.1, 0.4), KNEE_START, 0.4)
    shifted = _me(path, _signal({"pe_cmd": (PE0, PE0 * 1.05), "pf_cmd": (PF0, PF0)}, 0.1315, 0.4),
                  {**KNEE_START, "delay": 0.0}, 0.4)
    grid = np.round(np.arange(401) * 1e-3, 12)
    delayed, shifted = _at(delayed, grid), _at(shifted, grid)
    names = ("X", "V", "Pe", "fe", "F", "a1", "a2")
    _assert_close(np.array([delayed[n] for n in names]).T, np.array([shifted[n] for n in names]).T, 1e-6, names)


def test_model_exchange_actuator_with_a_dead_time_agrees_with_co_simulation(fmus):
    from fmpy import simulate_fmu
    path = fmus["fmi2"]["actuator"]
    start = {"tau": 0.05, "c": 10.0, "delay": 0.0237}
    signal = _signal({"p_cmd": (1e5, 4e5), "L": (0.18, 0.18), "Ldot": (0.0, 0.01)}, 0.1, 0.3)
    cs = simulate_fmu(str(path), stop_time=0.3, output_interval=1e-3, input=signal, start_values=dict(start))
    me = _at(_me(path, signal, start, 0.3), cs["time"])
    _assert_close(np.array([me["P"], me["f"]]).T, np.array([cs["P"], cs["f"]]).T, 1e-6, ("P", "f"))
    assert np.ptp(cs["P"]) > 2e5


# --- more than the FMU can hold -----------------------------------------------------------------------------------

def test_more_changes_on_their_way_than_the_fmu_holds_refuse_the_step_with_a_message(fmus, tmp_path):
    """A command that changes at every step of 0.1 ms through a dead time of 0.5 s: 5000 changes on their way,
    more than the FMU holds (MK_HISTORY - 1 = 2047 besides the one in force). The step that would overflow is
    refused with the message and the state kept; the steps before ran."""
    from fmpy.fmi1 import FMICallException
    fmu = Slave(fmus["fmi2"]["actuator"], tmp_path / "full", delay=0.5, tau=0.05, L=0.18, p_cmd=1e5)
    try:
        refused_at, before = None, None
        for k in range(2100):
            fmu.set(p_cmd=1e5 + 1e3 * (k % 2))
            before = fmu.get("P", "f")
            try:
                fmu.step(k * 1e-4, 1e-4)
            except FMICallException:
                refused_at = k
                break
        assert refused_at == 2048  # steps 1 .. 2047 each gave a change; the 2048th does not fit
        assert fmu.get("P", "f") == before  # the state kept
        assert any("the dead time delay = 0.5 s would hold more than 2047 changes of the commands on their way" in m
                   and "give the commands at most every" in m for m in fmu.messages), fmu.messages[-3:]
        assert np.isfinite(fmu.get("P", "f")).all()
    finally:
        fmu.free()


def test_model_exchange_refuses_more_changes_than_it_holds_with_a_message(fmus, tmp_path):
    from fmpy import extract, read_model_description
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Model, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, defaultCallbacks
    path = fmus["fmi2"]["actuator"]
    md = read_model_description(str(path))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    messages = []
    logger = fmi2CallbackLoggerTYPE(lambda env, name, status, category, message: messages.append(message.decode()))
    fmu = FMU2Model(guid=md.guid, unzipDirectory=extract(str(path), str(tmp_path / "me")),
                    modelIdentifier="McKibbenActuator", instanceName="me")
    fmu.instantiate(callbacks=fmi2CallbackFunctions(logger=logger, allocateMemory=defaultCallbacks.allocateMemory,
                                                    freeMemory=defaultCallbacks.freeMemory))
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["delay"], vr["tau"], vr["L"], vr["p_cmd"]], [0.5, 0.05, 0.18, 1e5])
    fmu.exitInitializationMode()
    fmu.newDiscreteStates()
    fmu.enterContinuousTimeMode()
    with pytest.raises(FMICallException):
        for k in range(1, 2100):
            fmu.setTime(k * 1e-4)
            fmu.setReal([vr["p_cmd"]], [1e5 + 1e3 * (k % 2)])
            event, terminate = fmu.completedIntegratorStep()
            assert not terminate
            if event:  # the first command given is announced as a time event; the later ones arrive after it
                assert k == 1
                fmu.enterEventMode()
                assert fmu.newDiscreteStates()[4:] == (True, 1e-4 + 0.5)  # nextEventTime: its arrival
                fmu.enterContinuousTimeMode()
    assert "would hold more than 2047 changes of the commands on their way" in messages[-1]
    fmu.terminate()
    fmu.freeInstance()
