"""The FMI 3.0 twins of the native FMUs (model-spec section 7c), checked against the FMI 2.0 native FMUs.

- fmpy's validation is clean for both FMI 3.0 FMUs (and the FMI 2.0 native ones they are compared with);
- same interface: every variable's name, value reference, causality, variability, unit, description and start
  value (Real -> Float64, Integer -> Int32, Boolean -> Boolean), the units, the default experiment, the outputs,
  plus FMI 3.0's one independent variable ``time``;
- same results: both driven by fmpy's simulate_fmu on the same steps agree to 1e-12 (relative to the output's
  range) on every output, on the cases the native FMUs are checked with against the pythonfmu ones (a pressure
  step with c, tau and Fc, runs onto both end stops, the actuator under changing inputs);
- Model Exchange through fmpy's CVode agrees with the FMI 2.0 Model Exchange to 1e-12 (a knee step onto the stop
  with damping and lag, one without a lag, the actuator's lag); the event indicators, variables in FMI 3.0, are
  those fmi3GetEventIndicators gives and change sign at the stop;
- a refused step ends the run: fmi3DoStep answers a NaN input with fmi3Discard and terminateSimulation = true,
  the state kept at lastSuccessfulTime, and simulate_fmu stops there with the message logged (Model Exchange: a
  negative pressure ends the run at once); a bad parameter is refused at fmi3ExitInitializationMode with Params'
  message, as in FMI 2.0; messages name FMI 3.0 functions;
- FMU state: a replay from a saved and a serialized state is identical;
- ``sources/`` builds with fmpy's compile (CMake, buildDescription.xml) into a binary that gives the same results.
"""
from __future__ import annotations

import ctypes
import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest

from mkctl.physics.simulate import default_commands
from test_native_fmu import ACTUATOR_CASES, KNEE_CASES

PE0, PF0 = default_commands()


def _compiler():
    from mkctl.native.build import find_compiler
    return find_compiler()


pytestmark = pytest.mark.skipif(_compiler() is None, reason="no C compiler: no native FMUs")


@pytest.fixture(scope="module")
def fmus(tmp_path_factory) -> dict[str, dict[str, Path]]:
    """{"fmi2": {"knee": ..., "actuator": ...}, "fmi3": {...}}: both built by mkctl.native (validated there)."""
    from mkctl.native.fmi3 import build_fmi3
    from mkctl.native.fmu import build_native
    out = tmp_path_factory.mktemp("fmi3")
    short = {"McKibbenKnee": "knee", "McKibbenActuator": "actuator"}
    return {"fmi2": {short[k]: v for k, v in build_native(out).items()},
            "fmi3": {short[k]: v for k, v in build_fmi3(out).items()}}


def test_an_effect_registered_then_unregistered_leaves_no_core_behind(monkeypatch, tmp_path):
    """The FMUs' core source is cached in the process by the key of what it is generated from: after an effect is
    registered (its core generated) and unregistered, the FMUs get the plain core again. (A cache without that
    key gave every later FMU of the process the effect's parameter vector: Model Exchange then failed.) The
    generator is stood in for by one that names the parameters it sees: the caching is what is tested."""
    from mkctl.native import build, fmu
    from mkctl.physics import effects, params
    monkeypatch.setattr(fmu, "_CORE_SOURCES", {})
    monkeypatch.setattr(build, "cache_dir", lambda: tmp_path)
    monkeypatch.setattr(fmu, "generate_core_source", lambda: f"core of {list(params.PARAMETER_NAMES)}")
    plain = fmu.core_source()
    effects.register(effects.Effect(
        "test_fmi3_stiffening", "f += k_fmi3 (L - L0)^2",
        parameters=(effects.Parameter("k_fmi3", "Pa", off=0.0, lower=0.0, upper=1e7, typical=2e4),),
        tension=lambda L, Ldot, P, p, xp: p.k_fmi3 * (L - p.L0) ** 2))
    try:
        with_effect = fmu.core_source()
    finally:
        effects.unregister("test_fmi3_stiffening")
    assert "k_fmi3" in with_effect and "k_fmi3" not in plain
    assert fmu.core_source() == plain


