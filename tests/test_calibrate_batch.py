"""Many muscles at once: ``mkctl calibrate --each`` runs one calibration per file on the batch engine."""
import csv
import subprocess
import sys

import pytest

from mkctl import read_muscle
from mkctl.analysis.batch import calibrate_batch
from mkctl.analysis.calibrate import calibrate, read_records
from mkctl.analysis.synth import synthesize, write_synthetic


@pytest.fixture(scope="module")
def muscles(tmp_path_factory):
    folder = tmp_path_factory.mktemp("muscles")
    for seed, b in ((1, 0.25), (2, 0.26)):
        record = synthesize("isometric", ["slack"], {"b": b}, seed=seed)
        write_synthetic(folder / f"muscle_b{int(b * 1000)}.csv", record)
    (folder / "broken.csv").write_text("# experiment = isometric\nlength_mm,pressure_kPa,force_N\n150,300,1\n")
    return folder


def test_each_file_is_its_own_muscle_and_matches_one_by_one(muscles, tmp_path):
    rows = calibrate_batch([muscles], tmp_path, jobs=0, progress=False)
    by_name = {row["file"].rsplit("/", 1)[-1]: row for row in rows}
    assert by_name["broken.csv"]["status"] == "error" and "at least 2 data rows" in by_name["broken.csv"]["error"]
    for name, b in (("muscle_b250.csv", 0.25), ("muscle_b260.csv", 0.26)):
        row = by_name[name]
        alone = calibrate(read_records([muscles / name]))
        assert row["status"] == "ok" and row["b"] == pytest.approx(alone.params.b, rel=1e-12)
        assert abs(row["b"] - b) < 4 * row["b_se"]  # the truth within the reported standard error
        assert "slack" in row["effects"].split(";")
        assert read_muscle(tmp_path / name.replace(".csv", ".muscle.json")).b == pytest.approx(row["b"])
    with open(tmp_path / "calibration_summary.csv", newline="") as handle:
        assert [r["status"] for r in csv.DictReader(handle)] == [row["status"] for row in rows]
    assert (tmp_path / "calibration_parameters.png").stat().st_size > 0


def test_the_command_line_reports_the_broken_file_and_finishes_the_rest(muscles, tmp_path):
    done = subprocess.run([sys.executable, "-m", "mkctl", "calibrate", "--each", str(muscles), "--out",
                           str(tmp_path), "--jobs", "0", "--quiet"], capture_output=True, text=True, timeout=300)
    assert done.returncode == 1 and "Traceback" not in done.stderr
    lines = done.stdout.splitlines()
    assert any(line.startswith("broken.csv") and "at least 2 data rows" in line for line in lines)
    assert sum(line.startswith("muscle_b") and "slack" in line for line in lines) == 2
