"""The compiled core (mkctl.native) against the Python path, finite differences, and without a compiler.

The C is generated from the library's own equations; these tests compare what it computes with the Python
evaluation of those equations (an independent evaluation: a different language, a different arrangement
of the arithmetic), the partial derivatives with finite differences of the compiled force, and check that
a machine without a C compiler (or with ``MKCTL_NATIVE=0``) gets the same results from the Python path.
"""
from __future__ import annotations

import json
import os
import re
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

from mkctl.errors import DomainError
from mkctl.native import build, compiled
from mkctl.physics import actuator, knee, stability
from mkctl.physics.params import Params
from mkctl.physics.simulate import (KNEE_OUTPUTS, default_commands, default_hip_height, knee_states, simulate_knee,
                                    state_outputs)

ROOT = Path(__file__).resolve().parents[1]
TOLERANCE = 1e-10

#: One parameter set per effect, and the record each is run on (factor on the holding extensor command).
CASES = {
    "paper (model 2)": (Params(), 1.04),
    "viscous damping c": (Params(c=40.0), 1.04),
    "Coulomb friction Fc": (Params(Fc=3.0, c=5.0), 1.04),
    "pressure lag tau": (Params(tau=0.03, c=20.0), 1.04),
    "model 1": (Params(model=1, c=10.0), 1.04),
    "saturation onto the lower end stop": (Params(c=40.0), 0.3),
    "saturation onto the upper end stop": (Params(c=40.0), 2.5),
    "every effect, onto the upper end stop": (Params(c=5.0, Fc=2.0, tau=0.02), 2.5),
}
#: Through an end-stop contact the two paths agree only to the integrator's own tolerance: the stop's damper
#: makes the force jump at contact (d V), the step control rejects and shrinks its way through the jump, and
#: its error estimate there is a difference of nearly equal stage derivatives, so an ulp of difference in the
#: force (the C arranges the same arithmetic differently) can accept a step the other path rejects. Both
#: results are within tolerance of the true solution; they need not be within 1e-10 of each other. Before the
#: first contact every output agrees to TOLERANCE; from it on, X to AFTER_CONTACT_X, the rest to AFTER_CONTACT.
#: These bounds are what the integrator itself gives through a contact: the Python path run through each run of
#: held commands (dense output) and the same run cut at every sample (KneeSimulator.step) differ there by as
#: much (V by 7e-7 m/s of 0.6 on "every effect, onto the upper end stop").
AFTER_CONTACT_X = 1e-8
AFTER_CONTACT = 1e-5
#: A slack flexor (slack=1) puts a kink (a jump in the derivative of the tension) where the tension reaches 0:
#: weaker than a contact, the same mechanism. Before the first slack sample every output agrees to TOLERANCE.
AFTER_KINK = 1e-9


def core_or_fail(params: Params):
    """The compiled core; skip where there is no compiler (the Python path is then all there is)."""
    if build.find_compiler() is None:
        pytest.skip("no C compiler here: the compiled core cannot be built")
    core = compiled.core_for(params)
    assert core is not None, compiled.status(params)
    return core


def python_path(monkeypatch):
    monkeypatch.setenv(build.ENV_SWITCH, "0")


def step_record(params: Params, factor: float, samples: int = 1500):
    """1.5 s at 1 kHz from rest: extensor command steps by ``factor`` at 0.1 s and back at 0.9 s."""
    t = np.arange(samples) * 1e-3
    pe0, pf0 = default_commands(params)
    pe = np.where((t >= 0.1) & (t < 0.9), pe0 * factor, pe0)
    return t, pe, np.full(samples, pf0)


def assert_agree(native: dict, python: dict, names=KNEE_OUTPUTS, tolerance=TOLERANCE, part=slice(None)):
    for name in names:
        a, b = np.asarray(native[name], dtype=float), np.asarray(python[name], dtype=float)
        scale = np.max(np.abs(b))
        worst = np.max(np.abs(a[part] - b[part]), initial=0.0)
        bound = (tolerance[name] if isinstance(tolerance, dict) else tolerance) * scale
        assert worst <= bound, f"{name}: compiled and Python differ by {worst:g} (scale {scale:g})"


