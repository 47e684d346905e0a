"""`mkctl sweep --mechanism`: any mechanism over many parameter sets (model-spec section 3b; issue 29).

The rest, a1 and a2 are checked against the independent simulator of tests/independent_mechanisms.py (hand-derived
lengths and moment arms, the rest by its own root finder, a1 and a2 by central differences of its generalized
force), the verdict and the step metrics against the knee sweep's own rules on the same a1, a2.
"""
from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import independent_mechanisms as hand
from mkctl.analysis.mechanism_files import mechanism
from mkctl.analysis.mechanism_sweep import MechanismSweep, sweep_mechanism
from mkctl.analysis.sweep import SweepError
from mkctl.physics.mechanism import builtin_mechanism
from mkctl.physics.params import Params

ROOT = Path(__file__).resolve().parents[1]


def _hand_coefficients(mech, pressures, params, q):
    """a1, a2 of the hand-derived mechanism at rest at q: central differences of its generalized force / M."""
    h_q, h_v = 1e-6, 1e-6
    F = lambda q_, v_: hand.generalized_force(mech, q_, v_, pressures, params)  # noqa: E731
    dF_dq = (F(q + h_q, 0.0) - F(q - h_q, 0.0)) / (2 * h_q)
    dF_dv = (F(q, h_v) - F(q, -h_v)) / (2 * h_v)
    M = mech.inertia(q)
    return dF_dv / M, dF_dq / M


def test_a_pulley_sweep_agrees_with_the_hand_derived_mechanism():
    result = sweep_mechanism(builtin_mechanism("pulley_joint"), {"c": [0.0, 60.0], "p1_kPa": [200.0, 400.0]},
                             fixed={"p2_kPa": 250.0}, jobs=0, progress=False)
    assert result.points == 4 and set(result.columns) >= {"theta_rad", "a1", "a2", "verdict", "error"}
    for i in range(result.points):
        c, p1 = result.c[i], result.p1_kPa[i]
        params = Params(c=float(c))
        mech = hand.pulley_joint(params)
        pressures = (p1 * 1e3, 250e3)
        q = hand.rest(mech, pressures, params)
        a1, a2 = _hand_coefficients(mech, pressures, params, q)
        assert result.theta_rad[i] == pytest.approx(q, abs=1e-9)
        assert result.a1[i] == pytest.approx(a1, rel=1e-6, abs=1e-9)
        assert result.a1[i] == pytest.approx(-2 * c * 0.02**2 / 0.015, abs=1e-9)  # -c (r_p^2 + r_p^2) / J
        assert result.a2[i] == pytest.approx(a2, rel=1e-5)
        assert result.verdict[i] == ("stable" if c > 0 else "marginal")
    damped = result.c > 0
    assert np.all(np.isfinite(result.settling_time_s[damped])) and np.all(np.isinf(result.settling_time_s[~damped]))


def test_the_hanging_mass_sweeps_its_mass_and_says_where_it_has_no_rest():
    result = sweep_mechanism(builtin_mechanism("hanging_mass"), {"m": [1.0, 5.0], "p1_kPa": [300.0]},
                             jobs=0, progress=False)
    for i in range(result.points):
        params = Params(m=float(result.m[i]))
        mech = hand.hanging_mass(params)
        assert result.L_m[i] == pytest.approx(hand.rest(mech, (300e3,), params), abs=1e-9)
    assert result.L_m[1] > result.L_m[0]  # a heavier mass pulls the muscle longer
    # no pressure and a heavy mass: the rubber alone cannot hold it, it would rest on its stop
    empty = sweep_mechanism(builtin_mechanism("hanging_mass"), {"p1_kPa": [0.0]}, fixed={"m": 500.0},
                            jobs=0, progress=False)
    assert empty.verdict.tolist() == ["undefined"] and "no stable equilibrium" in empty.error[0]


def test_names_and_ranges_are_refused_in_one_line():
    pulley = builtin_mechanism("pulley_joint")
    with pytest.raises(SweepError, match="cannot sweep 'alpha_deg': not a name of this sweep"):
        sweep_mechanism(pulley, {"alpha_deg": [10.0]}, jobs=0, progress=False)
    with pytest.raises(SweepError, match="outside the model's domain at .*p1_kPa = -5"):
        sweep_mechanism(pulley, {"p1_kPa": [-5.0, 100.0]}, jobs=0, progress=False)
    with pytest.raises(SweepError, match="r_p"):
        sweep_mechanism(pulley, {"r_p": [-1.0, 0.02]}, jobs=0, progress=False)
    # the knee's Table II is not the pulley's: only what the mechanism's lengths, mass and load use
    names = MechanismSweep(pulley).names
    assert "r_p" in names and "p2_kPa" in names and "L5" not in names and "m" not in names
    assert "m" in MechanismSweep(builtin_mechanism("hanging_mass")).names


def test_a_mechanism_file_sweeps_on_local_dask_workers():
    """The workers receive the mechanism with each chunk: a file's is read again there (its pickle)."""
    lever = mechanism(str(ROOT / "docs" / "examples" / "cam_lever.py"))
    here = sweep_mechanism(lever, {"c": [0.0, 30.0, 60.0]}, jobs=0, progress=False)
    there = sweep_mechanism(lever, {"c": [0.0, 30.0, 60.0]}, jobs=2, chunk=1, progress=False)
    assert "local processes" in there.workers
    for name in ("a1", "a2", here.subject.coordinate_column):
        np.testing.assert_allclose(there.columns[name], here.columns[name], rtol=1e-12)


def test_the_command_writes_the_table_and_the_maps(tmp_path):
    out = tmp_path / "sweep"
    done = subprocess.run([sys.executable, "-m", "mkctl", "sweep", "--mechanism", "pulley_joint", "--grid",
                           "c=0:100:3", "p1_kPa=200:400:3", "--out", str(out), "--jobs", "0", "--quiet"],
                          capture_output=True, text=True, cwd=tmp_path)
    assert done.returncode == 0, done.stderr
    assert "9 points" in done.stdout and "theta_rad" in done.stdout
    assert (out / "sweep.csv").read_text().splitlines()[0].startswith("c,p1_kPa,theta_rad,a1,a2,verdict")
    for quantity in ("verdict", "damping_ratio", "settling_time_s"):
        assert (out / f"sweep_{quantity}.png").stat().st_size > 5000
    bad = subprocess.run([sys.executable, "-m", "mkctl", "sweep", "--mechanism", "pulley_joint", "--grid",
                          "c=0:100:3", "--map", "X_m", "--out", str(out)], capture_output=True, text=True,
                         cwd=tmp_path)
    assert bad.returncode == 2 and "Traceback" not in bad.stderr
    assert bad.stderr.strip().splitlines() == [
        "mkctl sweep: error: --map X_m: not a quantity of this sweep (known: theta_rad, a1, a2, verdict, pole1_re, "
        "pole1_im, pole2_re, pole2_im, lag_pole, damping_ratio, natural_frequency_hz, settling_time_s, "
        "overshoot_percent, error)"]
