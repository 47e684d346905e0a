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
            yield pytest.param(block, id=f"{doc.name}-{i}")


@pytest.mark.parametrize("code", list(python_blocks()))
def test_example_runs(code, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    exec(compile(code, "<docs>", "exec"), {"__name__": "__docs__"})
    assert capsys.readouterr().out.strip(), "an example should print what it shows"


def test_the_spec_copy_in_docs_is_current():
    """docs/model-spec.md ends with the team's spec, ``shared/spec/model-spec.md`` beside this checkout (CI has it
    there) or in the folder ``MKCTL_SHARED`` names. Without it the test fails, unless ``MKCTL_NO_SHARED`` says why
    the spec is absent on purpose (e.g. ``MKCTL_NO_SHARED="a user's clone"``): then it skips with that reason,
    which ``-ra`` prints in the summary."""
    folder = Path(os.environ["MKCTL_SHARED"]) if os.environ.get("MKCTL_SHARED") else ROOT.parent / "shared"
    shared = folder / "spec" / "model-spec.md"
    if not shared.is_file():
        why = os.environ.get("MKCTL_NO_SHARED", "").strip()
        if why:
            pytest.skip(f"SPEC COPY NOT CHECKED: {shared} is absent on purpose (MKCTL_NO_SHARED: {why})")
        pytest.fail(f"{shared} not found, so docs/model-spec.md cannot be checked against the team's spec: put "
                    "shared/ beside the checkout, point MKCTL_SHARED at it, or set MKCTL_NO_SHARED to the reason "
                    "it is absent", pytrace=False)
    copy = (ROOT / "docs" / "model-spec.md").read_text()
    assert copy.endswith(shared.read_text()), "docs/model-spec.md differs from shared/spec/model-spec.md: copy it again"


def test_the_spec_check_fails_without_the_shared_folder(tmp_path, monkeypatch):
    """The check above cannot pass silently: pointed at an empty folder it fails, with a reason it skips."""
    monkeypatch.setenv("MKCTL_SHARED", str(tmp_path))
    monkeypatch.delenv("MKCTL_NO_SHARED", raising=False)
    with pytest.raises(pytest.fail.Exception, match="not found"):
        test_the_spec_copy_in_docs_is_current()
    monkeypatch.setenv("MKCTL_NO_SHARED", "testing the skip")
    with pytest.raises(pytest.skip.Exception, match="absent on purpose"):
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
