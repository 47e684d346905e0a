"""Diagnosis on data with hidden effects: the bench hides them, diagnose must find them without being told.

Each case writes a file with the virtual test bench (:mod:`mkctl.analysis.synth`), reads it back as a user's file,
and diagnoses it. The truth is what synth simulated with; diagnose sees only the file.
"""
import json

import numpy as np
import pytest

from mkctl.analysis import diagnose as dg
from mkctl.analysis.compare import compare, fit_percent, rmse, simulate_output
from mkctl.io.measurements import read_measurement
from mkctl.physics.params import Params
from mkctl.physics.simulate import simulate_knee
from mkctl.analysis.synth import synthesize, truth_path_for, write_synthetic

NOISE_MM = 0.01
KNEE = {"samples": 1500, "rate": 500.0}  # 3 s of record, as the default bench, at half the rate


def run(tmp_path, experiment, hidden, known=None, baseline="model2", seed=1, **options):
    options = {**(KNEE if experiment == "knee" else {}), **options}
    record = synthesize(experiment, hidden, known, baseline, NOISE_MM, seed, **options)
    path, _ = write_synthetic(tmp_path / f"{experiment}.csv", record)
    measurement = read_measurement(path)
    return dg.diagnose(measurement), record


def check(report, record, expected):
    assert report["missing"] == expected
    assert set(report["params"]) == {dg.CANDIDATES[e].parameter for e in expected}
    for effect in expected:
        name = dg.CANDIDATES[effect].parameter
        true = getattr(record.truth, name)
        assert report["params"][name] == pytest.approx(true, rel=0.10), name
        assert 0 < report["uncertainty"][name] < 0.1 * true
    # the error falls step by step, down to the noise
    rmses = [report["rmse_before"]] + [s["rmse"] for s in report["steps"]]
    assert all(b < a for a, b in zip(rmses, rmses[1:]))
    assert report["rmse_after"] < 1.5 * NOISE_MM
    assert report["stopped"] is not None  # the last round says why it stopped


def test_isotonic_elasticity_is_found_with_a_model1_baseline(tmp_path):
    report, record = run(tmp_path, "isotonic", ["elasticity"], baseline="model1")
    check(report, record, ["elasticity"])
    assert report["rmse_before"] > 100 * NOISE_MM


def test_isotonic_coulomb_friction_is_found_and_not_taken_for_damping(tmp_path):
    report, record = run(tmp_path, "isotonic", {"Fc": 1.5})
    check(report, record, ["coulomb_friction"])
    first = report["steps"][0]["candidates"]
    assert [c["effect"] for c in first] == ["coulomb_friction", "viscous_damping"]
    # the sweep at two rates separates them clearly: no near-tie
    assert report["steps"][0]["ties"] == []
    assert first[0]["signature"]["correlation"] > 0.8


def test_knee_viscous_damping_is_found(tmp_path):
    report, record = run(tmp_path, "knee", {"c": 30.0})
    check(report, record, ["viscous_damping"])
    signature = report["steps"][0]["candidates"][0]["signature"]
    assert signature["correlation"] > 0.8  # the force the model lacks goes with velocity
    assert signature["estimate"] == pytest.approx(30.0, rel=0.2)


def test_knee_pressure_lag_is_found(tmp_path):
    report, record = run(tmp_path, "knee", {"tau": 0.04})
    check(report, record, ["pressure_lag"])


def test_knee_coulomb_friction_is_found_when_the_damping_is_known(tmp_path):
    report, record = run(tmp_path, "knee", {"Fc": 2.0}, known={"c": 45.0})
    assert report["baseline_effects"] == ["elasticity", "viscous_damping"]
    check(report, record, ["coulomb_friction"])
    assert "viscous_damping" not in [c["effect"] for c in report["steps"][0]["candidates"]]


def test_knee_two_effects_at_once(tmp_path):
    report, record = run(tmp_path, "knee", {"c": 45.0, "tau": 0.03}, seed=3)
    assert sorted(report["missing"]) == ["pressure_lag", "viscous_damping"]
    check(report, record, report["missing"])


