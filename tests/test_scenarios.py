"""The scenario scripts run as users run them (``python scenarios/NAME.py``), with short settings."""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]

CASES = {
    "pressure_step": (["--duration", "0.6"], "new equilibrium"),
    "slow_squat": (["--duration", "1.0"], "stable all the way"),
    "push_recovery": (["--duration", "0.5", "--c", "40"], "pushed to"),
    "damping_sweep": (["--duration", "0.4", "--c", "0,80"], "overshoot"),
    "isotonic_sweep": (["--duration", "2.0"], "loop width"),
}


@pytest.mark.parametrize("name", CASES)
def test_scenario_runs_to_its_end_and_writes_csv_and_png(name, built_fmus, tmp_path):
    options, expected = CASES[name]
    done = subprocess.run([sys.executable, str(ROOT / "scenarios" / f"{name}.py"), "--out", str(tmp_path),
                           "--fmu-dir", str(built_fmus["knee"].parent), *options],
                          capture_output=True, text=True, cwd=tmp_path, timeout=180)
    assert done.returncode == 0, done.stderr[-3000:]
    assert expected in done.stdout and "wrote" in done.stdout
    assert (tmp_path / f"{name}.png").stat().st_size > 10_000
    data = np.genfromtxt(tmp_path / f"{name}.csv", delimiter=",", names=True)
    duration = float(options[options.index("--duration") + 1])
    assert data["time_s"][-1] == pytest.approx(duration), "the run must reach its stop time"
    assert all(np.all(np.isfinite(data[column])) for column in data.dtype.names)
    if name == "isotonic_sweep":
        np.testing.assert_allclose(data["f_N"], 50.0, atol=1e-6)  # the tension carries the load throughout
        assert data["contraction"].max() > 0.1


def test_scenario_reports_a_run_that_cannot_reach_its_end(built_fmus, tmp_path):
    # a push beyond the leg's range: X0 outside the model's domain, the FMU refuses, the script says why
    done = subprocess.run([sys.executable, str(ROOT / "scenarios" / "push_recovery.py"), "--out", str(tmp_path),
                           "--fmu-dir", str(built_fmus["knee"].parent), "--duration", "0.1", "--push-mm", "900"],
                          capture_output=True, text=True, cwd=tmp_path, timeout=120)
    assert done.returncode == 1
    assert "invalid start X0" in done.stderr and "Traceback" not in done.stderr
