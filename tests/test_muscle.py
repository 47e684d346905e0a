"""Muscle files (model-spec section 5b) and ``--params`` on the command line."""
import json
import subprocess
import sys

import pytest

from mkctl import Params, read_muscle, write_muscle
from mkctl.io.muscle import MuscleFileError, read_muscle_file


def test_a_muscle_file_round_trips(tmp_path):
    muscle = Params(b=0.25, L0=0.2, D0=0.012, C1=1.5e5, slack=1, Fc=0.8)
    path = write_muscle(tmp_path / "m.json", muscle, nrms_before=0.09, nrms_after=0.02,
                        not_identifiable=[["C1", "C2"]])
    assert read_muscle(path) == muscle
    data = read_muscle_file(path)
    assert data["effects"] == ["elasticity", "coulomb_friction", "slack"] and data["params"]["slack"] == 1
    assert data["not_identifiable"] == [["C1", "C2"]]


def test_names_not_given_keep_their_defaults_and_n_follows_the_braid(tmp_path):
    path = tmp_path / "m.json"
    path.write_text(json.dumps({"params": {"b": 0.26}}))
    p = read_muscle(path)
    assert p.b == 0.26 and p.L0 == Params().L0 and p.n == Params(b=0.26).n


@pytest.mark.parametrize("text, problem", [
    ("{not json", "not a JSON muscle file"),
    ('{"b": 0.25}', '"params" object'),
    ('{"params": {"braid": 0.25}}', "unknown parameter 'braid'"),
    ('{"params": {"b": "long"}}', "b must be a finite number"),
    ('{"params": {"L0": 0.3}}', "must be shorter than the braid"),
    ('{"params": {"slack": 2}}', "slack must be 0 (off) or 1 (on)"),
])
def test_bad_muscle_files_are_one_line(tmp_path, text, problem):
    path = tmp_path / "bad.json"
    path.write_text(text)
    with pytest.raises(MuscleFileError) as caught:
        read_muscle(path)
    assert problem in str(caught.value) and "\n" not in str(caught.value) and str(path) in str(caught.value)


def test_cli_params_feeds_the_analysis_and_command_line_values_win(tmp_path):
    path = write_muscle(tmp_path / "m.json", Params(m=3.0, c=20.0))
    def linearize(*extra):
        done = subprocess.run([sys.executable, "-m", "mkctl", "linearize", "--out", str(tmp_path / "o"),
                               "--params", str(path), *extra], capture_output=True, text=True, timeout=120)
        return done
    import numpy as np
    from mkctl.physics import stability
    with_file = linearize("--c", "20")
    assert with_file.returncode == 0, with_file.stderr
    # the extensor pressure that holds the muscle file's 3 kg hip at alpha = 60 deg is printed, in kPa
    pe = float(stability.equilibrium_pressure(np.radians(60), 100e3, Params(m=3.0)))
    assert f"pe = {pe / 1e3:.6g} kPa" in with_file.stdout
    heavier = linearize("--c", "20", "--set", "m=4")
    pe4 = float(stability.equilibrium_pressure(np.radians(60), 100e3, Params(m=4.0)))
    assert f"pe = {pe4 / 1e3:.6g} kPa" in heavier.stdout
    bad = linearize("--set", "m=-1")
    assert bad.returncode == 2 and "m must be positive" in bad.stderr and "Traceback" not in bad.stderr
    (tmp_path / "broken.json").write_text("{")
    broken = subprocess.run([sys.executable, "-m", "mkctl", "paper", "--out", str(tmp_path / "p"), "--params",
                             str(tmp_path / "broken.json")], capture_output=True, text=True, timeout=120)
    assert broken.returncode == 2 and "not a JSON muscle file" in broken.stderr
