"""The Python examples in the README and the API docs run as written."""
import os
import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
DOCS = [ROOT / "README.md", ROOT / "docs" / "api.md"]


def python_blocks():
    for doc in DOCS:
        for i, block in enumerate(re.findall(r"```python\n(.*?)```", doc.read_text(), re.S)):
            if '__name__ == "__main__"' not in block:  # a script's guard: run as a script (test_docs_blocks.py)
                yield pytest.param(block, id=f"{doc.name}-{i}")


@pytest.mark.parametrize("code", list(python_blocks()))
def test_example_runs(code, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "<docs>", "exec"), {"__name__": "__docs__"})
    assert capsys.readouterr().out.strip(), "an example should print what it shows"


#: Set (to anything but "" or "0") where the team's ``shared/`` folder must be there: ``.ci/run`` sets it, so that
#: CI fails instead of skipping when the spec copy cannot be checked.
REQUIRE_SHARED = "MKCTL_REQUIRE_SHARED"


def test_the_spec_copy_in_docs_is_current():
    """docs/model-spec.md ends with the team's spec, ``shared/spec/model-spec.md`` beside this checkout (CI has it
    there) or in the folder ``MKCTL_SHARED`` names. A clone with nothing beside it (a user's) skips with the reason,
    which ``-ra`` prints in the summary; with ``MKCTL_REQUIRE_SHARED=1`` (set by ``.ci/run``) a missing spec fails."""
    folder = Path(os.environ["MKCTL_SHARED"]) if os.environ.get("MKCTL_SHARED") else ROOT.parent / "shared"
    shared = folder / "spec" / "model-spec.md"
    if not shared.is_file():
        if os.environ.get(REQUIRE_SHARED, "").strip() not in ("", "0"):
            pytest.fail(f"{shared} not found, so docs/model-spec.md cannot be checked against the team's spec "
                        f"({REQUIRE_SHARED} is set): put shared/ beside the checkout or point MKCTL_SHARED at it",
                        pytrace=False)
        pytest.skip(f"spec copy not checked: the team's spec {shared} is not beside this checkout (a clone of its "
                    f"own; CI checks it with {REQUIRE_SHARED}=1)")
    copy = (ROOT / "docs" / "model-spec.md").read_text()
    assert copy.endswith(shared.read_text()), "docs/model-spec.md differs from shared/spec/model-spec.md: copy it again"


def test_the_spec_check_skips_in_a_clone_and_fails_where_required(tmp_path, monkeypatch):
    """The check above cannot pass silently: pointed at an empty folder it skips, and fails where CI requires it."""
    monkeypatch.setenv("MKCTL_SHARED", str(tmp_path))
    monkeypatch.delenv(REQUIRE_SHARED, raising=False)
    with pytest.raises(pytest.skip.Exception, match="not beside this checkout"):
        test_the_spec_copy_in_docs_is_current()
    monkeypatch.setenv(REQUIRE_SHARED, "1")
    with pytest.raises(pytest.fail.Exception, match="not found"):
        test_the_spec_copy_in_docs_is_current()
    (tmp_path / "spec").mkdir()
    (tmp_path / "spec" / "model-spec.md").write_text("not the spec\n")
    with pytest.raises(AssertionError, match="copy it again"):
        test_the_spec_copy_in_docs_is_current()


def layout_section() -> str:
    text = (ROOT / "README.md").read_text()
    return text[text.index("## Layout"):text.index("\n## ", text.index("## Layout") + 1)]


def test_the_readme_layout_names_every_module_of_each_package():
    """Each ``mkctl/NAME/`` bullet of the README's layout names exactly the modules in that folder."""
    section = " ".join(layout_section().split())
    packages = sorted(p for p in (ROOT / "mkctl").iterdir() if p.is_dir() and (p / "__init__.py").is_file())
    for package in packages:
        bullet = re.search(r"- `mkctl/" + package.name + r"/`: (.*?)(?= - `|$)", section)
        assert bullet, f"the README's layout has no bullet for mkctl/{package.name}/"
        named = set(re.findall(r"`(\w+)`", bullet.group(1)))
        modules = {p.stem for p in package.glob("*.py") if p.stem != "__init__"}
        modules |= {p.name for p in package.iterdir() if (p / "__init__.py").is_file()}
        assert modules <= named, f"README layout, mkctl/{package.name}/: not named: {sorted(modules - named)}"
        assert named <= modules | {"NAME"}, f"README layout, mkctl/{package.name}/: no such module {sorted(named - modules)}"
    top = {p.name for p in (ROOT / "mkctl").glob("*.py") if p.stem not in ("__init__", "__main__")}
    assert all(f"`mkctl/{name}`" in section for name in top), f"README layout misses one of {sorted(top)}"
    for folder in ("fmu", "scenarios", "tests", "bench", "docs"):
        assert f"`{folder}/`" in section and (ROOT / folder).is_dir(), folder
