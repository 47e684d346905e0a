"""The native FMUs (model-spec section 7b): built by mkctl.native.fmu, checked against the pythonfmu FMUs.

- same interface: every variable's name, value reference, type, causality, variability, unit, description and
  start value, the units, the default experiment, as read from both modelDescription.xml files (Model Exchange's
  local variables follow the slave's: tests/test_native_me.py);
- same results: both FMUs driven by fmpy with the same inputs, each in a fresh process, agree to 1e-9 (relative
  to the output's range) on every output: a pressure step with c, tau and Fc, runs onto both end stops, the
  actuator under changing inputs;
- the parameter checks are Params' own: for every parameter and several bad values, the native FMU refuses at
  exitInitializationMode (fmi2Error, a logged message) exactly when Params raises, with the same message;
- FMU state: a replay from a saved (and a serialized) state and after fmi2Reset is identical;
- a NaN input is refused with fmi2Discard and a message, the state kept, and the run carries on;
- the C host of fmu/fmi2_host.c runs the native knee with an empty environment; libcosimpy runs it too.
"""
from __future__ import annotations

import ctypes
import json
import math
import shutil
import subprocess
import zipfile
from pathlib import Path

import numpy as np
import pytest

from hosts import LIBCOSIM_KNEE_STEP
from mkctl.physics import knee
from mkctl.physics.params import DEFAULT, Params
from mkctl.physics.simulate import default_commands

ROOT = Path(__file__).resolve().parents[1]
PE0, PF0 = default_commands()

def _compiler():
    from mkctl.native.build import find_compiler
    return find_compiler()


pytestmark = pytest.mark.skipif(_compiler() is None, reason="no C compiler: no native FMUs")


@pytest.fixture(scope="session")
def native_fmus(tmp_path_factory) -> dict[str, Path]:
    from mkctl.native.fmu import build_native
    built = build_native(tmp_path_factory.mktemp("native"))
    return {"knee": built["McKibbenKnee"], "actuator": built["McKibbenActuator"]}


# --- interface ----------------------------------------------------------------------------------------------------

def _describe(path: Path) -> dict:
    from fmpy import read_model_description
    md = read_model_description(str(path))
    variables = [(v.name, v.valueReference, v.type, v.causality, v.variability, v.description,
                  getattr(v, "unit", None), None if v.start is None else float(v.start))
                 for v in md.modelVariables]
    units = {u.name: (u.baseUnit.kg, u.baseUnit.m, u.baseUnit.s, u.baseUnit.rad) if u.baseUnit else None
             for u in md.unitDefinitions}
    experiment = md.defaultExperiment
    return {"name": md.modelName, "variables": variables, "units": units,
            "experiment": (experiment.startTime, experiment.stopTime, experiment.stepSize),
            "outputs": [u.variable.name for u in md.outputs],
            "initial": [u.variable.name for u in md.initialUnknowns]}


@pytest.mark.parametrize("model", ["knee", "actuator"])
def test_native_fmu_shows_the_pythonfmu_fmus_interface_and_validates(native_fmus, built_fmus, model):
    from fmpy.validation import validate_fmu
    assert validate_fmu(str(native_fmus[model])) == []
    native, python = _describe(native_fmus[model]), _describe(built_fmus[model])
    # the slave's variables come first, unchanged; Model Exchange adds local variables after them (see
    # tests/test_native_me.py): its lag states and a der(...) of every state, and their units
    slave_count = len(python["variables"])
    added = native["variables"][slave_count:]
    assert added and all(v[3] == "local" and v[7] is None for v in added)
    assert native.pop("initial") == python.pop("initial") + [v[0] for v in added]
    added_units = {v[6] for v in added} - {v[6] for v in python["variables"]}
    assert set(native["units"]) == set(python["units"]) | added_units
    native["units"] = {name: value for name, value in native["units"].items() if name not in added_units}
    # pythonfmu writes start values with 16 digits, the native FMU with all 17 (exact): compare them apart
    native_variables, python_variables = native.pop("variables")[:slave_count], python.pop("variables")
    assert len(native_variables) == len(python_variables)
    for name, a, b in zip([v[0] for v in python_variables], native_variables, python_variables):
        assert a[:-1] == b[:-1], name
        assert (a[-1] is None and b[-1] is None) or a[-1] == pytest.approx(b[-1], rel=1e-15, abs=0), name
    assert native == python
    with zipfile.ZipFile(native_fmus[model]) as fmu:
        names = fmu.namelist()
        description = fmu.read("modelDescription.xml").decode()
    assert f"binaries/linux64/{python['name']}.so" in names
    listed = [line.split('"')[1] for line in description.splitlines() if "<File " in line]
    assert listed and all(f"sources/{name}" in names for name in listed)
    assert 'needsExecutionTool="false"' in description


