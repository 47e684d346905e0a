"""What calibrate is given (issue 30): the muscle's length, files of one muscle, comments, Table I's defaults.

- Without L0, a muscle whose lengths lie beyond Table I's braid (0.241 m) is refused, naming the default and
  '# L0 = ...'; a shorter one is fitted with Table I's L0 as a warning on stderr and in the muscle file.
- Files of different muscles given together are refused in one line: different L0 in their metadata, or lengths
  no one braid spans (a braid holds force only between b cos 54.7 deg and b).
- A '#' line is metadata only as '# key = value' with a known key, or a one-word key with one number or word
  (then an unknown key is refused naming the keys it could be); other '#' lines are comments.
- A refusal that comes from a Table I default says so and how to give one's own.
"""
from __future__ import annotations

import json

import numpy as np
import pytest

from mkctl.analysis.calibrate import CalibrationError, calibrate, isometric_record, reading_base
from mkctl.analysis.synth import synthesize_isometric
from mkctl.cli import main
from mkctl.errors import MeasurementFileError
from mkctl.io.measurements import read_measurement, write_measurement
from mkctl.physics.params import TABLE_I

#: A 20 mm muscle 400 mm long at rest (the issue's Festo muscles are 300-510 mm): not Table I's.
LONG = {"L0": 0.40, "D0": 0.020, "t0": 0.0015}
LONG_MUSCLE = {"b": 0.46, "n": 4.0, "C1": 2e5}


def _record(known, muscle, overrides=None, lengths=None, seed=0, source="long.csv"):
    rec = synthesize_isometric(muscle, known=known, noise=0.5, seed=seed, lengths=lengths)
    return isometric_record(rec.inputs["length"], rec.inputs["pressure"], rec.output, rec.inputs["branch"],
                            overrides, source=source), rec


def _write(path, rec, metadata, comments=()):
    write_measurement(path, "isometric", None, {"length": rec.inputs["length"], "pressure": rec.inputs["pressure"]},
                      rec.output, metadata=metadata, comments=comments, branch=rec.inputs["branch"])
    return path


def test_a_long_muscle_without_l0_is_refused_naming_table_i_and_how_to_give_it():
    record, rec = _record(LONG, LONG_MUSCLE, overrides={})
    assert rec.inputs["length"].max() > TABLE_I["b"].value
    with pytest.raises(CalibrationError) as error:
        calibrate([record], effects=[])
    message = str(error.value)
    assert "Table I's braid length b = 0.241 m" in message and "'# L0 = ...'" in message
    assert "L0 = 0.208 m" in message and "\n" not in message


def test_a_long_muscle_with_l0_is_fitted(tmp_path):
    record, _ = _record(LONG, LONG_MUSCLE, overrides=dict(LONG))
    result = calibrate([record], effects=[])
    assert result.assumed == [] and result.nrms_after < 0.02
    assert result.fitted["b"] == pytest.approx(LONG_MUSCLE["b"], rel=0.02)


def test_a_short_muscle_without_l0_is_fitted_with_table_i_s_as_a_warning(tmp_path, capsys):
    _, rec = _record({}, {"C1": 2.5e5}, overrides={})  # Table I's geometry, lengths below its braid
    path = _write(tmp_path / "short.csv", rec, {})
    status = main(["calibrate", str(path), "--out", str(tmp_path / "short.json"), "--effects", "none", "--quiet"])
    assert status == 0
    err = capsys.readouterr().err
    warnings = [line for line in err.splitlines() if "warning" in line]
    assert any("L0 not given" in line and "0.208 m" in line for line in warnings), err
    muscle = json.loads((tmp_path / "short.json").read_text())
    assert any(a.startswith("L0 not given") for a in muscle["assumed"])