def compare_paths(params, t, pe, pf, monkeypatch, contact_expected: bool) -> dict:
    """simulate_knee on both paths; every output within TOLERANCE (up to a first end-stop contact)."""
    native = simulate_knee(t, pe, pf, params)
    python_path(monkeypatch)
    python = simulate_knee(t, pe, pf, params)
    monkeypatch.delenv(build.ENV_SWITCH)
    assert native["V"].std() > 1e-3  # the record moves the leg
    low, high = knee.stop_positions(params)
    contact = np.flatnonzero((python["X"] < low) | (python["X"] > high))
    assert (contact.size > 0) == contact_expected
    if not contact_expected:
        assert_agree(native, python)
        np.testing.assert_array_equal(native["stable"], python["stable"])
        return python
    first = int(contact[0])
    assert_agree(native, python, part=slice(0, first))
    np.testing.assert_array_equal(native["stable"][:first], python["stable"][:first])
    states = ("X", "V", "Pe", "Pf") if params.tau > 0 else ("X", "V")
    after = {name: AFTER_CONTACT_X if name == "X" else AFTER_CONTACT for name in states}
    assert_agree(native, python, names=states, tolerance=after, part=slice(first, None))
    assert_outputs_follow_states(native, params, pe, pf, slice(first, None))
    return python


def assert_outputs_follow_states(native, params, pe, pf, part):
    """Every output of the compiled run equals the library's outputs at the compiled run's own states (to
    TOLERANCE): where the trajectories may part (after a contact), the outputs are still the same functions.
    Compared this way because some outputs amplify a state difference: a1 holds the friction's slope
    Fc / vs sech^2(V / vs), which turns a 1e-7 m/s difference in V near V = 0 into 1e-4 of a1."""
    lag = params.tau > 0
    indices = np.arange(len(native["X"]))[part]
    for k in indices:
        state = [native["X"][k], native["V"][k]] + ([native["Pe"][k], native["Pf"][k]] if lag else [])
        expected = state_outputs(state, pe[k], pf[k], params)
        for name in KNEE_OUTPUTS:
            value = float(native[name][k])
            assert value == pytest.approx(float(expected[name]), rel=TOLERANCE, abs=TOLERANCE * 1e-3), (name, k)


@pytest.mark.parametrize("case", list(CASES))
def test_compiled_simulate_knee_agrees_with_the_python_path(case, monkeypatch):
    params, factor = CASES[case]
    core_or_fail(params)
    compare_paths(params, *step_record(params, factor), monkeypatch, contact_expected="stop" in case)


def test_compiled_slack_agrees_with_the_python_path(monkeypatch):
    # a low flexor pressure: the flexor's model tension turns negative as the leg swings, and it goes slack
    params = Params(slack=1, m=3.0, c=10.0)
    core_or_fail(params)
    t = np.arange(1000) * 1e-3
    pe0 = float(stability.equilibrium_pressure(np.radians(50), 2e4, params))
    pe = np.where((t >= 0.1) & (t < 0.6), 1.05 * pe0, pe0)
    native = simulate_knee(t, pe, np.full(t.size, 2e4), params)
    python_path(monkeypatch)
    python = simulate_knee(t, pe, np.full(t.size, 2e4), params)
    assert (python["ff"] == 0).sum() > 100 and (python["ff"] > 0).sum() > 100
    first = int(np.flatnonzero(python["ff"] == 0)[0])
    assert_agree(native, python, part=slice(0, first))
    assert_agree(native, python, tolerance=AFTER_KINK, part=slice(first, None))
    np.testing.assert_array_equal(native["ff"] == 0, python["ff"] == 0)


@pytest.mark.parametrize("case", ["viscous damping c", "pressure lag tau"])
def test_compiled_knee_states_agrees_with_the_python_path(case, monkeypatch):
    params, factor = CASES[case]
    core_or_fail(params)
    t, pe, pf = step_record(params, factor)
    at = np.arange(0, t.size, 7)
    native = knee_states(t, pe, pf, params, at=at)
    python_path(monkeypatch)
    python = knee_states(t, pe, pf, params, at=at)
    assert_agree({"X": native[0], "V": native[1]}, {"X": python[0], "V": python[1]}, ("X", "V"))


