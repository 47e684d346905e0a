"""Valve openings as inputs (model-spec 4d, 7d; issue 28): the knee and a mechanism driven by their
switching valves' openings (1 open to the supply, 0 closed, -1 open to the exhaust), and the FMUs
built so.

The references are independent of mkctl's air path: the ISO 6358 flow, the volume and the opening
of tests/independent_pneumatics.py, the knee's geometry and tension of tests/independent_rig.py, a
hanging mass of tests/independent_mechanisms.py, and the mass balance written here,
``dp/dt = (k / V) (R T q - p dV/dt)``, integrated by scipy's solve_ivp (Radau) sample by sample;
the FMUs against the library.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import independent_mechanisms as im
import independent_pneumatics as ip
import independent_rig as rig
from mkctl.errors import DomainError, ParameterError
from mkctl.physics import knee, mechanism, simulate, stability
from mkctl.physics.params import Params

#: The air's values every test here uses (the spec's typical valve).
AIR = {
    "C_fill": 5e-9,
    "C_exhaust": 0.0,
    "P_supply": 2e6,
    "band": 2e4,
    "b_cr": 0.3,
    "m_sub": 0.5,
    "k_poly": 1.2,
    "V_dead": 5e-6,
    "T_air": 293.15,
    "C_leak": 0.0,
}


def air_params(**values) -> Params:
    return Params(
        valve_flow=1, c=45.0, **{**{k: v for k, v in AIR.items() if k != "C_leak"}, **values}
    )


def _clip(u):
    return min(max(u, -1.0), 1.0)


def _air_rate(P, u, L, Ldot, a, n, b):
    """The test's own mass balance of one muscle through a switching valve of opening u."""
    q = ip.net_flow(ip.opening("opening", _clip(u), P, a), P, a, a["T_air"])
    V = ip.volume(L, b, n, a["V_dead"])
    dV_dt = ip.volume_slope(L, b, n) * Ldot
    return a["k_poly"] / V * (ip.R * a["T_air"] * q - (P + ip.P_ATM) * dV_dt)


def independent_knee(time, ue, uf, P0, p: Params, a: dict):
    """The knee with the air driven by openings, from the spec's equations: (X, V, Pe, Pf)."""
    n = rig.turns(p)
    hidden = {"c": p.c}
    y = np.array([rig.rest_height(P0[0], P0[1], p), 0.0, *P0])
    out = np.empty((time.size, 4))
    out[0] = y
    for k in range(time.size - 1):

        def rhs(t, s, ue=ue[k], uf=uf[k]):
            Le, Lf, Ge, Gf = (float(v) for v in rig.knee_geometry(s[0], p))
            F = Ge * float(rig.tension(Le, s[2], -Ge * s[1], p, hidden)) - Gf * float(
                rig.tension(Lf, s[3], Gf * s[1], p, hidden)
            )
            return [
                s[1],
                F / p.m - p.g,
                _air_rate(s[2], ue, Le, -Ge * s[1], a, n, p.b),
                _air_rate(s[3], uf, Lf, Gf * s[1], a, n, p.b),
            ]

        sol = solve_ivp(
            rhs,
            (time[k], time[k + 1]),
            y,
            method="Radau",
            rtol=1e-11,
            atol=[1e-12, 1e-12, 1e-5, 1e-5],
        )
        assert sol.success, sol.message
        y = sol.y[:, -1]
        out[k + 1] = y
    return out


def _start(p, Pf=1e5, alpha=math.radians(60.0)):
    return float(stability.equilibrium_pressure(alpha, Pf, p)), Pf


def _compare(time, ue, uf, P0, p):
    ours = simulate.simulate_knee(time, ue, uf, p, stops=False, rtol=1e-11, inputs="opening", P0=P0)
    theirs = independent_knee(
        time, np.broadcast_to(ue, time.shape), np.broadcast_to(uf, time.shape), P0, p, AIR
    )
    return ours, theirs