# --- validation and interface --------------------------------------------------------------------------------------

def _describe(path: Path) -> dict:
    from fmpy import read_model_description
    md = read_model_description(str(path))
    types = {"Real": "Float64", "Integer": "Int32"}
    variables = [(v.name, v.valueReference, types.get(v.type, v.type), v.causality, v.variability, v.description,
                  v.unit, None if v.start is None else str(v.start).lower(),
                  None if v.derivative is None else v.derivative.name)
                 for v in md.modelVariables]
    units = {u.name: (u.baseUnit.kg, u.baseUnit.m, u.baseUnit.s, u.baseUnit.rad) if u.baseUnit else None
             for u in md.unitDefinitions}
    experiment = md.defaultExperiment
    return {"name": md.modelName, "variables": variables, "units": units,
            "experiment": (experiment.startTime, experiment.stopTime, experiment.stepSize),
            "outputs": [u.variable.name for u in md.outputs],
            "derivatives": [u.variable.name for u in md.derivatives],
            "initial": sorted(u.variable.name for u in md.initialUnknowns),
            "event indicators": md.numberOfEventIndicators,
            "interfaces": (md.modelExchange is not None, md.coSimulation is not None),
            "token": md.guid, "version": md.fmiVersion}


@pytest.mark.parametrize("model", ["knee", "actuator"])
def test_fmi3_fmu_validates_and_shows_the_fmi2_fmus_interface(fmus, model):
    from fmpy.validation import validate_fmu
    assert validate_fmu(str(fmus["fmi3"][model])) == []
    assert validate_fmu(str(fmus["fmi2"][model])) == []
    three, two = _describe(fmus["fmi3"][model]), _describe(fmus["fmi2"][model])
    assert (three.pop("version"), two.pop("version")) == ("3.0", "2.0")
    assert three.pop("token") != two.pop("token")  # two builds, two tokens
    nv, nz = len(two["variables"]), two["event indicators"]
    # indicators: the knee's end stops and slack; both models' lag direction (asymmetric_lag, spec 4b)
    assert three["interfaces"] == two["interfaces"] == (True, True) and nz > 0
    # FMI 3.0's own variables: time and the event indicators, after the FMI 2.0 FMU's
    time = three["variables"].pop(0)  # declared first
    assert time == ("time", nv, "Float64", "independent", "continuous", "simulation time", "s", None, None)
    indicators = three["variables"][nv:]
    del three["variables"][nv:]
    assert [(v[0], v[1], v[3]) for v in indicators] == [(f"event_indicator_{k}", nv + k, "local")
                                                       for k in range(1, nz + 1)]
    assert three["units"].pop("s", None) == two["units"].pop("s", (0, 0, 1, 0))  # the knee has no other "s"
    assert three == two
    with zipfile.ZipFile(fmus["fmi3"][model]) as fmu:
        names = fmu.namelist()
    assert f"binaries/x86_64-linux/{two['name']}.so" in names
    assert "sources/buildDescription.xml" in names and "sources/fmi3_wrapper.c" in names
    from mkctl.native.cross import find_cross_compiler
    assert (f"binaries/x86_64-windows/{two['name']}.dll" in names) == (find_cross_compiler() is not None)


# --- same results ---------------------------------------------------------------------------------------------------

def _simulate(fmu: Path, case: dict) -> dict[str, np.ndarray]:
    from fmpy import simulate_fmu
    names = list(case["signal"][0][1])
    signal = np.array([(t, *[row[n] for n in names]) for t, row in case["signal"]],
                      dtype=[("time", float)] + [(n, float) for n in names])
    result = simulate_fmu(str(fmu), stop_time=case["stop"], output_interval=case["dt"], input=signal,
                          start_values=case["start"])
    return {name: result[name].astype(float) for name in result.dtype.names}


@pytest.mark.parametrize("model, name", [("knee", name) for name in KNEE_CASES] +
                                        [("actuator", name) for name in ACTUATOR_CASES])