def test_compiled_record_with_measured_commands_agrees_with_the_python_path(monkeypatch):
    """A rig's record: commands measured with noise (a new run of held commands at every sample), held runs
    in between, a repeated time stamp (a zero-length interval) and an uneven sampling."""
    params = Params(c=30.0, tau=0.02)
    core_or_fail(params)
    rng = np.random.default_rng(3)
    t = np.cumsum(rng.uniform(0.5e-3, 1.5e-3, 800))
    t[400] = t[399]
    pe0, pf0 = default_commands(params)
    pe = pe0 * (1 + 0.03 * (t > 0.2)) + np.where(t < 0.5, rng.normal(0, 2e3, t.size), 0.0)
    pf = np.full(t.size, pf0)
    native = simulate_knee(t, pe, pf, params)
    at = np.sort(rng.choice(t.size, 60, replace=False))
    native_states = knee_states(t, pe, pf, params, at=at)
    python_path(monkeypatch)
    python = simulate_knee(t, pe, pf, params)
    python_states = knee_states(t, pe, pf, params, at=at)
    assert native["V"].std() > 1e-4
    assert_agree(native, python)
    assert_agree({"X": native_states[0], "V": native_states[1]}, {"X": python_states[0], "V": python_states[1]},
                 ("X", "V"))


@pytest.mark.parametrize("params", [Params(c=200.0), Params(c=200.0, Fc=1.5), Params(c=50.0, model=1),
                                    Params(c=300.0, Fc=2.0, slack=1)], ids=["damped", "damped+friction", "model 1",
                                                                            "damped+friction+slack"])
def test_compiled_damped_isotonic_test_agrees_with_the_python_path(params, monkeypatch):
    """The damped isotonic test (backward Euler, Newton in a bracket) in C against the Python loop, on a pressure
    sweep with the load doubled halfway; model 1 cannot carry it at low pressure and saturates at the braid
    limit there."""
    from mkctl.physics import isotonic
    core_or_fail(params)
    t = np.arange(1500) * 2e-3
    pressure = 300e3 * (1 - np.cos(2 * np.pi * t / 3.0)) / 2  # 0 -> 300 kPa -> 0
    load = np.where(t < 1.0, 60.0, 120.0)
    native = isotonic.simulate_isotonic(t, pressure, load, params)
    python_path(monkeypatch)
    python = isotonic.simulate_isotonic(t, pressure, load, params)
    assert np.ptp(python) > 0.01
    np.testing.assert_allclose(native, python, rtol=0, atol=TOLERANCE * np.ptp(python))
    at_limit = python == isotonic.length_limits(params)[1]
    np.testing.assert_array_equal(native == isotonic.length_limits(params)[1], at_limit)
    assert at_limit.any() == (params.model == 1)  # model 1 has no rubber: at low pressure nothing carries the load


def test_compiled_damped_isotonic_test_raises_the_python_error(monkeypatch):
    from mkctl.physics import isotonic
    params = Params(c=200.0, model=1)
    core_or_fail(params)
    t = np.arange(50) * 1e-2
    args = (t, np.zeros(t.size), np.full(t.size, 50.0), params, 0.15)
    with pytest.raises(DomainError) as native:  # model 1 with no pressure carries no load
        isotonic.simulate_isotonic(*args, saturate=False)
    python_path(monkeypatch)
    with pytest.raises(DomainError) as python:
        isotonic.simulate_isotonic(*args, saturate=False)
    assert str(native.value) == str(python.value)


def test_compiled_step_is_kneesimulator_step():
    # mk_knee_step is what a native FMU's doStep calls: steps of any size, first-same-as-last reuse
    from mkctl.physics.simulate import KneeSimulator
    params = Params(c=20.0, Fc=1.0, tau=0.02)
    core = core_or_fail(params)
    pe, pf = default_commands(params)
    python, native = KneeSimulator(params, None, pe, pf), KneeSimulator(params, None, pe, pf)
    step = core.stepper(native)
    for k, dt in enumerate([1e-3] * 30 + [20e-3] * 10 + [0.0, 5e-3, 1e-3]):
        command = pe * (1.05 if k >= 5 else 1.0)
        python.step(dt, command, pf)
        assert step(dt, command, pf) == 0
        np.testing.assert_allclose(native.state, python.state, rtol=1e-12, atol=1e-12)
        assert native.step_hint == pytest.approx(python.step_hint, rel=1e-6)
    assert step(1e-3, float("nan"), pf) != 0  # the commands' check, generated from check_pressure
    with pytest.raises(DomainError):
        python.step(1e-3, float("nan"), pf)


def test_compiled_record_without_stops_and_from_a_given_posture(monkeypatch):
    params = Params(c=30.0)
    core_or_fail(params)
    t, pe, pf = step_record(params, 0.97, 800)
    native = simulate_knee(t, pe, pf, params, X0=default_hip_height(params), stops=False, rtol=1e-8)
    python_path(monkeypatch)
    python = simulate_knee(t, pe, pf, params, X0=default_hip_height(params), stops=False, rtol=1e-8)
    assert_agree(native, python)


