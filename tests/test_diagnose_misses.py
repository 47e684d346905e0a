"""Issue 32: three misses of the diagnosis on rig-like records, each a class.

1. An effect that requires another (the registry's ``requires``: the asymmetric lag needs the lag)
   is reached when its prerequisite does not explain the record alone or is tied: the prerequisite
   is tried together with it.
2. A tie is reported as whole models (each alternative's effects, values, standard errors and
   RMSE), and the top level never holds the model with neither.
3. The noise of a quasi-static record's measured inputs (pressure, load) does not buy an effect.

The records: mkctl's own simulator driven by commands on both muscles (steps and ramps, a lighter
leg with a 12 mm muscle), the bench's (``synthesize``) and the independent rig's
(``tests/independent_rig.py``). Standard errors are checked at 3 of them (a 1-standard-error band
misses a third of honest estimates by chance).
"""
from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

from mkctl.analysis.diagnose import diagnose, save_pictures, summary
from mkctl.analysis.diagnose.search import dependent_start as _dependent_start, dependents as _dependents
from mkctl.analysis.diagnosis_rule import Score, extension_needed
from mkctl.analysis.synth import synthesize
from mkctl.io.measurements import measurement_from_arrays
from mkctl.physics import effects, stability
from mkctl.physics.params import Params
from mkctl.physics.simulate import simulate_knee

sys.path.insert(0, str(Path(__file__).parent))
import independent_rig as rig  # noqa: E402

#: a lighter leg with a 12 mm muscle, as the issue's rig
LEG = {"D0": 0.012, "m": 4.0}
SE_BAND = 3.0


def both_muscles_record(hidden: dict, seconds: float, rate: float, noise_mm: float, seed: int):
    """A knee record with steps and ramps on both muscles (mkctl's simulator, the truth = LEG +
    hidden), white output noise of ``noise_mm``; the file declares LEG."""
    base = Params(**LEG)
    t = np.arange(int(round(seconds * rate))) / rate
    pf0 = 150e3
    pe0 = float(stability.equilibrium_pressure(math.radians(60.0), pf0, base))
    pe, pf = np.full(t.size, pe0), np.full(t.size, pf0)
    end = t[-1]

    def step(values, at, level):
        values[t >= at * end] = level

    def ramp(values, start, stop, level):
        begin = values[np.searchsorted(t, start * end)]
        u = np.clip((t - start * end) / ((stop - start) * end), 0.0, 1.0)
        values[t >= start * end] = (begin + (level - begin) * u)[t >= start * end]

    step(pe, 0.05, pe0 * 1.05)
    step(pe, 0.18, pe0 * 0.97)
    step(pf, 0.30, pf0 * 1.1)
    step(pf, 0.42, pf0 * 0.93)
    ramp(pe, 0.55, 0.62, pe0 * 1.06)
    ramp(pf, 0.70, 0.76, pf0 * 1.08)
    step(pe, 0.85, pe0 * 0.98)
    step(pf, 0.92, pf0)
    x = simulate_knee(t, pe, pf, base.replace(**hidden)).X
    y = x + np.random.default_rng(seed).normal(0.0, noise_mm * 1e-3, x.size)
    return measurement_from_arrays("knee", t, {"pe_cmd": pe, "pf_cmd": pf}, y, params=LEG,
                                   source="both.csv")


def as_read(record, params=None, source="record.csv"):
    """A bench record (:func:`synthesize`) as a user's file would be read: inputs, output, known
    parameters."""
    return measurement_from_arrays(record.experiment, record.time, record.inputs, record.output,
                                   params=params, source=source)


def within(result, truth: dict, band: float = SE_BAND) -> dict:
    """{parameter: (value, standard error, truth)} of the parameters outside ``band`` standard
    errors."""
    return {k: (result.params[k], result.uncertainty.get(k), v) for k, v in truth.items()
            if not abs(result.params[k] - v) <= band * result.uncertainty.get(k, 0.0)}


# --- 1. an effect behind its prerequisite ------------------------------------------------------

def test_the_dependents_come_from_the_registry():
    """Which candidates wait for a prerequisite is read off the registry's ``requires``, not off
    names."""
    pending = ["viscous_damping", "pressure_lag", "dead_time", "asymmetric_lag"]
    waiting = {name for prerequisite in pending
               for name in _dependents(pending, set(), prerequisite)}
    expected = {e.name for e in effects.all_effects() if e.requires and e.name in pending
                and set(e.requires) <= set(pending)}
    assert waiting == expected and waiting  # the registry has at least one (the asymmetric lag)
    for name in waiting:
        (required,) = effects.get(name).requires
        # already on: not waiting
        assert name not in _dependents(pending, {required, name}, required)
        # a time constant starts at the prerequisite's (same unit), from its fitted values
        assert _dependent_start(name, {"tau": 0.07}) == pytest.approx(0.07)


