"""docs/api.md's notebook session runs as written, cell after cell in one namespace, and its numbers are right."""
import math
import re
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]


def cells() -> list[str]:
    return re.findall(r"```python cell\n(.*?)```", (ROOT / "docs" / "api.md").read_text(), re.S)


def test_the_notebook_session_runs_and_finds_what_was_hidden(tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    blocks = cells()
    assert len(blocks) >= 5
    namespace = {"__name__": "__main__"}  # as in Jupyter
    for block in blocks:
        exec(compile(block, "<docs/api.md cell>", "exec"), namespace)
    out = capsys.readouterr().out
    assert "isotonic 300" in out

    # the DataFrame measurement is the synthetic record, and its diagnosis finds the hidden friction
    record, measurement = namespace["record"], namespace["measurement"]
    np.testing.assert_allclose(measurement.output, record.output, rtol=1e-9, atol=1e-12)
    assert namespace["report"]["missing"] == ["coulomb_friction"]
    assert namespace["report"]["params"]["Fc"] == pytest.approx(record.hidden["Fc"], rel=0.05)

    # the batch: each record's hidden effects, a table, a figure saved only where asked
    batch = namespace["batch"]
    found = {Path(f).stem: r["missing"] for f, r in batch.reports.items()}
    assert found == namespace["hidden"] and not batch.errors
    assert len(namespace["table"]) == 3 and (tmp_path / "campaign_results" / "batch_summary.csv").is_file()
    assert (tmp_path / "campaign_parameters.png").is_file()
    assert "3 records, 3 diagnosed" in repr(batch)

    # the sweep: the reported optimum is the stable point with the smallest settling time, checked by a loop
    study = namespace["study"]
    assert study.points == 105 and study.counts["stable"] == 100  # c = 0 is marginal for every mass
    best_time, best = math.inf, None
    for i in range(study.points):
        if study.verdict[i] == "stable" and study.settling_time_s[i] < best_time:
            best_time, best = study.settling_time_s[i], i
    assert namespace["best"] == best
    assert sorted(p.name for p in tmp_path.glob("*.png")) == ["campaign_parameters.png"]
