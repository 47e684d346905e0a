"""Outputs read in counts (a joint encoder): the noise estimate, the bench's resolution, and the diagnosis.

A fine encoder on a slow motion repeats one count for many samples: its second differences are mostly zero, so
the estimate from them alone calls the record noise-free, and a perfect model then looks "incomplete". The noise
of such a sensor is at least its rounding error q / sqrt(12).
"""
import math

import numpy as np
import pytest

from mkctl.analysis import diagnose as dg
from mkctl.analysis.synth import synthesize, write_synthetic
from mkctl.cli import main
from mkctl.errors import ParameterError
from mkctl.io.measurements import read_measurement

COUNT_12_BIT = 360.0 / 2 ** 12  # deg
COUNT_14_BIT = 360.0 / 2 ** 14


def slow_motion(samples=3000):
    t = np.linspace(0.0, 3.0, samples)
    return 120.0 + 4.0 * np.sin(2 * np.pi * 0.4 * t)  # deg: a slow swing across about 180 counts of 12 bits


def test_the_count_of_an_encoder_is_found_through_a_files_rounding():
    counts = np.round(slow_motion() / COUNT_12_BIT) * COUNT_12_BIT
    written = np.round(counts, 6)  # the file keeps 6 decimals of the counts
    assert dg.quantization_step(written) == pytest.approx(COUNT_12_BIT, rel=1e-5)
    # what the second differences alone see: almost no noise at all
    assert dg.input_noise(written) < 0.1 * COUNT_12_BIT / math.sqrt(12)
    assert dg.output_noise(written) == pytest.approx(COUNT_12_BIT / math.sqrt(12), rel=1e-5)


def test_a_continuous_noisy_output_has_no_count_and_keeps_its_noise_estimate():
    rng = np.random.default_rng(0)
    noisy = slow_motion() + rng.normal(0.0, 0.01, 3000)
    assert dg.quantization_step(noisy) == 0.0
    assert dg.output_noise(noisy) == dg.input_noise(noisy)
    assert dg.output_noise(noisy) == pytest.approx(0.01, rel=0.1)
    # written with 3 decimals, the file's own grid (1e-3) lies far below the noise and changes nothing
    written = np.round(noisy, 3)
    assert dg.quantization_step(written) == pytest.approx(1e-3, rel=1e-6)
    assert dg.output_noise(written) == dg.input_noise(written)
    assert dg.quantization_step([1.0, 1.0, 2.0]) == 0.0  # two levels tell no grid


def test_synth_rounds_the_output_to_the_sensors_resolution():
    record = synthesize("knee", {"c": 30.0}, samples=300, rate=100.0, noise=0.0005, output="beta_deg",
                        resolution=COUNT_12_BIT)
    counts = np.degrees(record.output) / COUNT_12_BIT
    np.testing.assert_allclose(counts, np.round(counts), atol=1e-9)
    assert np.unique(np.round(counts)).size > 20  # the knee moves across many counts
    with pytest.raises(ParameterError, match="resolution"):
        synthesize("knee", None, samples=300, rate=100.0, resolution=-1.0)
    with pytest.raises(ParameterError, match="isometric"):
        synthesize("isometric", None, resolution=0.1)


@pytest.mark.parametrize("bits", [12, 14])
def test_damping_behind_a_joint_encoder_is_diagnosed_not_called_incomplete(tmp_path, bits):
    count = 360.0 / 2 ** bits
    record = synthesize("knee", {"c": 30.0}, seed=1, noise=0.0005, output="beta_deg", resolution=count)
    path, _ = write_synthetic(tmp_path / "encoder.csv", record)
    result = dg.diagnose(read_measurement(path))
    assert result.verdict == "diagnosed", result.notes
    assert result.missing == ["viscous_damping"]
    error = result.uncertainty["c"]
    assert 0 < error < 0.2 * 30.0
    assert abs(result.params["c"] - 30.0) < 4 * error
    assert result.rmse_after < 1.5 * count / math.sqrt(12)  # down to the encoder's rounding


def test_synth_command_writes_an_encoder_record(tmp_path, capsys):
    path = tmp_path / "angle.csv"
    assert main(["synth", "knee", str(path), "--samples", "200", "--rate", "100", "--output-column", "beta_deg",
                 "--resolution", str(COUNT_14_BIT), "--noise", "0.0005"]) == 0
    assert f"resolution {COUNT_14_BIT:g} deg" in capsys.readouterr().out
    values = read_measurement(path).output  # SI: rad
    assert dg.quantization_step(values) == pytest.approx(math.radians(COUNT_14_BIT), rel=1e-4)