def test_build_native_takes_its_start_values_from_params(tmp_path):
    from fmpy import read_model_description
    from mkctl.native.fmu import build_native
    from mkctl.physics.simulate import default_hip_height
    params = Params(m=2.5, c=40.0, b=0.25, model=1)
    built = build_native(tmp_path, params)
    starts = {v.name: v.start for v in read_model_description(str(built["McKibbenKnee"])).modelVariables}
    assert float(starts["m"]) == 2.5 and float(starts["c"]) == 40.0 and int(starts["model"]) == 1
    assert float(starts["n"]) == params.n != DEFAULT.n
    assert float(starts["X0"]) == default_hip_height(params)
    assert float(starts["pe_cmd"]) == default_commands(params)[0]
    starts = {v.name: v.start for v in read_model_description(str(built["McKibbenActuator"])).modelVariables}
    assert float(starts["b"]) == 0.25 and int(starts["model"]) == 1


# --- same results as the pythonfmu FMUs --------------------------------------------------------------------------

SIMULATE = r"""
import json, sys
import numpy as np
from fmpy import simulate_fmu
fmu, cases = sys.argv[1], json.loads(sys.argv[2])
out = []
for case in cases:
    names = list(case["signal"][0][1])
    signal = np.array([(t, *[row[n] for n in names]) for t, row in case["signal"]],
                      dtype=[("time", float)] + [(n, float) for n in names])
    result = simulate_fmu(fmu, stop_time=case["stop"], output_interval=case["dt"], input=signal,
                          start_values=case["start"])
    out.append({name: result[name].astype(float).tolist() for name in result.dtype.names})
print(json.dumps(out))
"""


def _steps(times, rows):
    """An fmpy input signal (time, {name: value}) with steps at the given times."""
    signal = []
    for k, (t, row) in enumerate(zip(times, rows)):
        if k > 0:
            signal.append((t, rows[k - 1]))
        signal.append((t, row))
    return signal


