"""Native FMUs of any mechanism (model-spec sections 3b, 7d; mkctl/native/mechanism_fmu.py).

Each FMU (hanging_mass, pulley_joint and the cam lever of docs/examples/cam_lever.py; FMI 2.0 and 3.0) runs
against the library's :func:`mkctl.physics.mechanism.simulate_mechanism`, the commands held from each sample
to the next in both:

- Co-Simulation: a host loop sets the commands at each sample and steps to the next; q to 1e-9 m (rad),
  the lengths, tensions and pressures to 1e-9 relative;
- Model Exchange: the host integrates the FMU's derivatives itself (scipy's DOP853, rtol 1e-12), the
  derivatives also compared call by call with ``mechanism_derivatives`` (1e-12);
- ``stable`` against the sign of the library's (a1, a2) at the final state;
- bad inputs and parameters: an error status and a logged message with the library's words, no crash;
- ``build_fmu.py --mechanism`` refuses a bad file in one line (exit 2, no traceback).

The FMUs are built once per module, without the other platforms' binaries (their cross builds are the
knee's code path, tests/test_platforms.py, test_win64.py).
"""
from __future__ import annotations

import ctypes
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mkctl.physics import mechanism as mech
from test_win64 import hosts, wine  # noqa: F401  (fixtures: the C hosts, Wine)

pytest.importorskip("fmpy")
ROOT = Path(__file__).resolve().parents[1]
CAM_LEVER = ROOT / "docs" / "examples" / "cam_lever.py"


def _mechanism(name):
    from mkctl.analysis.mechanism_files import mechanism
    return mechanism(str(CAM_LEVER) if name == "cam_lever" else name)


class Built(dict):
    """The FMUs by mechanism name, then "2" / "3", each mechanism built once, when a test first asks."""

    def __init__(self, out: Path):
        super().__init__()
        self.out = out

    def __missing__(self, name):
        from mkctl.native.mechanism_fmu import build_mechanism
        paths = build_mechanism(_mechanism(name), self.out, platforms=False)
        self[name] = {"2": next(p for k, p in paths.items() if k.startswith("native/")),
                      "3": next(p for k, p in paths.items() if k.startswith("fmi3/"))}
        return self[name]


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    from mkctl.native.build import find_compiler
    if find_compiler() is None:
        pytest.fail("no C compiler: the native mechanism FMUs need one")
    return Built(tmp_path_factory.mktemp("mechanism_fmus"))


#: The commands [Pa] of each muscle at the samples: two steps (one muscle: the first column).
TIME = np.round(np.arange(0.0, 0.6 + 1e-12, 0.01), 12)


def _commands(k):
    if k == 1:
        return [np.where(TIME < 0.1, 300e3, np.where(TIME < 0.3, 400e3, 250e3))]
    # the pulley: a smaller difference keeps the arm off its stops (a swing of about 0.3 rad)
    return [np.where(TIME < 0.1, 300e3, np.where(TIME < 0.3, 320e3, 295e3)),
            np.where(TIME < 0.1, 300e3, np.where(TIME < 0.3, 290e3, 310e3))]


