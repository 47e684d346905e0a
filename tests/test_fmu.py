"""The FMUs against model-spec section 7 and against mkctl: interface, accuracy, end stops, errors, state.

Every FMU run happens in a fresh interpreter (``run_python``, see conftest.py) so that the FMU runs its packed
copy of mkctl; the references are computed here with mkctl directly.
"""
from __future__ import annotations

import json
import math

import numpy as np
import pytest
from fmpy import read_model_description
from fmpy.validation import validate_fmu

from mkctl.physics import knee
from mkctl.physics.params import DEFAULT, INTEGER_PARAMETERS, PARAMETER_NAMES, RATED_PRESSURE, Params
from mkctl.physics.simulate import KNEE_OUTPUTS, ActuatorSimulator, KneeSimulator, default_commands, default_hip_height

SPEC_PARAMETERS = ("b n L0 D0 C1 C2 t0 m L1 L2 L5 L6 Lo Lu Lec Lfc r g c Fc vs tau").split()
PE0, PF0 = default_commands()

# --- fmpy.simulate_fmu, several runs in one subprocess ---------------------------------------------------
SIMULATE = r"""
import json, sys
import numpy as np
from fmpy import simulate_fmu
fmu, runs = sys.argv[1], json.loads(sys.argv[2])
results = []
for run in runs:
    messages = []
    def logger(component, instance, status, category, message):
        messages.append([int(status), message.decode() if isinstance(message, bytes) else str(message)])
    signal = None
    if run.get("input"):
        names = run["input_names"]
        signal = np.array([tuple(row) for row in run["input"]], dtype=[("time", float)] + [(n, float) for n in names])
    try:
        result = simulate_fmu(fmu, stop_time=run["stop"], output_interval=run["dt"], input=signal,
                              start_values=run.get("start", {}), debug_logging=True, logger=logger)
    except Exception as error:  # fmpy raises when a call returns fmi2Error or fmi2Fatal
        results.append({"columns": None, "exception": str(error), "messages": messages})
        continue
    results.append({"columns": {name: result[name].astype(float).tolist() for name in result.dtype.names},
                    "exception": None, "messages": messages})
import mkctl
print(json.dumps({"results": results, "mkctl": mkctl.__file__}))
"""


def _step_input(pe0, pe1, pf, t_step, stop):
    """fmpy input rows: pe_cmd steps from pe0 to pe1 at t_step (a repeated time is a discontinuity)."""
    return [[0.0, pe0, pf], [t_step, pe0, pf], [t_step, pe1, pf], [stop, pe1, pf]]


def _direct(params, dt, stop, pe_of_t, pf_of_t, X0=None):
    """mkctl stepped the way fmpy drives the FMU: inputs applied at t_k, held over the step, outputs at t_k+1."""
    steps = int(round(stop / dt))
    times = np.arange(steps + 1) * dt
    pe, pf = pe_of_t(0.0), pf_of_t(0.0)
    sim = KneeSimulator(params, default_hip_height(params) if X0 is None else X0, pe, pf)
    rows = [sim.outputs(pe, pf)]
    for k in range(steps):
        pe, pf = pe_of_t(times[k]), pf_of_t(times[k])
        sim.step(dt, pe, pf)
        rows.append(sim.outputs(pe, pf))
    return times, {name: np.array([row[name] for row in rows], dtype=float) for name in KNEE_OUTPUTS}


