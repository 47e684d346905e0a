"""`mkctl synth mechanism|actuator`, `compare` of their records, and `--mechanism` on linearize, rootlocus and
step; docs/mechanisms.md's command lines run as written."""
from __future__ import annotations

import json
import math
import os
import re
import shutil
import subprocess
import sys
from pathlib import Path

import pytest

from mkctl.cli import main

ROOT = Path(__file__).resolve().parents[1]


def _numbers(pattern, text):
    found = re.search(pattern, text)
    assert found, text
    return [float(v) for v in found.groups()]


def test_synth_and_compare_a_pulley_record(tmp_path, capsys):
    out = tmp_path / "arm.csv"
    assert main(["synth", "mechanism", str(out), "--mechanism", "pulley_joint", "--hidden", "c=40",
                 "--param", "r_p=0.025", "--samples", "1200", "--noise", "0.02"]) == 0
    text = out.read_text()
    assert "# mechanism = pulley_joint" in text and "# r_p = 0.025" in text and "c = 40" not in text
    truth = json.loads((tmp_path / "arm.truth.json").read_text())
    assert truth["hidden"] == {"c": 40.0} and truth["noise_unit"] == "deg"
    capsys.readouterr()
    assert main(["compare", str(out), "--out", str(tmp_path)]) == 0
    printed = capsys.readouterr().out
    assert "mechanism (pulley_joint)" in printed
    (rmse,) = _numbers(r"RMSE ([\d.]+) deg", printed)
    assert rmse > 0.2  # the missing damping, far above the 0.02 deg noise
    assert (tmp_path / "arm_compare_overlay.png").stat().st_size > 10_000


def test_synth_and_compare_a_driven_length_record(tmp_path, capsys):
    out = tmp_path / "pull.csv"
    assert main(["synth", "actuator", str(out), "--samples", "1000", "--noise", "0.2"]) == 0
    assert "p_cmd_kPa" in out.read_text() and "force_N" in out.read_text()
    capsys.readouterr()
    assert main(["compare", str(out), "--out", str(tmp_path)]) == 0
    (rmse,) = _numbers(r"RMSE ([\d.]+) N", capsys.readouterr().out)
    assert rmse == pytest.approx(0.2, rel=0.15)  # nothing hidden: the noise alone


@pytest.mark.parametrize("argv, expected", [
    (["synth", "mechanism", "x.csv"], "needs --mechanism"),
    (["synth", "mechanism", "x.csv", "--mechanism", "elbow"], "unknown mechanism 'elbow'"),
    (["synth", "knee", "x.csv", "--mechanism", "pulley_joint"], "belong to 'synth mechanism'"),
    (["synth", "mechanism", "x.csv", "--mechanism", "pulley_joint", "--hold", "300"], "got 1 pressure"),
    (["linearize", "--mechanism", "pulley_joint", "--alpha", "30"], "--alpha belongs to the knee"),
    (["linearize", "--mechanism", "pulley_joint", "--pressure", "300"], "got 1 pressure"),
    (["step", "--mechanism", "hanging_mass", "--pressure", "-5"], "outside [0"),
])
def test_bad_mechanism_options_are_one_line(tmp_path, capsys, argv, expected, monkeypatch):
    monkeypatch.chdir(tmp_path)
    assert main(argv + (["--out", str(tmp_path)] if argv[0] != "synth" else [])) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and expected in err, err


def test_diagnose_takes_a_driven_length_record(tmp_path, capsys):
    # its diagnosis is tested in tests/test_mechanism_diagnosis.py; here the command runs it
    out = tmp_path / "pull.csv"
    assert main(["synth", "actuator", str(out), "--samples", "400", "--hidden", "Fc=3"]) == 0
    capsys.readouterr()
    assert main(["diagnose", str(out), "--quiet"]) == 0
    printed = capsys.readouterr().out
    assert "missing: coulomb_friction" in printed and "verdict: diagnosed" in printed