def test_fmi3_gives_the_fmi2_results_to_1e_12(fmus, model, name):
    case = (KNEE_CASES if model == "knee" else ACTUATOR_CASES)[name]
    three, two = _simulate(fmus["fmi3"][model], case), _simulate(fmus["fmi2"][model], case)
    assert three["time"][-1] == pytest.approx(case["stop"]) and three.keys() == two.keys()
    moved = 0
    for output, ref in two.items():
        scale = max(1.0, np.abs(ref).max())
        assert np.abs(three[output] - ref).max() <= 1e-12 * scale, f"{name}: output {output}"
        moved += np.ptp(ref) > 0
    assert moved >= 3  # the case exercises the model


# --- Model Exchange -------------------------------------------------------------------------------------------------

def _signal(name_values: dict, at: float, stop: float):
    """An fmpy input signal: every input at its first value, each stepping to its second at time `at`."""
    rows = [(0.0, *[v[0] for v in name_values.values()]), (at, *[v[0] for v in name_values.values()]),
            (at, *[v[1] for v in name_values.values()]), (stop, *[v[1] for v in name_values.values()])]
    return np.array(rows, dtype=[("time", float)] + [(n, float) for n in name_values])


ME_CASES = {  # the Model Exchange cases of tests/test_native_me.py: damping, lag, an end-stop contact
    "knee step onto the stop": ("knee", {"c": 40.0, "tau": 0.02},
                                {"pe_cmd": (PE0, 3e6), "pf_cmd": (PF0, PF0)}, 0.6),
    "knee without a lag, slack, friction": ("knee", {"c": 40.0, "slack": 1, "Fc": 2.0},
                                            {"pe_cmd": (PE0, 3e6), "pf_cmd": (PF0, PF0)}, 0.5),
    "actuator lag": ("actuator", {"tau": 0.05, "c": 10.0},
                     {"p_cmd": (1e5, 4e5), "L": (0.18, 0.18), "Ldot": (0.0, 0.01)}, 0.4),
}


@pytest.mark.parametrize("name", list(ME_CASES))
def test_fmi3_model_exchange_gives_the_fmi2_results_to_1e_12(fmus, name):
    """Both through fmpy's CVode, the same tolerance: the same calls give the same numbers."""
    from fmpy import simulate_fmu
    model, start, inputs, stop = ME_CASES[name]
    runs = [simulate_fmu(str(fmus[version][model]), fmi_type="ModelExchange", stop_time=stop, output_interval=1e-3,
                         input=_signal(inputs, 0.1, stop), start_values=dict(start), relative_tolerance=1e-10)
            for version in ("fmi3", "fmi2")]
    three, two = ({n: r[n].astype(float) for n in r.dtype.names} for r in runs)
    assert two["time"][-1] == pytest.approx(stop) and len(two["time"]) > stop / 1e-3  # events add rows
    assert three.keys() == two.keys()
    for output, ref in two.items():
        assert three[output].shape == ref.shape, output
        assert np.abs(three[output] - ref).max() <= 1e-12 * max(1.0, np.abs(ref).max()), f"{name}: {output}"
    assert np.ptp(two["X" if model == "knee" else "P"]) > 0


def test_fmi3_event_indicators_are_variables_and_flip_at_the_stop(fmus, tmp_path):
    from fmpy import extract, read_model_description
    from fmpy.fmi3 import FMU3Model
    from mkctl.physics import knee
    from mkctl.physics.params import Params
    path = fmus["fmi3"]["knee"]
    md = read_model_description(str(path))
    indicators = [v.valueReference for v in md.modelVariables if v.name.startswith("event_indicator_")]
    nx, nz = len(md.derivatives), len(indicators)
    assert nz == md.numberOfEventIndicators > 0
    fmu = FMU3Model(guid=md.guid, unzipDirectory=extract(str(path), str(tmp_path / "knee")),
                    modelIdentifier=md.modelExchange.modelIdentifier, instanceName="test")
    fmu.instantiate()
    try:
        fmu.enterInitializationMode(startTime=0.0)
        fmu.exitInitializationMode()
        fmu.updateDiscreteStates()
        fmu.enterContinuousTimeMode()
        assert (fmu.getNumberOfContinuousStates(), fmu.getNumberOfEventIndicators()) == (nx, nz)
        x = (ctypes.c_double * nx)()
        fmu.getContinuousStates(x, nx)
        signs = []
        for X in (x[0], knee.stop_positions(Params())[1] + 1e-3):  # at rest, then beyond the upper stop
            x[0] = X
            fmu.setContinuousStates(x, nx)
            z = (ctypes.c_double * nz)()
            fmu.getEventIndicators(z, nz)
            assert fmu.getFloat64(indicators) == list(z)  # the variables are the indicators
            signs.append(np.sign(list(z)))
        assert (signs[0] != signs[1]).any()
    finally:
        fmu.terminate()
        fmu.freeInstance()