def test_model_descriptions_follow_the_spec_and_validate(built_fmus):
    for path in built_fmus.values():
        assert validate_fmu(str(path)) == []
    md = read_model_description(str(built_fmus["knee"]))
    variables = {v.name: v for v in md.modelVariables}
    assert {n for n, v in variables.items() if v.causality == "input"} == {"pe_cmd", "pf_cmd"}
    from mkctl.physics import effects  # sections 2-4 include 4b's effects: every registered effect's parameters
    from mkctl.fmi.interface import FMU_INTEGER_PARAMETERS, carried  # but not yet the air's (4d, 7d)
    assert {n for n, v in variables.items() if v.causality == "parameter"} == \
        set(SPEC_PARAMETERS) | {q.name for e in effects.all_effects() if carried(e) for q in e.parameters
                                if not q.switch} | set(FMU_INTEGER_PARAMETERS) | {"X0", "P_rated"}
    assert set(INTEGER_PARAMETERS) - set(FMU_INTEGER_PARAMETERS) == {"valve_flow"}
    assert {n for n, v in variables.items() if v.causality == "output"} == set(KNEE_OUTPUTS)
    assert set(SPEC_PARAMETERS) <= set(PARAMETER_NAMES)
    units = {u.name for u in md.unitDefinitions}
    for name, v in variables.items():
        assert v.description, name
        if v.type == "Real":
            assert v.unit in units, name
    assert variables["Pe"].unit == "Pa" and variables["c"].unit == "N.s/m" and variables["g"].unit == "m/s2"
    assert variables["model"].type == "Integer" and int(variables["model"].start) == 2
    assert variables["P_rated"].unit == "Pa" and float(variables["P_rated"].start) == 0.6e6
    assert variables["stable"].type == "Boolean"
    # defaults: Table I and II, effects off, X0 at alpha = 60 deg, inputs holding the leg at rest
    for name in SPEC_PARAMETERS:
        assert float(variables[name].start) == pytest.approx(getattr(DEFAULT, name), rel=1e-15), name
    assert float(variables["X0"].start) == pytest.approx(default_hip_height(), rel=1e-15)
    assert float(variables["pe_cmd"].start) == pytest.approx(PE0, rel=1e-15)
    assert float(variables["pf_cmd"].start) == pytest.approx(PF0, rel=1e-15)
    assert md.coSimulation.canGetAndSetFMUstate and md.coSimulation.canSerializeFMUstate
    assert float(md.defaultExperiment.stopTime) > 0 and float(md.defaultExperiment.stepSize) > 0

    md = read_model_description(str(built_fmus["actuator"]))
    variables = {v.name: v for v in md.modelVariables}
    assert {n for n, v in variables.items() if v.causality == "input"} == {"p_cmd", "L", "Ldot"}
    assert {n for n, v in variables.items() if v.causality == "output"} == {"f", "P"}
    from mkctl.physics import effects  # section 4's effects: every registered effect's parameters, 4b's included
    assert {n for n, v in variables.items() if v.causality == "parameter"} == {
        "b", "n", "L0", "D0", "C1", "C2", "t0", "c", "Fc", "vs", "tau", "P_rated", *FMU_INTEGER_PARAMETERS,
        *(q.name for e in effects.all_effects() if carried(e) for q in e.parameters if not q.switch)}
    # the rated pressure: 0.6 MPa, the value documented in docs/fmu.md and mkctl.physics.params
    assert variables["P_rated"].unit == "Pa" and float(variables["P_rated"].start) == 0.6e6 == RATED_PRESSURE
    assert variables["f"].unit == "N" and variables["Ldot"].unit == "m/s"