KNEE_CASES = {
    "pressure step, c, tau, Fc": {
        "stop": 0.6, "dt": 1e-3, "start": {"c": 40.0, "tau": 0.02, "Fc": 2.0},
        "signal": _steps([0.0, 0.1, 0.6], [{"pe_cmd": PE0, "pf_cmd": PF0}, {"pe_cmd": PE0 * 1.05, "pf_cmd": PF0},
                                           {"pe_cmd": PE0 * 1.05, "pf_cmd": PF0}])},
    "saturated onto the upper stop": {
        "stop": 0.5, "dt": 1e-3, "start": {"c": 40.0, "tau": 0.01},
        "signal": _steps([0.0, 0.5], [{"pe_cmd": 6e6, "pf_cmd": 0.0}, {"pe_cmd": 6e6, "pf_cmd": 0.0}])},
    "saturated onto the lower stop, model 1, Fc": {
        "stop": 0.5, "dt": 1e-3, "start": {"Fc": 5.0, "model": 1, "m": 5.0},
        "signal": _steps([0.0, 0.5], [{"pe_cmd": 0.0, "pf_cmd": 3e6}, {"pe_cmd": 0.0, "pf_cmd": 3e6}])},
}
ACTUATOR_CASES = {
    "lag, damping, friction under changing inputs": {
        "stop": 1.0, "dt": 1e-2, "start": {"tau": 0.05, "c": 10.0, "Fc": 3.0, "b": 0.25},
        "signal": _steps([0.0, 0.2, 0.5, 0.7, 1.0],
                         [{"p_cmd": 1e5, "L": 0.18, "Ldot": 0.0}, {"p_cmd": 4e5, "L": 0.17, "Ldot": -0.02},
                          {"p_cmd": 2e5, "L": 0.19, "Ldot": 0.01}, {"p_cmd": 2e5, "L": 0.2, "Ldot": 1e-4},
                          {"p_cmd": 2e5, "L": 0.2, "Ldot": 1e-4}])},
    "model 1, no lag": {
        "stop": 0.3, "dt": 1e-2, "start": {"model": 1},
        "signal": _steps([0.0, 0.1, 0.3], [{"p_cmd": 3e5, "L": 0.15, "Ldot": 0.0}, {"p_cmd": 5e5, "L": 0.2, "Ldot": 0.0},
                                           {"p_cmd": 5e5, "L": 0.2, "Ldot": 0.0}])},
}


def _compare(native_runs, python_runs, cases):
    for name, native, python in zip(cases, native_runs, python_runs):
        assert native["time"][-1] == pytest.approx(cases[name]["stop"]), name  # no refused step
        assert native.keys() == python.keys()
        for output in python:
            ref, got = np.array(python[output]), np.array(native[output])
            scale = max(1.0, np.abs(ref).max())
            assert np.abs(got - ref).max() <= 1e-9 * scale, f"{name}: output {output}"


@pytest.fixture(scope="module")
def knee_runs(native_fmus, built_fmus, run_python):
    cases = json.dumps(list(KNEE_CASES.values()))
    return run_python(SIMULATE, native_fmus["knee"], cases), run_python(SIMULATE, built_fmus["knee"], cases)


def test_native_knee_matches_the_pythonfmu_knee_on_every_output(knee_runs):
    native, python = knee_runs
    _compare(native, python, KNEE_CASES)
    step = np.array(python[0]["X"])
    assert np.ptp(step) > 1e-3  # the step moved the leg
    low, high = knee.stop_positions(Params(m=5.0, model=1))
    assert max(python[1]["X"]) > knee.stop_positions(Params(c=40.0, tau=0.01))[1]  # onto the upper stop
    assert min(python[2]["X"]) < low  # onto the lower stop


CONTACT_AT_5_MS = {
    "onto the upper stop at 5 ms steps": {
        "stop": 0.3, "dt": 5e-3, "start": {"c": 40.0, "tau": 0.01},
        "signal": _steps([0.0, 0.3], [{"pe_cmd": 6e6, "pf_cmd": 0.0}, {"pe_cmd": 6e6, "pf_cmd": 0.0}])}}


def test_at_an_end_stop_with_long_steps_the_fmus_agree_to_the_integrators_tolerance(native_fmus, built_fmus,
                                                                                   run_python):
    """The documented exception (docs/fmu.md, "Native FMUs"): striking a stop (a kink in the force) within a long
    communication step, the adaptive stepper's decisions can differ in the last bits, and the runs by ~1e-7."""
    cases = json.dumps(list(CONTACT_AT_5_MS.values()))
    native = run_python(SIMULATE, native_fmus["knee"], cases)[0]
    python = run_python(SIMULATE, built_fmus["knee"], cases)[0]
    assert native["time"][-1] == pytest.approx(0.3)
    assert max(python["X"]) > knee.stop_positions(Params(c=40.0, tau=0.01))[1]
    for output in ("X", "V", "alpha", "Le", "Lf", "fe", "ff", "F", "a1", "a2"):
        ref, got = np.array(python[output]), np.array(native[output])
        assert np.abs(got - ref).max() <= 1e-6 * max(1.0, np.abs(ref).max()), output