def test_a_fill_from_closed_matches_an_independent_simulator():
    p = air_params()
    P0 = _start(p)
    time = np.linspace(0.0, 0.1, 41)
    # closed, then the extensor's valve opens a third (a proportional valve): the leg rises
    ue = np.where(time < 0.02, 0.0, 0.3)
    ours, theirs = _compare(time, ue, 0.0, P0, p)
    closed = time <= 0.02
    # closed at rest: nothing moves (the start is an equilibrium, the air sealed)
    assert np.max(np.abs(ours.Pe[closed] - P0[0])) < 1e-6
    assert np.ptp(theirs[:, 0]) > 1e-3  # the leg moves (millimetres)
    assert ours.Pe[-1] > P0[0] + 1e4  # the extensor fills
    # measured: 5e-11 m, 6e-10 m/s, 3e-4 Pa and 5e-5 Pa
    assert np.max(np.abs(ours.X - theirs[:, 0])) < 1e-8
    assert np.max(np.abs(ours.V - theirs[:, 1])) < 1e-7
    assert np.max(np.abs(ours.Pe - theirs[:, 2])) < 0.2
    assert np.max(np.abs(ours.Pf - theirs[:, 3])) < 0.2
    # the flexor is sealed (uf = 0): its air is squeezed and expanded by the motion alone
    assert np.max(np.abs(ours.Pf - P0[1])) > 10.0


def test_a_switching_sequence_matches_an_independent_simulator():
    p = air_params()
    P0 = _start(p)
    time = np.linspace(0.0, 0.12, 49)
    # 1 / 0 / -1 on the extensor (full opening: the flow chokes), the flexor the other way round;
    # 1.5 and -3 are clipped to 1 and -1
    ue = np.select([time < 0.01, time < 0.05, time < 0.07], [1.5, 0.0, -1.0], 0.0)
    uf = np.select([time < 0.01, time < 0.05, time < 0.07], [-1.0, 0.0, 1.0], -3.0)
    ours, theirs = _compare(time, ue, uf, P0, p)
    assert np.ptp(theirs[:, 2]) > 1e5 and np.ptp(theirs[:, 3]) > 5e4  # the valves move the air
    # measured: 1.1e-9 m, 3.3e-8 m/s, 0.003 Pa and 0.08 Pa (of swings of 400 and 750 kPa)
    assert np.max(np.abs(ours.X - theirs[:, 0])) < 1e-8
    assert np.max(np.abs(ours.V - theirs[:, 1])) < 1e-7
    assert np.max(np.abs(ours.Pe - theirs[:, 2])) < 0.2
    assert np.max(np.abs(ours.Pf - theirs[:, 3])) < 0.2
    # the clip: 1.5 runs as 1, -3 as -1
    clipped = simulate.simulate_knee(
        time,
        np.clip(ue, -1, 1),
        np.clip(uf, -1, 1),
        p,
        stops=False,
        rtol=1e-11,
        inputs="opening",
        P0=P0,
    )
    assert np.array_equal(clipped.Pe, ours.Pe) and np.array_equal(clipped.X, ours.X)


def test_openings_are_not_the_pressure_path():
    """The same numbers as set-points give another run: the keyword really switches the inputs."""
    p = air_params()
    P0 = _start(p)
    time = np.linspace(0.0, 0.02, 5)
    run = simulate.simulate_knee(time, 0.0, 0.0, p, inputs="opening", P0=P0)
    assert np.allclose(run.Pe, P0[0], atol=1e-6)  # sealed at rest
    default = simulate.simulate_knee(time, 0.0, 0.0, p, inputs="opening")
    assert default.Pe[0] == simulate.default_start_pressures(p)[0]
    assert math.isclose(default.X[0], simulate.default_hip_height(p), rel_tol=1e-9)