@pytest.fixture(scope="module")
def knee_runs(built_fmus, run_python):
    """One subprocess, several runs of the knee FMU under fmpy."""
    stop = 1.0
    effects = {"c": 20.0, "Fc": 2.0, "tau": 0.05}
    runs = {
        "step_1ms": {"dt": 1e-3, "stop": stop, "start": {"c": 40.0}, "input_names": ["pe_cmd", "pf_cmd"],
                     "input": _step_input(PE0, PE0 * 1.05, PF0, 0.1, stop)},
        "step_20ms": {"dt": 20e-3, "stop": stop, "start": {"c": 40.0}, "input_names": ["pe_cmd", "pf_cmd"],
                      "input": _step_input(PE0, PE0 * 1.05, PF0, 0.1, stop)},
        "effects_1ms": {"dt": 1e-3, "stop": stop, "start": effects, "input_names": ["pe_cmd", "pf_cmd"],
                        "input": _step_input(PE0, PE0 * 0.95, PF0, 0.1, stop)},
        "effects_20ms": {"dt": 20e-3, "stop": stop, "start": effects, "input_names": ["pe_cmd", "pf_cmd"],
                         "input": _step_input(PE0, PE0 * 0.95, PF0, 0.1, stop)},
        "saturate_extensor": {"dt": 5e-3, "stop": 1.5, "start": {"c": 40.0}, "input_names": ["pe_cmd", "pf_cmd"],
                              "input": [[0.0, 6e6, 0.0], [1.5, 6e6, 0.0]]},
        "saturate_flexor": {"dt": 5e-3, "stop": 1.5, "start": {}, "input_names": ["pe_cmd", "pf_cmd"],
                            "input": [[0.0, 0.0, 3e6], [1.5, 0.0, 3e6]]},
        "slack_on": {"dt": 1e-3, "stop": 0.5, "start": {"c": 40.0, "slack": 1}, "input_names": ["pe_cmd", "pf_cmd"],
                     "input": [[0.0, PE0, 0.0], [0.5, PE0, 0.0]]},
        "slack_off": {"dt": 1e-3, "stop": 0.5, "start": {"c": 40.0}, "input_names": ["pe_cmd", "pf_cmd"],
                      "input": [[0.0, PE0, 0.0], [0.5, PE0, 0.0]]},
        "negative_mass": {"dt": 1e-3, "stop": 0.1, "start": {"m": -1.0}},
        "braid_too_short": {"dt": 1e-3, "stop": 0.1, "start": {"b": 0.2}},
        "actuator_reaches_b": {"dt": 1e-3, "stop": 0.1, "start": {"Lec": 0.3}},
        "leg_past_straight": {"dt": 1e-3, "stop": 0.1, "start": {"X0": 0.95}},
        "bad_model": {"dt": 1e-3, "stop": 0.1, "start": {"model": 3}},
        "nan_pressure": {"dt": 1e-3, "stop": 0.1, "input_names": ["pe_cmd", "pf_cmd"],
                         "input": [[0.0, PE0, PF0], [0.05, PE0, PF0], [0.05, math.nan, PF0], [0.1, math.nan, PF0]]},
    }
    out = run_python(SIMULATE, built_fmus["knee"], json.dumps(list(runs.values())))
    assert "resources" in out["mkctl"], "the FMU must run its packed mkctl"
    return {name: (result["columns"], result["messages"], result["exception"])
            for name, result in zip(runs, out["results"])}


def _pe_step(pe0, pe1, t_step):
    return lambda t: pe1 if t >= t_step - 1e-12 else pe0


@pytest.mark.parametrize("case, params, pe1", [("step", Params(c=40.0), PE0 * 1.05),
                                               ("effects", Params(c=20.0, Fc=2.0, tau=0.05), PE0 * 0.95)])
def test_knee_fmu_matches_mkctl_and_does_not_depend_on_the_communication_step(knee_runs, case, params, pe1):
    fine, _, _ = knee_runs[f"{case}_1ms"]
    coarse, _, _ = knee_runs[f"{case}_20ms"]
    assert fine["time"][-1] == pytest.approx(1.0, abs=1e-12) and coarse["time"][-1] == pytest.approx(1.0, abs=1e-12)
    times, ref = _direct(params, 1e-3, 1.0, _pe_step(PE0, pe1, 0.1), lambda t: PF0)
    np.testing.assert_allclose(fine["time"], times, atol=1e-12)
    for name in KNEE_OUTPUTS:
        np.testing.assert_allclose(fine[name], ref[name], rtol=1e-9, atol=1e-9, err_msg=name)
    assert np.ptp(fine["X"]) > 1e-3, "the step must move the leg"
    # the same run at 20 ms agrees within 1 micrometre at the shared sample times
    shared = np.searchsorted(np.round(fine["time"], 9), np.round(coarse["time"], 9))
    assert np.max(np.abs(np.array(fine["X"])[shared] - np.array(coarse["X"]))) < 1e-6


def test_knee_fmu_with_slack_matches_mkctl_with_slack(knee_runs):
    # with the flexor unpressurized, its model tension is negative (it would push): slack = 1 makes it 0
    on, messages, _ = knee_runs["slack_on"]
    off, _, _ = knee_runs["slack_off"]
    assert on["time"][-1] == pytest.approx(0.5), messages
    times, ref = _direct(Params(c=40.0, slack=1), 1e-3, 0.5, lambda t: PE0, lambda t: 0.0)
    for name in KNEE_OUTPUTS:
        np.testing.assert_allclose(on[name], ref[name], rtol=1e-9, atol=1e-9, err_msg=name)
    assert min(on["ff"]) == 0.0 and min(off["ff"]) < -0.5
    assert abs(on["X"][-1] - off["X"][-1]) > 1e-4, "slack must change the motion here"