class Host:
    """One instance of a native FMU through fmpy (FMI 2.0 or 3.0, Co-Simulation or Model Exchange), its log kept."""

    def __init__(self, path: Path, folder: Path, version: str, kind: str):
        from fmpy import extract, read_model_description
        self.md = read_model_description(str(path))
        self.vr = {v.name: v.valueReference for v in self.md.modelVariables}
        self.types = {v.name: v.type for v in self.md.modelVariables}
        self.version, self.kind, self.messages = version, kind, []
        unzipped = extract(str(path), str(folder))
        identifier = (self.md.coSimulation if kind == "cs" else self.md.modelExchange).modelIdentifier
        if version == "2":
            from fmpy.fmi2 import FMU2Model, FMU2Slave, fmi2CallbackFunctions, fmi2CallbackLoggerTYPE
            from fmpy.fmi2 import defaultCallbacks

            def logger(env, instance, status, category, message):
                self.messages.append(message.decode())
            self._logger = fmi2CallbackLoggerTYPE(logger)
            callbacks = fmi2CallbackFunctions(logger=self._logger, allocateMemory=defaultCallbacks.allocateMemory,
                                              freeMemory=defaultCallbacks.freeMemory)
            cls = FMU2Slave if kind == "cs" else FMU2Model
            self.fmu = cls(guid=self.md.guid, unzipDirectory=unzipped, modelIdentifier=identifier,
                           instanceName="test")
            self.fmu.instantiate(callbacks=callbacks)
        else:
            from fmpy.fmi3 import FMU3Model, FMU3Slave
            cls = FMU3Slave if kind == "cs" else FMU3Model
            self.fmu = cls(guid=self.md.guid, unzipDirectory=unzipped, modelIdentifier=identifier,
                           instanceName="test")
            self.fmu.instantiate(logMessage=lambda env, status, category, message:
                                 self.messages.append(message.decode()))
        self.nx = self.md.numberOfContinuousStates if version == "2" else len(self.md.derivatives)

    def call(self, function, *args) -> int:
        """The status of a call (fmpy raises above Warning: its status is the answer)."""
        from fmpy.fmi1 import FMICallException
        try:
            getattr(self.fmu, function)(*args)
        except FMICallException as error:
            return error.status
        return 0

    def set(self, **values):
        for name, value in values.items():
            if self.version == "2":
                setter = self.fmu.setInteger if self.types[name] == "Integer" else self.fmu.setReal
                setter([self.vr[name]], [int(value) if self.types[name] == "Integer" else value])
            elif self.types[name] == "Int32":
                self.fmu.setInt32([self.vr[name]], [int(value)])
            else:
                self.fmu.setFloat64([self.vr[name]], [value])

    def get(self, *names):
        getter = self.fmu.getReal if self.version == "2" else self.fmu.getFloat64
        return getter([self.vr[n] for n in names])

    def initialize(self, **start) -> int:
        if self.version == "2":
            self.fmu.setupExperiment(startTime=0.0)
            self.fmu.enterInitializationMode()
        else:
            self.fmu.enterInitializationMode(startTime=0.0)
        self.set(**start)
        status = self.call("exitInitializationMode")
        if status == 0 and self.kind == "me":
            if self.version == "2":
                self.fmu.newDiscreteStates()
            else:
                self.fmu.updateDiscreteStates()
            self.fmu.enterContinuousTimeMode()
        return status

    def step(self, t, dt) -> int:
        return self.call("doStep", t, dt)

    def derivatives(self, t, x):
        self.fmu.setTime(t)
        self.fmu.setContinuousStates((ctypes.c_double * self.nx)(*x), self.nx)
        dx = (ctypes.c_double * self.nx)()
        if self.version == "2":
            self.fmu.getDerivatives(dx, self.nx)
        else:
            self.fmu.getContinuousStateDerivatives(dx, self.nx)
        return np.array(dx)

    def states(self):
        x = (ctypes.c_double * self.nx)()
        self.fmu.getContinuousStates(x, self.nx)
        return np.array(x)


def _run(host: Host, mechanism, q0, **parameters):
    """The record through the FMU: commands set at each sample; q and each muscle's L, f, P at the samples."""
    from scipy.integrate import solve_ivp
    k = len(mechanism.muscles)
    commands = _commands(k)
    names = [f"p_cmd_{m}" for m in mechanism.muscles]
    outputs = ["q", *(f"{kind}_{m}" for kind in ("L", "f", "P") for m in mechanism.muscles)]
    assert host.initialize(q0=q0, **parameters, **{n: c[0] for n, c in zip(names, commands)}) == 0, host.messages
    rows = [host.get(*outputs)]
    for j in range(TIME.size - 1):
        if host.kind == "cs":
            assert host.step(TIME[j], TIME[j + 1] - TIME[j]) == 0, host.messages
        else:  # the host integrates the FMU's derivatives
            solution = solve_ivp(host.derivatives, (TIME[j], TIME[j + 1]), host.states(), method="DOP853",
                                 rtol=1e-12, atol=1e-13)
            assert solution.success
            host.fmu.setTime(TIME[j + 1])
            host.fmu.setContinuousStates((ctypes.c_double * host.nx)(*solution.y[:, -1]), host.nx)
        # the commands of sample j + 1 before its outputs, as the library reports them (P: the commands)
        host.set(**{n: c[min(j + 1, TIME.size - 1)] for n, c in zip(names, commands)})
        rows.append(host.get(*outputs))
    return np.array(rows)