def test_a_record_naming_a_file_needs_the_same_file_on_the_command_line(tmp_path, capsys, monkeypatch):
    monkeypatch.chdir(tmp_path)
    shutil.copy(ROOT / "docs" / "examples" / "cam_lever.py", tmp_path)
    assert main(["synth", "mechanism", "lever.csv", "--mechanism", "cam_lever.py", "--samples", "500"]) == 0
    assert "# mechanism = cam_lever.py" in (tmp_path / "lever.csv").read_text()
    capsys.readouterr()
    assert main(["compare", "lever.csv"]) == 2
    assert "a record cannot load code" in capsys.readouterr().err
    assert main(["compare", "lever.csv", "--mechanism", "cam_lever.py"]) == 0
    (rmse,) = _numbers(r"RMSE ([\d.]+) deg", capsys.readouterr().out)
    assert rmse == pytest.approx(0.01, rel=0.15)


def test_linearize_a_mechanism_prints_a1_a2_poles_and_verdict(tmp_path, capsys):
    assert main(["linearize", "--mechanism", "hanging_mass", "--pressure", "300", "--c", "50",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    a2, a1 = _numbers(r"a2 = ([-\d.e+]+) 1/s\^2.*a1 = ([-\d.e+]+) 1/s", out)
    assert a1 == pytest.approx(-5.0)  # -c (dL/dq)^2 / m = -50 / 10 (docs/mechanisms.md)
    assert "stable" in out and "L = 186.692 mm" in out
    real, imag = _numbers(r"poles: ([-\d.]+)-([\d.]+)j", out)
    assert real == pytest.approx(a1 / 2, rel=1e-3) and imag == pytest.approx(math.sqrt(-a2 - a1 ** 2 / 4), rel=1e-3)
    assert (tmp_path / "poles.png").is_file()


def test_the_knee_stays_the_default(tmp_path, capsys):
    assert main(["linearize", "--no-fmu", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "alpha = 60 deg, X = 0.849920 m, pe = 1693.661 kPa" in out and "a2 = -117.51 1/s^2" in out


def test_rootlocus_and_step_of_a_mechanism(tmp_path, capsys):
    assert main(["rootlocus", "--mechanism", "pulley_joint", "--vary", "gain", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "without lag: none (stable for every gain)" in out
    (kc,) = _numbers(r"tau = 0.05 s: ([\d.e+]+) Pa/rad", out)
    assert kc > 0
    assert main(["step", "--mechanism", "pulley_joint", "--pressure", "400,300", "--duration", "1",
                 "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    (small,) = _numbers(r"small step.*\n(?:.*\n)*?.*relative to its peak: ([\d.e-]+)", out)
    assert small < 0.01
    assert (tmp_path / "step_small.png").is_file() and (tmp_path / "rootlocus_gain.png").is_file()


def _doc_commands():
    text = (ROOT / "docs" / "mechanisms.md").read_text()
    return [line for block in re.findall(r"```bash\n(.*?)```", text, re.S) for line in block.splitlines()
            if line.strip() and not line.lstrip().startswith("#")]


@pytest.mark.slow  # ten commands, each a fresh process: about 25 s
def test_the_commands_of_docs_mechanisms_run_as_written(tmp_path):
    commands = _doc_commands()
    assert len(commands) >= 5 and any("synth mechanism" in c for c in commands)
    for path in (ROOT / "docs" / "examples").iterdir():
        shutil.copy(path, tmp_path / path.name)
    env = {**os.environ, "MPLBACKEND": "Agg",
           "PATH": str(Path(sys.executable).parent) + os.pathsep + os.environ.get("PATH", "")}
    for line in commands:
        done = subprocess.run(["bash", "-e", "-c", line], cwd=tmp_path, env=env, capture_output=True, text=True,
                              timeout=300)
        assert done.returncode == 0, f"{line!r}: {done.stdout[-1500:]}\n{done.stderr[-1500:]}"