def test_saturated_pressures_drive_the_knee_onto_its_end_stops(knee_runs):
    high_X = knee.stop_positions()[1]
    low_X = knee.stop_positions()[0]
    up, messages, _ = knee_runs["saturate_extensor"]
    assert up["time"][-1] == pytest.approx(1.5), messages
    assert np.degrees(up["alpha"][-1]) == pytest.approx(np.degrees(knee.ALPHA_STOP_HIGH), abs=0.5)
    assert up["X"][-1] == pytest.approx(high_X, abs=5e-4) and np.all(np.isfinite(up["X"]))
    down, messages, _ = knee_runs["saturate_flexor"]
    assert down["time"][-1] == pytest.approx(1.5), messages
    assert np.degrees(down["alpha"][-1]) == pytest.approx(np.degrees(knee.ALPHA_STOP_LOW), abs=0.5)
    assert min(down["X"]) > low_X - 0.01 and np.all(np.isfinite(down["X"]))


@pytest.mark.parametrize("case, expected", [
    ("negative_mass", "parameter m must be positive"),
    ("braid_too_short", "must be shorter than the braid"),
    ("actuator_reaches_b", "outside the model's domain 0 < L < b"),
    ("leg_past_straight", "invalid start X0 = 0.95 m"),
    ("bad_model", "parameter model must be 1 or 2"),
])
def test_bad_parameters_stop_the_run_at_initialization_with_a_logged_message(knee_runs, case, expected):
    columns, messages, exception = knee_runs[case]
    # fmi2Fatal (pythonfmu 0.7's only error status) from exitInitializationMode: fmpy raises before it records
    # any output, so no NaN row can reach a result
    assert columns is None and "fmi2ExitInitializationMode failed with status 4" in exception
    errors = [text for status, text in messages if status == 3]  # fmi2Error category
    assert any(expected in text for text in errors), messages


def test_a_nan_input_stops_the_run_where_it_came_with_finite_outputs(knee_runs):
    columns, messages, exception = knee_runs["nan_pressure"]
    assert exception is None
    assert columns["time"][-1] == pytest.approx(0.05), "the run must stop at the refused step, not carry on"
    errors = [text for status, text in messages if status == 3]
    assert any("input pe_cmd = nan Pa is not a finite number" in text for text in errors), messages
    for name, values in columns.items():  # the sample at the refused step keeps the last valid outputs
        assert np.all(np.isfinite(values)), name
    assert columns["Pe"][-1] == pytest.approx(PE0) and columns["X"][-1] == columns["X"][-2]