def test_openings_without_the_air_are_refused_in_one_line():
    time = np.linspace(0.0, 0.1, 3)
    with pytest.raises(ParameterError, match=r"openings as inputs need the air.*valve_flow = 1"):
        simulate.simulate_knee(time, 1.0, 0.0, Params(c=40.0), inputs="opening")
    with pytest.raises(ParameterError, match="valve_flow = 1"):
        mechanism.simulate_mechanism(
            time,
            [1.0],
            mechanism.builtin_mechanism("hanging_mass"),
            Params(m=5.0),
            inputs="opening",
            P0=[3e5],
        )
    with pytest.raises(ParameterError, match="inputs = 'valve'"):
        simulate.simulate_knee(time, 1.0, 0.0, air_params(), inputs="valve")
    with pytest.raises(DomainError, match="valve opening ue = nan"):
        simulate.simulate_knee(time, [0.0, np.nan, 0.0], 0.0, air_params(), inputs="opening")
    with pytest.raises(ParameterError, match="need P0"):
        mechanism.simulate_mechanism(
            time,
            [1.0],
            mechanism.builtin_mechanism("hanging_mass"),
            air_params(m=5.0),
            inputs="opening",
        )


def test_valve_input_clips_to_the_valves_range():
    assert [knee.valve_input(u) for u in (-2.0, -1.0, -0.25, 0.0, 0.5, 1.0, 7.0)] == [
        -1.0,
        -1.0,
        -0.25,
        0.0,
        0.5,
        1.0,
        1.0,
    ]
    assert np.array_equal(knee.valve_input(np.array([-5.0, 0.3, 5.0])), [-1.0, 0.3, 1.0])


def independent_hanging(time, u, P0, p, a, mech):
    n = rig.turns(p)
    y = np.array([im.rest(mech, [P0], p), 0.0, P0])
    out = np.empty((time.size, 3))
    out[0] = y
    for k in range(time.size - 1):

        def rhs(t, s, u=u[k]):
            F = im.generalized_force(mech, s[0], s[1], [s[2]], p) + im.stop_force(mech, s[0], s[1])
            return [s[1], F / p.m, _air_rate(s[2], u, s[0], s[1], a, n, p.b)]

        sol = solve_ivp(
            rhs, (time[k], time[k + 1]), y, method="Radau", rtol=1e-11, atol=[1e-12, 1e-12, 1e-5]
        )
        y = sol.y[:, -1]
        out[k + 1] = y
    return out


def test_a_hanging_mass_driven_by_its_valve_matches_an_independent_simulator():
    p = air_params(m=5.0)
    hanging = mechanism.builtin_mechanism("hanging_mass")
    time = np.linspace(0.0, 0.12, 25)
    u = np.select([time < 0.02, time < 0.06], [0.0, 0.2], -0.5)  # closed, fill, exhaust
    run = mechanism.simulate_mechanism(time, u, hanging, p, rtol=1e-11, inputs="opening", P0=[3e5])
    theirs = independent_hanging(time, u, 3e5, p, AIR, im.hanging_mass(p))
    assert np.ptp(theirs[:, 0]) > 1e-3 and np.ptp(theirs[:, 2]) > 5e4
    assert np.max(np.abs(run.q - theirs[:, 0])) < 1e-8
    assert np.max(np.abs(run.P[:, 0] - theirs[:, 2])) < 0.2


# --- the native knee FMU built with valve inputs (model-spec 7d) ----------------------------------

#: A valve of moderate size on a damped knee, with a leak: the FMU's start values in these tests.
FMU_START = dict(valve_flow=1, C_fill=1e-9, C_leak=2e-12, c=40.0)
FMU_OUTPUTS = ("X", "V", "alpha", "beta", "Le", "Lf", "fe", "ff", "Pe", "Pf", "F", "a1", "a2")


