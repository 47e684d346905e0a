"""Every code block of the README and the docs runs as written, as a user runs it.

- Each ``python`` block runs as a script (``python block.py`` in a fresh process, so ``__main__`` is what a user's
  script has), in a folder holding what its page says it runs beside (``docs/examples/``' files, the FMUs in
  ``dist/``, the measurement file the page made). Its numbers are compared: a ``print(...)`` whose comment starts
  with a number (``# 75.248 N``, ``# +-10.84j``) must print that number to the digits written, one whose comment
  starts with a quoted word (``# 'stable'``) must print that word.
- docs/api.md's notebook session runs as one script, its cells indented under ``if __name__ == "__main__":`` as
  the page says (marked ``slow``).
- The README's ``bash runnable`` block runs line by line in a fresh clone (marked ``slow``: about a minute).
"""
from __future__ import annotations

import json
import os
import re
import shutil
import subprocess
import sys
import textwrap
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PAGES = [ROOT / "README.md", *sorted(p for p in (ROOT / "docs").glob("*.md") if p.name != "model-spec.md")]

#: Blocks that take more than a few seconds (a diagnosis of a 3000-sample record, a calibration, the claims grid).
SLOW_BLOCKS = {"diagnosis.md-0", "calibrate.md-0", "physics.md-0"}

#: Prepended to a block run as a script: records each print's line and text in the file DOCS_PRINTS names.
RECORDER = """import builtins as _b, json as _j, os as _o, sys as _s
def _recording_print(*args, _print=_b.print, **kwargs):
    _print(*args, **kwargs)
    frame = _s._getframe(1)
    if frame.f_code.co_filename == __file__ and "file" not in kwargs:
        with open(_o.environ["DOCS_PRINTS"], "a") as _h:
            _h.write(_j.dumps([frame.f_lineno - {lines}, kwargs.get("sep", " ").join(map(str, args))]) + "\\n")
_b.print = _recording_print
"""
RECORDER_LINES = RECORDER.count("\n")

NUMBER = r"[-+]?(?:\d+\.?\d*|\.\d+)(?:[eE][-+]?\d+)?"


def python_blocks():
    for page in PAGES:
        for i, block in enumerate(re.findall(r"```python\n(.*?)```", page.read_text(), re.S)):
            name = f"{page.name}-{i}"
            slow = name in SLOW_BLOCKS or "diagnose_batch(" in block  # a batch starts a local cluster: ~10 s
            marks = [pytest.mark.slow] if slow else []
            yield pytest.param(page, block, id=name, marks=marks)


def expected_values(block: str) -> dict[int, tuple[str, str]]:
    """{line: ("number", text) or ("word", text)} for the block's prints whose comment states what they print."""
    found = {}
    for number, line in enumerate(block.splitlines(), 1):
        code, _, comment = line.partition("  # ")
        if not code.lstrip().startswith("print(") or not comment:
            continue
        comment = comment.strip()
        value = re.match(r"(?:~|\+-)?(" + NUMBER + r")", comment)
        word = re.match(r"'([^']+)'", comment)
        if value:
            found[number] = ("number", value.group(1))
        elif word:
            found[number] = ("word", word.group(1))
    return found


def matches_number(written: str, printed: str) -> bool:
    """Whether a number in ``printed`` equals ``written`` to the digits written (75.248 matches 75.2481...)."""
    mantissa = written.lower().split("e")[0]
    decimals = len(mantissa.split(".")[1]) if "." in mantissa else 0
    exponent = int(written.lower().split("e")[1]) if "e" in written.lower() else 0
    step = 10.0 ** (exponent - decimals)
    target = abs(float(written))
    return any(abs(abs(float(n)) - target) <= 0.5 * step * (1 + 1e-9) for n in re.findall(NUMBER, printed))


@pytest.fixture(scope="module")
def workspace(tmp_path_factory, built_fmus):
    """What the pages' blocks run beside: docs/examples' files, the FMUs in dist/, leg.csv of docs/diagnosis.md."""
    folder = tmp_path_factory.mktemp("docs_blocks")
    for path in (ROOT / "docs" / "examples").iterdir():
        shutil.copy(path, folder / path.name)
    (folder / "dist").mkdir()
    for path in built_fmus.values():
        shutil.copy(path, folder / "dist" / path.name)
    synth = subprocess.run([sys.executable, "-m", "mkctl", "synth", "knee", "leg.csv", "--hidden",
                            "viscous_damping,pressure_lag"], cwd=folder, capture_output=True, text=True)
    assert synth.returncode == 0, synth.stderr
    return folder