# --- low-level calls: statuses, FMU state, reset, the actuator ------------------------------------------
LOW_LEVEL = r"""
import json, sys
import numpy as np
from fmpy import read_model_description, extract
from fmpy.fmi1 import FMICallException
from ctypes import byref
from fmpy.fmi2 import (FMU2Slave, calloc, free, fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE,
                       fmi2CallbackFunctions, fmi2CallbackLoggerTYPE)
from fmpy.logging import addLoggerProxy

def open_fmu(path, name):
    md = read_model_description(path)
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(path), modelIdentifier=md.coSimulation.modelIdentifier,
                    instanceName=name)
    messages = []
    def logger(component, instance, status, category, message):
        messages.append([int(status), message.decode()])
    callbacks = fmi2CallbackFunctions()  # as fmpy.simulate_fmu builds them for a logger
    callbacks.logger = fmi2CallbackLoggerTYPE(logger)
    callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
    callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
    addLoggerProxy(byref(callbacks))
    fmu.instantiate(callbacks=callbacks, loggingOn=True)
    fmu.keep_alive = (callbacks, logger)
    return fmu, {v.name: v.valueReference for v in md.modelVariables}, messages

def init(fmu, vr, values):
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    for name, value in values.items():
        if name in ("model", "slack"):
            fmu.setInteger([vr[name]], [value])
        else:
            fmu.setReal([vr[name]], [value])
    fmu.exitInitializationMode()

def run(fmu, vr, t, steps, dt, inputs):
    X = []
    for k in range(steps):
        for name, value in inputs(t).items():
            fmu.setReal([vr[name]], [value])
        fmu.doStep(t, dt)
        t += dt
        X.append(fmu.getReal([vr["X"], vr["V"], vr["Pe"]]))
    return t, X

out = {}
knee, vr, messages = open_fmu(sys.argv[1], "knee")
pe0 = knee.getReal([vr["pe_cmd"]])[0]
setting = {"c": 30.0, "tau": 0.05, "Fc": 1.0, "slack": 1}
wave = lambda t: {"pe_cmd": pe0 * (1 + 0.05 * np.sin(7 * t)), "pf_cmd": 0.0}
init(knee, vr, setting)
t, first = run(knee, vr, 0.0, 100, 2e-3, wave)
state = knee.getFMUstate()
serialized = knee.serializeFMUstate(state)
t_saved = t
_, original = run(knee, vr, t, 150, 2e-3, wave)
knee.setFMUstate(state)
_, replay = run(knee, vr, t_saved, 150, 2e-3, wave)
knee.setFMUstate(knee.deSerializeFMUstate(serialized))
_, replay_serialized = run(knee, vr, t_saved, 150, 2e-3, wave)
knee.freeFMUstate(state)
knee.reset()
init(knee, vr, setting)
_, after_reset = run(knee, vr, 0.0, 100, 2e-3, wave)
knee.reset()  # back to the start values (slack = 0): the saved state must bring every setting back
init(knee, vr, {})
knee.setFMUstate(knee.deSerializeFMUstate(serialized))
_, replay_into_reset = run(knee, vr, t_saved, 150, 2e-3, wave)
out["knee"] = {"first": first, "original": original, "replay": replay, "replay_serialized": replay_serialized,
               "after_reset": after_reset, "replay_into_reset": replay_into_reset}

# a NaN input: doStep answers fmi2Discard, the host carries on, the state is kept, a finite input resumes
statuses = []
knee.setReal([vr["pe_cmd"]], [float("nan")])
try:
    knee.doStep(0.2, 1e-3)
    statuses.append(0)
except FMICallException as error:
    statuses.append(error.status)
X_after = knee.getReal([vr["X"]])[0]
knee.setReal([vr["pe_cmd"]], [pe0])
knee.doStep(0.2, 1e-3)
out["knee_nan"] = {"statuses": statuses, "X_after": X_after, "X_resumed": knee.getReal([vr["X"]])[0],
                   "messages": messages}
knee.terminate()
knee.freeInstance()

act, vr, messages = open_fmu(sys.argv[2], "actuator")
init(act, vr, {"tau": 0.1, "c": 50.0, "Fc": 2.0, "model": 2})
act.setReal([vr["p_cmd"], vr["L"], vr["Ldot"]], [300e3, 0.18, 0.0])  # start P(0) = 300 kPa
rows = []
t = 0.0
for k in range(40):
    L, Ldot = 0.18 + 0.01 * np.sin(3 * t), 0.03 * np.cos(3 * t)
    act.setReal([vr["p_cmd"], vr["L"], vr["Ldot"]], [500e3, L, Ldot])
    act.doStep(t, 0.01)
    t += 0.01
    rows.append([t, L, Ldot] + act.getReal([vr["f"], vr["P"]]))
statuses = []
for bad in ([500e3, 0.25, 0.0], [float("nan"), 0.18, 0.0]):
    act.setReal([vr["p_cmd"], vr["L"], vr["Ldot"]], bad)
    try:
        act.doStep(t, 0.01)
        statuses.append(0)
    except FMICallException as error:
        statuses.append(error.status)
out["actuator"] = {"rows": rows, "statuses": statuses, "messages": messages}
act.terminate()
act.freeInstance()
print(json.dumps(out))
"""


@pytest.fixture(scope="module")
def low_level(built_fmus, run_python):
    return run_python(LOW_LEVEL, built_fmus["knee"], built_fmus["actuator"])


def test_fmu_state_restores_everything_and_reset_returns_to_the_start(low_level):
    runs = low_level["knee"]
    assert np.ptp(np.array(runs["original"])[:, 0]) > 1e-4, "the replayed stretch must move"
    # the integrator's step and the pressure lag are part of the state: the replay is bit for bit the same
    np.testing.assert_array_equal(runs["replay"], runs["original"])
    np.testing.assert_array_equal(runs["replay_serialized"], runs["original"])
    np.testing.assert_array_equal(runs["after_reset"], runs["first"])
    np.testing.assert_array_equal(runs["replay_into_reset"], runs["original"])


def test_a_nan_input_is_discarded_and_the_host_carries_on(low_level):
    result = low_level["knee_nan"]
    assert result["statuses"] == [2]  # fmi2Discard
    assert math.isfinite(result["X_after"]) and math.isfinite(result["X_resumed"])
    assert any("input pe_cmd = nan Pa" in text for status, text in result["messages"] if status == 3)