#: Each build takes ~10-20 s (tracing 24 effect variants): the pulley (two muscles) runs by default, the
#: hanging mass and the cam lever file with MKCTL_SLOW=1.
MECHANISMS = ("pulley_joint", pytest.param("hanging_mass", marks=pytest.mark.slow),
              pytest.param("cam_lever", marks=pytest.mark.slow))


@pytest.mark.parametrize("version", ["2", "3"])
@pytest.mark.parametrize("kind", ["cs", "me"])
@pytest.mark.parametrize("name", MECHANISMS)
def test_fmu_against_simulate_mechanism(built, tmp_path, name, kind, version):
    mechanism = _mechanism(name)
    k = len(mechanism.muscles)
    reference = mech.simulate_mechanism(TIME, _commands(k), mechanism)
    assert np.ptp(reference.q) > 1e-3  # it moves
    host = Host(built[name][version], tmp_path / "fmu", version, kind)
    assert host.nx == 2 + k
    got = _run(host, mechanism, float(reference.q[0]))
    np.testing.assert_allclose(got[:, 0], reference.q, rtol=0, atol=1e-9)
    np.testing.assert_allclose(got[:, 1:1 + k], reference.L, rtol=0, atol=1e-9)
    # the tension: dL of 1e-9 m times a muscle's stiffness (~1e4 N/m)
    np.testing.assert_allclose(got[:, 1 + k:1 + 2 * k], reference.f, rtol=1e-7, atol=1e-6)
    np.testing.assert_array_equal(got[:, 1 + 2 * k:], reference.P)


@pytest.mark.parametrize("kind", ["cs", "me"])
@pytest.mark.parametrize("name", ["pulley_joint", pytest.param("hanging_mass", marks=pytest.mark.slow)])
def test_effects_a_pressure_lag_and_damping(built, tmp_path, name, kind):
    """tau > 0 makes each muscle's pressure a state (another generated variant, 2 + k states), c > 0 damps."""
    from mkctl.physics.params import Params
    mechanism = _mechanism(name)
    k = len(mechanism.muscles)
    effects = {"tau": 0.02, "c": 30.0, "Fc": 2.0}
    reference = mech.simulate_mechanism(TIME, _commands(k), mechanism, Params(**effects))
    host = Host(built[name]["2"], tmp_path / "fmu", "2", kind)
    got = _run(host, mechanism, float(reference.q[0]), **effects)
    np.testing.assert_allclose(got[:, 0], reference.q, rtol=0, atol=1e-9)
    # the lag states: both integrators' absolute tolerance on a pressure is 1e-3 Pa
    np.testing.assert_allclose(got[:, 1 + 2 * k:], reference.P, rtol=1e-9, atol=1e-2)
    assert np.ptp(reference.P) > 1e4 and not np.array_equal(reference.P, np.array(_commands(k)).T)


@pytest.mark.parametrize("name", MECHANISMS)
def test_derivatives_and_stable_against_the_library(built, tmp_path, name):
    mechanism = _mechanism(name)
    p = mechanism.bind()
    k = len(mechanism.muscles)
    commands = (320e3, 280e3)[:k]
    host = Host(built[name]["2"], tmp_path / "fmu", "2", "me")
    q_eq = mech.equilibrium(mechanism, commands, p)
    assert host.initialize(q0=q_eq, **{f"p_cmd_{m}": c for m, c in zip(mechanism.muscles, commands)}) == 0
    stops = mechanism.stop_positions(p)
    for q, qdot in ((q_eq, 0.0), (q_eq * 0.98 + 0.02 * stops[0], 0.3), (stops[1] + 0.001 * abs(stops[1]), -0.2)):
        want = mech.mechanism_derivatives((q, qdot), commands, mechanism, p, stops)
        got = host.derivatives(0.0, [q, qdot, *commands])  # the lag states are inert without a lag
        np.testing.assert_allclose(got[:2], want, rtol=1e-12, atol=1e-12)
        assert list(got[2:]) == [0.0] * k
        a1, a2 = mech.stability_coefficients(mechanism, q, commands, p, qdot)
        assert host.fmu.getBoolean([host.vr["stable"]])[0] == bool(a1 < 0 and a2 < 0)
        np.testing.assert_allclose(host.get("a1", "a2"), [a1, a2], rtol=1e-10)


