"""Slack as a diagnosis candidate on a knee record: a flexor with no pressure on a bent leg would push in
model 2; a real braid goes slack. Found when hidden, not added when absent."""
import json
import subprocess
import sys

import numpy as np
import pytest

from mkctl import Params
from mkctl.analysis.diagnose import diagnose
from mkctl.io.measurements import measurement_from_arrays, write_measurement
from mkctl.physics import knee, simulate, stability


def _record(truth: Params, seed: int):
    pe0 = float(stability.equilibrium_pressure(np.radians(40), 0.0, truth))
    t = np.arange(1200) / 1000.0
    pe = np.full(t.size, pe0)
    pe[t > 0.1] *= 1.05
    pe[t > 0.7] = pe0 * 0.95
    pf = np.zeros(t.size)
    X = simulate.simulate_knee(t, pe, pf, truth)["X"]
    noisy = X + np.random.default_rng(seed).normal(0.0, 1e-5, X.size)  # 0.01 mm
    return t, pe, pf, noisy


def test_the_flexor_would_push_in_this_posture():
    # the premise of the test: at alpha = 40 deg with no flexor pressure the model-2 flexor tension is negative
    p = Params(m=3.0)
    geo = knee.geometry_at_X(float(knee.X_from_alpha(np.radians(40), p)), p)
    assert knee.knee_force(geo, 0.0, 1e6, 0.0, p).ff < -5.0


def test_hidden_slack_is_found_and_absent_slack_is_not_added():
    t, pe, pf, X = _record(Params(slack=1, m=3.0), 1)
    found = diagnose(measurement_from_arrays("knee", t, {"pe_cmd": pe, "pf_cmd": pf}, X, params={"m": 3.0}))
    report = found.to_dict()
    assert report["missing"] == ["slack"]
    assert report["rmse_after"] < 2 * 0.01 < report["rmse_before"]  # mm: down to the noise
    from mkctl.io.diagnosis_report import summary
    assert "  slack = 1 (on)" in summary(found)  # a switch, not a value with a standard error
    t, pe, pf, X = _record(Params(m=3.0), 2)
    clean = diagnose(measurement_from_arrays("knee", t, {"pe_cmd": pe, "pf_cmd": pf}, X, params={"m": 3.0}))
    assert clean.to_dict()["missing"] == []


def test_slack_diagnosis_on_the_command_line_writes_its_pictures(tmp_path):
    t, pe, pf, X = _record(Params(slack=1, m=3.0), 3)
    path = write_measurement(tmp_path / "k.csv", "knee", t, {"pe_cmd": pe, "pf_cmd": pf}, X, metadata={"m": 3.0})
    done = subprocess.run([sys.executable, "-m", "mkctl", "diagnose", str(path), "--json", str(tmp_path / "r.json"),
                           "--quiet"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 0, done.stderr
    assert json.loads((tmp_path / "r.json").read_text())["missing"] == ["slack"]
    assert len(list(tmp_path.glob("*.png"))) >= 3