def test_actuator_fmu_matches_mkctl(low_level):
    params = Params(tau=0.1, c=50.0, Fc=2.0)
    sim = ActuatorSimulator(params, 300e3)
    for t, L, Ldot, f, P in low_level["actuator"]["rows"]:
        sim.step(0.01, 500e3)
        assert P == pytest.approx(sim.pressure, rel=1e-12)
        assert f == pytest.approx(sim.outputs(500e3, L, Ldot)["f"], rel=1e-10, abs=1e-9)
    assert low_level["actuator"]["rows"][-1][4] == pytest.approx(500e3 - 200e3 * math.exp(-4.0), rel=1e-9)
    assert low_level["actuator"]["statuses"] == [2, 2]  # fmi2Discard for L >= b and for a NaN pressure
    texts = [text for status, text in low_level["actuator"]["messages"] if status == 3]
    assert any("actuator length L = 0.25 m is outside the model's domain" in text for text in texts), texts
    assert any("input p_cmd = nan Pa is not a finite number" in text for text in texts), texts


def test_fmpy_simulate_alone_runs_the_default_experiment(built_fmus, tmp_path):
    import subprocess
    import sys
    from pathlib import Path
    fmpy_cli = Path(sys.executable).parent / "fmpy"
    out = tmp_path / "default.csv"
    done = subprocess.run([str(fmpy_cli), "simulate", str(built_fmus["knee"]), "--output-file", str(out)],
                          capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr
    data = np.genfromtxt(out, delimiter=",", names=True)
    md = read_model_description(str(built_fmus["knee"]))
    assert data["time"][-1] == pytest.approx(float(md.defaultExperiment.stopTime))
    # the default run holds the leg at rest at alpha = 60 deg: the equilibrium of the default commands
    np.testing.assert_allclose(data["alpha"], np.radians(60.0), atol=1e-9)


def test_the_fmus_do_not_load_scipy_into_the_host(built_fmus, run_python):
    """A host that loads our FMUs gets numpy, not scipy (and its second OpenBLAS): the FMUs never need it."""
    code = (
        "import json, sys\n"
        "from fmpy import simulate_fmu\n"
        "for fmu in sys.argv[1:]:\n"
        "    simulate_fmu(fmu, stop_time=0.01, output_interval=1e-3)\n"
        "print(json.dumps(sorted(m for m in sys.modules if m.split('.')[0] == 'scipy')))\n"
    )
    assert run_python(code, built_fmus["knee"], built_fmus["actuator"]) == []


# --- what a user of the fmpy command line sees -----------------------------------------------------------
def _fmpy_cli(fmu, tmp_path, *args):
    """``python -m fmpy.cli simulate FMU ARGS`` in a fresh process, outside the repository."""
    import subprocess
    import sys
    return subprocess.run([sys.executable, "-m", "fmpy.cli", "simulate", str(fmu), *args], capture_output=True,
                          text=True, cwd=tmp_path, timeout=120)


@pytest.mark.parametrize("model, start, expected", [
    ("knee", ["m", "-1"], "invalid parameters: parameter m must be positive, got -1.0"),
    ("knee", ["model", "3"], "invalid parameters: parameter model must be 1 or 2, got 3"),
    ("knee", ["P_rated", "0"], "invalid parameters: parameter P_rated must be a positive number, got 0.0"),
    ("actuator", ["L", "0.25"], "actuator length L = 0.25 m is outside the model's domain 0 < L < b = 0.241 m"),
    ("actuator", ["b", "0.2"], "rest length L0 = 0.208 m must be shorter than the braid b = 0.2 m"),
])
def test_the_fmpy_command_line_names_a_bad_parameter_and_fails_without_writing_a_result(built_fmus, tmp_path,
                                                                                        model, start, expected):
    out = tmp_path / "result.csv"
    done = _fmpy_cli(built_fmus[model], tmp_path, "--start-values", *start, "--output-file", str(out))
    assert done.returncode != 0
    assert expected in done.stderr.splitlines()[0], done.stderr  # the first line, before fmpy's traceback
    assert not out.exists()


def test_the_fmpy_command_line_names_a_bad_input_and_writes_no_nan(built_fmus, tmp_path):
    signal = tmp_path / "input.csv"  # L reaches the braid length b = 0.241 m at t = 0.5 s
    signal.write_text('"time","L"\n0,0.18\n0.5,0.18\n0.5,0.25\n1.0,0.25\n')
    out = tmp_path / "result.csv"
    done = _fmpy_cli(built_fmus["actuator"], tmp_path, "--input-file", str(signal), "--output-file", str(out))
    assert "actuator length L = 0.25 m is outside the model's domain" in done.stderr, done.stderr
    data = np.genfromtxt(out, delimiter=",", names=True)
    assert data["time"][-1] == pytest.approx(0.5), "the run stops at the refused step"
    assert np.all(np.isfinite(data["f"])) and np.all(np.isfinite(data["P"]))


# --- the rated pressure -----------------------------------------------------------------------------------
RATED = r"""
import json, sys
import numpy as np
from fmpy import simulate_fmu
fmu, rows, start = sys.argv[1], json.loads(sys.argv[2]), json.loads(sys.argv[3])
messages = []
def logger(component, instance, status, category, message):
    messages.append([int(status), message.decode()])
signal = None
if rows:
    signal = np.array([tuple(r) for r in rows], dtype=[("time", float), ("p_cmd", float)])
result = simulate_fmu(fmu, stop_time=float(sys.argv[4]), output_interval=0.01, input=signal, start_values=start,
                      debug_logging=True, logger=logger)
print(json.dumps({"end": float(result["time"][-1]), "messages": messages}))
"""


def _rated_run(fmu, tmp_path, rows, start, stop):
    import json
    import subprocess
    import sys
    done = subprocess.run([sys.executable, "-c", RATED, str(fmu), json.dumps(rows), json.dumps(start), str(stop)],
                          capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr
    out = json.loads(done.stdout.splitlines()[-1])
    warnings = [text for status, text in out["messages"] if status == 1 and "rated pressure" in text]
    on_stderr = [line for line in done.stderr.splitlines() if "rated pressure" in line]
    return out["end"], warnings, on_stderr


def test_the_actuator_warns_once_per_excursion_above_the_rated_pressure(built_fmus, tmp_path):
    # 0.3 MPa, then above 0.6 MPa from 0.2 s to 0.4 s (two samples), back below, then above again from 0.7 s
    rows = [[0.0, 3e5], [0.2, 3e5], [0.2, 7e5], [0.4, 6.5e5], [0.4, 3e5], [0.7, 3e5], [0.7, 8e5], [1.0, 8e5]]
    end, warnings, on_stderr = _rated_run(built_fmus["actuator"], tmp_path, rows, {}, 1.0)
    assert end == pytest.approx(1.0)
    assert len(warnings) == 2 and len(on_stderr) == 2, warnings
    assert "muscle pressure P = 0.7 MPa exceeds the rated pressure P_rated = 0.6 MPa" in warnings[0]
    assert "muscle pressure P = 0.8 MPa exceeds" in warnings[1] and "t = 0.71 s" in warnings[1]
    # a muscle rated higher: no warning
    _, warnings, on_stderr = _rated_run(built_fmus["actuator"], tmp_path, rows, {"P_rated": 1e6}, 1.0)
    assert warnings == [] and on_stderr == []


def test_the_knee_defaults_run_with_one_warning_for_the_extensor(built_fmus, tmp_path):
    end, warnings, on_stderr = _rated_run(built_fmus["knee"], tmp_path, [], {}, 0.2)
    assert end == pytest.approx(0.2)
    # Table II's 10 kg needs ~1.69 MPa in the extensor at alpha = 60 deg; the flexor holds 0.1 MPa
    assert len(warnings) == 1 and len(on_stderr) == 1, warnings
    assert f"extensor pressure Pe = {PE0 / 1e6:.4g} MPa exceeds the rated pressure P_rated = 0.6 MPa" in warnings[0]


# --- memory and handles -------------------------------------------------------------------------------------
CYCLES = r"""
import json, os, sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
fmu_path, cycles = sys.argv[1], int(sys.argv[2])
md = read_model_description(fmu_path)
fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(fmu_path), modelIdentifier=md.coSimulation.modelIdentifier,
                instanceName="cycle")
vr = {v.name: v.valueReference for v in md.modelVariables}

def usage():
    status = dict(line.split(":", 1) for line in open("/proc/self/status"))
    return {"rss_kB": int(status["VmRSS"].split()[0]), "threads": int(status["Threads"]),
            "fds": len(os.listdir("/proc/self/fd"))}

def cycle():
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    fmu.setReal([vr["c"]], [40.0])
    fmu.exitInitializationMode()
    for k in range(5):
        fmu.doStep(k * 1e-3, 1e-3)
    x = fmu.getReal([vr["X"]])[0]
    state = fmu.getFMUstate()
    fmu.freeFMUstate(state)
    fmu.terminate()
    fmu.fmi2FreeInstance(fmu.component)
    return x

for _ in range(100):  # warm-up: imports, caches and the allocator's arenas reach their size
    cycle()
before = usage()
values = {cycle() for _ in range(cycles)}
after = usage()
print(json.dumps({"before": before, "after": after, "distinct": len(values)}))
"""


def test_1000_instantiate_free_cycles_in_one_process_keep_memory_and_handles_flat(built_fmus, run_python):
    out = run_python(CYCLES, built_fmus["knee"], 1000, timeout=600)
    before, after = out["before"], out["after"]
    assert out["distinct"] == 1, "every cycle is the same run"
    assert after["fds"] == before["fds"] and after["threads"] == before["threads"], out
    # pythonfmu 0.7 itself keeps 1-3 kB per instance (docs/fmu.md, "Memory"); the FMUs as first built kept
    # 11-36 kB (the whole slave class per instance): 4 MB over 1000 cycles tells them apart
    assert after["rss_kB"] - before["rss_kB"] < 4096, out


# --- a user's muscle: build_fmu.py --params ----------------------------------------------------------------
def test_build_fmu_with_a_muscle_file_makes_fmus_whose_defaults_are_that_muscle(tmp_path, run_python):
    import subprocess
    import sys
    from pathlib import Path

    from mkctl.io.muscle import write_muscle

    root = Path(__file__).resolve().parents[1]
    muscle = Params(b=0.25, n=3.1, L0=0.2, D0=0.012, C1=1.5e5, m=3.0, c=20.0, slack=1)
    path = write_muscle(tmp_path / "muscle.json", muscle)
    out = tmp_path / "fmus"
    done = subprocess.run([sys.executable, str(root / "build_fmu.py"), "--out", str(out), "--no-run", "--params",
                           str(path)], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    knee_fmu = out / "McKibbenKnee.fmu"
    variables = {v.name: v for v in read_model_description(str(knee_fmu)).modelVariables}
    for name in SPEC_PARAMETERS:
        assert float(variables[name].start) == pytest.approx(getattr(muscle, name), rel=1e-15), name
    assert int(variables["slack"].start) == 1 and int(variables["model"].start) == 2
    pe0, pf0 = default_commands(muscle)
    assert float(variables["pe_cmd"].start) == pytest.approx(pe0, rel=1e-15)
    assert float(variables["X0"].start) == pytest.approx(default_hip_height(muscle), rel=1e-15)
    actuator = {v.name: v for v in read_model_description(str(out / "McKibbenActuator.fmu")).modelVariables}
    assert float(actuator["n"].start) == 3.1 and int(actuator["slack"].start) == 1

    # the FMU's run with its defaults (and a 5 % step) is the library's run of that muscle: n = 3.1 as given,
    # not derived from b, L0, D0
    run = json.dumps([{"dt": 1e-3, "stop": 0.3, "input_names": ["pe_cmd", "pf_cmd"],
                       "input": _step_input(pe0, pe0 * 1.05, pf0, 0.1, 0.3)}])
    columns = run_python(SIMULATE, knee_fmu, run)["results"][0]["columns"]
    times, ref = _direct(muscle, 1e-3, 0.3, _pe_step(pe0, pe0 * 1.05, 0.1), lambda t: pf0)
    assert np.ptp(ref["X"]) > 1e-4
    for name in KNEE_OUTPUTS:
        np.testing.assert_allclose(columns[name], ref[name], rtol=1e-9, atol=1e-9, err_msg=name)

    bad = tmp_path / "bad.json"
    bad.write_text('{"params": {"braid": 0.25}}')
    done = subprocess.run([sys.executable, str(root / "build_fmu.py"), "--out", str(tmp_path / "no"), "--no-run",
                           "--params", str(bad)], capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 2 and len(done.stderr.strip().splitlines()) == 1
    assert "unknown parameter 'braid'" in done.stderr and not (tmp_path / "no").exists()
