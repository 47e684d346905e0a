"""Model Exchange of the native FMUs (model-spec section 7c): one binary and one modelDescription.xml with both
interfaces, the Model Exchange one generated from the same equations as Co-Simulation.

- both interfaces declared, fmpy's validation clean, the states and their derivatives declared as FMI 2.0 wants;
- the derivatives are the library's right-hand side (knee.knee_derivatives, against Python, at states in and out
  of an end-stop contact), the event indicators change sign where it switches (the stops);
- the knee step with damping, lag and an end-stop contact, through fmpy's CVode, agrees with the Co-Simulation
  run to 1e-6 of each output's range, and an event falls on the contact; without a lag too (the lag states stay);
- the actuator's pressure lag through CVode agrees with the exact lag of Co-Simulation;
- a negative pressure ends a Model Exchange run with the message; a parameter Model Exchange cannot represent
  (mkctl.native.fmu.ME_REFUSED_PARAMETERS, none today) is refused at initialization. (A dead time runs under
  Model Exchange: tests/test_native_deadtime.py.)
The native FMUs carry no Python: they run in this process.
"""
from __future__ import annotations

import ctypes
import zipfile
from pathlib import Path

import numpy as np
import pytest

from mkctl.physics import knee
from mkctl.physics.params import Params
from mkctl.physics.simulate import default_commands

PE0, PF0 = default_commands()


def _compiler():
    from mkctl.native.build import find_compiler
    return find_compiler()


pytestmark = pytest.mark.skipif(_compiler() is None, reason="no C compiler: no native FMUs")


@pytest.fixture(scope="module")
def native(tmp_path_factory) -> dict[str, Path]:
    from mkctl.native.fmu import build_native
    built = build_native(tmp_path_factory.mktemp("native_me"))
    return {"knee": built["McKibbenKnee"], "actuator": built["McKibbenActuator"]}


def _signal(name_values: dict, at: float, stop: float):
    """An fmpy input signal: every input at its first value, each stepping to its second at time `at`."""
    names = list(name_values)
    rows = [(0.0, *[v[0] for v in name_values.values()]), (at, *[v[0] for v in name_values.values()]),
            (at, *[v[1] for v in name_values.values()]), (stop, *[v[1] for v in name_values.values()])]
    return np.array(rows, dtype=[("time", float)] + [(n, float) for n in names])


def _me_and_cs(path, signal, start, stop, output=None, rtol=1e-10):
    """The same run through Model Exchange (fmpy's CVode) and Co-Simulation; the Model Exchange rows at the
    Co-Simulation's sample times (the first row at a time, as Co-Simulation records it before an input event)."""
    from fmpy import simulate_fmu
    cs = simulate_fmu(str(path), stop_time=stop, output_interval=1e-3, input=signal, start_values=dict(start),
                      output=output)
    me = simulate_fmu(str(path), fmi_type="ModelExchange", stop_time=stop, output_interval=1e-3, input=signal,
                      start_values=dict(start), relative_tolerance=rtol, output=output)
    assert me["time"][-1] == pytest.approx(stop) and cs["time"][-1] == pytest.approx(stop)
    rows = [int(np.flatnonzero(np.abs(me["time"] - t) < 1e-12)[0]) for t in cs["time"]]
    return me, me[rows], cs


# --- the modelDescription -------------------------------------------------------------------------------------------

@pytest.mark.parametrize("model, states", [("knee", ["X", "V", "Pe_lag", "Pf_lag"]), ("actuator", ["P_lag"])])
def test_both_interfaces_in_one_fmu_and_the_states_declared(native, model, states):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu
    path = native[model]
    assert validate_fmu(str(path)) == []
    md = read_model_description(str(path))
    assert md.modelExchange is not None and md.coSimulation is not None
    assert md.modelExchange.modelIdentifier == md.coSimulation.modelIdentifier
    assert md.numberOfContinuousStates == len(states)
    assert [d.variable.derivative.name for d in md.derivatives] == states
    assert [d.variable.name for d in md.derivatives] == [f"der({s})" for s in states]
    if model == "knee":  # the stops: where the contact and its damper switch, at least
        assert md.numberOfEventIndicators >= 4
    with zipfile.ZipFile(path) as fmu:
        text = fmu.read("modelDescription.xml").decode()
    for element in ("<ModelExchange", "<CoSimulation"):
        block = text.split(element)[1].split("</")[0]
        assert "knee_me.c" in block or "actuator_me.c" in block  # both list the sources


# --- derivatives and event indicators, call by call ----------------------------------------------------------------

