"""The pythonfmu FMUs of any mechanism, and the air in the pythonfmu knee and mechanism FMUs
(model-spec 3b, 4d, 7d).

Every FMU run happens in a fresh interpreter (``run_python``, conftest.py: pythonfmu 0.7 FMUs are
tested in a subprocess); the main runs all in one process, one after the other (they share the
module names ``mkctl`` and ``pythonfmu``). The host sets each sample's commands, steps to the next
sample and reads the outputs there; the references are computed here with mkctl directly, and
compared sample by sample (by time):

- hanging_mass, pulley_joint and the cam lever file (docs/examples/cam_lever.py) against
  :func:`mkctl.physics.mechanism.simulate_mechanism`: q and the lengths to 1e-9 m (rad), the
  pressures exactly; a pressure lag, a dead time and damping set as FMU parameters at run time;
- the pulley joint built with the air (valve_flow and a leak in the build's parameters) against
  simulate_mechanism with the same, its air mass flows ``q_<muscle>`` against
  :func:`mkctl.physics.actuator.air_mass_flow` at the FMU's own pressures and commands;
- the knee built with the air against :func:`mkctl.physics.simulate.simulate_knee`, qe and qf
  against air_mass_flow;
- the pythonfmu pulley-joint FMU against the native one (both built here): the same variables
  (names, units, start values, descriptions) and the same outputs;
- the mechanism file travels as itself: the FMU carries it byte for byte, and no other file of the
  FMU holds its text; a user's effect file travels too;
- errors in the library's words, and the FMU state replayed through a dead time.
"""
from __future__ import annotations

import json
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np
import pytest

from mkctl.physics import actuator
from mkctl.physics import mechanism as mech
from mkctl.physics.params import Params

pytest.importorskip("fmpy")
pytest.importorskip("pythonfmu")
ROOT = Path(__file__).resolve().parents[1]
CAM_LEVER = ROOT / "docs" / "examples" / "cam_lever.py"

#: Sample times [s] and the commands at them [Pa]: two steps (one muscle: the first column).
TIME = np.round(np.arange(0.0, 0.4 + 1e-12, 0.01), 12)
#: The air on: a slow valve and a leak, so that the pressures lag the commands visibly.
AIR = dict(valve_flow=1, C_fill=2e-9, C_leak=2e-12, band=2e4)


def _commands(k):
    if k == 1:
        return [np.where(TIME < 0.1, 300e3, np.where(TIME < 0.25, 400e3, 250e3))]
    # the pulley: a smaller difference keeps the arm off its stops
    return [np.where(TIME < 0.1, 300e3, np.where(TIME < 0.25, 320e3, 295e3)),
            np.where(TIME < 0.1, 300e3, np.where(TIME < 0.25, 290e3, 310e3))]


def _mechanism(name):
    from mkctl.analysis.mechanism_files import mechanism
    return mechanism(str(CAM_LEVER) if name == "cam_lever" else name)


# --- the host: runs in a fresh process ----------------------------------------------------------
HOST = r"""
import json, sys
from fmpy import extract, read_model_description
from fmpy.fmi2 import FMU2Slave
jobs, results = json.loads(open(sys.argv[1]).read()), []
for job in jobs:
    md = read_model_description(job["fmu"])
    vr = {v.name: v.valueReference for v in md.modelVariables}
    kinds = {v.name: v.type for v in md.modelVariables}
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=extract(job["fmu"]),
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="test")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()

    def put(values):
        for name, value in values.items():
            if kinds[name] == "Integer":
                fmu.setInteger([vr[name]], [int(value)])
            else:
                fmu.setReal([vr[name]], [float(value)])

    put(job["start"])
    put({n: c[0] for n, c in job["inputs"].items()})
    fmu.exitInitializationMode()
    time, rows = job["time"], []
    rows.append(fmu.getReal([vr[n] for n in job["outputs"]]))
    for j in range(len(time) - 1):
        fmu.doStep(time[j], time[j + 1] - time[j])
        # sample j + 1's commands, then its outputs (the library reports P at the commands it sees)
        put({n: c[j + 1] for n, c in job["inputs"].items()})
        rows.append(fmu.getReal([vr[n] for n in job["outputs"]]))
    fmu.terminate()
    fmu.freeInstance()
    results.append(rows)
print(json.dumps(results))
"""


