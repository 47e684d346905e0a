"""The main job (`mkctl run`) on a small setting: every promised file exists and the index names them all."""
import re

import pytest

from mkctl.cli import main

PROMISED = [
    "fmu/McKibbenKnee.fmu", "fmu/McKibbenActuator.fmu",
    "scenario/pressure_step.png", "scenario/pressure_step.csv",
    "paper/fig5_contraction.png", "paper/fig7_surfaces.png", "paper/fig7_sections.png", "paper/claims.md",
    "control/poles.png", "control/rootlocus_c.png", "control/rootlocus_tau.png", "control/rootlocus_gain.png",
    "control/step_small.png", "control/step_large.png",
    "diagnosis/knee_hidden_damping.csv", "diagnosis/diagnosis.json",
    "index.md", "index.html",
]


@pytest.fixture(scope="module")
def run_folder(tmp_path_factory):
    out = tmp_path_factory.mktemp("run") / "out"
    assert main(["run", "--out", str(out), "--quick"]) == 0
    return out


def test_every_promised_file_exists(run_folder):
    missing = [name for name in PROMISED if not (run_folder / name).is_file()]
    assert not missing, f"mkctl run did not write {missing}"
    assert len(list((run_folder / "diagnosis").glob("*.png"))) >= 4


def test_index_names_every_figure_with_a_sentence(run_folder):
    index = (run_folder / "index.md").read_text()
    figures = sorted(p.relative_to(run_folder).as_posix() for p in run_folder.rglob("*.png"))
    for figure in figures:
        match = re.search(r"### (.+)\n\n(.+)\n\n!\[[^\]]*\]\(" + re.escape(figure) + r"\)", index)
        assert match, f"the index does not show {figure} with a sentence"
        assert len(match.group(2).split()) >= 6, f"the sentence for {figure} says too little"
    for name in PROMISED[:-2]:
        assert f"({name})" in index, f"the index does not link {name}"
    html = (run_folder / "index.html").read_text()
    assert all(f'src="{figure}"' in html for figure in figures)


def test_the_diagnosis_found_the_hidden_damping(run_folder):
    import json
    report = json.loads((run_folder / "diagnosis" / "diagnosis.json").read_text())
    assert report["missing"] == ["viscous_damping"]
    assert report["params"]["c"] == pytest.approx(45.0, rel=0.1)


def test_bad_output_folder_is_one_line_error(tmp_path, capsys):
    blocker = tmp_path / "file"
    blocker.write_text("x")
    assert main(["run", "--out", str(blocker)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "not a folder" in err[0]