def test_inputs_and_parameters_out_of_range_are_errors_with_the_library_words(built, tmp_path):
    from mkctl.errors import MkctlError
    mechanism = _mechanism("hanging_mass")
    path = built["hanging_mass"]["2"]
    # a negative pressure command: the step is refused, not run
    host = Host(path, tmp_path / "a", "2", "cs")
    assert host.initialize() == 0
    host.set(p_cmd_muscle=-1.0)
    assert host.step(0.0, 0.01) in (2, 3)  # fmi2Discard or fmi2Error
    assert any("below 0" in m for m in host.messages)
    # a start coordinate outside the geometry (L > b): the library's message
    with pytest.raises(MkctlError) as library:
        mech.simulate_mechanism(TIME[:3], [np.full(3, 3e5)], mechanism, q0=0.3)
    host = Host(path, tmp_path / "b", "2", "cs")
    assert host.initialize(q0=0.3) == 3
    assert any(str(library.value) in m for m in host.messages), (host.messages, str(library.value))
    # an own parameter out of its bounds (FMI 3.0): Mechanism.bind's message
    pulley = _mechanism("pulley_joint")
    with pytest.raises(MkctlError) as library:
        pulley.bind(J=-1.0)
    host = Host(built["pulley_joint"]["3"], tmp_path / "c", "3", "cs")
    assert host.initialize(J=-1.0) == 3
    assert any(str(library.value) in m for m in host.messages), (host.messages, str(library.value))


def _build_fmu(*args, cwd: Path):
    return subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), *args], capture_output=True, text=True,
                          cwd=cwd, timeout=300)


BAD_FILES = {
    "a parameter named like an FMU variable": '''
def lengths(q, p, xp):
    return (p.q0 - 0.01 * q,)
def inertia(q, p, xp):
    return 1.0
def load(q, qdot, p, xp):
    return -10.0 * xp.sin(q)
def stops(p):
    return (-0.5, 0.5)
MECHANISM = {"name": "clash", "coordinate": {"name": "phi", "unit": "rad"}, "muscles": ["m1"],
             "parameters": [{"name": "q0", "unit": "m", "default": 0.2, "lower": 0.1, "upper": 0.23}],
             "lengths": lengths, "inertia": inertia, "load": load, "stops": stops}
''',
    "a length that cannot be traced": '''
def lengths(q, p, xp):
    return (0.2 if q > 0 else 0.19,)
def inertia(q, p, xp):
    return 1.0
def load(q, qdot, p, xp):
    return 0.0
def stops(p):
    return (-0.5, 0.5)
MECHANISM = {"name": "branchy", "coordinate": {"name": "phi", "unit": "rad"}, "muscles": ["m1"],
             "parameters": [], "lengths": lengths, "inertia": inertia, "load": load, "stops": stops}
''',
}


@pytest.mark.parametrize("problem", list(BAD_FILES))
def test_build_refuses_a_bad_mechanism_file_in_one_line(tmp_path, problem):
    path = tmp_path / "bad_mechanism.py"
    path.write_text(BAD_FILES[problem])
    done = _build_fmu("--mechanism", str(path), "--out", str(tmp_path / "dist"), cwd=tmp_path)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("build_fmu: ") and "Traceback" not in done.stderr, done.stderr
    assert not (tmp_path / "dist" / "native").exists() or not any((tmp_path / "dist" / "native").iterdir())


@pytest.mark.parametrize("name, model", [("pulley_joint", "McKibbenPulleyJoint"),
                                         pytest.param("hanging_mass", "McKibbenHangingMass", marks=pytest.mark.slow),
                                         pytest.param("cam_lever", "McKibbenCamLever", marks=pytest.mark.slow)])