def _job(fmu, inputs, outputs, start=None):
    return {"fmu": str(fmu), "time": TIME.tolist(), "start": dict(start or {}),
            "outputs": list(outputs),
            "inputs": {name: np.asarray(c, float).tolist() for name, c in inputs.items()}}


def _mechanism_outputs(mechanism, air=False):
    muscles = mechanism.muscles
    return ["q", *(f"{kind}_{m}" for kind in ("L", "f", "P") for m in muscles),
            *((f"q_{m}" for m in muscles) if air else ())]


def _mechanism_job(fmu, mechanism, q0, start=None, air=False):
    k = len(mechanism.muscles)
    inputs = {f"p_cmd_{m}": c for m, c in zip(mechanism.muscles, _commands(k))}
    return _job(fmu, inputs, _mechanism_outputs(mechanism, air), {"q0": q0, **(start or {})})


def _run(jobs, run_python, folder):
    path = folder / "jobs.json"
    path.write_text(json.dumps(jobs))
    return [np.array(rows) for rows in run_python(HOST, path, timeout=300)]


#: The cases: (mechanism, parameters set at run time, built with the air).
CASES = {
    "pulley_joint": ("pulley_joint", {}, False),
    "hanging_mass": ("hanging_mass", {}, False),
    "cam_lever": ("cam_lever", {}, False),
    "pulley lag, damping": ("pulley_joint", {"tau": 0.02, "c": 30.0}, False),
    "pulley dead time": ("pulley_joint", {"delay": 0.025}, False),
    "pulley with the air": ("pulley_joint", {}, True),
}


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """The pythonfmu FMUs (no native ones, no default experiments): the mechanisms, the pulley and
    the knee built with the air."""
    from mkctl.fmu.build import build, build_mechanism_fmus
    out = tmp_path_factory.mktemp("pyfmu")
    paths = {}
    for name in ("pulley_joint", "hanging_mass", "cam_lever"):
        what = CAM_LEVER if name == "cam_lever" else name
        paths[name] = build_mechanism_fmus(what, out / name, run=False, native=False)
    paths["air pulley"] = build_mechanism_fmus("pulley_joint", out / "air", Params(**AIR),
                                               run=False, native=False)
    paths["air knee"] = build(out / "knee", run=False, params=Params(**AIR, c=40.0), native=False)
    return paths


def _knee_commands():
    from mkctl.physics.simulate import default_commands
    pe, pf = default_commands(Params(**AIR, c=40.0))
    return np.where(TIME < 0.1, pe, pe * 1.05), np.full(TIME.size, pf)


@pytest.fixture(scope="module")
def runs(built, run_python, tmp_path_factory):
    """({case: (reference, rows)}, the air knee's rows): every run in one subprocess."""
    jobs, references = [], {}
    for case, (name, start, air) in CASES.items():
        mechanism = _mechanism(name)
        params = Params(**(AIR if air else {}), **start)
        commands = _commands(len(mechanism.muscles))
        references[case] = mech.simulate_mechanism(TIME, commands, mechanism, params)
        fmu = next(iter(built["air pulley" if air else name].values()))
        jobs.append(_mechanism_job(fmu, mechanism, float(references[case].q[0]), start, air))
    pe, pf = _knee_commands()
    jobs.append(_job(built["air knee"]["McKibbenKnee"], {"pe_cmd": pe, "pf_cmd": pf},
                     ["X", "Pe", "Pf", "qe", "qf"]))
    p_cmd, L, Ldot = _actuator_inputs()
    jobs.append(_job(built["air knee"]["McKibbenActuator"], {"p_cmd": p_cmd, "L": L, "Ldot": Ldot},
                     ["P", "f", "q"]))
    rows = _run(jobs, run_python, tmp_path_factory.mktemp("jobs"))
    return {case: (references[case], r) for case, r in zip(CASES, rows)}, rows[-2], rows[-1]