def _openings(k):
    """Step k of 1 ms: ue closed, open to the supply at 50 ms, closed at 150, open to the exhaust
    at 250, a third open at 300, 1.5 (clipped to 1) at 450; uf closed, half open to the exhaust at
    100 ms, open to the supply at 200, closed at 260, -2 (clipped to -1) at 400."""
    ue = (
        0.0
        if k < 50
        else 1.0 if k < 150 else 0.0 if k < 250 else -1.0 if k < 300 else 0.3 if k < 450 else 1.5
    )
    uf = 0.0 if k < 100 else -0.5 if k < 200 else 1.0 if k < 260 else 0.0 if k < 400 else -2.0
    return ue, uf


@pytest.fixture(scope="module")
def valve_fmus(tmp_path_factory) -> dict:
    """The knee built with valve inputs, FMI 2.0 and 3.0 (this platform's binary only)."""
    from mkctl.native import build, fmi3, fmu

    if build.find_compiler() is None:
        pytest.skip("no C compiler here")
    out = tmp_path_factory.mktemp("valve_fmus")
    return {
        "fmi2": fmu.build_one("McKibbenKnee", out / "knee2.fmu", valves=True, windows=False),
        "fmi3": fmi3.build_one("McKibbenKnee", out / "knee3.fmu", valves=True, platforms=False),
    }


def test_valve_input_variants_are_a_core_of_their_own(valve_fmus):
    """The valve-input build's core holds the air's variants with the openings as inputs; the cores
    of the
    builds without the option carry none of it (their C is unchanged: sha256 compared before and
    after).
    """
    from mkctl.native import fmu
    from mkctl.native.variants import all_variants, valve_input_variants

    variants = valve_input_variants()
    assert variants and all(v.air and v.opening and v.name.endswith("au") for v in variants)
    assert [v.name[:-1] for v in variants] == [v.name for v in all_variants(air=True) if v.air]
    valves = fmu.core_source(valves=True)
    assert f"knee_rhs_{variants[0].name}(" in valves and "MK_FMU_VALVE_AIR_MESSAGE" in valves
    for other in (fmu.core_source(), fmu.core_source(True)):
        assert (
            "MK_FMU_VALVE_AIR_MESSAGE" not in other and f"knee_rhs_{variants[0].name}(" not in other
        )


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_co_simulation_knee_with_valve_inputs_agrees_with_the_library(
    valve_fmus, tmp_path, version
):
    from test_air_core import _Knee

    from mkctl.physics import actuator

    p = Params(**FMU_START)
    knee_fmu = _Knee(valve_fmus[version], tmp_path / "cs", **FMU_START)
    names = {v.name: v for v in knee_fmu.md.modelVariables}
    assert {"ue", "uf", "Pe0", "Pf0", "qe", "qf"} <= set(names) and "pe_cmd" not in names
    assert names["ue"].causality == "input" and names["valve_flow"].start in ("1", 1)
    knee_fmu.fmu.exitInitializationMode()
    P0 = simulate.default_start_pressures(p)
    assert list(knee_fmu.get("Pe", "Pf")) == list(P0)
    sim = simulate.KneeSimulator(p, simulate.default_hip_height(p), *P0, opening=True)
    got, ref = [], []
    for k in range(600):
        ue, uf = _openings(k)
        knee_fmu.set(ue=ue, uf=uf)
        knee_fmu.fmu.doStep(k * 1e-3, 1e-3)
        got.append(list(knee_fmu.get(*FMU_OUTPUTS, "qe", "qf")))
        sim.step(1e-3, ue, uf)
        outputs = sim.outputs(ue, uf)
        flows = [
            actuator.air_mass_flow(outputs[P], knee.valve_input(u), p)  # the library's own flow
            for P, u in (("Pe", ue), ("Pf", uf))
        ]
        ref.append([outputs[name] for name in FMU_OUTPUTS] + flows)
    got, ref = np.array(got), np.array(ref)
    pe = FMU_OUTPUTS.index("Pe")
    assert (
        np.ptp(ref[:, pe]) > 1e5 and np.ptp(ref[:, 0]) > 0.05
    )  # the valves move the air and the leg
    q = len(FMU_OUTPUTS)
    assert ref[:, q].min() < 0 < ref[:, q].max()  # fills and exhausts
    # measured: 1e-14 of each output's scale (the same algorithm, C against Python)
    for j, name in enumerate(FMU_OUTPUTS + ("qe", "qf")):
        scale = (
            max(1.0, np.abs(ref[:, j]).max())
            if name not in ("qe", "qf")
            else np.abs(ref[:, j]).max()
        )
        assert np.abs(got[:, j] - ref[:, j]).max() <= 1e-9 * scale, name
    # and the record's run (simulate_knee: its steps not cut at the samples), to the integrator's
    # tolerance (measured: 4e-9 of X's scale, 7e-8 of Pe's)
    t = np.arange(1, 601) * 1e-3
    run = simulate.simulate_knee(
        np.r_[0.0, t],
        *np.array([_openings(k) for k in range(601)]).T,
        p,
        X0=simulate.default_hip_height(p),
        inputs="opening",
    )
    for j, name in enumerate(("X", "Pe", "Pf")):
        column = FMU_OUTPUTS.index(name)
        scale = np.ptp(ref[:, column]) + np.abs(ref[:, column]).max()
        assert np.abs(np.asarray(run[name])[1:] - got[:, column]).max() <= 5e-7 * scale, name