def test_generated_right_hand_side_and_outputs_agree_with_the_library_at_random_states():
    rng = np.random.default_rng(1)
    for params in (Params(c=40.0, Fc=2.0, tau=0.02), Params(model=1)):
        core = core_or_fail(params)
        stops = knee.stop_positions(params)
        low, high = stops
        for _ in range(20):
            X, V = rng.uniform(low - 0.02, high + 0.002), rng.normal(0, 0.3)  # some beyond the stops
            Pe, Pf, pe_cmd, pf_cmd = rng.uniform(0, 2e6, 4)
            state = [X, V, Pe, Pf][: len(knee.state_names(params))]
            expected = knee.knee_derivatives(state, pe_cmd, pf_cmd, params, stops)
            got = core.knee_rhs(params, state, pe_cmd, pf_cmd, stops)
            np.testing.assert_allclose(got, expected, rtol=1e-12, atol=1e-9)
            outputs = core.knee_outputs(params, state, pe_cmd, pf_cmd)
            P = (Pe, Pf) if params.tau > 0 else (pe_cmd, pf_cmd)
            geo = knee.geometry_at_X(X, params)
            force = knee.knee_force_partials(geo, V, *P, params)
            reference = {"X": X, "V": V, "alpha": geo.alpha, "beta": geo.beta, "Le": geo.Le, "Lf": geo.Lf,
                         "fe": force.fe, "ff": force.ff, "Pe": P[0], "Pf": P[1], "F": force.F,
                         "a1": force.dF_dV / params.m, "a2": force.dF_dX / params.m}
            for i, name in enumerate(KNEE_OUTPUTS):
                if name == "stable":
                    assert outputs[i] == float(reference["a1"] < 0 and reference["a2"] < 0)
                else:
                    assert outputs[i] == pytest.approx(reference[name], rel=1e-11, abs=1e-12), name


@pytest.mark.parametrize("params", [Params(c=40.0), Params(Fc=3.0, c=5.0), Params(model=1)])
def test_generated_partials_match_finite_differences_of_the_generated_force(params):
    core = core_or_fail(params)
    index = {name: i for i, name in enumerate(KNEE_OUTPUTS)}
    pe, pf = default_commands(params)
    for X in np.linspace(*knee.stop_positions(params), 7)[1:-1]:
        for V in (-0.05, 0.0, 0.02):
            out = core.knee_outputs(params, [X, V], pe, pf)

            def force(dX=0.0, dV=0.0):
                return core.knee_outputs(params, [X + dX, V + dV], pe, pf)[index["F"]]

            hX, hV = 1e-6, 1e-6 * max(params.vs, 1e-3)
            dF_dX = (force(dX=hX) - force(dX=-hX)) / (2 * hX)
            dF_dV = (force(dV=hV) - force(dV=-hV)) / (2 * hV)
            assert out[index["a2"]] * params.m == pytest.approx(dF_dX, rel=1e-5, abs=1e-3)
            assert out[index["a1"]] * params.m == pytest.approx(dF_dV, rel=1e-5, abs=1e-3)


def test_generated_actuator_and_stop_positions_agree_with_the_library():
    for params in (Params(), Params(model=1, c=20.0, Fc=1.5, tau=0.05)):
        core = core_or_fail(params)
        assert core.stop_positions(params) == pytest.approx(knee.stop_positions(params), rel=1e-13)
        for L, P, Ldot in ((0.15, 3e5, 0.0), (0.2, 1e5, -0.01), (0.18, 6e5, 0.003)):
            assert core.actuator("tension", params, L, P, Ldot) == pytest.approx(
                float(actuator.tension(L, P, Ldot, params)), rel=1e-12)
        assert core.actuator("lagged_pressure", params, 1e5, 4e5, 0.01) == pytest.approx(
            float(actuator.lagged_pressure(1e5, 4e5, params.tau, 0.01)), rel=1e-13)
        # the domain checks are generated too: a length beyond the braid fails in C as in Python
        assert core.actuator("tension", params, params.b * 1.01, 1e5, 0.0) is None
        with pytest.raises(DomainError):
            actuator.tension(params.b * 1.01, 1e5, 0.0, params)


def _number_free(message: str) -> str:
    return re.sub(r"-?\d[\d.e+-]*", "#", message)