class Model:
    """One Model Exchange instance of a native FMU, initialized with the given start values."""

    def __init__(self, path: Path, tmp_path: Path, **start):
        from fmpy import read_model_description
        from fmpy.fmi2 import FMU2Model
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        types = {v.name: v.type for v in self.md.modelVariables}
        folder = tmp_path / path.stem
        with zipfile.ZipFile(path) as fmu:
            fmu.extractall(folder)
        self.nx, self.nz = self.md.numberOfContinuousStates, self.md.numberOfEventIndicators
        self.fmu = FMU2Model(guid=self.md.guid, unzipDirectory=str(folder),
                             modelIdentifier=self.md.modelExchange.modelIdentifier, instanceName="me")
        self.fmu.instantiate()
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for name, value in start.items():
            if types[name] == "Integer":
                self.fmu.setInteger([self.vr[name]], [int(value)])
            else:
                self.fmu.setReal([self.vr[name]], [value])
        self.fmu.exitInitializationMode()
        self.fmu.newDiscreteStates()
        self.fmu.enterContinuousTimeMode()

    def set_states(self, x):
        self.fmu.setContinuousStates((ctypes.c_double * self.nx)(*x), self.nx)

    def derivatives(self, x):
        self.set_states(x)
        dx = (ctypes.c_double * self.nx)()
        self.fmu.getDerivatives(dx, self.nx)
        return list(dx)

    def indicators(self, x):
        self.set_states(x)
        z = (ctypes.c_double * self.nz)()
        self.fmu.getEventIndicators(z, self.nz)
        return np.array(z)

    def free(self):
        self.fmu.terminate()
        self.fmu.freeInstance()


def test_knee_derivatives_are_the_librarys_right_hand_side(native, tmp_path):
    values = dict(c=40.0, tau=0.02, Fc=2.0, slack=1, pe_cmd=2.2e6, pf_cmd=3e5)
    params = Params(c=40.0, tau=0.02, Fc=2.0, slack=1)
    stops = knee.stop_positions(params)
    model = Model(native["knee"], tmp_path, **values)
    try:
        for X, V, Pe, Pf in [(0.85, 0.1, 1.8e6, 1e5), (stops[1] + 2e-4, 0.05, 2.5e6, 2e5),  # in contact above
                             (stops[0] - 1e-4, -0.2, 1e5, 2e6), (0.75, -0.3, 5e5, 4e5)]:
            got = model.derivatives([X, V, Pe, Pf])
            want = knee.knee_derivatives((X, V, Pe, Pf), values["pe_cmd"], values["pf_cmd"], params, stops)
            np.testing.assert_allclose(got, want, rtol=1e-12, atol=1e-12)
    finally:
        model.free()


def test_without_a_lag_the_lag_states_stay_and_the_pressures_are_the_commands(native, tmp_path):
    model = Model(native["knee"], tmp_path, c=40.0, pe_cmd=2e6, pf_cmd=1e5)
    try:
        dx = model.derivatives([0.84, 0.1, 7.0, 8.0])
        want = knee.knee_derivatives((0.84, 0.1), 2e6, 1e5, Params(c=40.0), knee.stop_positions(Params(c=40.0)))
        np.testing.assert_allclose(dx[:2], want, rtol=1e-12)
        assert dx[2:] == [0.0, 0.0]
        assert model.fmu.getReal([model.vr["Pe"], model.vr["Pf"]]) == [2e6, 1e5]
    finally:
        model.free()


def test_event_indicators_change_sign_at_the_end_stops(native, tmp_path):
    """At V = 0 crossing a stop flips two indicators: the contact (X against the stop) and its damper's
    (k (X - stop) + d V); nothing else switches there."""
    params = Params(c=40.0, tau=0.02)
    low, high = knee.stop_positions(params)
    model = Model(native["knee"], tmp_path, c=40.0, tau=0.02)
    try:
        for stop in (low, high):
            below = model.indicators([stop - 1e-7, 0.0, PE0, PF0])
            above = model.indicators([stop + 1e-7, 0.0, PE0, PF0])
            assert np.isfinite(below).all() and np.isfinite(above).all()
            assert int(np.sum(np.sign(below) != np.sign(above))) == 2, (below, above)
    finally:
        model.free()


# --- whole runs through fmpy's CVode ----------------------------------------------------------------------------

def test_knee_step_onto_the_stop_agrees_with_co_simulation(native):
    """The knee step with damping, lag and an end-stop contact: the extensor command steps at 0.1 s to 3 MPa,
    which drives the leg onto the upper stop."""
    start = {"c": 40.0, "tau": 0.02}
    signal = _signal({"pe_cmd": (PE0, 3e6), "pf_cmd": (PF0, PF0)}, 0.1, 0.6)
    me_all, me, cs = _me_and_cs(native["knee"], signal, start, 0.6)
    high = knee.stop_positions(Params(**start))[1]
    assert cs["X"].max() > high + 5e-4  # onto the stop, in contact
    for name in cs.dtype.names[1:]:
        ref, got = cs[name].astype(float), me[name].astype(float)
        assert np.abs(got - ref).max() <= 1e-6 * max(1.0, np.abs(ref).max()), name
    # an event indicator located the contact: CVode stopped where X reaches the stop
    extra = np.setdiff1d(np.round(me_all["time"], 12), np.round(cs["time"], 12))
    at_events = me_all[np.isin(np.round(me_all["time"], 12), extra)]
    assert len(at_events) and np.abs(at_events["X"] - high).min() < 1e-9


