"""The virtual test bench's realism: command shapes, sensor noise on inputs, coloured output noise, offsets, angle.

Each property is checked against what it must be by its definition (the chirp's cycle count from its
frequency law, the lag's exponential, the AR(1) correlation exp(-dt/tau)), not against the code's own output.
"""
import math

import numpy as np
import pytest

from mkctl.analysis import synth
from mkctl.analysis.synth import synthesize, write_synthetic
from mkctl.errors import ParameterError
from mkctl.io.measurements import read_measurement
from mkctl.physics.isotonic import simulate_isotonic
from mkctl.physics.simulate import default_commands


def test_knee_shapes_reach_the_same_levels_by_steps_ramps_or_a_chirp():
    pe0, _ = default_commands()
    t, steps, pf = synth.knee_inputs(1000, 200.0, shape="steps")
    _, ramps, _ = synth.knee_inputs(1000, 200.0, shape="ramps")
    assert set(np.round(steps / pe0, 6)) == {1.0, *[f for _, f in synth.KNEE_STEPS]}
    # ramps: continuous (no jump larger than a ramp's slope allows), same final level as the steps
    largest_change = max(abs(a - b) for (_, a), (_, b) in zip(((0, 1.0), *synth.KNEE_STEPS), synth.KNEE_STEPS))
    per_sample = largest_change * pe0 / (synth.RAMP_FRACTION * t[-1] * 200.0)
    assert np.max(np.abs(np.diff(ramps))) <= per_sample * 1.01
    assert ramps[-1] == pytest.approx(steps[-1])
    assert np.all(pf == pf[0])


def test_chirp_changes_at_every_sample_and_sweeps_its_frequency():
    rate, samples = 500.0, 2000
    t, pe, _ = synth.knee_inputs(samples, rate, shape="chirp")
    pe0, _ = default_commands()
    start = 0.05 * t[-1]
    moving = t > start + 1 / rate
    assert np.all(np.diff(pe[moving]) != 0)
    assert np.max(np.abs(pe / pe0 - 1)) == pytest.approx(synth.CHIRP_AMPLITUDE, rel=1e-3)
    # a linear chirp from f0 to f1 makes (f0 + f1) / 2 * duration cycles: two sign changes each
    f0, f1 = synth.CHIRP_FREQUENCIES
    cycles = 0.5 * (f0 + f1) * (t[-1] - start)
    deviation = pe[moving] / pe0 - 1
    crossings = np.count_nonzero(np.diff(np.sign(deviation)) != 0)
    assert abs(crossings - 2 * cycles) <= 2


def test_isotonic_pressure_noise_is_on_the_file_not_on_the_truth():
    record = synthesize("isotonic", {}, noise=0.0, samples=1500, input_noise=2.0, seed=3)
    written = record.inputs["pressure"]
    clean = record.inputs_clean["pressure"]
    assert np.std(written - clean) == pytest.approx(2e3, rel=0.1)  # 2 kPa
    # the truth is the clean pressure's length, not the noisy one's
    np.testing.assert_allclose(record.output_clean, simulate_isotonic(record.time, clean, record.inputs["force"],
                                                                      record.truth))


def test_coloured_noise_has_the_asked_deviation_and_correlation():
    rng = np.random.default_rng(0)
    time = np.arange(20000) * 1e-3
    e = synth.colored_noise(rng, 0.5, time, tau=0.01)
    assert np.std(e) == pytest.approx(0.5, rel=0.05)
    rho = np.corrcoef(e[1:], e[:-1])[0, 1]
    assert rho == pytest.approx(math.exp(-1e-3 / 0.01), abs=0.02)
    white = synth.colored_noise(rng, 0.5, time)
    assert abs(np.corrcoef(white[1:], white[:-1])[0, 1]) < 0.03


def test_declared_offset_is_removed_by_the_reader_and_an_undeclared_one_stays(tmp_path):
    declared = synthesize("knee", {}, noise=0.0, samples=200, rate=100.0, offset=12.5, declare_offset=True)
    path, _ = write_synthetic(tmp_path / "d.csv", declared)
    assert "# x_offset_mm = 12.5" in path.read_text()
    np.testing.assert_allclose(read_measurement(path).output, declared.output, atol=1e-9)
    hidden = synthesize("knee", {}, noise=0.0, samples=200, rate=100.0, offset=12.5)
    path, _ = write_synthetic(tmp_path / "h.csv", hidden)
    np.testing.assert_allclose(read_measurement(path).output, hidden.output + 12.5e-3, atol=1e-9)


def test_angle_output_and_measured_pressures_of_the_truth(tmp_path):
    tau = 0.05
    record = synthesize("knee", {"tau": tau}, noise=0.0, samples=400, rate=200.0, output="beta_deg",
                        pressures=True)
    path, _ = write_synthetic(tmp_path / "b.csv", record)
    m = read_measurement(path)
    assert m.output_column == "beta_deg" and m.output_quantity == "beta"
    assert np.all((m.output > np.radians(90)) & (m.output < np.radians(180)))
    # the written pe is the truth's lagged pressure: after the first step at t1 it approaches the new
    # command as P = P_cmd + (P(t1) - P_cmd) exp(-(t - t1) / tau)
    pe_cmd, pe = m.inputs["pe_cmd"], m.inputs["pe"]
    k = int(np.flatnonzero(np.diff(pe_cmd) != 0)[0]) + 1  # first sample holding the new command
    t = m.time[k:k + 20] - m.time[k]
    expected = pe_cmd[k] + (pe[k] - pe_cmd[k]) * np.exp(-t / tau)
    np.testing.assert_allclose(pe[k:k + 20], expected, rtol=1e-6)


@pytest.mark.parametrize("options, message", [
    ({"shape": "zigzag"}, "unknown command shape"),
    ({"input_noise": -1.0}, "input noise"),
    ({"output": "x_furlong"}, "not an output"),
    ({"noise_tau": float("nan")}, "correlation time"),
])
def test_bad_options_are_one_line_errors(options, message):
    with pytest.raises(ParameterError, match=message):
        synthesize("knee", {}, samples=50, rate=100.0, **options)