def test_a_negative_pressure_ends_an_fmi3_model_exchange_run_with_the_message(fmus, capsys):
    from fmpy import simulate_fmu
    signal = _signal({"pe_cmd": (PE0, -1e5), "pf_cmd": (PF0, PF0)}, 0.1, 0.5)
    result = simulate_fmu(str(fmus["fmi3"]["knee"]), fmi_type="ModelExchange", stop_time=0.5, output_interval=1e-3,
                          input=signal, start_values={"c": 40.0})
    assert result["time"][-1] == pytest.approx(0.1)
    shown = capsys.readouterr().out
    assert shown.count("fmi3UpdateDiscreteStates at t = 0.1 s: input pe_cmd = -100000.0 Pa is below 0") == 1


# --- the FMI 3.0 calls themselves --------------------------------------------------------------------------------

class Fmi3:
    """One FMI 3.0 instance through fmpy's FMU3Slave, its log messages kept."""

    def __init__(self, path: Path, folder: Path):
        from fmpy import extract, read_model_description
        from fmpy.fmi3 import FMU3Slave
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        self.messages = []
        self.fmu = FMU3Slave(guid=self.md.guid, unzipDirectory=extract(str(path), str(folder)),
                             modelIdentifier=self.md.coSimulation.modelIdentifier, instanceName="test")
        self.fmu.instantiate(logMessage=lambda env, status, category, message:
                             self.messages.append((status, message.decode())))

    def status(self, function, *args) -> int:
        """The fmi3Status of a call (fmpy raises for a status above fmi3Warning: its status is the answer)."""
        from fmpy.fmi1 import FMICallException
        try:
            return getattr(self.fmu, function)(self.fmu.component, *args)
        except FMICallException as error:
            return error.status

    def initialize(self, **start) -> int:
        """fmi3EnterInitializationMode, the start values, fmi3ExitInitializationMode: the last status."""
        assert self.status("fmi3EnterInitializationMode", False, 0.0, 0.0, False, 0.0) == 0
        for name, value in start.items():
            assert self.set(name, value) == 0
        return self.status("fmi3ExitInitializationMode")

    def set(self, name, value) -> int:
        vr = (ctypes.c_uint32 * 1)(self.vr[name])
        if self.types[name] == "Int32":
            return self.status("fmi3SetInt32", vr, 1, (ctypes.c_int32 * 1)(int(value)), 1)
        return self.status("fmi3SetFloat64", vr, 1, (ctypes.c_double * 1)(value), 1)

    def get(self, name) -> float:
        value = (ctypes.c_double * 1)()
        assert self.status("fmi3GetFloat64", (ctypes.c_uint32 * 1)(self.vr[name]), 1, value, 1) <= 1
        return value[0]

    def step(self, t, dt) -> tuple[int, bool, float]:
        """fmi3DoStep: (status, terminateSimulation, lastSuccessfulTime)."""
        flags = [ctypes.c_bool() for _ in range(3)]
        last = ctypes.c_double()
        status = self.status("fmi3DoStep", ctypes.c_double(t), ctypes.c_double(dt), True,
                             *map(ctypes.byref, flags), ctypes.byref(last))
        return status, flags[1].value, last.value

    def free(self):
        self.fmu.fmi3FreeInstance(self.fmu.component)