def test_knee_step_without_a_lag_agrees_and_the_lag_states_stay(native):
    start = {"c": 40.0, "slack": 1, "Fc": 2.0}
    signal = _signal({"pe_cmd": (PE0, 3e6), "pf_cmd": (PF0, PF0)}, 0.1, 0.5)
    output = ["X", "V", "fe", "ff", "a2", "Pe", "Pe_lag", "der(Pe_lag)"]
    _, me, cs = _me_and_cs(native["knee"], signal, start, 0.5, output=output)
    for name in ("X", "V", "fe", "ff", "a2", "Pe"):
        ref, got = cs[name].astype(float), me[name].astype(float)
        assert np.abs(got - ref).max() <= 1e-6 * max(1.0, np.abs(ref).max()), name
    assert set(me["der(Pe_lag)"]) == {0.0} and len(set(me["Pe_lag"])) == 1


def test_actuator_lag_through_cvode_agrees_with_the_exact_lag(native):
    start = {"tau": 0.05, "c": 10.0}
    signal = _signal({"p_cmd": (1e5, 4e5), "L": (0.18, 0.18), "Ldot": (0.0, 0.01)}, 0.1, 0.4)
    _, me, cs = _me_and_cs(native["actuator"], signal, start, 0.4)
    assert np.ptp(cs["P"]) > 2e5
    for name in ("P", "f"):
        ref, got = cs[name].astype(float), me[name].astype(float)
        assert np.abs(got - ref).max() <= 1e-6 * max(1.0, np.abs(ref).max()), name


# --- refusals --------------------------------------------------------------------------------------------------

def test_a_negative_pressure_ends_a_model_exchange_run_with_the_message(native, capfd):
    from fmpy import simulate_fmu
    signal = _signal({"pe_cmd": (PE0, -1e5), "pf_cmd": (PF0, PF0)}, 0.1, 0.5)
    result = simulate_fmu(str(native["knee"]), fmi_type="ModelExchange", stop_time=0.5, output_interval=1e-3,
                          input=signal, start_values={"c": 40.0})
    assert result["time"][-1] == pytest.approx(0.1)
    assert all(np.isfinite(result[n].astype(float)).all() for n in result.dtype.names)
    shown = capfd.readouterr().out
    assert shown.count("fmi2NewDiscreteStates at t = 0.1 s: input pe_cmd = -100000.0 Pa is below 0") == 1


def test_a_parameter_model_exchange_cannot_represent_is_refused_at_initialization(tmp_path, monkeypatch):
    """The mechanism of model-spec section 7c (a parameter Model Exchange cannot represent; none today, the dead
    time runs), shown on a parameter the FMU has: Model Exchange refuses it when not 0, with the reason;
    Co-Simulation runs it."""
    from fmpy.fmi1 import FMICallException
    from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, defaultCallbacks
    from mkctl.native import fmu as native_fmu
    monkeypatch.setattr(native_fmu, "ME_REFUSED_PARAMETERS", {"c": "a test of the refusal"})
    path = native_fmu.build_one("McKibbenKnee", tmp_path / "McKibbenKnee.fmu")
    messages = []
    logger = fmi2CallbackLoggerTYPE(lambda env, name, status, category, message: messages.append(message.decode()))
    callbacks = fmi2CallbackFunctions(logger=logger, allocateMemory=defaultCallbacks.allocateMemory,
                                      freeMemory=defaultCallbacks.freeMemory)
    from fmpy import read_model_description
    from fmpy.fmi2 import FMU2Model
    md = read_model_description(str(path))
    with zipfile.ZipFile(path) as fmu:
        fmu.extractall(tmp_path / path.stem)
    vr = {v.name: v.valueReference for v in md.modelVariables}
    for kind, cls in (("me", FMU2Model), ("cs", FMU2Slave)):
        fmu = cls(guid=md.guid, unzipDirectory=str(tmp_path / path.stem), modelIdentifier="McKibbenKnee",
                  instanceName=kind)
        fmu.instantiate(callbacks=callbacks)
        fmu.setupExperiment(startTime=0.0)
        fmu.enterInitializationMode()
        fmu.setReal([vr["c"]], [40.0])
        if kind == "me":
            with pytest.raises(FMICallException):
                fmu.exitInitializationMode()
            assert messages[-1] == ("Model Exchange cannot run c = 40.0 N.s/m: a test of the refusal")
        else:
            fmu.exitInitializationMode()  # Co-Simulation runs it
            fmu.doStep(0.0, 1e-3)
        fmu.freeInstance()
