"""mkctl sweep: every quantity against an independent path (the per-posture analysis, python-control)."""
import math
import subprocess
import sys
from pathlib import Path

import control as ct
import numpy as np
import pandas as pd
import pytest

from mkctl.analysis import control as mc
from mkctl.analysis.sweep import (SweepError, evaluate_points, grid_points, parse_axis, step_metrics, sweep)
from mkctl.physics import stability
from mkctl.physics.params import Params

ROOT = Path(__file__).resolve().parents[1]


def _step_info(num_poles, time):
    """python-control's step_info of the unit-gain all-pole system with these poles, on a fine grid."""
    den = np.real(np.poly(num_poles))
    sys = ct.tf([den[-1]], den)
    response = ct.step_response(sys, time)
    return ct.step_info(response.outputs, response.time, SettlingTimeThreshold=0.02, final_output=1.0)


@pytest.mark.parametrize("zeta, wn", [(0.05, 10.0), (0.3, 4.0), (0.7, 20.0), (1.0, 5.0), (2.5, 3.0)])
def test_step_metrics_of_a_second_order_system_match_the_textbook_and_python_control(zeta, wn):
    poles = np.roots([1.0, 2 * zeta * wn, wn * wn])
    settling, overshoot = step_metrics(poles[None, :])
    expected = 100 * math.exp(-math.pi * zeta / math.sqrt(1 - zeta ** 2)) if zeta < 1 else 0.0
    assert overshoot[0] == pytest.approx(expected, abs=1e-6)
    time = np.linspace(0, 1.5 * settling[0], 60_001)
    info = _step_info(poles, time)
    assert settling[0] == pytest.approx(info["SettlingTime"], abs=2 * (time[1] - time[0]))
    assert overshoot[0] == pytest.approx(info["Overshoot"], abs=1e-3)


def test_step_metrics_with_a_lag_match_python_control_on_the_analytic_linearization():
    op = mc.operating_point(math.radians(60), pf=100e3, params=Params(c=60.0, tau=0.04))
    lin = mc.analytic_linearization(op)
    # from pe_cmd to X; the Pf lag state is not reached from pe_cmd (and no slycot here for minreal): drop it
    keep = [lin.state_labels.index(name) for name in ("X", "V", "Pe")]
    plant = ct.ss(lin.A[np.ix_(keep, keep)], lin.B[keep, :1], lin.C[:1, keep], 0.0)
    time = np.linspace(0, 6.0, 60_001)
    response = ct.step_response(plant, time)
    final = float(ct.dcgain(plant))
    info = ct.step_info(response.outputs / final, response.time, SettlingTimeThreshold=0.02, final_output=1.0)
    settling, overshoot = step_metrics(np.asarray(plant.poles())[None, :])
    assert settling[0] == pytest.approx(info["SettlingTime"], abs=2 * (time[1] - time[0]))
    assert overshoot[0] == pytest.approx(info["Overshoot"], abs=1e-3)
    assert 0 < overshoot[0] < 100


def test_each_point_agrees_with_the_analysis_of_its_posture():
    points = {"c": np.array([0.0, 30.0, 30.0, 120.0]), "alpha_deg": np.array([60.0, 30.0, 70.0, 45.0]),
              "pf_kPa": np.array([100.0, 50.0, 250.0, 0.0]), "m": np.array([10.0, 4.0, 10.0, 7.5])}
    out = evaluate_points(points)
    for i in range(4):
        params = Params(c=points["c"][i], m=points["m"][i])
        ref = stability.posture_stability(math.radians(points["alpha_deg"][i]), Pf=points["pf_kPa"][i] * 1e3,
                                          params=params)
        assert out["pe_kPa"][i] == pytest.approx(ref.Pe / 1e3, rel=1e-12)
        assert out["X_m"][i] == pytest.approx(ref.X, rel=1e-12)
        assert out["a1"][i] == pytest.approx(ref.a1, rel=1e-9, abs=1e-12)
        assert out["a2"][i] == pytest.approx(ref.a2, rel=1e-9)
        assert out["verdict"][i] == ref.verdict
        assert sorted([complex(out["pole1_re"][i], out["pole1_im"][i]),
                       complex(out["pole2_re"][i], out["pole2_im"][i])],
                      key=lambda z: z.imag) == pytest.approx(sorted(ref.poles, key=lambda z: z.imag))
        assert out["error"][i] == ""
    assert out["verdict"][0] == "marginal" and out["settling_time_s"][0] == math.inf


def test_poles_with_a_lag_are_the_poles_of_the_linearization_found_by_python_control():
    params = Params(c=25.0, tau=0.08, m=6.0)
    out = evaluate_points({"alpha_deg": np.array([55.0])}, fixed={"c": 25.0, "tau": 0.08, "m": 6.0})
    op = mc.operating_point(math.radians(55.0), pf=100e3, params=params)  # find_operating_point, not our formula
    expected = sorted(np.asarray(mc.analytic_linearization(op).poles()), key=lambda z: (z.imag, z.real))
    ours = sorted([complex(out["pole1_re"][0], out["pole1_im"][0]), complex(out["pole2_re"][0], out["pole2_im"][0]),
                   complex(out["lag_pole"][0], 0.0), complex(out["lag_pole"][0], 0.0)],  # one lag per muscle
                  key=lambda z: (z.imag, z.real))
    assert ours == pytest.approx(expected, rel=1e-6)
    assert out["pe_kPa"][0] == pytest.approx(op.pe / 1e3, rel=1e-6)


