"""The `mkctl synth`, `compare` and `diagnose` commands, and how they answer bad input."""
import json
import subprocess
import sys

import pytest

from mkctl.cli import main

BAD = {
    "missing_column.csv": ("# experiment = knee\ntime_s,pe_cmd_kPa,x_mm\n0,1,1\n1,1,1\n",
                           "line 2: missing column for 'pf_cmd'"),
    "unknown_experiment.csv": ("# experiment = walk\ntime_s,pe_cmd_kPa,pf_cmd_kPa,x_mm\n0,1,1,1\n1,1,1,1\n",
                               "line 1: unknown experiment 'walk'"),
    "unknown_parameter.csv": ("# experiment = knee\n# cc = 4\ntime_s,pe_cmd_kPa,pf_cmd_kPa,x_mm\n0,1,1,1\n1,1,1,1\n",
                              "line 2: unknown metadata key 'cc'"),
    "non_numeric.csv": ("# experiment = knee\ntime_s,pe_cmd_kPa,pf_cmd_kPa,x_mm\n0,1,1,1\n1,1,x,1\n",
                        "line 4: column 'pf_cmd_kPa' is not a number: 'x'"),
    "time.csv": ("# experiment = knee\ntime_s,pe_cmd_kPa,pf_cmd_kPa,x_mm\n0,1,1,1\n2,1,1,1\n1,1,1,1\n",
                 "line 5: time does not increase"),
    "empty.csv": ("", "line 1: the file is empty"),
}


@pytest.mark.parametrize("name", sorted(BAD))
@pytest.mark.parametrize("command", ["compare", "diagnose"])
def test_bad_input_is_one_line_and_exit_status_2(tmp_path, capsys, name, command):
    text, expected = BAD[name]
    path = tmp_path / name
    path.write_text(text)
    assert main([command, str(path)]) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and expected in captured.err
    assert captured.err.startswith(f"mkctl {command}: error: {path}")
    assert captured.out == ""


def test_bad_input_through_python_m_has_no_traceback(tmp_path):
    path = tmp_path / "non_numeric.csv"
    path.write_text(BAD["non_numeric.csv"][0])
    for args in (["diagnose", str(path), "--json", str(tmp_path / "o.json")], ["compare", str(tmp_path / "nope.csv")],
                 ["synth", "knee", str(tmp_path / "s.csv"), "--hidden", "spring"]):
        done = subprocess.run([sys.executable, "-m", "mkctl", *args], capture_output=True, text=True, timeout=120)
        assert done.returncode == 2, done.stderr
        assert "Traceback" not in done.stderr and done.stderr.count("\n") == 1
    assert not (tmp_path / "o.json").exists()


def test_synth_compare_and_diagnose_from_the_command_line(tmp_path, capsys):
    data = tmp_path / "iso.csv"
    assert main(["synth", "isotonic", str(data), "--hidden", "Fc=1.2", "--samples", "600", "--seed", "4"]) == 0
    out = capsys.readouterr().out
    assert "hidden effects: coulomb_friction (Fc = 1.2 N)" in out
    assert json.loads((tmp_path / "iso.truth.json").read_text())["hidden"] == {"Fc": 1.2}
    assert "Fc" not in data.read_text()

    assert main(["compare", str(data), "--out", str(tmp_path / "cmp")]) == 0
    out = capsys.readouterr().out
    assert "RMSE" in out and "fit" in out
    assert (tmp_path / "cmp" / "iso_compare_overlay.png").stat().st_size > 0
    assert (tmp_path / "cmp" / "iso_compare_residual.png").stat().st_size > 0

    report_path = tmp_path / "out" / "report.json"
    assert main(["diagnose", str(data), "--json", str(report_path), "--quiet"]) == 0
    out = capsys.readouterr().out
    assert "missing: coulomb_friction" in out and "Fc = 1.2" in out
    report = json.loads(report_path.read_text())
    assert report["missing"] == ["coulomb_friction"] and report["params"]["Fc"] == pytest.approx(1.2, rel=0.1)
    assert report["rmse_after"] < report["rmse_before"]
    for path in report["pictures"].values():
        assert path.startswith(str(tmp_path / "out")) and path.endswith(".png")
