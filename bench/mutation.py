"""Mutation testing of the physics and the diagnosis rule with mutmut 3: which wrong answers do the tests let through?

    python bench/mutation.py                                   # the physics (actuator, knee, stability)
    python bench/mutation.py --preset diagnosis                # the diagnosis acceptance rule
    python bench/mutation.py --targets mkctl/physics/knee.py --tests tests/test_knee.py tests/test_pinned.py
    python bench/mutation.py --sample 0.3 --seed 1             # a random 30 % of the mutants (faster)
    python bench/mutation.py --preset diagnosis --root ../other-checkout   # another checkout, read only

mutmut changes one thing at a time in the target files (an operator, a number, an argument, a comparison) and
runs the chosen tests against each change; a mutant the tests do not fail on "survives". The script works in a
temporary copy of the package (mkctl/, docs/, README.md and the chosen tests), so the checkout is never touched
and PYTHONPATH cannot point the tests at the unmutated code. It prints the counts, the kill rate and every
survivor with its diff (``--show``), and returns 0 (a survivor is a finding, not an error).

mutmut 3 runs the tests once, then forks every mutant's test run from that process: whatever the package caches
(the lambdified derivatives, the sympy namespace, a parameter set's structure) arrives already built, so a mutant in
the code that builds it is never run unless a test empties the cache first (``fresh`` in tests/test_physics_pins.py).

Kill rate = killed / (killed + survived + timeout + suspicious): the share of the mutants the tests reach that they
catch. Mutants in code no selected test runs ("no tests") are counted apart and in the strict rate, killed / all.
Run on demand, like every benchmark (not part of the test suite); ~10 mutants per second on two cores.
"""
from __future__ import annotations

import argparse
import json
import os
import random
import shutil
import subprocess
import sys
import tempfile
import time
from pathlib import Path

CHECKOUT = Path(__file__).resolve().parents[1]
ROOT = CHECKOUT  #: the checkout whose package and tests are copied (``--root``)
MUTMUT = [sys.executable, "-m", "mutmut"]

#: Target files and the fast test selection that guards them.
PRESETS = {
    "physics": (
        ["mkctl/physics/actuator.py", "mkctl/physics/knee.py", "mkctl/physics/stability.py"],
        ["tests/test_actuator.py", "tests/test_knee.py", "tests/test_stability.py", "tests/test_pinned.py",
         "tests/test_params.py", "tests/test_slack.py", "tests/test_physics_params.py",
         "tests/test_effects.py", "tests/test_rig_effects.py",  # the registry: generated partials, 4b terms
         "tests/test_physics_pins.py", "tests/test_knee_pins.py"],  # from empty caches; exact error texts
    ),
    "diagnosis": (  # the acceptance rule, apart from the loop that fits (mkctl.analysis.diagnosis_rule)
        ["mkctl/analysis/diagnosis_rule.py"],
        ["tests/test_diagnose_rule.py"],
    ),
}

def _status(exit_code) -> str:
    """The verdict of a mutant from mutmut's exit code of its test run (mutmut.stats.status_by_exit_code)."""
    from mutmut.stats import status_by_exit_code

    return status_by_exit_code.get(exit_code, "not checked") if exit_code is not None else "not checked"


def prepare(work: Path, targets: list[str], tests: list[str], pytest_args: list[str]) -> None:
    """A copy of the package and the chosen tests in work, with mutmut's configuration in its pyproject.toml."""
    shutil.copytree(ROOT / "mkctl", work / "mkctl", ignore=shutil.ignore_patterns("__pycache__", "*.pyc"))
    for extra in ("docs", "README.md"):
        source = ROOT / extra
        if source.is_dir():
            shutil.copytree(source, work / extra)
        elif source.is_file():
            shutil.copy2(source, work / extra)
    (work / "tests").mkdir()
    for helper in sorted((ROOT / "tests").glob("*.py")):  # conftest.py and the modules tests import (compiled_check)
        if not helper.name.startswith("test_"):
            shutil.copy2(helper, work / "tests" / helper.name)
    for test in tests:
        shutil.copy2(ROOT / test, work / test)
    config = {
        "source_paths": ["mkctl"],
        "only_mutate": targets,
        "also_copy": ["docs", "README.md"],
        "pytest_add_cli_args_test_selection": tests,
        "pytest_add_cli_args": ["-p", "no:cacheprovider", "-q", *pytest_args],
    }
    lines = ["[tool.mutmut]"] + [f"{key} = {json.dumps(value)}" for key, value in config.items()]
    lines += ["", "[tool.pytest.ini_options]", 'testpaths = ["tests"]', ""]
    (work / "pyproject.toml").write_text("\n".join(lines))


def mutmut(work: Path, args: list[str], log: Path, timeout: float | None = None) -> int:
    """Run ``mutmut ARGS`` in work, its output (progress spinners) into log; the exit status."""
    env = {k: v for k, v in os.environ.items() if k != "PYTHONPATH"}  # the mutated copy, not the checkout
    with log.open("a") as handle:
        try:
            return subprocess.run(MUTMUT + args, cwd=work, env=env, stdout=handle, stderr=subprocess.STDOUT,
                                  timeout=timeout).returncode
        except subprocess.TimeoutExpired:
            handle.write(f"\n(stopped after {timeout:g} s)\n")
            return -1


def verdicts(work: Path) -> dict[str, str]:
    """{mutant name: verdict} from the .meta files mutmut writes beside each mutated file."""
    found = {}
    for meta in sorted((work / "mutants").rglob("*.meta")):
        for name, code in json.loads(meta.read_text())["exit_code_by_key"].items():
            found[name] = _status(code)
    return found


