"""Native mechanism FMUs built with the air (model-spec 4d, 7d; mkctl/native/mechanism_fmu.py, air).

With ``valve_flow`` on, each muscle's pressure is a state of its air's mass balance, coupled to the
motion through dV/dt (:func:`mkctl.physics.actuator.air_pressure_derivative`), and the FMU outputs
each muscle's net air mass flow ``q_<muscle>``. Each FMU (the pulley joint; the hanging mass with
MKCTL_SLOW=1; FMI 2.0 and 3.0) runs against the library's
:func:`mkctl.physics.mechanism.simulate_mechanism`, without and with a leak:

- Co-Simulation: q, qdot and the pressures to 1e-9 of their range, against simulate_mechanism as it
  runs (its compiled core: the same generated C, measured 1e-11) and against its Python loop (the
  library's equations in Python, independent of the generated C: q and qdot to 1e-9, measured 2e-10;
  the pressures to 1e-8, measured 2.8e-9: where the regulator's opening has a kink, at the band's
  edges and where it switches from filling to exhausting, a step across it amplifies the
  rounding-level differences of the generated right-hand side, as in the knee,
  tests/test_air_core.py). The commands change at every sample (steps and a small wobble), so that
  the library integrates each sample interval on its own, as the FMU's doStep does: the same steps
  of the same Dormand-Prince 5(4) at the same tolerances. (With commands held over many samples the
  library integrates the run in one go while the FMU restarts at every doStep; both then differ by
  their own integration error, about 1e-7 of P's range here.)
- Model Exchange: the host integrates the FMU's derivatives with scipy's DOP853 (rtol 1e-12, the
  event indicators not used) and agrees to 3e-6 of each range (measured up to 7.7e-7 of P's range,
  1.3e-7 of q's): the size of the library's own integration error across the regulator's kinks
  (simulate_mechanism at its rtol 1e-10 against rtol 1e-13: up to 4.2e-7 of P's range on these
  records), not the FMU's: its derivatives equal ``mechanism_derivatives`` to 1e-12 call by call,
  and an event indicator changes sign where the regulator switches from filling to exhausting.
- ``q_<muscle>`` against :func:`mkctl.physics.actuator.air_mass_flow` at the regulator's opening
  (:func:`~mkctl.physics.actuator.valve_opening`) of the FMU's recorded pressure and command.
- The interface: section 4d's names; ``tau_heat`` (``air_heat``) refused at the build in one line.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from mkctl.physics import actuator, backend
from mkctl.physics import mechanism as mech
from mkctl.physics.params import Params
from test_mechanism_fmu import ROOT, TIME, Host, _mechanism

pytest.importorskip("fmpy")

#: The air on, the build's start values (the default valve of model-spec 4d).
AIR = {"valve_flow": 1}
#: A leak strong enough to show in 0.6 s (C_leak [m^3/(s Pa)]: a leak-down time constant of ~2 s).
LEAK = {"C_leak": 1e-10}


class BuiltWithAir(dict):
    """The FMUs built with the air by mechanism name, then "2" / "3", built when first asked."""

    def __init__(self, out: Path):
        super().__init__()
        self.out = out

    def __missing__(self, name):
        from mkctl.native.mechanism_fmu import build_mechanism
        paths = build_mechanism(_mechanism(name), self.out, Params(**AIR), platforms=False)
        self[name] = {"2": next(p for k, p in paths.items() if k.startswith("native/")),
                      "3": next(p for k, p in paths.items() if k.startswith("fmi3/"))}
        return self[name]


@pytest.fixture(scope="module")
def built_air(tmp_path_factory):
    from mkctl.native.build import find_compiler
    if find_compiler() is None:
        pytest.fail("no C compiler: the native mechanism FMUs need one")
    return BuiltWithAir(tmp_path_factory.mktemp("mechanism_air_fmus"))


def _commands(k):
    """Each muscle's command [Pa] at the samples: steps beyond the regulator's band (it saturates,
    fills and exhausts) and a 2 kPa wobble at 3 Hz, so that every sample brings a new command."""
    wobble = 2e3 * np.sin(2 * np.pi * 3.0 * TIME)
    if k == 1:
        return [np.where(TIME < 0.1, 300e3, np.where(TIME < 0.3, 350e3, 280e3)) + wobble]
    return [np.where(TIME < 0.1, 300e3, np.where(TIME < 0.3, 330e3, 290e3)) + wobble,
            np.where(TIME < 0.1, 300e3, np.where(TIME < 0.3, 285e3, 315e3)) - wobble]


def _run(host: Host, mechanism, q0, **parameters):
    """The record through the FMU, commands set at each sample: rows of q, qdot, each P, each
    q_<muscle>; and the commands (samples, muscles)."""
    import ctypes

    from scipy.integrate import solve_ivp
    k = len(mechanism.muscles)
    commands = _commands(k)
    names = [f"p_cmd_{m}" for m in mechanism.muscles]
    outputs = ["q", "qdot", *(f"P_{m}" for m in mechanism.muscles),
               *(f"q_{m}" for m in mechanism.muscles)]
    start = {n: c[0] for n, c in zip(names, commands)}
    assert host.initialize(q0=q0, **parameters, **start) == 0, host.messages
    rows = [host.get(*outputs)]
    for j in range(TIME.size - 1):
        if host.kind == "cs":
            assert host.step(TIME[j], TIME[j + 1] - TIME[j]) == 0, host.messages
        else:  # the host integrates the FMU's derivatives
            solution = solve_ivp(host.derivatives, (TIME[j], TIME[j + 1]), host.states(),
                                 method="DOP853", rtol=1e-12, atol=1e-13)
            assert solution.success
            host.fmu.setTime(TIME[j + 1])
            host.fmu.setContinuousStates((ctypes.c_double * host.nx)(*solution.y[:, -1]), host.nx)
        host.set(**{n: c[j + 1] for n, c in zip(names, commands)})
        rows.append(host.get(*outputs))
    return np.array(rows), np.array(commands).T


AIR_MECHANISMS = ("pulley_joint", pytest.param("hanging_mass", marks=pytest.mark.slow))


@pytest.mark.parametrize("leak", [False, True], ids=["valve", "valve+leak"])
@pytest.mark.parametrize("version", ["2", "3"])
@pytest.mark.parametrize("kind", ["cs", "me"])
@pytest.mark.parametrize("name", AIR_MECHANISMS)
def test_fmu_with_the_air_against_simulate_mechanism(built_air, tmp_path, name, kind, version,
                                                     leak):
    mechanism = _mechanism(name)
    k = len(mechanism.muscles)
    extra = {**AIR, **(LEAK if leak else {})}
    params = Params(**extra)
    reference = mech.simulate_mechanism(TIME, _commands(k), mechanism, params)
    previous = backend.install_mechanism(None)  # the Python loop
    try:
        python = mech.simulate_mechanism(TIME, _commands(k), mechanism, params)
    finally:
        backend.install_mechanism(previous)
    host = Host(built_air[name][version], tmp_path / "fmu", version, kind)
    assert host.nx == 2 + k
    got, commands = _run(host, mechanism, float(reference.q[0]), **extra)
    q, qdot, P, flows = got[:, 0], got[:, 1], got[:, 2:2 + k], got[:, 2 + k:]
    # the air is on: the pressures are states, not the commands, and the valves fill and exhaust
    assert np.abs(reference.P - commands).max() > 5e3
    assert flows.min() < 0 < flows.max()
    for run, bound, P_bound in ((reference, 1e-9, 1e-9), (python, 1e-9, 1e-8)):
        if kind == "me":
            bound = P_bound = 3e-6
        assert np.abs(q - run.q).max() <= bound * np.ptp(run.q)
        assert np.abs(qdot - run.qdot).max() <= bound * np.ptp(run.qdot)
        for i in range(k):
            assert np.abs(P[:, i] - run.P[:, i]).max() <= P_bound * np.ptp(run.P[:, i])
    # each muscle's mass flow: the library's at the FMU's recorded pressure and the command in force
    opening = actuator.valve_opening(P, commands, params)
    want = np.array(actuator.air_mass_flow(P, opening, params))
    np.testing.assert_allclose(flows, want, rtol=1e-12, atol=1e-12 * np.abs(want).max())


@pytest.mark.parametrize("name", AIR_MECHANISMS)
def test_derivatives_and_event_indicators_with_the_air(built_air, tmp_path, name):
    """Model Exchange's derivatives equal mechanism_derivatives (the pressures from the air's mass
    balance); an event indicator changes sign where a muscle's regulator switches from filling to
    exhausting."""
    import ctypes
    mechanism = _mechanism(name)
    k = len(mechanism.muscles)
    params = Params(**AIR, **LEAK)
    p = mechanism.bind(params)
    commands = (320e3, 280e3)[:k]
    q_eq = mech.equilibrium(mechanism, commands, p)
    host = Host(built_air[name]["2"], tmp_path / "fmu", "2", "me")
    start = {f"p_cmd_{m}": c for m, c in zip(mechanism.muscles, commands)}
    assert host.initialize(q0=q_eq, **LEAK, **start) == 0
    stops = mechanism.stop_positions(p)
    rng = np.random.default_rng(5)
    for _ in range(20):
        state = [rng.uniform(*stops), rng.normal(0.0, 0.3),
                 *(c + rng.normal(0.0, 3e4) for c in commands)]
        want = mech.mechanism_derivatives(state, commands, mechanism, p, stops)
        np.testing.assert_allclose(host.derivatives(0.0, state), want, rtol=1e-12, atol=1e-9)
    nz = host.md.numberOfEventIndicators

    def indicators(P1):
        state = (ctypes.c_double * host.nx)(q_eq, 0.0, P1, *commands[1:])
        host.fmu.setContinuousStates(state, host.nx)
        z = (ctypes.c_double * nz)()
        host.fmu.getEventIndicators(z, nz)
        return np.array(z)

    below, above = indicators(commands[0] - 10.0), indicators(commands[0] + 10.0)
    assert np.any(np.sign(below) != np.sign(above)), "no event indicator at the regulator's switch"


def test_the_interface_with_the_air(built_air):
    from fmpy import read_model_description
    from fmpy.validation import validate_fmu
    mechanism = _mechanism("pulley_joint")
    for version in ("2", "3"):
        path = built_air["pulley_joint"][version]
        assert validate_fmu(str(path)) == []
        variables = {v.name: v for v in read_model_description(str(path)).modelVariables}
        assert {"valve_flow", "C_fill", "C_exhaust", "P_supply", "band", "b_cr", "m_sub", "k_poly",
                "V_dead", "T_air", "C_leak"} <= set(variables) and "tau_heat" not in variables
        assert int(variables["valve_flow"].start) == 1
        for m in mechanism.muscles:
            assert variables[f"q_{m}"].causality == "output" and variables[f"q_{m}"].unit == "kg/s"


def test_the_air_switched_off_in_an_fmu_built_with_it(built_air, tmp_path):
    """valve_flow = 0 at run time: the section 4 pressure path (the pressures the commands, no flow),
    the library's run without the air."""
    mechanism = _mechanism("pulley_joint")
    reference = mech.simulate_mechanism(TIME, _commands(2), mechanism, Params())
    host = Host(built_air["pulley_joint"]["2"], tmp_path / "fmu", "2", "cs")
    got, commands = _run(host, mechanism, float(reference.q[0]), valve_flow=0)
    assert np.abs(got[:, 0] - reference.q).max() <= 1e-9 * np.ptp(reference.q)
    np.testing.assert_array_equal(got[:, 2:4], commands)
    assert not np.any(got[:, 4:])


def test_the_airs_temperature_is_refused_in_one_line(tmp_path):
    muscle = tmp_path / "hot.json"
    muscle.write_text('{"params": {"valve_flow": 1, "tau_heat": 0.5}}')
    command = [sys.executable, str(ROOT / "build_fmu.py"), "--mechanism", "pulley_joint",
               "--params", str(muscle), "--out", str(tmp_path / "dist")]
    done = subprocess.run(command, capture_output=True, text=True, cwd=tmp_path, timeout=300)
    assert done.returncode == 2, done.stderr
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and "air_heat" in lines[0], done.stderr
    assert "Traceback" not in done.stderr
    assert not (tmp_path / "dist" / "native").exists()