def test_files_of_different_muscles_are_refused_in_one_line(tmp_path):
    a, _ = _record(LONG, LONG_MUSCLE, overrides=dict(LONG), source="a.csv")
    other = {**LONG, "L0": 0.30}
    b, _ = _record(other, {**LONG_MUSCLE, "b": 0.35}, overrides=other, source="b.csv")
    with pytest.raises(CalibrationError, match="b.csv gives L0 = 0.3 but a.csv gives 0.4: files of different muscles") as error:
        calibrate([a, b], effects=[])
    assert "\n" not in str(error.value)


def test_lengths_no_one_muscle_spans_are_refused_naming_the_files():
    """A 300 mm and a 510 mm muscle, neither with L0 (so metadata cannot tell): their lengths (0.22-0.51 m)
    span a ratio above sqrt(3), which one braid cannot."""
    short_muscle = {"L0": 0.30, "D0": 0.02, "t0": 0.0015}
    long_muscle = {"L0": 0.51, "D0": 0.02, "t0": 0.0015}
    a, rec_a = _record(short_muscle, {"b": 0.34, "n": 3.0}, overrides={"L0": 0.30}, source="festo_300.csv")
    b, rec_b = _record(long_muscle, {"b": 0.58, "n": 5.0}, overrides={"L0": 0.30}, source="festo_510.csv")
    ratio = rec_b.inputs["length"].max() / rec_a.inputs["length"].min()
    assert ratio > np.sqrt(3)
    with pytest.raises(CalibrationError, match="cannot belong to one muscle") as error:
        calibrate([a, b], effects=[])
    assert "festo_300.csv and festo_510.csv" in str(error.value) and "\n" not in str(error.value)


COMMENTS = ("pressure = supply minus drop", "Festo DMSP-20-300N = 20 mm muscle", "note: x = 3 at the start",
            "rig = the long one (see lab book)", "=== data ===")


def test_comment_lines_with_an_equals_sign_are_comments(tmp_path):
    _, rec = _record(LONG, LONG_MUSCLE)
    path = _write(tmp_path / "commented.csv", rec, dict(LONG), comments=COMMENTS)
    assert all(f"# {c}" in path.read_text() for c in COMMENTS)
    measurement = read_measurement(path, base=reading_base())
    assert measurement.params.L0 == pytest.approx(0.40)


@pytest.mark.parametrize("line, words", [
    ("# l0 = 0.4", ["unknown metadata key 'l0'", "did you mean 'L0'"]),
    ("# D_0 = 0.02", ["unknown metadata key 'D_0'", "did you mean 'D0'"]),
    ("# presure = 3", ["unknown metadata key 'presure'", "known: experiment"]),
])
def test_a_mistyped_key_is_refused_naming_the_keys_it_could_be(tmp_path, line, words):
    _, rec = _record(LONG, LONG_MUSCLE)
    path = _write(tmp_path / "typo.csv", rec, dict(LONG))
    text = path.read_text().replace("# experiment", f"{line}\n# experiment", 1)
    path.write_text(text)
    with pytest.raises(MeasurementFileError) as error:
        read_measurement(path)
    assert all(w in str(error.value) for w in words) and "\n" not in str(error.value)


def test_a_refusal_from_table_i_s_braid_says_so_and_how_to_give_b(tmp_path, capsys):
    """`compare` on a file of a muscle longer than Table I's braid: the refusal names 0.241 m as Table I's b."""
    _, rec = _record(LONG, LONG_MUSCLE)
    path = _write(tmp_path / "long.csv", rec, {"L0": 0.40})
    with pytest.raises(MeasurementFileError) as error:
        read_measurement(path)
    message = str(error.value)
    assert "must be shorter than the braid b = 0.241 m" in message
    assert "Table I's braid (thread) length b, a default" in message and "'# b = ...'" in message
    assert main(["compare", str(path)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "Table I's braid" in err[0]
    # with its own b the same file reads
    path.write_text(path.read_text().replace("# L0 = 0.4", "# L0 = 0.4\n# b = 0.46"))
    assert read_measurement(path).params.b == pytest.approx(0.46)