def test_an_extension_is_kept_only_when_it_passes_bic_and_the_held_out_gain():
    model = Score(rss_train=1.0, n_train=200, k=2, rmse_holdout=0.10)
    better = Score(rss_train=0.5, n_train=200, k=3, rmse_holdout=0.05)
    assert extension_needed(model, better)
    assert not extension_needed(model, Score(0.99, 200, 3, 0.05))  # BIC barely moves
    assert not extension_needed(model, Score(0.5, 200, 3, 0.099))  # the held-out part does not gain


@pytest.mark.parametrize("seed", [0, 1])
def test_asymmetric_lag_with_damping_on_both_muscles(seed):
    """The issue's first record (fill 0.05 s, exhaust 0.15 s, damping 40 N s/m, 0.05 mm of noise,
    steps and ramps on both muscles, 1 kHz): all three found, each value within its standard errors
    of the truth."""
    truth = {"tau": 0.05, "tau_exhaust": 0.15, "c": 40.0}
    result = diagnose(both_muscles_record(truth, 6.0, 1000.0, 0.05, seed))
    assert result.verdict == "diagnosed", summary(result)
    assert sorted(result.missing) == ["asymmetric_lag", "pressure_lag", "viscous_damping"]
    assert not within(result, {"tau": 0.05, "tau_exhaust": 0.15}), within(result, truth)


@pytest.mark.parametrize("seed", [1, 2])
def test_asymmetric_lag_found_when_the_lag_alone_does_not_explain(seed):
    """The bench's steps on the extensor: the lag alone takes the damping's share (tau ~ 0.17 s) and
    the exhausting time constant then gains nothing beside it, so forward selection stopped
    "incomplete" at 17 times the noise; the wider search now tries what requires an effect on top of
    it (damping + lag + asymmetric)."""
    record = synthesize("knee", {"tau": 0.05, "tau_exhaust": 0.15, "c": 40.0}, {}, "model2", 0.05,
                        seed, samples=3000, rate=1000.0)
    result = diagnose(as_read(record))
    assert result.verdict == "diagnosed", summary(result)
    assert sorted(result.missing) == ["asymmetric_lag", "pressure_lag", "viscous_damping"]
    assert not within(result, {"tau": 0.05, "tau_exhaust": 0.15})


def test_a_prerequisite_tied_with_a_rival_is_tried_with_what_requires_it():
    """The issue's first class on the bench: damping known, a lag filling with 30 ms and exhausting
    with 80 ms, ramps at 200 Hz, 0.3 mm of noise. The lag alone ties with a dead time (round 3 ended
    "undecided" here), and the asymmetric lag, which requires the lag, was never a candidate; fitted
    together, the lag and its exhausting time constant beat every rival by the rule, and are added
    in one step."""
    record = synthesize("knee", {"tau": 0.03, "tau_exhaust": 0.08}, {"c": 40.0}, "model2", 0.3, 0,
                        samples=2000, rate=200.0, shape="ramps")
    result = diagnose(as_read(record, {"c": 40.0}))
    assert result.verdict == "diagnosed", summary(result)
    first = result.steps[0]
    assert (first["added"], first["added_with"]) == ("pressure_lag", ["asymmetric_lag"])
    (tried,) = first["with_requirements"]
    assert tried["effects"] == ["pressure_lag", "asymmetric_lag"] and tried["accepted"]
    assert sorted(result.missing) == ["asymmetric_lag", "pressure_lag"]
    assert not within(result, {"tau": 0.03, "tau_exhaust": 0.08})


def test_the_selection_asks_for_what_requires_an_effect_on_a_tie_and_on_a_stop():
    """The rule's forward selection hands a round that ends tied or stopped to
    ``with_requirements``, and adds what it returns (pure: hand-built scores)."""
    from mkctl.analysis.diagnosis_rule import Candidate, Decision, forward_selection

    base = Score(1.0, 200, 0, 0.10)
    tied = [Candidate("a", Score(0.5, 200, 1, 0.050)), Candidate("b", Score(0.5, 200, 1, 0.0501))]
    asked, added = [], []

    def with_requirements(decision):
        asked.append(decision.verdict)
        if decision.verdict == "undecided":
            return Decision("add", "a", together=("a2",), judgements=decision.judgements)
        return decision

    def add(decision):
        added.append((decision.effect, decision.together))
        return Score(0.2, 200, 2, 0.02)

    rounds = iter([tied, [Candidate("c", Score(0.2, 200, 3, 0.02), switched_off=True)]])
    end = forward_selection(base, lambda: ["a", "b", "c"], lambda names: next(rounds), add,
                            with_requirements=with_requirements)
    assert asked == ["undecided", "stop"] and added == [("a", ("a2",))] and end.verdict == "stop"