def test_a_refused_step_ends_the_run_in_fmi3(fmus, tmp_path):
    fmu = Fmi3(fmus["fmi3"]["knee"], tmp_path)
    try:
        assert fmu.initialize(c=40.0) == 0
        assert fmu.step(0.0, 0.01)[:2] == (0, False)
        X = fmu.get("X")
        assert fmu.set("pe_cmd", float("nan")) == 0
        assert fmu.step(0.01, 0.01) == (2, True, 0.01)  # fmi3Discard, terminate, the state kept at 0.01 s
        assert fmu.messages[-1] == (2, "doStep at t = 0.01 s: input pe_cmd = nan Pa is not a finite number")
        assert fmu.get("X") == X and fmu.get("time") == 0.01
    finally:
        fmu.free()


def test_simulate_fmu_stops_at_a_refused_step_with_the_message(fmus, capsys):
    from fmpy import simulate_fmu
    signal = np.array([(0.0, PE0), (0.1, PE0), (0.1, float("nan")), (0.2, float("nan"))],
                      dtype=[("time", float), ("pe_cmd", float)])
    with pytest.raises(Exception, match="fmi3DoStep failed with status 2"):
        simulate_fmu(str(fmus["fmi3"]["knee"]), stop_time=0.2, output_interval=1e-3, input=signal)
    assert "input pe_cmd = nan Pa is not a finite number" in capsys.readouterr().out


def test_a_bad_parameter_is_refused_with_params_message_and_fmi3_names(fmus, tmp_path):
    fmu = Fmi3(fmus["fmi3"]["actuator"], tmp_path)
    try:
        assert fmu.initialize(b=-0.1) == 3
        assert fmu.messages[-1] == (3, "invalid parameters: parameter b must be positive, got -0.1")
        assert fmu.step(0.0, 0.01)[0] == 3
        assert fmu.status("fmi3Reset") == 0
        assert fmu.initialize() == 0
        assert fmu.set("b", 0.3) == 3  # a fixed parameter after initialization: the FMI 3.0 call named
        assert fmu.messages[-1][1].startswith("fmi3SetFloat64: b is a fixed parameter: set it before "
                                              "fmi3ExitInitializationMode")
        assert fmu.set("model", 2) == 3
        assert fmu.messages[-1][1].startswith("fmi3SetInt32: model is a fixed parameter")
    finally:
        fmu.free()


def test_fmu_state_replays_identically_in_fmi3(fmus, tmp_path):
    fmu = Fmi3(fmus["fmi3"]["knee"], tmp_path)
    f = fmu.fmu
    try:
        assert fmu.initialize(c=40.0, tau=0.02, pe_cmd=PE0 * 1.05) == 0
        run = lambda t0: [(fmu.step(t0 + k * 1e-3, 1e-3), fmu.get("X"))[1] for k in range(50)]  # noqa: E731
        run(0.0)
        state = f.getFMUState()
        serialized = f.serializeFMUState(state)
        rest = run(0.05)
        f.setFMUState(state)
        assert run(0.05) == rest
        restored = f.deserializeFMUState(serialized)
        f.setFMUState(restored)
        assert run(0.05) == rest and len(set(rest)) == 50
        f.freeFMUState(state)
        f.freeFMUState(restored)
    finally:
        fmu.free()


# --- sources/ -------------------------------------------------------------------------------------------------------

def test_fmi3_sources_build_with_fmpy_compile(fmus, tmp_path):
    if shutil.which("cmake") is None:
        pytest.skip("cmake is not installed: fmpy's compile needs it")
    from fmpy.build import build_platform_binary
    folder = tmp_path / "actuator"
    with zipfile.ZipFile(fmus["fmi3"]["actuator"]) as archive:
        archive.extractall(folder)
    shutil.rmtree(folder / "binaries")
    (tmp_path / "build").mkdir()
    build_platform_binary(folder, build_dir=tmp_path / "build")
    assert (folder / "binaries" / "x86_64-linux" / "McKibbenActuator.so").is_file()
    rebuilt = shutil.make_archive(str(tmp_path / "rebuilt"), "zip", folder)
    case = next(iter(ACTUATOR_CASES.values()))
    got, ref = _simulate(Path(rebuilt), case), _simulate(fmus["fmi2"]["actuator"], case)
    for output in ref:
        assert np.abs(got[output] - ref[output]).max() <= 1e-12 * max(1.0, np.abs(ref[output]).max()), output