def test_native_actuator_matches_the_pythonfmu_actuator(native_fmus, built_fmus, run_python):
    cases = json.dumps(list(ACTUATOR_CASES.values()))
    native = run_python(SIMULATE, native_fmus["actuator"], cases)
    python = run_python(SIMULATE, built_fmus["actuator"], cases)
    _compare(native, python, ACTUATOR_CASES)
    assert np.ptp(python[0]["f"]) > 10  # the inputs moved the tension


# --- the native FMU in this process: fmpy's FMU2Slave with a logger that keeps the messages ------------------------

class Native:
    """One instance of a native FMU, driven call by call, with its log messages collected."""

    def __init__(self, path: Path, tmp_path: Path, name="test"):
        from fmpy import read_model_description
        from fmpy.fmi2 import FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE, defaultCallbacks
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        folder = tmp_path / f"{path.stem}_{name}"
        if not folder.exists():
            with zipfile.ZipFile(path) as fmu:
                fmu.extractall(folder)
        self.messages = []

        def logger(env, instance, status, category, message):
            self.messages.append((status, message.decode()))

        self._logger = fmi2CallbackLoggerTYPE(logger)
        self._callbacks = fmi2CallbackFunctions(logger=self._logger, allocateMemory=defaultCallbacks.allocateMemory,
                                                freeMemory=defaultCallbacks.freeMemory)
        self.fmu = FMU2Slave(guid=self.md.guid, unzipDirectory=str(folder),
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName=name)
        self.fmu.instantiate(callbacks=self._callbacks)

    def status(self, function, *args) -> int:
        """The fmi2Status of a call (fmpy raises for a status above fmi2Warning: its status is the answer)."""
        from fmpy.fmi1 import FMICallException
        try:
            return getattr(self.fmu, function)(self.fmu.component, *args)
        except FMICallException as error:
            return error.status

    def set(self, name, value) -> int:
        vr = (ctypes.c_uint * 1)(self.vr[name])
        if self.types[name] == "Integer":
            return self.status("fmi2SetInteger", vr, 1, (ctypes.c_int * 1)(int(value)))
        return self.status("fmi2SetReal", vr, 1, (ctypes.c_double * 1)(value))

    def initialize(self, **values) -> int:
        self.fmu.setupExperiment(startTime=0.0)
        self.fmu.enterInitializationMode()
        for name, value in values.items():
            assert self.set(name, value) == 0
        return self.status("fmi2ExitInitializationMode")

    def get(self, *names):
        return self.fmu.getReal([self.vr[n] for n in names])

    def step(self, t, dt) -> int:
        return self.status("fmi2DoStep", ctypes.c_double(t), ctypes.c_double(dt), 1)

    def free(self):
        self.fmu.fmi2FreeInstance(self.fmu.component)


def _params_verdict(values: dict) -> str | None:
    """What the pythonfmu slave does with these parameter values: the message of Params, or None if valid."""
    if "P_rated" in values:  # the slaves' own parameter, checked before Params
        rated = values.pop("P_rated")
        if not (math.isfinite(rated) and rated > 0):
            return f"invalid parameters: parameter P_rated must be a positive number, got {rated!r}"
    given = values
    values = {**{name: getattr(DEFAULT, name) for name in values}, **values}
    if values.get("n", DEFAULT.n) == DEFAULT.n and {"b", "L0", "D0"} & set(given):
        values["n"] = None  # n left at its start value while the geometry changes: derived
    try:
        Params(**values)
    except Exception as error:  # noqa: BLE001 - every ParameterError message is compared
        return f"invalid parameters: {error}"
    return None