def test_model_names_and_the_variables_a_host_sees(built, name, model):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu
    mechanism = _mechanism(name)
    for version in ("2", "3"):
        path = built[name][version]
        assert path.name == f"{model}.fmu" and validate_fmu(str(path)) == []
        md = read_model_description(str(path))
        assert md.modelExchange is not None and md.coSimulation is not None
        variables = {v.name: v for v in md.modelVariables}
        inputs = [v.name for v in md.modelVariables if v.causality == "input"]
        assert inputs == [f"p_cmd_{m}" for m in mechanism.muscles]
        for own in mechanism.parameters:
            assert float(variables[own.name].start) == own.start
        assert float(variables["q0"].start) == pytest.approx(
            mech.equilibrium(mechanism, (3e5,) * len(mechanism.muscles), mechanism.bind()), abs=1e-12)
        outputs = {v.name for v in md.modelVariables if v.causality == "output"}
        assert {"q", "qdot", "a1", "a2", "stable"} <= outputs
        assert {f"{kind}_{m}" for kind in ("L", "f", "P") for m in mechanism.muscles} <= outputs
        # built without the air (tests/test_mechanism_fmu_air.py builds it with): none of it offered
        air = {"valve_flow", "C_fill", "C_leak", *(f"q_{m}" for m in mechanism.muscles)}
        assert not air & set(variables)


@pytest.mark.slow
@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_the_windows_binary_under_wine_gives_the_linux_results(wine, hosts, tmp_path_factory, version):
    """The pulley FMU built with every platform's binary (as the knee's: tests/test_win64.py), its DLL run by the
    cross-compiled C host under Wine against the Linux one, to 1e-9."""
    import zipfile

    from toolchain_helpers import host_arguments as _arguments, run_host as _run_host
    from mkctl.native.mechanism_fmu import build_mechanism
    command, env = wine
    out = tmp_path_factory.mktemp("mechanism_win64")
    paths = build_mechanism(_mechanism("pulley_joint"), out)
    folder = out / version
    with zipfile.ZipFile(paths[f"{'native' if version == 'fmi2' else 'fmi3'}/McKibbenPulleyJoint"]) as archive:
        archive.extractall(folder)
    arguments = _arguments(folder, "q", 0.5, p_cmd_muscle1=3.3e5, tau=0.02, c=5.0)
    linux = _run_host([str(hosts[version, "linux"]), *arguments], env={})
    windows = _run_host([*command, str(hosts[version, "windows"]), *arguments], env=env)
    assert linux.shape == windows.shape == (501, 2) and np.ptp(linux[:, 1]) > 1e-2  # it moved
    np.testing.assert_allclose(windows, linux, rtol=0, atol=1e-9)


# --- the knee as a system of FMUs (McKibbenKneeSystem.ssp) ----------------------------------------------------------

#: The knee's run: damping c = 40 N s/m in every FMU, the extensor command stepped by 5 % at 0.1 s, 0.5 s long.
SSP_STOP, SSP_STEP_AT, DAMPING = 0.5, 0.1, 40.0


@pytest.fixture(scope="module")
def knee_system(tmp_path_factory):
    """(the SSP file, the monolithic native knee FMU), built without the other platforms' binaries."""
    from mkctl.native.fmu import build_one
    from mkctl.native.ssp import build_knee_ssp
    out = tmp_path_factory.mktemp("knee_ssp")
    return build_knee_ssp(out, platforms=False), build_one("McKibbenKnee", out / "McKibbenKnee.fmu", windows=False)


def _monolithic(knee_fmu: Path, folder: Path, dt: float) -> np.ndarray:
    """X of the monolithic knee FMU at every dt (its integrator is adaptive: dt only sets the samples)."""
    from mkctl.physics.simulate import default_commands
    pe0, _ = default_commands()
    host = Host(knee_fmu, folder, "2", "cs")
    assert host.initialize(c=DAMPING) == 0
    X = [host.get("X")[0]]
    for j in range(round(SSP_STOP / dt)):
        if abs(j * dt - SSP_STEP_AT) < 1e-12:
            host.set(pe_cmd=pe0 * 1.05)
        assert host.step(j * dt, dt) == 0
        X.append(host.get("X")[0])
    return np.array(X)


