"""The `mkctl synth`, `compare` and `diagnose` commands, and how they answer bad input."""
import json
import subprocess
import sys

import pytest

from mkctl.cli import main

BAD = {
    "missing_column.csv": ("# experiment = knee\ntime_s,pe_cmd_kPa,x_mm\n0,1,1\n1,1,1\n",
                           "line 2: missing column 'pf_cmd_kPa'"),
    "semicolons.csv": ("# experiment = knee\ntime_s;pe_cmd_kPa;pf_cmd_kPa;x_mm\n0;1;1;1\n1;1;1;1\n",
                       "line 2: not comma-separated"),
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


def one_line_error(capsys, command, args, expected):
    """main(args) fails with exit status 2 and exactly one stderr line holding ``expected``, nothing on stdout."""
    assert main(args) == 2
    captured = capsys.readouterr()
    assert captured.err.count("\n") == 1 and captured.err.startswith(f"mkctl {command}: error: ")
    assert expected in captured.err, captured.err
    assert "Traceback" not in captured.err and captured.out == ""


@pytest.fixture(scope="module")
def good_csv(tmp_path_factory):
    folder = tmp_path_factory.mktemp("good")
    path = folder / "good.csv"
    assert main(["synth", "knee", str(path), "--samples", "600"]) == 0
    return path


@pytest.fixture
def places(tmp_path):
    """A file and a folder to misuse as output paths."""
    (tmp_path / "afile").write_text("x")
    (tmp_path / "adir").mkdir()
    return tmp_path / "afile", tmp_path / "adir"


def test_bad_output_paths_are_one_line_errors_before_any_work(good_csv, places, tmp_path, capsys, monkeypatch):
    afile, adir = places
    capsys.readouterr()

    def must_not_run(*args, **kwargs):
        raise AssertionError("the output paths must be checked before the work")

    monkeypatch.setattr("mkctl.analysis.diagnose.diagnose", must_not_run)
    monkeypatch.setattr("mkctl.analysis.compare.compare", must_not_run)
    cases = [
        ("compare", ["--out", str(afile)], f"--out {afile}: is a file, not a folder"),
        ("compare", ["--out", str(afile / "sub")], f"{afile} is a file, not a folder"),
        ("diagnose", ["--json", str(afile / "x.json")], f"--json {afile / 'x.json'}: {afile} is a file, not a folder"),
        ("diagnose", ["--json", str(adir)], f"--json {adir}: is a folder, not a file"),
        ("diagnose", ["--json", "/proc/x.json"], "--json /proc/x.json: cannot write into the folder /proc"),
        ("diagnose", ["--out", str(afile), "--json", str(tmp_path / "y.json")], f"--out {afile}: is a file"),
    ]
    for command, options, expected in cases:
        one_line_error(capsys, command, [command, str(good_csv), *options], expected)
    assert not list(adir.iterdir()) and not (tmp_path / "y.json").exists()
    assert not list(good_csv.parent.glob("*.png"))


def test_synth_refuses_bad_output_paths(places, capsys):
    afile, adir = places
    one_line_error(capsys, "synth", ["synth", "knee", str(adir)], f"output file {adir}: is a folder, not a file")
    one_line_error(capsys, "synth", ["synth", "knee", str(afile / "s.csv")], f"{afile} is a file, not a folder")


def test_synth_hidden_and_param_are_repeatable_and_take_lists_in_any_order(tmp_path, capsys):
    first, second, third = (tmp_path / name for name in ("a.csv", "b.csv", "c.csv"))
    assert main(["synth", "--hidden", "c=45", "knee", str(first), "--samples", "300"]) == 0
    assert json.loads(first.with_name("a.truth.json").read_text())["hidden"] == {"c": 45.0}
    assert main(["synth", "--hidden", "c=45", "--hidden", "tau=0.05", "--param", "m=9", "knee", str(second),
                 "--samples", "300"]) == 0
    assert main(["synth", "knee", str(third), "--hidden", "c=45,tau=0.05", "--param", "m=9,Fc=0.5",
                 "--samples", "300"]) == 0
    for path in (second, third):
        truth = json.loads(path.with_name(path.stem + ".truth.json").read_text())
        assert truth["hidden"] == {"c": 45.0, "tau": 0.05} and truth["known"] == {"m": 9.0, **(
            {"Fc": 0.5} if path == third else {})}
    assert "# m = 9.0" in third.read_text() and "# Fc = 0.5" in third.read_text()
    out = capsys.readouterr().out
    assert "hidden effects: viscous_damping, pressure_lag" in out
    # the form mkctl run uses
    assert main(["synth", "knee", str(tmp_path / "d.csv"), "--hidden", "c=45", "--seed", "1", "--samples", "300"]) == 0


@pytest.mark.parametrize("rows", [3, 30])  # with 30 rows the mean of equal values is off by rounding
def test_compare_says_the_fit_is_undefined_for_a_constant_output(rows, tmp_path, capsys):
    path = tmp_path / "flat.csv"
    row = "1693.6609594,100,849.921054893"
    body = "".join(f"{k / 1000:g},{row}\n" for k in range(rows))
    path.write_text(f"# experiment = knee\ntime_s,pe_cmd_kPa,pf_cmd_kPa,x_mm\n{body}")
    assert main(["compare", str(path), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "fit undefined (the measured output is constant" in out and "nan" not in out