def test_isotonic_two_effects_at_once(tmp_path):
    report, record = run(tmp_path, "isotonic", ["elasticity", "coulomb_friction"], baseline="model1")
    check(report, record, ["elasticity", "coulomb_friction"])


@pytest.mark.parametrize("experiment", ["knee", "isotonic"])
def test_no_effect_is_invented_in_data_that_has_none(tmp_path, experiment):
    report, _ = run(tmp_path, experiment, {}, seed=5)
    assert report["missing"] == [] and report["params"] == {} and report["steps"] == []
    assert report["rmse_after"] == report["rmse_before"] < 1.5 * NOISE_MM
    for row in report["stopped"]["candidates"]:
        assert not (row["passes_bic"] and row["passes_holdout"])
        assert row["delta_bic"] > -dg.BIC_THRESHOLD


def test_report_is_json_with_the_spec_keys_and_pictures(tmp_path):
    report, _ = run(tmp_path, "isotonic", {"c": 200.0})
    data = json.loads(json.dumps(dg.public(report), allow_nan=False))
    for key in ("experiment", "baseline", "output", "rmse_before", "rmse_after", "missing", "params", "steps"):
        assert key in data
    assert data["output"] == "length_mm" and data["experiment"] == "isotonic"
    step = data["steps"][0]
    assert {"added", "rmse", "candidates"} <= set(step)
    assert {"effect", "rmse", "bic", "params", "signature"} <= set(step["candidates"][0])
    paths = dg.save_pictures(read_measurement(tmp_path / "isotonic.csv"), report, tmp_path / "png")
    assert set(paths) == {"error_steps", "overlay", "residuals", "signatures"}
    for path in paths.values():
        with open(path, "rb") as f:
            assert f.read(8) == b"\x89PNG\r\n\x1a\n"
    assert any("missing: viscous_damping" in line for line in dg.summary(report))


def test_near_ties_name_the_experiment_that_separates_them():
    rows = [{"effect": "viscous_damping", "bic": -500.0, "passes_bic": True},
            {"effect": "pressure_lag", "bic": -495.0, "passes_bic": True},
            {"effect": "coulomb_friction", "bic": -300.0, "passes_bic": True}]
    ties = dg._ties(rows)
    assert [t["effects"] for t in ties] == [["viscous_damping", "pressure_lag"]]
    assert "clamped" in ties[0]["experiment"]
    assert all(dg.DISCRIMINATING_EXPERIMENTS.get(frozenset({a, b}))
               for a in dg.CANDIDATES for b in dg.CANDIDATES if a != b)


def test_knee_output_on_a_subset_matches_simulate_knee(tmp_path):
    record = synthesize("knee", {"c": 20.0, "tau": 0.02}, samples=400, rate=400.0, noise=0.0)
    path, _ = write_synthetic(tmp_path / "k.csv", record, truth_file=False)
    m = read_measurement(path)
    at = np.arange(0, m.samples, 7)
    reference = simulate_knee(m.time, m.inputs["pe_cmd"], m.inputs["pf_cmd"], record.truth)["X"]
    np.testing.assert_allclose(simulate_output(m, record.truth, at), reference[at], atol=1e-8)
    np.testing.assert_allclose(simulate_output(m, record.truth), reference, atol=1e-8)


def test_compare_scores_against_hand_computed_values(tmp_path):
    y = np.array([1.0, 2.0, 3.0, 4.0])
    yhat = np.array([1.0, 2.0, 3.0, 5.0])
    assert rmse(y, yhat) == pytest.approx(0.5)
    assert fit_percent(y, yhat) == pytest.approx(100 * (1 - 1 / np.sqrt(5)))
    record = synthesize("isotonic", {}, noise=0.0, samples=200)
    path, _ = write_synthetic(tmp_path / "i.csv", record, truth_file=False)
    result = compare(read_measurement(path))
    assert result.rmse < 1e-8 and result.fit_percent > 99.999  # the baseline is the truth here
    assert truth_path_for(path).name == "i.truth.json"


def test_elasticity_candidate_switches_model2_on():
    params = dg.CANDIDATES["elasticity"].apply(Params(model=1), 1.5e5)
    assert params.model == 2 and params.C1 == 1.5e5 and params.C2 == Params().C2