def _actuator_inputs():
    """The actuator's set-point stepped up and down while its length is held, then pulled longer."""
    p_cmd = np.where(TIME < 0.05, 300e3, np.where(TIME < 0.2, 450e3, 350e3))
    Ldot = np.where(TIME < 0.25, 0.0, 0.02)
    L = 0.19 + np.concatenate([[0.0], np.cumsum(Ldot[:-1] * np.diff(TIME))])
    return p_cmd, L, Ldot


@pytest.mark.parametrize("case", list(CASES))
def test_mechanism_fmu_against_simulate_mechanism(runs, case):
    name, start, air = CASES[case]
    k = len(_mechanism(name).muscles)
    reference, got = runs[0][case]
    assert np.ptp(reference.q) > 1e-3  # it moves
    # With the air the pressures are states held to 1e-3 Pa; the FMU's integration, cut at every
    # communication step, and the record loop's, through each run of held commands, then differ by
    # up to 3.9e-9 rad (measured; simulate_mechanism itself moves by 2.2e-8 rad from rtol 1e-10 to
    # 1e-13): 1e-8 there, 1e-9 elsewhere.
    atol = 1e-8 if air else 1e-9
    np.testing.assert_allclose(got[:, 0], reference.q, rtol=0, atol=atol)
    np.testing.assert_allclose(got[:, 1:1 + k], reference.L, rtol=0, atol=atol)
    # the tension: dL of 1e-9 m times a muscle's stiffness (~1e4 N/m)
    np.testing.assert_allclose(got[:, 1 + k:1 + 2 * k], reference.f, rtol=1e-6 if air else 1e-7,
                               atol=1e-6)
    P = got[:, 1 + 2 * k:1 + 3 * k]
    if actuator.has_pressure_states(Params(**(AIR if air else {}), **start)):
        assert np.ptp(reference.P) > 1e4
        assert not np.array_equal(reference.P, np.array(_commands(k)).T)
        # both integrators hold a pressure to 1e-3 Pa absolute; with the air the regulator's
        # opening bends where it saturates and the runs differ by up to 0.083 Pa (measured;
        # simulate_mechanism itself moves by 0.094 Pa from rtol 1e-10 to 1e-13, and the FMU lies
        # within 0.026 Pa of that tight run)
        np.testing.assert_allclose(P, reference.P, rtol=1e-6 if air else 1e-9, atol=1e-2)
    else:
        np.testing.assert_array_equal(P, reference.P)


def _flows(P, commands, params):
    """air_mass_flow at the regulator's opening, sample by sample and muscle by muscle [kg/s]."""
    return np.array([[actuator.air_mass_flow(p, actuator.valve_opening(p, c, params), params)
                      for p, c in zip(P_row, c_row)] for P_row, c_row in zip(P, commands)])


def test_mechanism_air_flows_are_the_library_air_mass_flow(runs):
    assert _mechanism("pulley_joint").muscles == ("muscle1", "muscle2")
    _, got = runs[0]["pulley with the air"]
    want = _flows(got[:, 5:7], np.array(_commands(2)).T, Params(**AIR))
    assert np.abs(want).max() > 1e-5  # the air flows (kg/s)
    np.testing.assert_allclose(got[:, 7:9], want, rtol=1e-12, atol=1e-18)


def test_knee_fmu_with_the_air_against_simulate_knee(runs):
    from mkctl.physics.simulate import default_hip_height, simulate_knee
    params = Params(**AIR, c=40.0)
    pe, pf = _knee_commands()
    reference = simulate_knee(TIME, pe, pf, params, default_hip_height(params))
    got = runs[1]
    assert np.ptp(reference["X"]) > 1e-4 and np.ptp(reference["Pe"]) > 1e4
    np.testing.assert_allclose(got[:, 0], reference["X"], rtol=0, atol=1e-9)
    np.testing.assert_allclose(got[:, 1:3], np.c_[reference["Pe"], reference["Pf"]], rtol=1e-9,
                               atol=1e-2)
    want = _flows(got[:, 1:3], np.c_[pe, pf], params)
    assert np.abs(want[:, 0]).max() > 1e-5
    np.testing.assert_allclose(got[:, 3:5], want, rtol=1e-12, atol=1e-18)