@pytest.mark.parametrize("kind", ["nan command", "out of the domain"])
def test_compiled_path_raises_the_python_error(kind, monkeypatch):
    params = Params(c=10.0)
    core_or_fail(params)
    t, pe, pf = step_record(params, 1.04, 600)
    stops = True
    if kind == "nan command":
        pe = pe.copy()
        pe[300] = np.nan
    else:  # no stops, a huge extensor pressure: the leg stretches out of the model's domain
        pe, stops = np.where(t > 0.1, 5e7, pe), False
    with pytest.raises(DomainError) as native:
        simulate_knee(t, pe, pf, params, stops=stops)
    python_path(monkeypatch)
    with pytest.raises(DomainError) as python:
        simulate_knee(t, pe, pf, params, stops=stops)
    assert _number_free(str(native.value)) == _number_free(str(python.value))


_FALLBACK = """
import json, sys
import numpy as np
from mkctl.native import compiled
from mkctl.physics.params import Params
from mkctl.physics.simulate import default_commands, simulate_knee
params = Params(c=40.0, tau=0.02)
t = np.arange(400) * 1e-3
pe0, pf0 = default_commands(params)
run = simulate_knee(t, np.where(t > 0.05, 1.04 * pe0, pe0), pf0, params)
print(json.dumps({"status": compiled.status(params), "X": run["X"].tolist(), "F": run["F"].tolist()}))
"""


@pytest.mark.parametrize("hide", ["no compiler", "MKCTL_NATIVE=0"])
def test_without_a_compiler_the_python_path_gives_the_same_results(hide, tmp_path):
    params = Params(c=40.0, tau=0.02)
    core_or_fail(params)
    t = np.arange(400) * 1e-3
    pe0, pf0 = default_commands(params)
    reference = simulate_knee(t, np.where(t > 0.05, 1.04 * pe0, pe0), pf0, params)
    env = {**os.environ, "PYTHONPATH": str(ROOT), build.ENV_CACHE: str(tmp_path / "empty-cache")}
    if hide == "no compiler":
        env.update(CC="/nonexistent/cc", PATH=str(tmp_path))  # an empty PATH: no cc, gcc or clang either
    else:
        env[build.ENV_SWITCH] = "0"
    done = subprocess.run([sys.executable, "-c", _FALLBACK], capture_output=True, text=True, env=env,
                          cwd=tmp_path, timeout=300)
    assert done.returncode == 0, done.stderr[-2000:]
    result = json.loads(done.stdout.strip().splitlines()[-1])
    assert result["status"].startswith("python ("), result["status"]
    assert not (tmp_path / "empty-cache" / "native").exists() or not any(
        (tmp_path / "empty-cache" / "native").glob("core-*"))
    assert_agree({"X": result["X"], "F": result["F"]}, reference, ("X", "F"))


#: Test files run again with the compiler hidden: the simulation, the control analysis and a diagnosis.
NO_COMPILER_SUITE = ("tests/test_simulate.py", "tests/test_typed_results.py", "tests/test_control.py",
                     "tests/test_diagnose_encoder.py")


def test_the_simulation_tests_pass_without_a_compiler(tmp_path):
    """A machine with no C compiler: these test files pass on the Python path, and no core is built."""
    cache = tmp_path / "empty-cache"
    env = {**os.environ, "PYTHONPATH": str(ROOT), build.ENV_CACHE: str(cache), "CC": "/nonexistent/cc"}
    env.pop(build.ENV_SWITCH, None)
    done = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-p", "no:randomly",
                           *NO_COMPILER_SUITE], capture_output=True, text=True, env=env, cwd=ROOT, timeout=600)
    assert done.returncode == 0, done.stdout[-3000:]
    summary = done.stdout.strip().splitlines()[-1]
    assert re.search(r"\d+ passed", summary) and "failed" not in summary and "error" not in summary, summary
    assert not list(cache.glob("native/core-*")), "a core was built although the compiler is hidden"


def test_the_build_is_cached_by_generated_source(tmp_path, monkeypatch):
    if build.find_compiler() is None:
        pytest.skip("no C compiler here")
    monkeypatch.setenv(build.ENV_CACHE, str(tmp_path))
    variants = (compiled.Variant.of(Params()),)
    first = build.build_library(variants)
    stamp = first.stat().st_mtime_ns
    assert build.build_library(variants) == first and first.stat().st_mtime_ns == stamp  # not rebuilt
    source = build.generated_source(variants).read_text()
    assert first.name.startswith("core-") and first.parent == tmp_path / "native"
    # the source holds the integrator's constants as integrate.py has them, not retyped ones
    from mkctl.physics import integrate
    assert repr(integrate._A[6][4]) in source and repr(integrate._E[4]) in source