BAD_VALUES = (0.0, -1.0, math.nan, math.inf)
CROSS_CASES = ({"L0": 0.25}, {"L0": 0.241}, {"t0": 0.0065}, {"model": 3}, {"model": 0}, {"n": -1.0}, {"n": 0.0},
               {"b": 0.2}, {"D0": 0.002})


@pytest.mark.parametrize("model", ["knee", "actuator"])
def test_parameter_checks_are_those_of_params_with_the_same_messages(native_fmus, tmp_path, model):
    fmu = Native(native_fmus[model], tmp_path)
    parameters = [v.name for v in fmu.md.modelVariables if v.causality == "parameter" and v.name != "X0"]
    cases = [{name: value} for name in parameters if fmu.types[name] == "Real" for value in BAD_VALUES]
    cases += list(CROSS_CASES) + ([{"slack": 2}, {"slack": -1}] if "slack" in fmu.vr else [])
    refused = 0
    try:
        for case in cases:
            fmu.status("fmi2Reset")
            fmu.messages.clear()
            status = fmu.initialize(**case)
            expected = _params_verdict(case)
            if expected is None:
                assert not any("invalid parameters" in m for _, m in fmu.messages), case
                continue
            refused += 1
            assert status == 3, case  # fmi2Error
            assert [m for s, m in fmu.messages if s == 3] == [expected], case
            assert fmu.step(0.0, 1e-3) == 3 and fmu.messages[-1][1] == f"doStep at t = 0 s refused: {expected}"
    finally:
        fmu.free()
    assert refused > len(parameters)  # most bad values are bad


def test_an_impossible_start_is_refused_with_the_librarys_message(native_fmus, tmp_path):
    fmu = Native(native_fmus["knee"], tmp_path)
    try:
        with pytest.raises(Exception) as error:
            knee.beta_from_X(0.95, DEFAULT)
        assert fmu.initialize(X0=0.95) == 3
        assert fmu.messages[-1][1] == f"invalid start X0 = 0.95 m: {error.value}"
        fmu.status("fmi2Reset")
        assert fmu.initialize(Lec=0.3) == 3  # an actuator length reaches b
        assert fmu.messages[-1][1].startswith("the start state is outside the model's domain: actuator length L = ")
    finally:
        fmu.free()


def test_a_nan_input_is_discarded_with_a_message_and_the_run_carries_on(native_fmus, tmp_path):
    fmu = Native(native_fmus["knee"], tmp_path)
    try:
        assert fmu.initialize(c=40.0, pe_cmd=PE0 * 1.05) == 0
        for k in range(50):
            assert fmu.step(k * 1e-3, 1e-3) == 0
        before = fmu.get("X", "V")
        pe = fmu.get("Pe")
        fmu.set("pe_cmd", math.nan)
        assert fmu.get("X", "V") == before and fmu.get("Pe") == pe  # not NaN: the last valid outputs, and why
        assert fmu.messages[-1][1].startswith("outputs that depend on the pressures are undefined: pressure is not "
                                              "a finite number")
        assert fmu.messages[-1][1].endswith("; the outputs keep their last valid values")
        assert fmu.step(0.05, 1e-3) == 2  # fmi2Discard
        assert fmu.messages[-1] == (2, "doStep at t = 0.05 s: input pe_cmd = nan Pa is not a finite number")
        fmu.set("pe_cmd", PE0 * 1.05)
        assert fmu.get("X", "V") == before  # the refused step changed nothing
        assert fmu.step(0.05, 1e-3) == 0 and fmu.get("X")[0] != before[0]
    finally:
        fmu.free()


def test_a_parameter_set_after_initialization_is_an_error_not_ignored(native_fmus, tmp_path):
    fmu = Native(native_fmus["knee"], tmp_path)
    try:
        assert fmu.initialize() == 0
        assert fmu.set("m", 5.0) == 3
        assert "m is a fixed parameter" in fmu.messages[-1][1]
        assert fmu.set("pe_cmd", PE0) == 0  # inputs can be set
        assert fmu.step(0.0, 1e-3) == 0
    finally:
        fmu.free()