@pytest.mark.parametrize("page, block", list(python_blocks()))
def test_python_block_runs_as_a_script_and_prints_its_numbers(page, block, workspace, tmp_path):
    folder = tmp_path / "run"
    shutil.copytree(workspace, folder)
    script = folder / "block.py"
    script.write_text(RECORDER.format(lines=RECORDER_LINES) + block)
    prints = tmp_path / "prints.jsonl"
    prints.touch()
    done = subprocess.run([sys.executable, str(script)], cwd=folder, capture_output=True, text=True, timeout=600,
                          env={**os.environ, "DOCS_PRINTS": str(prints), "MPLBACKEND": "Agg"})
    assert done.returncode == 0, f"{page.name}: {done.stderr[-3000:]}"
    printed: dict[int, str] = {}
    for line in prints.read_text().splitlines():
        number, text = json.loads(line)
        printed.setdefault(number, text)
    for number, (kind, value) in expected_values(block).items():
        line = block.splitlines()[number - 1].strip()
        assert number in printed, f"{page.name}: {line!r} printed nothing"
        if kind == "number":
            assert matches_number(value, printed[number]), f"{page.name}: {line!r} printed {printed[number]!r}"
        else:
            assert value in printed[number], f"{page.name}: {line!r} printed {printed[number]!r}"


def test_the_readme_numbers_are_checked():
    """The comparison above is not vacuous: the README's example states its numbers, and a wrong one fails."""
    readme = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(), re.S)[0]
    expected = expected_values(readme)
    assert ("number", "75.248") in expected.values()
    assert {("word", "marginal"), ("word", "stable")} <= set(expected.values())
    assert matches_number("75.248", "75.24812345") and not matches_number("75.248", "75.2502")
    assert matches_number("10.84", "[-0.+10.84160563j -0.-10.84160563j]")
    assert matches_number("1.127e-05", "2.98 1.1271e-05") and not matches_number("1.127e-05", "1.13e-05")


def notebook_script() -> str:
    cells = re.findall(r"```python cell\n(.*?)```", (ROOT / "docs" / "api.md").read_text(), re.S)
    body = "\n".join(cells)
    return 'if __name__ == "__main__":\n' + textwrap.indent(body, "    ")


@pytest.mark.slow
def test_the_notebook_session_runs_as_a_script(tmp_path):
    """docs/api.md's session, its cells under the main guard the page shows, runs as ``python session.py``."""
    script = tmp_path / "session.py"
    script.write_text(notebook_script() + '\n    print("missing:", report["missing"], "batch:", repr(batch))\n')
    done = subprocess.run([sys.executable, str(script)], cwd=tmp_path, capture_output=True, text=True, timeout=900,
                          env={**os.environ, "MPLBACKEND": "Agg"})
    assert done.returncode == 0, done.stderr[-3000:]
    assert "isotonic 300" in done.stdout and "missing: ['coulomb_friction']" in done.stdout
    assert "3 records, 3 diagnosed" in done.stdout
    assert (tmp_path / "campaign_parameters.png").is_file()


def runnable_lines(page: Path) -> list[str]:
    lines = []
    for block in re.findall(r"```bash runnable\n(.*?)```", page.read_text(), re.S):
        lines += [line for line in block.splitlines() if line.strip() and not line.lstrip().startswith("#")]
    return lines


def test_the_readme_has_a_runnable_block_with_its_table_commands():
    """Every program and subcommand the README's table names is in the runnable block (which the slow test runs)."""
    text = (ROOT / "README.md").read_text()
    table = text.split("## What is in it")[1].split("The same commands")[0]
    named = {" ".join(m.split()[:2]) for m in re.findall(r"`((?:mkctl|python|fmpy) [^`]+)`", table)}
    ran = {" ".join(line.split()[:2]) for line in runnable_lines(ROOT / "README.md")}
    assert len(named) >= 10 and named <= ran, sorted(named - ran)


@pytest.mark.slow
def test_the_readme_commands_run_as_written_in_a_fresh_clone(tmp_path):
    """Each line of the README's runnable block, in order, from the root of a fresh clone, in this venv."""
    clone = tmp_path / "mkctl"
    done = subprocess.run(["git", "clone", "-q", str(ROOT), str(clone)], capture_output=True, text=True)
    if done.returncode != 0:
        pytest.skip(f"cannot clone this checkout: {done.stderr.strip()}")
    env = {**os.environ, "PYTHONPATH": str(clone), "MPLBACKEND": "Agg",
           "PATH": str(Path(sys.executable).parent) + os.pathsep + os.environ.get("PATH", "")}
    for line in runnable_lines(clone / "README.md"):
        done = subprocess.run(["bash", "-e", "-c", line], cwd=clone, env=env, capture_output=True, text=True,
                              timeout=900)
        assert done.returncode == 0, f"README: {line!r} failed:\n{done.stdout[-2000:]}\n{done.stderr[-2000:]}"
    assert (clone / "knee.csv").is_file() and (clone / "report.json").is_file()
    assert json.loads((clone / "report.json").read_text())["missing"] == ["viscous_damping"]
    assert (clone / "results").is_dir() and (clone / "muscle.json").is_file()