def test_actuator_fmu_with_the_air_against_the_librarys_actuator(runs):
    """The pythonfmu actuator built with the air (ACTUATOR_WITH_AIR, the native one's interface): its
    pressure a state of the mass balance at the length and rate it is given, against
    ActuatorSimulator stepped alike (itself checked against simulate_air and an independent
    simulator in tests/test_valve_inputs.py); q against air_mass_flow at its own pressure."""
    from mkctl.physics.simulate import ActuatorSimulator
    params = Params(**AIR, c=40.0)  # the build's parameters (the knee's and the actuator's)
    p_cmd, L, Ldot = _actuator_inputs()
    sim, want = ActuatorSimulator(params, float(p_cmd[0])), []
    for j in range(TIME.size):
        if j:
            sim.step(float(TIME[j] - TIME[j - 1]), float(p_cmd[j - 1]), float(L[j - 1]),
                     float(Ldot[j - 1]))
        out = sim.outputs(float(p_cmd[j]), float(L[j]), float(Ldot[j]))
        want.append([out["P"], out["f"], out["q"]])
    want, got = np.array(want), runs[2]
    assert np.ptp(want[:, 0]) > 5e4 and not np.allclose(want[:, 0], p_cmd, atol=1e3)  # it lags
    np.testing.assert_allclose(got[:, 0], want[:, 0], rtol=1e-9, atol=1e-3)
    np.testing.assert_allclose(got[:, 1], want[:, 1], rtol=1e-9, atol=1e-6)
    flow = [actuator.air_mass_flow(P, actuator.valve_opening(P, c, params), params)
            for P, c in zip(got[:, 0], p_cmd)]
    np.testing.assert_allclose(got[:, 2], flow, rtol=1e-12, atol=1e-18)


def test_knee_with_the_air_shows_the_native_knees_air_variables(built):
    from fmpy import read_model_description

    from mkctl.fmi.interface import KNEE_WITH_AIR
    from mkctl.native.fmu import slave_interface
    md = read_model_description(str(built["air knee"]["McKibbenKnee"]))
    native = slave_interface("McKibbenKnee", Params(**AIR, c=40.0), air=True)
    got = [(v.name, v.causality, v.unit, v.description) for v in md.modelVariables]
    assert got == [(v.name, v.causality, v.unit, v.description) for v in native.variables]
    names = {v.name for v in md.modelVariables}
    assert {"valve_flow", "C_fill", "V_dead", "C_leak", "qe", "qf"} <= names
    assert md.description.startswith(KNEE_WITH_AIR.description + " (pythonfmu FMU")
    # the actuator carries the air too, with the native actuator's interface
    from mkctl.fmi.interface import ACTUATOR_WITH_AIR
    md = read_model_description(str(built["air knee"]["McKibbenActuator"]))
    assert [v.name for v in md.modelVariables] == [v.name for v in ACTUATOR_WITH_AIR.variables(
        Params(**AIR, c=40.0))]
    assert {"valve_flow", "C_fill", "q"} <= {v.name for v in md.modelVariables}


def test_the_mechanism_file_travels_as_itself(built):
    fmu = built["cam_lever"]["McKibbenCamLever"]
    text = CAM_LEVER.read_bytes()
    carried = "resources/mkctl_mechanism/cam_lever.py"
    with zipfile.ZipFile(fmu) as archive:
        assert archive.read(carried) == text
        script = archive.read("resources/mckibben_mechanism.py")
        others = [archive.read(n) for n in archive.namelist()
                  if n != carried and not n.endswith((".so", ".dll"))]
    assert script == (ROOT / "mkctl" / "fmu" / "scripts" / "mckibben_mechanism.py").read_bytes()
    words = b"whose radius grows with the angle"  # the file's own words, in no mkctl module
    assert words in text and not any(words in data for data in others)