# --- 2. a tie as whole models ------------------------------------------------------------------

@pytest.fixture(scope="module")
def tie():
    """The issue's third record's class: 200 Hz, 12 s, ramps, a 60 ms lag and damping 45 N s/m, 0.3
    mm of noise: the lag and a dead time tie once the damping is in."""
    record = synthesize("knee", {"tau": 0.06, "c": 45.0}, {}, "model2", 0.3, 0, samples=2400,
                        rate=200.0, shape="ramps")
    measurement = as_read(record, source="tie.csv")
    return measurement, diagnose(measurement)


def test_each_alternative_of_a_tie_is_a_whole_model(tie):
    _, result = tie
    assert result.verdict == "undecided", summary(result)
    tied = {frozenset(u["effects"]) for u in result.undecided}
    assert tied == {frozenset({"pressure_lag", "dead_time"})}
    by_rival = {tuple(a["with"]): a for a in result.alternatives}
    assert set(by_rival) == {("pressure_lag",), ("dead_time",)}
    lag = by_rival[("pressure_lag",)]
    assert sorted(lag["effects"]) == ["pressure_lag", "viscous_damping"]
    assert set(lag["params"]) == {"c", "tau"} and set(lag["uncertainty"]) == {"c", "tau"}
    # the alternative that holds the truth holds it: its damping and lag within their standard
    # errors
    for name, true in (("c", 45.0), ("tau", 0.06)):
        assert abs(lag["params"][name] - true) <= SE_BAND * lag["uncertainty"][name], lag
    for alternative in result.alternatives:
        assert alternative["rmse"] > 0 and alternative["adequate"] is True


def test_the_top_level_of_a_tie_is_what_the_alternatives_share(tie):
    _, result = tie
    for alternative in result.alternatives:
        assert set(result.missing) <= set(alternative["effects"])
    assert set(result.params) <= {p for a in result.alternatives for p in a["params"]}
    # a shared value lies among the alternatives' own values
    for name, value in result.params.items():
        values = [a["params"][name] for a in result.alternatives]
        error = result.uncertainty[name]
        assert min(values) - error <= value <= max(values) + error
    best = min(a["rmse"] for a in result.alternatives)
    # the error after is a real alternative's
    assert result.rmse_after == pytest.approx(best, rel=1e-9)
    data = result.to_dict()
    effects_in_json = [a["effects"] for a in data["alternatives"]]
    assert effects_in_json == [a["effects"] for a in result.alternatives]
    text = "\n".join(summary(result))
    assert "alternative 1 (with " in text and "alternative 2 (with " in text


def test_the_pictures_of_a_tie_draw_each_alternative(tie, tmp_path):
    measurement, result = tie
    paths = save_pictures(measurement, result, tmp_path)
    from matplotlib import image
    for key in ("overlay", "residuals", "error_steps"):
        assert Path(paths[key]).stat().st_size > 0
        assert image.imread(paths[key]).shape[0] > 100
    from mkctl.io.diagnosis_report import error_bars
    labels, values, colours = error_bars(result)
    assert sum("pressure_lag" in label for label in labels[1:]) >= 1
    assert values[-2:] == [a["rmse"] for a in result.alternatives]


# --- 3. input noise on quasi-static records ----------------------------------------------------

def isotonic_with_noisy_inputs(seed: int, pressure_kpa: float = 4.0, load_n: float = 0.3,
                               length_mm: float = 0.1, correlation_s: float = 0.5):
    """The issue's second record's class: a 16 mm muscle, model 2, nothing hidden, noisy pressure
    and load, AR(1) length noise."""
    known = {"D0": 0.016}
    record = synthesize("isotonic", {}, known, "model2", length_mm, seed, input_noise=pressure_kpa,
                        noise_tau=correlation_s)
    inputs = dict(record.inputs)
    load_noise = np.random.default_rng(100 + seed).normal(0.0, load_n, inputs["force"].size)
    inputs["force"] = inputs["force"] + load_noise
    return measurement_from_arrays("isotonic", record.time, inputs, record.output, params=known,
                                   source="iso.csv")


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_nothing_added_on_a_clean_isotonic_record_under_the_issues_noise(seed):
    result = diagnose(isotonic_with_noisy_inputs(seed))
    assert result.verdict == "nothing missing" and result.missing == [], summary(result)