@pytest.mark.parametrize("version", ["fmi2", "fmi3"])
def test_model_exchange_knee_with_valve_inputs_agrees_with_the_library(valve_fmus, version):
    # fmpy's CVode integrates the FMU's derivatives (the right-hand side traced with the openings),
    # the openings stepping (each change given twice: fmpy holds an input between rows of equal
    # time); measured 7e-8 of Pe's range, 1e-9 of X's: CVode's error (the Co-Simulation runs the
    # core's own integrator and meets 1e-14)
    from fmpy import simulate_fmu

    p = Params(**FMU_START)
    t = np.arange(0.0, 0.6, 1e-3)
    openings = np.array([_openings(k) for k in range(t.size)])
    changes = [0, *np.flatnonzero(np.any(np.diff(openings, axis=0) != 0, axis=1)) + 1]
    rows = [(0.0, *openings[0])]
    for k in changes[1:]:
        rows += [(t[k], *openings[k - 1]), (t[k], *openings[k])]
    rows.append((t[-1], *openings[-1]))
    signals = np.array(rows, dtype=[("time", float), ("ue", float), ("uf", float)])
    result = simulate_fmu(
        str(valve_fmus[version]),
        fmi_type="ModelExchange",
        start_values=FMU_START,
        input=signals,
        output=["X", "Pe", "Pf"],
        stop_time=float(t[-1]),
        output_interval=1e-3,
        relative_tolerance=1e-10,
    )
    ref = simulate.simulate_knee(
        t, openings[:, 0], openings[:, 1], p, inputs="opening", X0=simulate.default_hip_height(p)
    )
    index = np.clip(np.searchsorted(t, result["time"] - 1e-9), 0, t.size - 1)
    on_grid = np.abs(t[index] - result["time"]) < 1e-9
    assert on_grid.sum() >= t.size - 1
    rows, index = result[on_grid], index[on_grid]
    for name in ("X", "Pe", "Pf"):
        expected = np.asarray(ref[name])[index]
        scale = np.ptp(ref[name]) + np.abs(ref[name]).max()
        assert np.abs(rows[name] - expected).max() <= 1e-6 * scale, name


_REFUSED = r"""
import json, sys
sys.path.insert(0, sys.argv[3])
from test_air_core import _Knee
path, kind = sys.argv[1], sys.argv[2]
found = {}
for case, start in [("no_air", {"valve_flow": 0}), ("dead_time", {"valve_flow": 1, "delay": 0.01})]:
    knee = _Knee(path, sys.argv[4] + "/" + case, kind=kind, **start)
    try:
        knee.fmu.exitInitializationMode()
        outcome = "accepted"
    except Exception as error:  # fmpy raises on fmi2Error / fmi3Error
        outcome = str(error)
    found[case] = {"outcome": outcome, "messages": knee.messages}
    knee.fmu.freeInstance()
print(json.dumps(found))
"""


