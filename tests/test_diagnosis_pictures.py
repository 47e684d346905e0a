"""The diagnosis pictures show what their captions say: each signature panel against its effect's own regressor,
the error bars ending on the final fit, overlays with quantity names, and root loci holding every pole."""
import math

import numpy as np
import pytest

from mkctl.analysis import control as mc
from mkctl.analysis.diagnose import diagnose
from mkctl.analysis.synth import synthesize
from mkctl.physics import effects
from mkctl.io.diagnosis_report import (LAG_PICTURE_TAU, _pressure_deficit, error_bars, input_panels, output_label, parameter_text,
                                       save_pictures, summary)
from mkctl.io.measurements import read_measurement
from mkctl.analysis.synth import write_synthetic


@pytest.fixture(scope="module")
def damped(tmp_path_factory):
    """A knee record with damping hidden, diagnosed (about a second)."""
    folder = tmp_path_factory.mktemp("pictures")
    path, _ = write_synthetic(folder / "knee.csv", synthesize("knee", hidden=["viscous_damping"], samples=1500, seed=2))
    measurement = read_measurement(path)
    return measurement, diagnose(measurement), folder


def test_each_signature_is_against_its_effects_own_regressor(damped):
    measurement, result, _ = damped
    sigs = result.signatures
    speed = sigs["viscous_damping"]["x"]
    direction = sigs["coulomb_friction"]["x"]
    assert np.all(np.abs(direction) <= 1) and direction.min() < -0.9 and direction.max() > 0.9
    np.testing.assert_allclose(direction, np.tanh(speed / (measurement.params.vs * 1e3)))
    # pressure friction: the pressure times the direction (not the velocity again, nor the direction alone)
    np.testing.assert_allclose(sigs["pressure_friction"]["x"], sigs["pressure_threshold"]["x"] * direction)
    assert np.ptp(sigs["pressure_friction"]["x"] - direction) > 1.0
    # slack: the smaller muscle tension of the model, positive everywhere in this record (nothing goes slack)
    assert sigs["slack"]["x"].min() > 1.0 and np.ptp(sigs["slack"]["x"]) > 1.0
    # the lag: the extensor's pressure behind its command at the first round's fitted tau, zero between transients
    behind, label = _pressure_deficit(measurement, result, effects.get("pressure_lag"))
    fitted = next(r["params"]["tau"] for r in result.steps[0]["candidates"] if r["effect"] == "pressure_lag")
    tau = fitted or LAG_PICTURE_TAU
    assert f"tau = {tau:.3g} s" in label and behind.shape == measurement.time.shape
    step = np.flatnonzero(np.diff(measurement.inputs["pe_cmd"]))[0] + 1  # first command step
    jump = (measurement.inputs["pe_cmd"][step] - measurement.inputs["pe_cmd"][step - 1]) / 1e3
    dt = measurement.time[step + 1] - measurement.time[step]
    assert behind[step] == pytest.approx(jump, rel=1e-9)  # the lag has not moved yet at the step's sample
    assert behind[step + 1] == pytest.approx(jump * math.exp(-dt / tau), rel=1e-9)
    assert behind[step - 1] == 0.0


def test_the_last_error_bar_is_the_final_fit_the_report_prints(damped):
    _, result, _ = damped
    labels, values, _ = error_bars(result)
    assert values[0] == result.rmse_before and values[1:-1] == result.error_steps[1:]
    assert values[-1] == result.rmse_after and "final" in labels[-1]
    assert f"after: RMSE {values[-1]:.4g}" in "\n".join(summary(result))


def test_overlay_labels_and_inputs(damped):
    measurement, result, folder = damped
    assert output_label(measurement) == "hip height X [mm]"
    panels = input_panels(measurement)
    assert [label for label, _ in panels] == ["extensor pe [kPa]", "flexor pf [kPa]"]
    np.testing.assert_allclose(panels[1][1][0][0], measurement.inputs["pf_cmd"] / 1e3)
    paths = save_pictures(measurement, result, folder)
    assert set(paths) == {"error_steps", "overlay", "residuals", "signatures"}


def test_switches_print_as_on_or_off():
    assert parameter_text("slack", 0) == "slack = 0 (off)"
    assert parameter_text("slack", 1.0) == "slack = 1 (on)"
    assert parameter_text("c", 45.0234) == "c = 45.02 N s/m"


def test_the_lag_sweep_shows_every_pole_and_the_gain_locus_every_symbol():
    op = mc.operating_point(math.radians(60), Pf=100e3)
    op = op.with_params(c=mc.damping_for_zeta(0.3, op))
    taus = np.geomspace(1e-3, 1.0, 20)
    fig = mc.plot_lag_sweep(op, taus, gain=2e7)
    _, open_loop, closed = mc.lag_sweep(op, taus, 2e7)
    for ax, poles in zip(fig.axes[:2], (open_loop, closed)):
        left, right = ax.get_xlim()
        bottom, top = ax.get_ylim()
        poles = poles[np.isfinite(poles)]
        assert left <= poles.real.min() and poles.real.max() <= right
        assert bottom <= poles.imag.min() and poles.imag.max() <= top
    fig, _ = mc.plot_gain_locus(op, np.geomspace(1e4, 1e8, 50))
    legend = fig.axes[0].get_legend()
    for handle in legend.legend_handles:
        assert handle.get_marker() not in (None, "", " ", "None")
