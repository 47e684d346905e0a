"""The fuzzer of bench/fuzz.py on a small fixed budget: bad measurement files, muscle files, options and hostile
names (issue 30: record names, metadata values, comments, column names, effect descriptions and units), and
issue 30's new surfaces: mechanism and actuator records, mechanism files, simulate_muscle_pressure's extremes.

The contract (issue 20): a refusal is one line on stderr with a non-zero exit and no warning before it; an
accepted run writes and prints only finite numbers; never a traceback, never a hang. The generator is seeded, so
the same cases run every time; ``python bench/fuzz.py`` runs thousands on demand.
"""
from __future__ import annotations

import importlib.util
import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
spec = importlib.util.spec_from_file_location("mkctl_fuzz", ROOT / "bench" / "fuzz.py")
fuzz = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = fuzz  # its dataclasses look their module up there
spec.loader.exec_module(fuzz)

#: Cases per kind in the suite: about forty seconds in all on one core.
BUDGET = {"measurement": 24, "muscle": 12, "option": 16, "hostile": 16,
          # issue 30's new surfaces: mechanism and actuator records (one naming a file that writes PWNED if
          # run), broken and hostile mechanism files, the pneumatics' Python API at its extremes
          "record": 12, "mechfile": 12, "pneumatic": 30,
          # effect files made bad (a parameter's number, the term) or changing the interpreter
          "effectfile": 10}


@pytest.fixture(scope="module")
def base(tmp_path_factory):
    return fuzz.base_files(tmp_path_factory.mktemp("fuzz-base"))


@pytest.mark.parametrize("kind", sorted(BUDGET))
def test_fuzzed_input_is_refused_in_one_line_or_accepted_with_finite_numbers(kind, base, tmp_path):
    import random

    rng = random.Random(f"issue-20-{kind}")
    results = [fuzz.run_case(fuzz.GENERATORS[kind](rng, base), tmp_path / f"case{i}", timeout=300)
               for i in range(BUDGET[kind])]
    broken = [f"{r.outcome}: {r.case.label}: mkctl {' '.join(map(str, r.case.argv))[:120]}: {r.detail[:300]}"
              for r in results if r.outcome not in ("refused", "accepted")]
    assert not broken, "\n".join(broken)
    assert any(r.outcome == "refused" for r in results)  # the generator does make bad input
    if kind in ("record", "mechfile", "effectfile"):  # a record names code, never runs it
        assert not list(tmp_path.rglob("PWNED"))
    if kind == "pneumatic":  # some integrate (a finite pressure.csv written), not all are refused
        assert any(r.outcome == "accepted" for r in results)
    if kind == "hostile":  # hostile names are mostly legal: most runs are accepted, none runs the payload
        assert sum(r.outcome == "accepted" for r in results) >= len(results) // 3
        assert not list(tmp_path.rglob("PWNED"))


def test_the_fuzzer_sees_a_broken_contract(tmp_path, monkeypatch):
    """The judge itself: a traceback, a warning, two lines and a written NaN are each caught."""
    import warnings

    import mkctl.cli

    def fake(argv):
        what = argv[0]
        if what == "raise":
            raise ZeroDivisionError("float division by zero")
        if what == "warn":
            warnings.warn("overflow encountered in multiply", RuntimeWarning)
            return 0
        if what == "two":
            print("a\nb", file=sys.stderr)
            return 2
        if what == "nan":
            Path("out.csv").write_text("time_s,x_mm\n0,nan\n")
            return 0
        if what == "inject":  # a generated file that runs a name pasted into it
            Path("mine.py").write_text(f'"""for {fuzz.PAYLOAD}.csv"""\n')
            return 0
        if what == "json":
            Path("report.json").write_text('{"file": "a"b"}')
            return 0
        if what == "limit":  # what a user's file did to mkctl's process, left behind
            sys.setrecursionlimit(sys.getrecursionlimit() + 7)
            return 0
        if what == "chdir":
            os.chdir("..")
            return 2
        print("RMSE inf mm")
        return 0

    monkeypatch.setattr(mkctl.cli, "main", fake)
    limit = sys.getrecursionlimit()
    outcomes = {w: fuzz.run_case(fuzz.Case("option", w, [w]), tmp_path / w).outcome
                for w in ("raise", "warn", "two", "nan", "print", "inject", "json", "limit", "chdir")}
    assert outcomes == {"raise": "traceback", "warn": "warnings", "two": "not one line", "nan": "non-finite written",
                        "print": "non-finite printed", "inject": "code executed", "json": "broken file written",
                        "limit": "interpreter changed", "chdir": "interpreter changed"}
    assert sys.getrecursionlimit() == limit  # and the judge put it back for the next case


@pytest.mark.parametrize("args", [
    ["compare", "knee.csv"],  # with a metadata line "# r = 10"
    ["step", "--no-fmu", "--dt", "1e-12", "--out", "out"],
    ["linearize", "--no-fmu", "--params", "nested.json", "--out", "out"],
])
def test_a_handful_through_a_real_process_have_no_traceback(base, tmp_path, args):
    """In a real process warnings and tracebacks go to stderr: still one line."""
    (tmp_path / "knee.csv").write_text(base["knee.csv"].replace("# baseline = model2\n", "# baseline = model2\n# r = 10\n"))
    (tmp_path / "nested.json").write_text('{"params": ' + "[" * 100_000 + "]" * 100_000 + "}")
    done = subprocess.run([sys.executable, "-m", "mkctl", *args], capture_output=True, text=True, cwd=tmp_path,
                          timeout=300)
    assert done.returncode == 2 and done.stderr.count("\n") == 1 and "Traceback" not in done.stderr, done.stderr