def test_a_grid_holds_every_combination_and_chunks_reassemble_in_order():
    result = sweep({"c": (0, 100, 5), "alpha_deg": [30, 45, 60]}, fixed={"tau": 0.02}, jobs=0, progress=False)
    assert result.points == 15
    combos = set(zip(result.c, result.alpha_deg))
    assert combos == {(c, a) for c in np.linspace(0, 100, 5) for a in (30.0, 45.0, 60.0)}
    small = sweep({"c": (0, 100, 5), "alpha_deg": [30, 45, 60]}, fixed={"tau": 0.02}, jobs=0, progress=False,
                  chunk=4)
    for name in ("c", "alpha_deg", "a1", "a2", "settling_time_s", "pe_kPa"):
        np.testing.assert_allclose(small.columns[name], result.columns[name], rtol=1e-12)
    table = result.to_dataframe()
    assert isinstance(table, pd.DataFrame) and len(table) == 15
    assert (table["lag_pole"] == -50.0).all()
    text = repr(result)
    assert "15 points" in text and "verdicts" in text


def test_a_random_sample_is_reproducible_and_inside_its_ranges():
    ranges = {"c": (10, 200), "m": (2, 10)}
    a = sweep(random=50, ranges=ranges, seed=4, jobs=0, progress=False)
    b = sweep(random=50, ranges=ranges, seed=4, jobs=0, progress=False)
    np.testing.assert_array_equal(a.c, b.c)
    assert a.c.min() >= 10 and a.c.max() <= 200 and a.m.min() >= 2 and a.m.max() <= 10
    assert a.counts == {"stable": 50}  # damping everywhere, and alpha = 60 deg holds its position


@pytest.mark.parametrize("grid, message", [
    ({"alpha_deg": (30, 90, 4)}, "alpha_deg = 90 is outside the end stops"),
    ({"m": (-1, 5, 3)}, "parameter m must be positive"),
    ({"pf_kPa": (-10, 100, 3)}, "below 0"),
    ({"L0": (0.2, 0.25, 3)}, "must be shorter than the braid"),
    ({"speed": (0, 1, 2)}, "cannot sweep 'speed'"),
])
def test_a_range_outside_the_domain_is_refused_before_any_work(grid, message):
    with pytest.raises(SweepError, match=message):
        sweep(grid, jobs=0, progress=False)


def test_a_point_where_the_model_is_undefined_is_marked_and_the_others_computed():
    out = evaluate_points({"alpha_deg": np.array([60.0, 80.0, 40.0])})
    assert list(out["verdict"]) == ["marginal", "undefined", "unstable" if out["a2"][2] > 0 else "marginal"]
    assert "end stops" in out["error"][1] and out["error"][0] == ""
    assert math.isnan(out["a1"][1]) and math.isfinite(out["a1"][2])


def test_parse_axis_forms():
    assert parse_axis("c=0:200:21") == ("c", (0.0, 200.0, 21))
    assert parse_axis("m=2,5,9") == ("m", [2.0, 5.0, 9.0])
    assert parse_axis("tau=0:0.1", random=True) == ("tau", (0.0, 0.1))
    with pytest.raises(SweepError, match="NAME=START:STOP:COUNT"):
        parse_axis("c=0:x:3")
    assert grid_points({"c": (0, 1, 2), "m": [3, 4]})["m"].tolist() == [3, 4, 3, 4]


def test_maps_are_returned_and_saved_only_when_asked(tmp_path):
    result = sweep({"c": (0, 100, 4), "m": (4, 10, 3), "alpha_deg": [40, 60]}, jobs=0, progress=False)
    figure = result.plot_map("damping_ratio", "c", "m")
    assert "alpha_deg = 60" in figure.axes[0].get_title()
    assert not list(tmp_path.iterdir())
    result.plot_map("verdict", path=tmp_path / "v.png")
    paths = result.save(tmp_path)
    assert (tmp_path / "v.png").stat().st_size > 0
    back = pd.read_csv(paths[0])
    np.testing.assert_allclose(back["a2"], result.a2)
    if len(paths) > 1:
        np.testing.assert_allclose(pd.read_parquet(paths[1])["damping_ratio"], result.damping_ratio)


def _mkctl(*args, cwd):
    return subprocess.run([sys.executable, "-m", "mkctl", *args], capture_output=True, text=True, cwd=cwd,
                          env={"PYTHONPATH": str(ROOT), "PATH": "/usr/bin:/bin"}, timeout=120)


def test_cli_sweep_writes_the_table_and_maps(tmp_path):
    done = _mkctl("sweep", "--grid", "c=0:200:5", "m=2:10:3", "--set", "tau=0.01", "--map", "overshoot_percent",
                  "--out", str(tmp_path / "out"), "--quiet", cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    table = pd.read_csv(tmp_path / "out" / "sweep.csv")
    assert len(table) == 15 and set(table["m"]) == {2.0, 6.0, 10.0}
    assert (tmp_path / "out" / "sweep_overshoot_percent.png").is_file()
    assert "15 points" in done.stdout


@pytest.mark.parametrize("args, message", [
    (["--grid", "alpha_deg=10:90:5"], "outside the end stops"),
    (["--grid", "zeta=0:1:3"], "cannot sweep 'zeta'"),
    (["--random", "10"], "--random needs at least one --range"),
])
def test_cli_sweep_bad_input_is_one_line(tmp_path, args, message):
    done = _mkctl("sweep", *args, "--out", str(tmp_path), cwd=tmp_path)
    assert done.returncode == 2
    assert message in done.stderr and len(done.stderr.strip().splitlines()) == 1, done.stderr
