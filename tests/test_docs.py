"""The Python examples in the README and the API docs run as written."""
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", ROOT / "docs" / "api.md"]


def python_blocks():
    for doc in DOCS:
        for i, block in enumerate(re.findall(r"```python\n(.*?)```", doc.read_text(), re.S)):
            yield pytest.param(block, id=f"{doc.name}-{i}")


@pytest.mark.parametrize("code", list(python_blocks()))
def test_example_runs(code, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "<docs>", "exec"), {"__name__": "__docs__"})
    assert capsys.readouterr().out.strip(), "an example should print what it shows"


def test_the_spec_copy_in_docs_is_current():
    shared = ROOT.parent / "shared" / "spec" / "model-spec.md"
    if not shared.is_file():
        pytest.skip("no shared/ beside this checkout to compare with")
    copy = (ROOT / "docs" / "model-spec.md").read_text()
    assert copy.endswith(shared.read_text()), "docs/model-spec.md differs from shared/spec/model-spec.md: copy it again"