def test_heavy_input_noise_buys_no_damping():
    """16 kPa on the pressure (four times the issue's): damping c = 63 N s/m was added on this
    record, because BIC counted the residual's samples as independent while the smoothed pressure's
    noise, passed on by the model, is correlated over its window; the correlation of both noises is
    now what BIC counts with."""
    result = diagnose(isotonic_with_noisy_inputs(3, pressure_kpa=16.0))
    assert result.missing == [], summary(result)
    assert any("BIC counts the samples as correlated" in note for note in result.notes)


def test_a_real_friction_under_input_noise_has_an_honest_standard_error():
    """Fc = 0.5 N under 16 kPa of pressure noise: the friction comes out 1.77 N, and its standard
    error (0.22 N from the fit alone) now includes how far other realisations of the inputs' noise
    move it."""
    known = {"D0": 0.016}
    record = synthesize("isotonic", {"Fc": 0.5}, known, "model2", 0.1, 3, input_noise=16.0,
                        noise_tau=0.5)
    inputs = dict(record.inputs)
    load_noise = np.random.default_rng(103).normal(0.0, 0.3, inputs["force"].size)
    inputs["force"] = inputs["force"] + load_noise
    result = diagnose(measurement_from_arrays("isotonic", record.time, inputs, record.output,
                                              params=known, source="fric.csv"))
    assert result.verdict in ("diagnosed", "undecided"), summary(result)
    if "coulomb_friction" in result.missing:
        assert abs(result.params["Fc"] - 0.5) <= SE_BAND * result.uncertainty["Fc"], summary(result)


@pytest.mark.parametrize("seed", [0, 1])
def test_asymmetric_lag_with_damping_on_the_independent_rig(seed):
    """The independent rig (its own equations, coloured output noise of 10 ms, the valves 0.1 ms
    late), a 4 kg leg with 12 mm muscles, fill 0.05 s, exhaust 0.15 s, damping 40 N s/m, 0.05 mm of
    noise at 1 kHz. Round 1 ties the lag with damping and both frictions, and every pair falls
    short: the wider search finds damping, the lag and its exhausting time constant (seed 1 chose a
    spurious fourth effect before the best combination had to earn each of its effects)."""
    truth = {"tau": 0.05, "tau_exhaust": 0.15, "c": 40.0}
    m = rig.knee_record(truth, params=Params(m=4.0, D0=0.012), samples=3000, rate=1000.0,
                        noise=5e-5, noise_tau=0.01, seed=seed)
    result = diagnose(m)
    assert result.verdict == "diagnosed", summary(result)
    assert sorted(result.missing) == ["asymmetric_lag", "pressure_lag", "viscous_damping"]
    assert not within(result, {"tau": 0.05, "tau_exhaust": 0.15})


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_nothing_added_on_a_clean_isotonic_rig_record_under_the_issues_noise(seed):
    """The independent rig's isotonic test (a known damper of 100 N s/m), 4 kPa on the pressure, 0.3
    N on the load, 0.1 mm of AR(1) length noise over 1 s."""
    params = Params(D0=0.016, c=100.0)
    m = rig.isotonic_record({"c": 100.0}, params=params, noise=1e-4, noise_tau=1.0,
                            pressure_noise=4e3, seed=seed)
    load = m.inputs["force"] + np.random.default_rng(50 + seed).normal(0.0, 0.3, m.samples)
    inputs = {"pressure": m.inputs["pressure"], "force": load}
    m = measurement_from_arrays("isotonic", m.time, inputs, m.output,
                                params={"D0": 0.016, "c": 100.0}, source="rig.csv")
    result = diagnose(m)
    frictions = {"coulomb_friction", "pressure_friction"}
    assert not frictions & set(result.missing), summary(result)


def test_a_tie_of_many_alternatives_draws_every_one(tie, tmp_path):
    """Four explanations and the baseline: the overlay draws five curves (it ran out of colours at
    four)."""
    import dataclasses

    from mkctl.io.diagnosis_report import plot_overlay

    measurement, result = tie
    curves = {"baseline": result.simulated_before,
              **{f"alternative {k}": result.simulated_after + k * 1e-4 for k in range(4)}}
    path = plot_overlay(measurement, curves, tmp_path / "many.png")
    assert path.stat().st_size > 0
    many = dataclasses.replace(result, alternatives=result.alternatives * 2,
                               alternative_simulated=result.alternative_simulated * 2)
    paths = save_pictures(measurement, many, tmp_path, stem="many")
    assert Path(paths["overlay"]).stat().st_size > 0