def test_actuator_length_out_of_the_domain_is_discarded_and_the_state_kept(native_fmus, tmp_path):
    fmu = Native(native_fmus["actuator"], tmp_path)
    try:
        assert fmu.initialize(tau=0.1, p_cmd=1e5) == 0
        fmu.set("p_cmd", 3e5)
        assert fmu.step(0.0, 0.05) == 0
        P = fmu.get("P")[0]
        assert 1e5 < P < 3e5
        fmu.set("L", 0.3)
        assert fmu.step(0.05, 0.05) == 2
        assert "outside the model's domain 0 < L < b = 0.241 m" in fmu.messages[-1][1]
        fmu.set("L", 0.18)
        assert fmu.get("P")[0] == P
    finally:
        fmu.free()


def _run(fmu, t0, steps, dt=1e-3):
    X = []
    for k in range(steps):
        assert fmu.step(t0 + k * dt, dt) == 0
        X.append(tuple(fmu.get("X", "V", "Pe", "F")))
    return X


def test_fmu_state_and_reset_replay_identically(native_fmus, tmp_path):
    fmu = Native(native_fmus["knee"], tmp_path)
    start = dict(c=20.0, tau=0.02, Fc=1.0, pe_cmd=PE0 * 1.04)
    try:
        assert fmu.initialize(**start) == 0
        first = _run(fmu, 0.0, 100)
        state = fmu.fmu.getFMUstate()
        serialized = fmu.fmu.serializeFMUstate(state)
        rest = _run(fmu, 0.1, 100)
        fmu.fmu.setFMUstate(state)
        assert _run(fmu, 0.1, 100) == rest
        fmu.fmu.freeFMUstate(state)
        _run(fmu, 0.2, 10)
        restored = fmu.fmu.deSerializeFMUstate(serialized)
        fmu.fmu.setFMUstate(restored)
        assert _run(fmu, 0.1, 100) == rest
        fmu.fmu.freeFMUstate(restored)
        fmu.status("fmi2Reset")
        assert fmu.initialize(**start) == 0
        assert _run(fmu, 0.0, 100) == first
        assert len(set(first)) == 100  # it moved
    finally:
        fmu.free()


# --- hosts without Python --------------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def c_host(tmp_path_factory):
    from mkctl.native.fmu import fmi2_headers
    binary = tmp_path_factory.mktemp("c_host") / "fmi2_host"
    subprocess.run([*_compiler(), "-Wall", "-I", str(fmi2_headers()), "-o", str(binary), str(ROOT / "fmu" / "fmi2_host.c"),
                    "-ldl"], check=True, capture_output=True)
    return binary


def test_native_knee_runs_in_the_c_host_with_an_empty_environment(c_host, native_fmus, tmp_path):
    from fmpy import read_model_description
    from mkctl.physics.simulate import KneeSimulator, default_hip_height
    folder = tmp_path / "knee"
    with zipfile.ZipFile(native_fmus["knee"]) as fmu:
        fmu.extractall(folder)
    md = read_model_description(str(native_fmus["knee"]))
    vr = {v.name: v.valueReference for v in md.modelVariables}
    pe = PE0 * 1.05
    args = [str(c_host), str(folder), md.guid, "0.5", "0.001", str(vr["X"]), f"{vr['c']}=40", f"{vr['pe_cmd']}={pe!r}"]
    done = subprocess.run(args, capture_output=True, text=True, env={}, timeout=60)  # no Python, no preload
    assert done.returncode == 0, done.stderr[-3000:]
    time, X = np.loadtxt(done.stdout.splitlines()).T
    assert time[-1] == pytest.approx(0.5) and len(X) == 501
    sim = KneeSimulator(Params(c=40.0), default_hip_height(), pe, PF0)
    direct = [sim.state[0]] + [sim.step(1e-3, pe, PF0)[0] for _ in range(500)]
    assert np.ptp(direct) > 1e-3
    np.testing.assert_allclose(X, direct, rtol=0, atol=1e-9)
    needed = subprocess.run(["ldd", str(folder / "binaries" / "linux64" / "McKibbenKnee.so")], capture_output=True,
                            text=True).stdout
    assert "python" not in needed.lower()