@pytest.mark.parametrize("version,kind", [("fmi2", "cs"), ("fmi3", "me")])
def test_a_valve_input_knee_refuses_no_air_and_a_dead_time_in_one_line(
    valve_fmus, tmp_path, version, kind
):
    import json
    import subprocess
    import sys
    from pathlib import Path

    done = subprocess.run(
        [
            sys.executable,
            "-c",
            _REFUSED,
            str(valve_fmus[version]),
            kind,
            str(Path(__file__).parent),
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    found = json.loads(done.stdout.strip().splitlines()[-1])
    try:  # the library's own words
        simulate.check_inputs("opening", Params())
    except ParameterError as error:
        library = str(error)
    for case, words in (("no_air", library), ("dead_time", "carries no dead time")):
        result = found[case]
        assert result["outcome"] != "accepted", case
        assert any(words in message for message in result["messages"]), (case, result["messages"])


# --- one muscle with the air: the library's actuator and the native actuator FMU (7d) -------------

#: A leak on top of the spec's typical valve: the actuator FMU's start values in these tests.
ACTUATOR_START = dict(valve_flow=1, C_leak=1e-11)


def _actuator_command(k, valves):
    """Step k of 1 ms: a valve open, closed, half open to the exhaust, then beyond 1 (clipped);
    or set-points."""
    if valves:
        return 1.0 if k < 100 else 0.0 if k < 150 else -0.5 if k < 250 else 1.7
    return 8e5 if k < 100 else 3e5 if k < 250 else 6e5


def _length(k):
    """Held at 0.17 m for 150 ms, then pulled longer at 50 mm/s (the inputs L, Ldot of each
    step)."""
    return (0.17, 0.0) if k < 150 else (0.17 + 0.05 * (k - 150) * 1e-3, 0.05)


@pytest.mark.parametrize("valves", [False, True], ids=["regulator", "valve"])
def test_the_libraries_actuator_with_the_air_matches_an_independent_simulator(valves):
    p = Params(**ACTUATOR_START)
    a = {**AIR, "C_leak": 1e-11, "tau_heat": 0.0}
    time = np.arange(0, 151) * 1e-3
    command = np.array([_actuator_command(k, valves) for k in range(151)])
    sim = simulate.ActuatorSimulator(p, 1e5, opening=valves)
    ours = [1e5] + [sim.step(1e-3, command[k], 0.17, 0.0) for k in range(150)]
    mode = "opening" if valves else "command"
    theirs, _, _ = ip.simulate(
        time, mode, np.clip(command, -1, 1) if valves else command, a, p.b, p.n, 1e5, length=0.17
    )
    assert np.ptp(theirs) > 5e5
    # measured: 6e-11 (set-points) and 6e-12 (openings) of the pressure's range
    assert np.abs(np.array(ours) - theirs).max() <= 1e-9 * np.ptp(theirs)
    with pytest.raises(ParameterError, match="needs its length L"):
        sim.step(1e-3, command[0])


@pytest.fixture(scope="module")
def actuator_fmus(tmp_path_factory) -> dict:
    """The actuator built with the air: with set-points (FMI 2.0) and with valve inputs (FMI 2.0 and
    3.0)."""
    from mkctl.native import build, fmi3, fmu

    if build.find_compiler() is None:
        pytest.skip("no C compiler here")
    out = tmp_path_factory.mktemp("actuator_fmus")
    name = "McKibbenActuator"
    return {
        ("fmi2", False): fmu.build_one(name, out / "a2.fmu", air=True, windows=False),
        ("fmi2", True): fmu.build_one(name, out / "a2u.fmu", air=True, valves=True, windows=False),
        ("fmi3", True): fmi3.build_one(
            name, out / "a3u.fmu", air=True, valves=True, platforms=False
        ),
    }


@pytest.mark.parametrize("version,valves", [("fmi2", False), ("fmi2", True), ("fmi3", True)])
def test_co_simulation_actuator_with_the_air_agrees_with_the_library(
    actuator_fmus, tmp_path, version, valves
):
    from test_air_core import _Knee

    from mkctl.physics import pneumatics

    p = Params(**ACTUATOR_START)
    start = {**ACTUATOR_START, "L": 0.17, **({"P_start": 1e5} if valves else {"p_cmd": 1e5})}
    fmu = _Knee(actuator_fmus[version, valves], tmp_path / "cs", **start)
    names = {v.name for v in fmu.md.modelVariables}
    assert {"q", "C_fill", "valve_flow", "L", "Ldot"} <= names
    assert ("u" in names) == valves and ("p_cmd" in names) != valves
    fmu.fmu.exitInitializationMode()
    sim = simulate.ActuatorSimulator(p, 1e5, opening=valves)
    got, ref = [], []
    for k in range(300):
        command, (L, Ldot) = _actuator_command(k, valves), _length(k)
        fmu.set(**{"u" if valves else "p_cmd": command, "L": L, "Ldot": Ldot})
        fmu.fmu.doStep(k * 1e-3, 1e-3)
        got.append(fmu.get("P", "f", "q"))
        sim.step(1e-3, command, L, Ldot)
        outputs = sim.outputs(command, L, Ldot)
        ref.append([outputs[name] for name in ("P", "f", "q")])
    got, ref = np.array(got), np.array(ref)
    assert ref[:, 2].min() < 0 < ref[:, 2].max()  # fills and exhausts
    assert np.ptp(ref[150:, 0]) > 0 and ref[170, 0] != ref[169, 0]  # pulled longer: squeezed air
    # measured: 2e-15 to 3e-14 of each output's largest (the same algorithm, C against Python)
    for j, name in enumerate(("P", "f", "q")):
        assert np.abs(got[:, j] - ref[:, j]).max() <= 1e-9 * np.abs(ref[:, j]).max(), name
    # clamped (the first 150 ms) against simulate_air, another integrator (Radau at rtol 1e-12)
    t = np.arange(0, 151) * 1e-3
    command = np.array([_actuator_command(k, valves) for k in range(151)])
    air = pneumatics.simulate_air(
        t,
        p,
        length=0.17,
        P_start=1e5,
        method="Radau",
        rtol=1e-12,
        atol=1e-8,
        **({"opening": np.clip(command, -1, 1)} if valves else {"command": command}),
    )
    # measured: 6e-11 (set-points), 6e-12 (openings) of the pressure's range
    assert np.abs(got[:150, 0] - air.P[1:]).max() <= 1e-9 * np.ptp(air.P)
    held = command[1:] == command[:-1]  # its flow at a sample takes that sample's command
    assert (
        np.abs(got[:150, 2] - air.mass_flow[1:])[held].max() <= 1e-8 * np.abs(air.mass_flow).max()
    )


@pytest.mark.parametrize("version,valves", [("fmi2", False), ("fmi3", True)])
def test_model_exchange_actuator_with_the_air_agrees_with_simulate_air(
    actuator_fmus, version, valves
):
    # fmpy's CVode integrates the generated air rate (relative_tolerance 1e-10); measured 2e-9 (set-
    # points) and 4e-9 (openings) of the pressure's range
    from fmpy import simulate_fmu

    from mkctl.physics import pneumatics

    p = Params(**ACTUATOR_START)
    t = np.arange(0, 0.3, 1e-3)
    command = np.array([_actuator_command(k, valves) for k in range(t.size)])
    command = np.clip(command, -1, 1) if valves else command
    name = "u" if valves else "p_cmd"
    rows = [(0.0, command[0], 0.17, 0.0)]
    for k in [*np.flatnonzero(np.diff(command) != 0) + 1]:
        rows += [(t[k], command[k - 1], 0.17, 0.0), (t[k], command[k], 0.17, 0.0)]
    rows.append((t[-1], command[-1], 0.17, 0.0))
    signals = np.array(rows, dtype=[("time", float), (name, float), ("L", float), ("Ldot", float)])
    result = simulate_fmu(
        str(actuator_fmus[version, valves]),
        fmi_type="ModelExchange",
        input=signals,
        start_values={**ACTUATOR_START, "L": 0.17, **({"P_start": 1e5} if valves else {})},
        output=["P", "q"],
        stop_time=float(t[-1]),
        output_interval=1e-3,
        relative_tolerance=1e-10,
    )
    # the regulator's pressure starts at its first command, as the lag does
    air = pneumatics.simulate_air(
        t,
        p,
        length=0.17,
        P_start=1e5 if valves else command[0],
        method="Radau",
        rtol=1e-12,
        atol=1e-8,
        **({"opening": command} if valves else {"command": command}),
    )
    index = np.clip(np.searchsorted(t, result["time"] - 1e-9), 0, t.size - 1)
    on_grid = np.abs(t[index] - result["time"]) < 1e-9
    assert on_grid.sum() >= t.size - 1
    assert np.abs(result["P"][on_grid] - air.P[index[on_grid]]).max() <= 1e-7 * np.ptp(air.P)


def test_an_actuator_with_valve_inputs_refuses_no_air_in_one_line(actuator_fmus, tmp_path):
    import json
    import subprocess
    import sys
    from pathlib import Path

    script = _REFUSED.replace(
        '("dead_time", {"valve_flow": 1, "delay": 0.01})',
        '("dead_time", {"valve_flow": 1, ' '"delay": 0.01, "L": 0.17})',
    ).replace('{"valve_flow": 0}', '{"valve_flow": 0, "L": 0.17}')
    done = subprocess.run(
        [
            sys.executable,
            "-c",
            script,
            str(actuator_fmus["fmi2", True]),
            "cs",
            str(Path(__file__).parent),
            str(tmp_path),
        ],
        capture_output=True,
        text=True,
        timeout=120,
    )
    assert done.returncode == 0, done.stderr[-2000:]
    found = json.loads(done.stdout.strip().splitlines()[-1])
    for case, words in (("no_air", "valve_flow = 1"), ("dead_time", "carries no dead time")):
        assert found[case]["outcome"] != "accepted", case
        assert any(words in message for message in found[case]["messages"]), (
            case,
            found[case]["messages"],
        )


def test_a_dead_time_delays_the_openings_step_by_step_as_over_a_record():
    """KneeSimulator stepping (as an FMU runs it) and simulate_knee (a record) see the openings a
    dead time late alike: the first openings act until later ones arrive."""
    p = air_params(delay=0.015)
    P0 = _start(p)
    time = np.arange(0, 61) * 1e-3
    ue = np.where(time < 0.02, 0.2, -0.3)
    uf = np.where(time < 0.03, 0.0, 0.4)
    X0 = simulate.rest_hip_height(*P0, p)
    run = simulate.simulate_knee(time, ue, uf, p, X0=X0, stops=False, inputs="opening", P0=P0)
    sim = simulate.KneeSimulator(p, X0, *P0, stops=False, opening=True)
    stepped = [sim.state.copy()] + [sim.step(1e-3, ue[k], uf[k]).copy() for k in range(60)]
    stepped = np.array(stepped)
    undelayed = simulate.simulate_knee(time, ue, uf, air_params(), X0=X0, stops=False,
                                       inputs="opening", P0=P0)
    assert np.abs(undelayed.Pe - run.Pe).max() > 1e4  # the dead time shows
    # measured: 2e-9 of Pe's range, 3e-7 of X's (0.45 mm); a closed valve first would miss by 0.27
    assert np.abs(stepped[:, 2] - run.Pe).max() <= 1e-6 * np.ptp(run.Pe)
    assert np.abs(stepped[:, 0] - run.X).max() <= 1e-6 * np.ptp(run.X)