@pytest.fixture(scope="module")
def native_pulley(tmp_path_factory):
    from mkctl.native.build import find_compiler
    from mkctl.native.mechanism_fmu import build_mechanism
    if find_compiler() is None:
        pytest.fail("no C compiler: the native mechanism FMUs need one")
    paths = build_mechanism(mech.PULLEY_JOINT, tmp_path_factory.mktemp("native"), platforms=False)
    return paths["native/McKibbenPulleyJoint"]


def test_pythonfmu_and_native_mechanism_fmus_show_one_interface_and_agree(
        built, native_pulley, run_python, tmp_path):
    from fmpy import read_model_description
    python_fmu = built["pulley_joint"]["McKibbenPulleyJoint"]
    mds = [read_model_description(str(f)) for f in (python_fmu, native_pulley)]
    rows = [[(v.name, v.valueReference, v.type, v.causality, v.variability, v.unit,
              None if v.start is None else float(v.start), v.description)
             for v in md.modelVariables if v.causality != "local"]  # ME's locals: native only
            for md in mds]
    assert len(rows[0]) == len(rows[1]) == 41
    for mine, theirs in zip(*rows):  # pythonfmu writes a start value with 15 digits, native 17
        assert mine[:6] + mine[7:] == theirs[:6] + theirs[7:]
        same = mine[6] is None and theirs[6] is None
        assert same or mine[6] == pytest.approx(theirs[6], rel=1e-14), mine
    assert mds[0].modelName == mds[1].modelName == "McKibbenPulleyJoint"
    mechanism = mech.PULLEY_JOINT
    start = {"tau": 0.01, "J": 0.02}
    q0 = mech.equilibrium(mechanism, (300e3, 300e3), mechanism.bind(Params(tau=0.01), J=0.02))
    jobs = [_mechanism_job(f, mechanism, q0, start) for f in (python_fmu, native_pulley)]
    python_rows, native_rows = _run(jobs, run_python, tmp_path)
    assert np.ptp(python_rows[:, 0]) > 1e-3
    np.testing.assert_allclose(python_rows[:, 0:3], native_rows[:, 0:3], rtol=0, atol=1e-9)  # q, L
    np.testing.assert_allclose(python_rows[:, 3:5], native_rows[:, 3:5], rtol=1e-7,
                               atol=1e-6)  # f
    np.testing.assert_allclose(python_rows[:, 5:7], native_rows[:, 5:7], rtol=1e-9,
                               atol=1e-2)  # P, the lag's states


ERRORS = r"""
import json, sys
from fmpy import extract, read_model_description
from fmpy.fmi1 import FMICallException
from fmpy.fmi2 import FMU2Slave
path = sys.argv[1]
md = read_model_description(path)
vr = {v.name: v.valueReference for v in md.modelVariables}
folder = extract(path)


def instance(**start):
    fmu = FMU2Slave(guid=md.guid, unzipDirectory=folder,
                    modelIdentifier=md.coSimulation.modelIdentifier, instanceName="test")
    fmu.instantiate()
    fmu.setupExperiment(startTime=0.0)
    fmu.enterInitializationMode()
    for name, value in start.items():
        fmu.setReal([vr[name]], [value])
    try:
        fmu.exitInitializationMode()
    except FMICallException as error:
        return fmu, int(error.status)
    return fmu, 0


def status(call, *args):
    try:
        call(*args)
    except FMICallException as error:
        return int(error.status)
    return 0


out = {}
_, out["bad J"] = instance(J=-1.0)
fmu, out["start"] = instance()
fmu.setReal([vr["p_cmd_muscle1"]], [-1.0])
out["negative command"] = status(fmu.doStep, 0.0, 0.01)
# the FMU state with a dead time (commands on their way) and a lag: replayed, the same steps give
# the same q
fmu, _ = instance(delay=0.03, tau=0.02)
commands = [300e3 + 2e3 * j for j in range(30)]
for j in range(10):
    fmu.setReal([vr["p_cmd_muscle1"]], [commands[j]])
    fmu.doStep(0.01 * j, 0.01)
state = fmu.serializeFMUstate(fmu.getFMUstate())
runs = []
for attempt in range(2):
    if attempt:
        fmu.setFMUstate(fmu.deSerializeFMUstate(state))
    q = []
    for j in range(10, 30):
        fmu.setReal([vr["p_cmd_muscle1"]], [commands[j]])
        fmu.doStep(0.01 * j, 0.01)
        q.append(fmu.getReal([vr["q"]])[0])
    runs.append(q)
out["replayed"] = runs
print(json.dumps(out))
"""