def _system_in_fmpy(ssp: Path, folder: Path, dt: float) -> np.ndarray:
    """q of the mechanism in the SSP system, run by a small master loop over fmpy's FMU2Slave: the SSD's
    components, parameter bindings and connections (fmpy.ssp.ssd.read_ssd); at each communication point the
    mechanism's outputs go to the actuators, their tensions (which depend on those inputs at once) back,
    then every FMU steps by dt with its inputs held."""
    import zipfile

    from fmpy.ssp.ssd import read_ssd
    from mkctl.physics.simulate import default_commands
    pe0, _ = default_commands()
    with zipfile.ZipFile(ssp) as archive:
        archive.extractall(folder / "ssp")
    system = read_ssd(str(ssp), validate=True).system
    hosts_ = {c.name: Host(folder / "ssp" / c.source, folder / c.name, "2", "cs") for c in system.elements}
    for component in system.elements:
        start = {"c": DAMPING} if component.name != "mechanism" else {}
        for binding in component.parameterBindings or []:
            for parameter_set in binding.parameterValues:
                start.update({parameter.name: float(parameter.value) for parameter in parameter_set.parameters})
        assert hosts_[component.name].initialize(**start) == 0
    connections = [(c.startElement, c.startConnector, c.endElement, c.endConnector) for c in system.connections]

    def exchange():  # the mechanism's outputs first (no feedthrough), then the actuators' tensions
        for a, output, b, target in sorted(connections, key=lambda c: c[0] != "mechanism"):
            hosts_[b].set(**{target: hosts_[a].get(output)[0]})

    q = [hosts_["mechanism"].get("q")[0]]
    for j in range(round(SSP_STOP / dt)):
        if abs(j * dt - SSP_STEP_AT) < 1e-12:
            hosts_["extensor"].set(p_cmd=pe0 * 1.05)
        exchange()
        for host in hosts_.values():
            assert host.step(j * dt, dt) == 0, host.messages
        q.append(hosts_["mechanism"].get("q")[0])
    return np.array(q)


def test_the_ssp_file_is_valid_and_connects_the_mechanism_to_two_actuators(knee_system):
    from fmpy.ssp.ssd import read_ssd
    ssp, _ = knee_system
    system = read_ssd(str(ssp), validate=True).system  # against the SSP 1.0 schema fmpy ships
    assert [(e.name, Path(e.source).name) for e in system.elements] == [
        ("mechanism", "McKibbenKneeMechanism.fmu"), ("extensor", "McKibbenActuator.fmu"),
        ("flexor", "McKibbenActuator.fmu")]
    pairs = {(c.startElement, c.startConnector, c.endElement, c.endConnector) for c in system.connections}
    for muscle in ("extensor", "flexor"):
        assert {("mechanism", f"L_{muscle}", muscle, "L"), ("mechanism", f"Ldot_{muscle}", muscle, "Ldot"),
                (muscle, "f", "mechanism", f"f_{muscle}")} <= pairs


def test_the_system_of_fmus_converges_to_the_monolithic_knee_as_the_step_shrinks(knee_system, tmp_path):
    """The co-simulation's error (inputs held over each step) falls with the communication step, to the
    monolithic knee FMU's X; the mechanism alone's q is the same hip height."""
    ssp, knee_fmu = knee_system
    errors = {}
    for dt in (2e-3, 1e-3, 5e-4):
        reference = _monolithic(knee_fmu, tmp_path / f"knee{dt}", dt)
        q = _system_in_fmpy(ssp, tmp_path / f"system{dt}", dt)
        assert q.shape == reference.shape and np.ptp(reference) > 1e-3  # it moved
        errors[dt] = float(np.max(np.abs(q - reference)))
    print("max |X_system - X_knee| by step:", errors)
    assert errors[5e-4] < errors[1e-3] < errors[2e-3] < 1e-3
    assert errors[2e-3] / errors[5e-4] > 2.5  # first order in the step, at least