def _random_params(rng, variant) -> Params:
    """A random parameter set of the given structure: every real table parameter moved off its default, the
    variant's structural effects on at a random value (off values for the others), every other effect on or off
    at random (their terms are always compiled in: off must give the same as Python's skipped term)."""
    from mkctl.physics import effects
    from mkctl.physics.params import BASE_NAMES, DEFAULT
    values = {name: getattr(DEFAULT, name) * rng.uniform(0.97, 1.03) for name in BASE_NAMES if name != "n"}
    for effect in effects.all_effects():
        if effect.moves_air:
            continue  # the air has variants of its own (Variant.air; tests/test_air_core.py checks them)
        on = effect.name in variant.on if effect.structural else bool(rng.integers(2))
        for q in effect.parameters:
            if q.switch:
                values[q.name] = (q.upper if q.off == q.lower else q.lower) if on and q is effect.switch_parameter \
                    else q.off
            elif not on and q is effect.switch_parameter:
                values[q.name] = q.off
            else:
                typical = q.typical if q.typical is not None else (q.start or q.scale)
                values[q.name] = typical * rng.uniform(0.5, 1.5)
    values["c"] = values["c"] * 40.0 / 45.0 if values["c"] else 0.0
    return Params(**values)


def test_every_parameter_is_a_run_time_input_and_every_branch_a_variant():
    # one library with all variants; random parameter sets of each structure, random states: the compiled
    # right-hand side and outputs follow the library. A new parameter the equations branch on, but that no
    # variant covers, makes this fail (the trace would have taken one branch for every value).
    from mkctl.native.variants import ALL_VARIANTS, Variant
    if build.find_compiler() is None:
        pytest.skip("no C compiler here")
    core = compiled.Core(build.build_library(ALL_VARIANTS))
    rng = np.random.default_rng(7)
    for variant in ALL_VARIANTS:
        for _ in range(3):
            params = _random_params(rng, variant)
            assert Variant.of(params) == variant
            stops = knee.stop_positions(params)
            pe, pf = default_commands(params)
            for _ in range(4):
                X, V = rng.uniform(*stops), rng.normal(0, 0.2)
                state = [X, V, pe * rng.uniform(0.8, 1.2), pf * rng.uniform(0, 2)][: variant.nstate]
                pe_cmd, pf_cmd = pe * rng.uniform(0.8, 1.2), pf * rng.uniform(0, 2)
                np.testing.assert_allclose(core.knee_rhs(params, state, pe_cmd, pf_cmd, stops),
                                           knee.knee_derivatives(state, pe_cmd, pf_cmd, params, stops),
                                           rtol=1e-11, atol=1e-9)
                simulate_outputs = core.knee_outputs(params, state, pe_cmd, pf_cmd)
                assert simulate_outputs is not None
                P = (state[2], state[3]) if variant.lag else (pe_cmd, pf_cmd)
                from mkctl.physics.simulate import knee_outputs
                expected = knee_outputs(X, V, *P, params)
                for i, name in enumerate(expected):
                    assert simulate_outputs[i] == pytest.approx(float(expected[name]), rel=1e-10, abs=1e-9), name
                L, Ldot = rng.uniform(0.16, 0.22), rng.normal(0, 0.01)
                assert core.actuator("tension", params, L, pe_cmd, Ldot) == pytest.approx(
                    float(actuator.tension(L, pe_cmd, Ldot, params)), rel=1e-11, abs=1e-9)


_RACE = """
import sys, time
from mkctl.native import build, compiled
from mkctl.physics.params import Params
time.sleep(max(0.0, float(sys.argv[1]) - time.time()))  # both start at the same moment
build.generated_source((compiled.Variant.of(Params()),))
print("generated" if build._GENERATED else "read")
"""


def test_processes_starting_together_on_an_empty_cache_generate_the_source_once(tmp_path):
    env = {**os.environ, "PYTHONPATH": str(ROOT), build.ENV_CACHE: str(tmp_path / "cache")}
    start = f"{time.time() + 3.0:.3f}"
    runs = [subprocess.Popen([sys.executable, "-c", _RACE, start], stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                             text=True, env=env) for _ in range(2)]
    outputs = [run.communicate(timeout=300) for run in runs]
    assert all(run.returncode == 0 for run in runs), [err[-2000:] for _, err in outputs]
    assert sorted(out.strip() for out, _ in outputs) == ["generated", "read"]
