"""The isometric (blocked-force) model, its synthetic bench and its file round trip.

References: the spec's table of model 2 (model-spec section 2), the spec's rule for friction at a clamped
length (f - Fc up, f + Fc down, section 5) and slack (max(f, 0) applied last, section 4).
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from mkctl.analysis.compare import plot_isometric, simulate_output
from mkctl.analysis.synth import isometric_inputs, synthesize, synthesize_isometric, write_synthetic
from mkctl.errors import DomainError
from mkctl.io.measurements import read_measurement
from mkctl.physics.isometric import hysteresis_tension, isometric_tension
from mkctl.physics.params import Params


def test_tension_matches_the_spec_table_on_both_branches():
    # model-spec section 2: f2(0.18 m, 300 kPa) = 75.248131 N; section 5: f - Fc up, f + Fc down
    p = Params(Fc=2.0)
    assert isometric_tension(0.18, 300e3, 1, p) == pytest.approx(75.248131 - 2.0, abs=1e-6)
    assert isometric_tension(0.18, 300e3, -1, p) == pytest.approx(75.248131 + 2.0, abs=1e-6)
    assert isometric_tension(0.18, 300e3, 1, Params()) == pytest.approx(75.248131, abs=1e-6)


def test_slack_applies_last_to_the_whole_tension():
    # f2(0.16 m, 200 kPa) = -1.807147 N (spec table): a slack muscle carries nothing instead of pushing
    assert isometric_tension(0.16, 200e3, 1, Params()) == pytest.approx(-1.807147, abs=1e-6)
    assert isometric_tension(0.16, 200e3, 1, Params(slack=1)) == 0.0
    # friction first, slack last: down branch -1.807 + 2 > 0 stays, up branch -1.807 - 2 clips to 0
    assert isometric_tension(0.16, 200e3, -1, Params(slack=1, Fc=2.0)) == pytest.approx(0.192853, abs=1e-6)
    assert isometric_tension(0.16, 200e3, 1, Params(slack=1, Fc=2.0)) == 0.0


def test_arrays_broadcast_and_bad_branches_are_refused():
    L = np.array([0.16, 0.18])
    out = isometric_tension(L, 300e3, np.array([1, -1]), Params(Fc=1.0))
    assert out.shape == (2,)
    assert out[1] == pytest.approx(75.248131 + 1.0, abs=1e-6)
    with pytest.raises(DomainError, match="branch"):
        isometric_tension(0.18, 300e3, 0, Params(Fc=1.0))
    with pytest.raises(DomainError, match="branch"):
        hysteresis_tension(10.0, np.array([1, 2]), 1.0)
    with pytest.raises(DomainError):
        isometric_tension(0.25, 300e3, 1, Params())  # beyond b = 0.241 m


def test_bench_inputs_step_up_then_down_at_each_length():
    time, length, pressure, branch = isometric_inputs(400)
    assert length.size == 400 and np.unique(length).size == 4
    for value in np.unique(length):
        here = length == value
        p, s = pressure[here], branch[here]
        rising = np.diff(p) > 0
        # the branch of each point after the first follows the direction the pressure came from
        assert np.array_equal(s[1:] > 0, rising)
        assert p.min() == 0.0 and p.max() == pytest.approx(600e3)
    assert np.all(np.diff(time) > 0)


def test_synthetic_record_is_the_truth_plus_offset_and_survives_the_file(tmp_path):
    record = synthesize_isometric(["slack", "coulomb_friction"], noise=0.0, offset=1.5)
    truth = Params(slack=1, Fc=2.0)
    assert record.truth == truth
    expected = isometric_tension(record.inputs["length"], record.inputs["pressure"], record.inputs["branch"], truth)
    assert np.allclose(record.output, expected, atol=1e-12)  # the offset is added when written
    assert (record.output_clean[record.inputs["length"] < 0.16] >= 0).all()
    path, truth_path = write_synthetic(tmp_path / "iso.csv", record)
    truth_json = json.loads(truth_path.read_text())
    assert truth_json["offset"] == 1.5 and truth_json["noise_unit"] == "N"
    m = read_measurement(path)
    assert m.experiment == "isometric"
    assert np.array_equal(m.branch, record.inputs["branch"])
    assert np.allclose(simulate_output(m, truth), m.output - 1.5, atol=1e-9)


def test_synthesize_dispatches_isometric_with_force_noise():
    record = synthesize("isometric", ["coulomb_friction"], noise=None, seed=1)
    residual = record.output - record.output_clean
    assert 0.4 < residual.std() < 0.6  # the default 0.5 N


def test_force_against_pressure_figure(tmp_path):
    record = synthesize_isometric(["slack"], noise=0.3)
    path = plot_isometric(record.inputs["length"], record.inputs["pressure"], record.output,
                          record.inputs["branch"], {"truth": Params(slack=1), "model 2": Params()},
                          tmp_path / "iso.png", L0=0.208)
    assert path.stat().st_size > 10_000


@pytest.mark.parametrize("hidden, expected", [
    (["slack", "coulomb_friction"], {"slack", "coulomb_friction"}),
    (["coulomb_friction"], {"coulomb_friction"}),
    ([], set()),
])
def test_diagnose_finds_the_isometric_effects(tmp_path, hidden, expected):
    from mkctl.analysis.diagnose import diagnose, save_pictures

    path, _ = write_synthetic(tmp_path / "iso.csv", synthesize_isometric(hidden, noise=0.5, seed=3))
    m = read_measurement(path)
    report = diagnose(m)
    assert set(report["missing"]) == expected
    if "coulomb_friction" in expected:
        assert report["params"]["Fc"] == pytest.approx(2.0, abs=4 * report["uncertainty"]["Fc"])
    assert report["rmse_after"] < 0.6  # the 0.5 N noise
    pictures = save_pictures(m, report, tmp_path)
    assert "isometric" in pictures


def test_compare_cli_draws_tension_against_pressure(tmp_path):
    import subprocess
    import sys

    path, _ = write_synthetic(tmp_path / "iso.csv", synthesize_isometric(["slack"], noise=0.5))
    done = subprocess.run([sys.executable, "-m", "mkctl", "compare", str(path)], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert (tmp_path / "iso_compare_isometric.png").exists()
    # the file hides slack; the baseline (no slack) pushes at the short length: RMSE well above the noise
    assert float(done.stdout.split("RMSE ")[1].split()[0]) > 1.0


def test_synth_cli_writes_an_isometric_bench(tmp_path):
    import subprocess
    import sys

    done = subprocess.run([sys.executable, "-m", "mkctl", "synth", "isometric", str(tmp_path / "b.csv"), "--hidden",
                           "slack", "--offset", "2", "--noise", "0"], capture_output=True, text=True)
    assert done.returncode == 0, done.stderr
    assert "noise 0 N" in done.stdout and "sensor offset 2 N" in done.stdout
    truth = json.loads((tmp_path / "b.truth.json").read_text())
    assert truth["hidden_effects"] == ["slack"] and truth["offset"] == 2.0
    m = read_measurement(tmp_path / "b.csv")
    expected = isometric_tension(m.inputs["length"], m.inputs["pressure"], m.branch, Params(slack=1)) + 2.0
    assert np.allclose(m.output, expected, atol=1e-9)
    bad = subprocess.run([sys.executable, "-m", "mkctl", "synth", "isometric", str(tmp_path / "c.csv"), "--offset",
                          "nan"], capture_output=True, text=True)
    assert bad.returncode == 2 and "offset" in bad.stderr and "Traceback" not in bad.stderr