LIBCOSIM_SYSTEM = r"""
import json, sys
from libcosimpy.CosimEnums import CosimVariableType
from libcosimpy.CosimExecution import CosimExecution
from libcosimpy.CosimLogging import CosimLogLevel, log_output_level
from libcosimpy.CosimManipulator import CosimManipulator
from libcosimpy.CosimObserver import CosimObserver
log_output_level(CosimLogLevel.ERROR)
ssp, pe1, stop, dt, at, damping = sys.argv[1], *map(float, sys.argv[2:])
ns, steps = round(dt * 1e9), round(stop / dt)
execution = CosimExecution.from_ssp_file(ssp_path=ssp, step_size=ns)
index = {name: execution.slave_index_from_instance_name(name) for name in ("mechanism", "extensor", "flexor")}
vr = {name: {v.name.decode(): v.reference for v in execution.slave_variables(i)} for name, i in index.items()}
for muscle in ("extensor", "flexor"):
    execution.real_initial_value(index[muscle], vr[muscle]["c"], damping)
observer = CosimObserver.create_time_series()
execution.add_observer(observer)
override = CosimManipulator.create_override()
execution.add_manipulator(override)
observer.start_time_series(index["mechanism"], vr["mechanism"]["q"], CosimVariableType.REAL)
ok = [execution.simulate_until(round(at / dt) * ns)]
override.slave_real_values(index["extensor"], [vr["extensor"]["p_cmd"]], [pe1])
ok.append(execution.simulate_until(steps * ns))
times, _, q = observer.time_series_real_samples(index["mechanism"], vr["mechanism"]["q"], from_step=1,
                                                sample_count=steps)
print(json.dumps({"ok": ok, "time": [t / 1e9 for t in times], "q": list(q)}))
"""


@pytest.mark.slow
def test_libcosim_runs_the_ssp_file_near_the_monolithic_knee(knee_system, tmp_path):
    """libcosimpy reads the SSP file itself (components, connections, the parameter bindings' start commands)."""
    import json

    from mkctl.physics.simulate import default_commands
    pytest.importorskip("libcosimpy")
    ssp, knee_fmu = knee_system
    pe0, _ = default_commands()
    errors = {}
    for dt in (2e-3, 1e-3, 5e-4):
        done = subprocess.run([sys.executable, "-c", LIBCOSIM_SYSTEM, str(ssp), repr(pe0 * 1.05), repr(SSP_STOP),
                               repr(dt), repr(SSP_STEP_AT), repr(DAMPING)], capture_output=True, text=True,
                              timeout=300)
        assert done.returncode == 0, done.stderr[-2000:]
        run = json.loads(done.stdout.splitlines()[-1])
        assert run["ok"] == [True, True]
        reference = _monolithic(knee_fmu, tmp_path / f"knee{dt}", dt)[1:]
        q = np.array(run["q"])
        assert q.shape == reference.shape and np.allclose(run["time"], dt * np.arange(1, q.size + 1))
        errors[dt] = float(np.max(np.abs(q - reference)))
    print("libcosim: max |X_system - X_knee| by step:", errors)
    assert errors[5e-4] < errors[1e-3] < errors[2e-3] < 2e-3
    assert errors[2e-3] / errors[5e-4] > 2.5  # first order in the step, at least


HOSTILE = 'a lever */ #include "evil.h" %n%s \\ \' ?? <x/> & end'


def test_no_text_of_a_mechanism_file_reaches_the_c_or_breaks_the_xml(tmp_path):
    """A mechanism file's free text (its description) stays out of the generated C and comes back
    intact from the modelDescription (escaped by ElementTree)."""
    from xml.etree import ElementTree as ET

    from mkctl.analysis.mechanism_files import mechanism
    from mkctl.native import fmu
    from mkctl.native.mechanism_fmu import mechanism_interface
    text = CAM_LEVER.read_text().replace(
        '"description": "a lever lifted by one muscle over a cam"', f'"description": {HOSTILE!r}')
    assert text.count("evil.h") == 1
    path = tmp_path / "hostile_lever.py"
    path.write_text(text)
    interface = mechanism_interface(mechanism(str(path)))
    sources = [fmu.variables_source(interface), fmu.variables_header(interface, "{guid}"),
               *(source for _, source in interface.generated_sources)]
    assert not any("evil" in source or "*/ #include" in source for source in sources)
    root = ET.fromstring(fmu.model_description(interface, "{guid}", ["a.c"], interface.event_indicators))
    assert root.get("description").startswith(HOSTILE)