def test_native_knee_runs_in_libcosimpy(native_fmus, run_python):
    pytest.importorskip("libcosimpy")
    from mkctl.physics.simulate import KneeSimulator, default_hip_height
    pe1 = PE0 * 1.05
    run = run_python(LIBCOSIM_KNEE_STEP, native_fmus["knee"], repr(pe1), "0.5")
    assert run["ok"] == [True, True] and len(run["X"]) == 500
    sim = KneeSimulator(Params(c=40.0), default_hip_height(), PE0, PF0)
    direct = [sim.step(1e-3, PE0 if k < 100 else pe1, PF0)[0] for k in range(500)]
    np.testing.assert_allclose(run["X"], direct, rtol=0, atol=1e-9)
    assert np.ptp(direct) > 1e-3


# --- the scenarios run either FMU ---------------------------------------------------------------------------------

@pytest.mark.parametrize("name", ["pressure_step", "isotonic_sweep"])
def test_a_scenario_gives_the_same_results_with_the_native_fmus(name, native_fmus, built_fmus, tmp_path):
    import csv
    import sys
    fmu_dir = built_fmus["knee"].parent
    (fmu_dir / "native").mkdir(exist_ok=True)
    for which in ("knee", "actuator"):
        shutil.copy2(native_fmus[which], fmu_dir / "native" / native_fmus[which].name)
    tables = []
    for native in (False, True):
        out = tmp_path / ("native" if native else "python")
        done = subprocess.run([sys.executable, str(ROOT / "scenarios" / f"{name}.py"), "--fmu-dir", str(fmu_dir),
                               "--out", str(out), *(["--native"] if native else [])],
                              capture_output=True, text=True, timeout=300)
        assert done.returncode == 0, done.stderr[-3000:]
        with open(out / f"{name}.csv") as handle:
            rows = list(csv.reader(handle))
        tables.append((rows[0], np.array([[float(x == "True") if x in ("True", "False") else float(x) for x in row]
                                          for row in rows[1:]])))
    (header, python), (native_header, native) = tables
    assert header == native_header and python.shape == native.shape and python.shape[0] > 100
    scale = np.maximum(1.0, np.abs(python).max(axis=0))
    assert (np.abs(native - python) <= 1e-9 * scale).all()


def test_a_pressure_above_p_rated_is_warned_once_per_excursion(native_fmus, tmp_path):
    fmu = Native(native_fmus["actuator"], tmp_path)
    if "P_rated" not in fmu.vr:
        fmu.free()
        pytest.skip("the slaves of this checkout have no P_rated")
    try:
        assert fmu.fmu.fmi2SetDebugLogging(fmu.fmu.component, 1, 0, None) == 0
        assert fmu.initialize(P_rated=5e5, p_cmd=1e5) == 0
        warnings = lambda: [m for s, m in fmu.messages if s == 1]  # noqa: E731
        for k, p in enumerate((6e5, 7e5, 4e5, 8e5)):  # above, still above, below, above again
            fmu.set("p_cmd", p)
            assert fmu.step(k * 0.1, 0.1) == 0
        assert warnings() == [
            "t = 0.1 s: muscle pressure P = 0.6 MPa exceeds the rated pressure P_rated = 0.5 MPa",
            "t = 0.4 s: muscle pressure P = 0.8 MPa exceeds the rated pressure P_rated = 0.5 MPa"]
        fmu.status("fmi2Reset")
        fmu.messages.clear()
        assert fmu.initialize(P_rated=-1.0) == 3
        assert fmu.messages[-1][1] == "invalid parameters: parameter P_rated must be a positive number, got -1.0"
    finally:
        fmu.free()