def test_errors_with_the_library_words_and_the_fmu_state(built, tmp_path):
    from mkctl.errors import MkctlError
    path = built["pulley_joint"]["McKibbenPulleyJoint"]
    done = subprocess.run([sys.executable, "-c", ERRORS, str(path)], capture_output=True,
                          text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 0, done.stderr[-3000:]
    out = json.loads(done.stdout.strip().splitlines()[-1])
    with pytest.raises(MkctlError) as library:
        mech.PULLEY_JOINT.bind(J=-1.0)
    # fmi2Error or fmi2Fatal, and the library's words on the host's stderr
    assert out["bad J"] >= 3 and str(library.value) in done.stderr
    assert out["start"] == 0 and out["negative command"] in (2, 3) and "below 0" in done.stderr
    assert all("Traceback" not in line for line in done.stderr.splitlines())
    first, again = out["replayed"]
    assert first == again and np.ptp(first) > 1e-4
    # and those steps are the library's: the commands through the dead time and the lag
    commands = [300e3 + 2e3 * j for j in range(30)]
    time = np.round(np.arange(31) * 0.01, 12)
    pulley = mech.PULLEY_JOINT
    reference = mech.simulate_mechanism(
        time, [np.array(commands + commands[-1:]), np.full(31, 300e3)], pulley,
        Params(delay=0.03, tau=0.02), q0=mech.equilibrium(pulley, (300e3, 300e3), pulley.bind()))
    np.testing.assert_allclose(first, reference.q[11:31], rtol=0, atol=1e-9)


DRAG = '''
def quadratic_drag(L, Ldot, P, p, xp):
    return p.c_quad * Ldot * xp.abs(Ldot)


EFFECTS = [{"name": "quadratic_drag", "description": "Ldot |Ldot|",
            "parameters": [{"name": "c_quad", "unit": "N s^2/m^2", "off": 0.0, "lower": 0.0,
                            "upper": 1e6, "typical": 2000.0}],
            "term": quadratic_drag}]
'''


def test_build_fmu_mechanism_carries_your_effect_files(tmp_path, run_python, monkeypatch):
    """``build_fmu.py --mechanism NAME --effects FILE.py --no-native``: the pythonfmu FMU alone, the
    effect packed and registered by the slave; with its parameter set at run time it runs as
    simulate_mechanism with it."""
    from mkctl.analysis.effect_files import register_effect_file, unregister_effect_file
    effect = tmp_path / "drag.py"
    effect.write_text(DRAG)
    out = tmp_path / "dist"
    done = subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "--mechanism",
                           "pulley_joint", "--effects", str(effect), "--no-native", "--no-run",
                           "--out", str(out)], capture_output=True, text=True, cwd=tmp_path,
                          timeout=300)
    assert done.returncode == 0, done.stderr
    assert sorted(p.name for p in out.iterdir()) == ["McKibbenPulleyJoint.fmu"]  # no native/
    mechanism = mech.PULLEY_JOINT
    # the reference in the library's Python loop: no compiled core to build for the effect
    monkeypatch.setenv("MKCTL_NATIVE", "0")
    register_effect_file(effect)
    try:
        reference = mech.simulate_mechanism(TIME, _commands(2), mechanism, Params(c_quad=2000.0))
    finally:
        unregister_effect_file(effect)
    plain = mech.simulate_mechanism(TIME, _commands(2), mechanism)
    assert np.abs(reference.q - plain.q).max() > 1e-4  # the drag acts
    job = _mechanism_job(out / "McKibbenPulleyJoint.fmu", mechanism, float(reference.q[0]),
                         {"c_quad": 2000.0})
    got, = _run([job], run_python, tmp_path)
    np.testing.assert_allclose(got[:, 0], reference.q, rtol=0, atol=1e-9)