def diff(work: Path, name: str) -> str:
    done = subprocess.run(MUTMUT + ["show", name], cwd=work, capture_output=True, text=True,
                          env={k: v for k, v in os.environ.items() if k != "PYTHONPATH"})
    lines = [line for line in done.stdout.splitlines() if line.startswith(("-", "+")) and
             not line.startswith(("---", "+++"))]
    return "\n".join("      " + line for line in lines) or "      (no diff shown)"


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--preset", choices=sorted(PRESETS), default="physics",
                        help="targets and tests together (default physics)")
    parser.add_argument("--targets", nargs="+", metavar="FILE", help="files to mutate (replace the preset's)")
    parser.add_argument("--tests", nargs="+", metavar="FILE", help="test files to run (replace the preset's)")
    parser.add_argument("--sample", type=float, default=1.0, metavar="FRACTION",
                        help="test a random fraction of the mutants (default 1: all)")
    parser.add_argument("--seed", type=int, default=0, help="seed of the sample (default 0)")
    parser.add_argument("--max-children", type=int, default=2, help="parallel mutant runs (default 2)")
    parser.add_argument("--time-limit", type=float, default=None, metavar="S",
                        help="stop mutmut after this long and report what it checked")
    parser.add_argument("--show", type=int, default=40, metavar="N", help="diffs of at most N survivors (default 40)")
    parser.add_argument("--root", type=Path, default=CHECKOUT, metavar="DIR",
                        help="the checkout to copy the package and tests from (default: this one; read only)")
    parser.add_argument("--keep", type=Path, metavar="DIR", help="work in DIR and keep it (mutmut browse there)")
    parser.add_argument("--pytest-args", nargs=argparse.REMAINDER, default=[],
                        help="more pytest arguments (e.g. -k 'not slow'); must come last")
    args = parser.parse_args(argv)
    global ROOT
    ROOT = args.root.resolve()
    targets = args.targets or PRESETS[args.preset][0]
    tests = [t for t in (args.tests or PRESETS[args.preset][1]) if (ROOT / t).is_file()]
    missing = [t for t in targets if not (ROOT / t).is_file()]
    if missing or not tests:
        parser.error(f"no such target {missing[0]}" if missing else "none of the test files exists")
    if not 0 < args.sample <= 1:
        parser.error("--sample must be in (0, 1]")

    work = args.keep or Path(tempfile.mkdtemp(prefix="mkctl-mutation-"))
    if args.keep and work.exists():
        shutil.rmtree(work)
    work.mkdir(parents=True, exist_ok=True)
    log = work / "mutmut.log"
    started = time.perf_counter()
    try:
        prepare(work, targets, tests, args.pytest_args)
        print(f"mutating {', '.join(targets)}\nagainst {', '.join(tests)}\nin {work} (log: {log})", flush=True)
        names: list[str] = []
        if args.sample < 1:
            # generate the mutants (and the coverage stats) without testing any, then draw the sample
            mutmut(work, ["run", "--max-children", str(args.max_children), "no_such_mutant_to_only_generate"], log)
            every = sorted(verdicts(work))
            names = sorted(random.Random(args.seed).sample(every, max(1, round(args.sample * len(every)))))
            print(f"sample: {len(names)} of {len(every)} mutants (seed {args.seed})", flush=True)
        status = mutmut(work, ["run", "--max-children", str(args.max_children), *names], log, args.time_limit)
        found = verdicts(work)
        if names:
            found = {name: found.get(name, "not checked") for name in names}
        if status not in (0, -1) and not any(v not in ("not checked",) for v in found.values()):
            print(f"mutmut failed (exit status {status}); the last lines of its log:\n"
                  + "\n".join(log.read_text().splitlines()[-15:]), file=sys.stderr)
            return 1
        report(work, found, targets, args.show, time.perf_counter() - started)
    finally:
        if not args.keep:
            shutil.rmtree(work, ignore_errors=True)
    return 0


def report(work: Path, found: dict[str, str], targets: list[str], show: int, elapsed: float) -> None:
    counts: dict[str, int] = {}
    for verdict in found.values():
        counts[verdict] = counts.get(verdict, 0) + 1
    killed, survived = counts.get("killed", 0), counts.get("survived", 0)
    reached = killed + survived + counts.get("timeout", 0) + counts.get("suspicious", 0)
    print(f"\n{len(found)} mutants in {elapsed:.0f} s: " + ", ".join(f"{n} {v}" for v, n in sorted(counts.items())))
    by_file: dict[str, list[str]] = {}
    for name, verdict in found.items():  # e.g. mkctl.physics.knee.x_knee_force__mutmut_3 -> mkctl.physics.knee
        by_file.setdefault(name.rsplit(".", 1)[0], []).append(verdict)
    for module, verdict_list in sorted(by_file.items()):
        k, s = verdict_list.count("killed"), verdict_list.count("survived")
        print(f"  {module}: {k} killed, {s} survived, {verdict_list.count('no tests')} no tests"
              + (f", kill rate {100 * k / (k + s):.1f} %" if k + s else ""))
    if reached:
        print(f"KILL RATE {100 * killed / reached:.1f} % ({killed} of the {reached} mutants the tests reach); "
              f"strict {100 * killed / len(found):.1f} % of all {len(found)}")
    survivors = sorted(name for name, verdict in found.items() if verdict == "survived")
    if survivors:
        print(f"\nsurvivors ({len(survivors)}; diffs of the first {min(show, len(survivors))}):")
        for i, name in enumerate(survivors):
            print(f"  {name}")
            if i < show:
                print(diff(work, name))
    untested = sorted(name for name, verdict in found.items() if verdict == "no tests")
    if untested:
        functions = sorted({name.split("__mutmut_")[0] for name in untested})
        print(f"\nno selected test runs these functions ({len(untested)} mutants): {', '.join(functions)}")


if __name__ == "__main__":
    sys.exit(main())
