"""Fuzz mkctl as a careless user and a hostile file would: bad measurement files, muscle files and options.

Each case is one ``mkctl`` command run in this process through :func:`mkctl.cli.main` (stdout and stderr
captured, warnings recorded, a time limit per case) on a file or an option made bad in one way: a metadata line
added or changed, a cell, a row, the header or the bytes of a measurement file; a value, a key or the structure of
a muscle file; one option of synth, step, rootlocus, linearize or sweep; a hostile name (issue 30: quotes, triple
quotes, line breaks, ``</script>``, ``&``, ``%``, backslashes, non-ASCII, control characters, a payload that
creates ``PWNED`` if ever run as code) as a record's file name, a metadata value, a comment, a column name, or an
effect file's description and unit; and issue 30's new surfaces: a mechanism or actuator record (model-spec
5d) made bad, or naming a mechanism file that creates ``PWNED`` if it runs (a record never loads code by itself);
a mechanism file broken, untraceable, out of 0 < L < b or with hostile names, given with ``--mechanism`` to synth,
compare, linearize, rootlocus or step; an effect file broken (a parameter's number, its term) given with
``--effects``; a mechanism or effect file whose first lines change the interpreter (the recursion limit,
sys.stdout, the working folder, numpy's errors, ...); and :func:`mkctl.physics.pneumatics.simulate_muscle_pressure`
(no CLI: its Python API, run as a CLI would by :func:`run_pneumatic`) at its extremes. The contract (issues 20
and 30) is:

- a refusal is one line on stderr and a non-zero exit, with no warning printed before it;
- an accepted run exits 0 and writes and prints only finite numbers;
- never a traceback, never a hang;
- a user's file leaves the interpreter as it found it (the settings of :func:`_interpreter`);
- nothing of the input runs as code: every Python file the case wrote is compiled and run in a fresh process,
  and no ``PWNED`` file appears; every JSON file written parses.

Each case gets one outcome of :data:`OUTCOMES`; the first two are the contract kept, the others break it.
Usage::

    python bench/fuzz.py                     # 2000 cases, seed 0, counts per outcome and kind
    python bench/fuzz.py --cases 300 --seed 4 --show 5
    python bench/fuzz.py --cases 200 --kind effectfile --kind mechfile

The suite's tests/test_fuzz.py runs the same generator on a small fixed budget.
"""
from __future__ import annotations

import argparse
import contextlib
import functools
import io
import json
import random
import re
import signal
import sys
import tempfile
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path

#: The repository (docs/examples holds a valid mechanism file).
ROOT = Path(__file__).resolve().parents[1]
#: Outcomes: the contract kept (refused, accepted) or broken (the rest).
OUTCOMES = ("refused", "accepted", "traceback", "hang", "warnings", "not one line", "non-finite written",
            "non-finite printed", "code executed", "broken file written", "interpreter changed")
#: Seconds a case may take before it counts as a hang.
CASE_TIMEOUT_S = 300

#: Values a careless user or a broken file puts where a number belongs.
HOSTILE_NUMBERS = ("0", "-0", "-1", "1", "0.5", "-0.5", "1e308", "-1e308", "1e-308", "1e-320", "1e-12", "1e6",
                   "1e12", "99999999999", "nan", "NaN", "inf", "-inf", "Infinity", "1e400", "9" * 400, "abc", "",
                   " ", "1,5", "0x10", "1_000", "1e", "--1", "+5", "١٢", "1" * 5000)

#: Numbers the model may accept (so that not every case is refused at once).
PLAUSIBLE = ("0.01", "0.1", "0.5", "2", "10", "45", "100", "300")

#: Names a hostile colleague gives a record, a column, a metadata value or an effect's description (issue 30).
#: PAYLOAD creates the file PWNED in the working folder if it is ever run as code.
PAYLOAD = 'x""";__import__("os").system("touch PWNED");"""y'
HOSTILE_NAMES = (PAYLOAD, "x';__import__('os').system('touch PWNED');'", "it's \"quoted\"", "line\nbreak",
                 "cr\rreturn", "</script><script>alert(1)</script>", "a & b &amp; <c>", "100 % %s %n %.6g",
                 "back\\slash\\", "ünïcødé µ² 中文", "ctrl\x01\x07\x1b[31m", "\udcff undecodable", "tab\there",
                 "[x](javascript:alert(1)) *em* `code`", "=HYPERLINK(\"http://x\")", "-rf", " ",
                 "*/ /* ??= \\n", "$x^{$ \\frac{1}{0} $_$")

FLOAT_WORD = re.compile(r"(?<![A-Za-z_])[-+]?(nan|inf|infinity)(?![A-Za-z_])", re.IGNORECASE)


@dataclass
class Case:
    """One command to run: its kind (``measurement``, ``muscle``, ``option``), a label and the arguments."""

    kind: str
    label: str
    argv: list
    files: dict = field(default_factory=dict)  #: {name: text or bytes} written into the case's folder first
    #: what runs argv instead of :func:`mkctl.cli.main` (a surface without a CLI: the pneumatics' Python API)
    runner: object = None


@dataclass
class Result:
    case: Case
    outcome: str
    status: object
    stdout: str
    stderr: str
    detail: str = ""
    seconds: float = 0.0


class _Timeout(BaseException):
    """Raised by the alarm inside a case that runs too long (BaseException: no ``except Exception`` eats it)."""


# --- running one case -------------------------------------------------------------------------------

def run_case(case: Case, folder: Path, timeout: float = CASE_TIMEOUT_S) -> Result:
    """Run ``case`` in ``folder`` (its files written there first; paths in argv are relative to it) and judge it."""
    import os
    from mkctl.cli import main

    main = case.runner or main
    folder.mkdir(parents=True, exist_ok=True)
    for name, content in case.files.items():
        path = folder / name
        if isinstance(content, bytes):
            path.write_bytes(content)
        else:  # a lone surrogate (an undecodable name) as the byte it stands for
            path.write_text(content, encoding="utf-8", errors="surrogateescape")
    before = {p: p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file()}
    out, err = io.StringIO(), io.StringIO()
    status, error = None, None

    def alarm(*_):
        raise _Timeout()

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.setitimer(signal.ITIMER_REAL, timeout)
    cwd = os.getcwd()
    kept = _interpreter()  # a user file's code may change it: the next case starts afresh
    changed = ""
    start = time.perf_counter()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        try:
            os.chdir(folder)
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
                expected = _interpreter()
                status = main([str(a) for a in case.argv])
                changed = _changed(expected, _interpreter())
        except SystemExit as stop:  # argparse
            status = stop.code if isinstance(stop.code, int) else 2
        except _Timeout:
            status = "hang"
        except BaseException as exc:  # noqa: BLE001 - a traceback is what the fuzzer looks for
            import traceback

            status, error = "traceback", "".join(traceback.format_exception_only(type(exc), exc)).strip()
            error += " | " + " <- ".join(f"{Path(f.filename).name}:{f.lineno}"
                                         for f in traceback.extract_tb(exc.__traceback__)[-4:])
        finally:
            signal.setitimer(signal.ITIMER_REAL, 0)
            signal.signal(signal.SIGALRM, previous)
            os.chdir(cwd)
            _restore(kept)
            _unregister_effects(folder, case)
    seconds = time.perf_counter() - start
    stdout, stderr = out.getvalue(), err.getvalue()
    result = Result(case, "", status, stdout, stderr, seconds=seconds)
    executed, broken_file = _code_executed(folder, before), _broken_files(folder, before)
    if executed:
        result.outcome, result.detail = "code executed", executed
    elif broken_file and status not in ("hang", "traceback"):
        result.outcome, result.detail = "broken file written", broken_file
    elif status == "hang":
        result.outcome, result.detail = "hang", f"over {timeout:g} s"
    elif changed:
        result.outcome, result.detail = "interpreter changed", changed
    elif status == "traceback":
        result.outcome, result.detail = "traceback", error
    elif caught:
        result.outcome = "warnings"
        result.detail = "; ".join(sorted({f"{w.category.__name__}: {w.message}" for w in caught}))[:300]
    elif status != 0:
        lines = [line for line in stderr.splitlines() if line.strip()]
        ok = len(lines) == 1 and stderr.endswith("\n")
        result.outcome = "refused" if ok else "not one line"
        if not ok:
            result.detail = f"{len(lines)} lines, {len(stderr)} characters: {stderr[:200]!r}"
    else:
        written = _nonfinite_files(folder, before)
        printed = FLOAT_WORD.search(stdout)
        if written:
            result.outcome, result.detail = "non-finite written", written
        elif printed:
            where = stdout[max(0, printed.start() - 80):printed.end() + 20]
            result.outcome, result.detail = "non-finite printed", where
        else:
            result.outcome = "accepted"
    return result


def _interpreter() -> dict:
    """The interpreter's settings a user's file can change and mkctl must put back (the judge's own
    list, independent of mkctl.analysis.effect_files.InterpreterState)."""
    import os

    import numpy as np

    try:
        cwd = os.getcwd()
    except OSError:
        cwd = None
    return {"recursion limit": sys.getrecursionlimit(), "sys.stdin": sys.stdin, "sys.stdout": sys.stdout,
            "sys.stderr": sys.stderr, "working folder": cwd, "sys.argv": list(sys.argv),
            "numpy's error state": np.geterr(), "trace function": sys.gettrace()}


def _changed(before: dict, after: dict) -> str:
    """'what: before -> after' for each setting the case left changed, or ''."""
    return "; ".join(f"{key}: {before[key]!r:.60} -> {after[key]!r:.60}" for key in before
                     if (before[key] is not after[key]) and before[key] != after[key])


def _restore(state: dict) -> None:
    import numpy as np

    sys.setrecursionlimit(state["recursion limit"])
    sys.argv[:] = state["sys.argv"]
    np.seterr(**state["numpy's error state"])
    sys.settrace(state["trace function"])


def _unregister_effects(folder: Path, case: Case) -> None:
    """Unregister what the case's effect files registered (``--effects`` registers in this process): each case
    starts from the same registry, and so does whatever runs in this process after the fuzzer."""
    from mkctl.analysis.effect_files import EffectFileError, unregister_effect_file

    argv = [str(a) for a in case.argv]
    given = {argv[i + 1] for i, a in enumerate(argv[:-1]) if a == "--effects"}
    for name in case.files:  # only the files given with --effects: unregistering reads (runs) the file,
        if name in given:    # and a file a record merely names (evil.py) must never run
            with contextlib.suppress(EffectFileError):
                unregister_effect_file(folder / name)


def _written(folder: Path, before: dict, suffix: str) -> list:
    return [p for p in sorted(folder.rglob(f"*{suffix}")) if p.is_file() and before.get(p) != p.stat().st_mtime_ns]


def _code_executed(folder: Path, before: dict) -> str:
    """Run every Python file the case wrote (a suggested effect file) in a fresh process, as ``--effects`` would;
    then 'what ran' if a PWNED file exists (the payload ran, here or there), else ''."""
    import subprocess

    problems = []
    for path in _written(folder, before, ".py"):
        try:
            compile(path.read_bytes(), str(path), "exec")
        except SyntaxError as error:
            problems.append(f"{path.name} is not valid Python ({error.msg}, line {error.lineno})")
            continue
        subprocess.run([sys.executable, "-c", "import runpy, sys; runpy.run_path(sys.argv[1])", str(path)],
                       cwd=folder, capture_output=True, timeout=120)
    if any(folder.rglob("PWNED")):
        return "PWNED exists: the payload ran" + (f" ({'; '.join(problems)})" if problems else "")
    return ""


def _broken_files(folder: Path, before: dict) -> str:
    """'file: why' for a JSON file the case wrote that does not parse, or a Python file that does not compile."""
    for path in _written(folder, before, ".json"):
        try:
            json.loads(path.read_text(encoding="utf-8"))
        except (ValueError, UnicodeDecodeError) as error:
            return f"{path.name}: {type(error).__name__}: {str(error)[:100]}"
    for path in _written(folder, before, ".py"):
        try:
            compile(path.read_bytes(), str(path), "exec")
        except SyntaxError as error:
            return f"{path.name}: not valid Python: {error.msg} (line {error.lineno})"
    return ""


#: Written tables whose non-finite cells are documented in words (mkctl.analysis.sweep: settling time inf =
#: never settles); the fuzzer does not count them.
DOCUMENTED_NONFINITE = ("sweep.csv",)


def _nonfinite_files(folder: Path, before: dict) -> str:
    """'file: the first non-finite token' for a text file written or changed by the case, or ''."""
    for path in sorted(folder.rglob("*")):
        if not path.is_file() or path.suffix not in (".csv", ".json", ".txt", ".md") or path.name in DOCUMENTED_NONFINITE:
            continue
        if before.get(path) == path.stat().st_mtime_ns:
            continue
        text = path.read_text(encoding="utf-8", errors="replace")
        if path.suffix == ".csv":  # the header and metadata hold names (x_offset_mm, ...), not numbers
            text = "\n".join(line for line in text.splitlines() if line[:1].isdigit() or line[:1] in "-+.")
        found = FLOAT_WORD.search(text)
        if found:
            return f"{path.name}: {text[max(0, found.start() - 40):found.end() + 10]!r}"
    return ""


# --- the cases ---------------------------------------------------------------------------------------

def base_files(folder: Path) -> dict:
    """Small valid files to mutate: a knee, an isotonic and an isometric record, and a muscle file (text)."""
    from mkctl.analysis.synth import synthesize, write_synthetic
    from mkctl.io.muscle import write_muscle
    from mkctl.physics.params import DEFAULT

    folder.mkdir(parents=True, exist_ok=True)
    files = {}
    for name, args in (("knee.csv", ("knee", {"c": 45.0}, dict(samples=200, rate=100.0))),
                       ("isotonic.csv", ("isotonic", {"Fc": 1.0}, dict(samples=200))),
                       ("isometric.csv", ("isometric", ["slack"], dict(samples=80)))):
        experiment, hidden, options = args
        path, _ = write_synthetic(folder / name, synthesize(experiment, hidden, seed=1, **options), truth_file=False)
        files[name] = path.read_text(encoding="utf-8")
    files["muscle.json"] = write_muscle(folder / "muscle.json", DEFAULT).read_text(encoding="utf-8")
    # model-spec 5d: mechanism records (a mechanism file's and a built-in's) and an actuator record
    files["cam_lever.py"] = (ROOT / "docs" / "examples" / "cam_lever.py").read_text(encoding="utf-8")
    (folder / "cam_lever.py").write_text(files["cam_lever.py"], encoding="utf-8")
    for name, argv in (("mech_cam.csv", ["mechanism", "--mechanism", "cam_lever.py", "--samples", "200"]),
                       ("mech_hang.csv", ["mechanism", "--mechanism", "hanging_mass", "--samples", "200"]),
                       ("actuator.csv", ["actuator", "--samples", "150"])):
        _in_folder(folder, ["synth", argv[0], name, *argv[1:], "--no-truth"])
        files[name] = (folder / name).read_text(encoding="utf-8")
    return files


def _in_folder(folder: Path, argv: list) -> None:
    """Run one valid mkctl command in folder (its output unseen; a failure stops the fuzzer)."""
    import os
    from mkctl.cli import main

    cwd = os.getcwd()
    try:
        os.chdir(folder)
        with contextlib.redirect_stdout(io.StringIO()):
            status = main(argv)
    finally:
        os.chdir(cwd)
    if status != 0:
        raise RuntimeError(f"mkctl {' '.join(argv)} failed: the fuzzer's base files are not made")


def _number(rng: random.Random) -> str:
    if rng.random() < 0.25:
        return rng.choice(PLAUSIBLE)
    if rng.random() < 0.15:  # anything between tiny and huge, either sign
        return f"{rng.choice((-1, 1)) * 10 ** rng.uniform(-30, 30):.6g}"
    return rng.choice(HOSTILE_NUMBERS)


def measurement_case(rng: random.Random, files: dict, name: str = None, command=None) -> Case:
    """A measurement file made bad in one way, through compare (mostly) or diagnose (``command(rng, name,
    content, label)`` makes the case: :func:`_measurement_command` unless given)."""
    from mkctl.physics.params import PARAMETER_NAMES

    make = command or _measurement_command
    name = name or rng.choice(("knee.csv", "isotonic.csv", "isometric.csv"))
    lines = files[name].splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    rows = list(range(header + 1, len(lines)))
    what = rng.randrange(12)
    if what <= 2:  # a metadata line: a parameter, an offset or a key of its own, with a hostile value
        quantity = {"knee.csv": "x", "isotonic.csv": "length", "isometric.csv": "force",
                    "actuator.csv": "force"}.get(name, "q")
        key = rng.choice((*PARAMETER_NAMES, f"{quantity}_offset_{'N' if quantity == 'force' else 'mm'}",
                          "experiment", "baseline", "model", "", "x y", "m" * 300))
        lines.insert(header, f"# {key} = {_number(rng)}")
        label = f"metadata {key[:20]} = {lines[header][-20:]}"
    elif what <= 5:  # one cell
        row = rng.choice(rows)
        cells = lines[row].split(",")
        column = rng.randrange(len(cells))
        cells[column] = _number(rng)
        lines[row] = ",".join(cells)
        label = f"cell {row + 1}:{column + 1} = {cells[column][:20]}"
    elif what == 6:  # rows: dropped, repeated, reversed, or only one left
        choice = rng.randrange(4)
        body = lines[header + 1:]
        body = [body[0]] if choice == 0 else body[::-1] if choice == 1 else body + body[-3:] if choice == 2 \
            else body[:: rng.randint(2, 50)]
        lines = lines[:header + 1] + body
        label = f"rows changed ({choice})"
    elif what == 7:  # the header
        cells = lines[header].split(",")
        cells[rng.randrange(len(cells))] = rng.choice(("x", "", "time_h", "x_km", "x_mm", "beta_deg", "pe_kPa",
                                                       "branch", "force_lbf", "length_in", "é" * 40))
        lines[header] = ",".join(cells)
        label = f"header {lines[header][:40]}"
    elif what == 8:  # the bytes
        data = "\n".join(lines).encode()
        cut = rng.randrange(len(data))
        data = data[:cut] if rng.random() < 0.5 else data[:cut] + bytes(rng.randrange(256) for _ in range(20)) + data[cut:]
        return make(rng, name, data, f"bytes changed at {cut}")
    elif what == 9:  # separators and line ends
        text = "\n".join(lines)
        text = rng.choice((text.replace(",", ";"), text.replace("\n", "\r\n"), text.replace("\n", "\r"),
                           "\ufeff" + text, text.replace(".", ","), text + "\n" * 5 + "1,2,3,4"))
        return make(rng, name, text, "separators changed")
    elif what == 10:  # a long value
        lines.insert(header, f"# m = {'1' * rng.choice((100, 10_000, 1_000_000))}")
        label = "a long metadata value"
    else:  # a scaled column: a unit mistake
        column = rng.randrange(len(lines[header].split(",")))
        factor = rng.choice((1e-3, 0.1, 10.0, 25.4, 1e3, -1.0, 0.0))
        for row in rows:
            cells = lines[row].split(",")
            try:
                cells[column] = repr(float(cells[column]) * factor)
            except ValueError:
                pass
            lines[row] = ",".join(cells)
        label = f"column {column + 1} times {factor:g}"
    return make(rng, name, "\n".join(lines) + "\n", label)


def _measurement_command(rng, name, content, label) -> Case:
    command = "diagnose" if rng.random() < 0.15 else "compare"
    argv = [command, name, "--out", "out"] + (["--quiet"] if command == "diagnose" else [])
    return Case("measurement", f"{command} {name}: {label}", argv, {name: content})


def muscle_case(rng: random.Random, files: dict) -> Case:
    """A muscle file made bad in one way, through linearize, synth or compare."""
    from mkctl.physics.params import PARAMETER_NAMES

    data = json.loads(files["muscle.json"])
    what = rng.randrange(8)
    if what <= 3:  # a parameter's value: a number as JSON text, or another JSON type
        name = rng.choice(PARAMETER_NAMES)
        value = rng.choice(("1e308", "-1", "0", "1e-320", "9" * 400, "null", '"2"', "[1]", "{}", "true",
                            *PLAUSIBLE, "1e400", "-1e308"))
        data["params"][name] = "@@"
        text = json.dumps(data).replace('"@@"', value)
        label = f"{name} = {value[:20]}"
    elif what == 4:  # a key of its own, or params missing
        choice = rng.randrange(3)
        if choice == 0:
            data["params"]["spring"] = 1.0
        elif choice == 1:
            data.pop("params")
        else:
            data["params"] = [1, 2]
        text, label = json.dumps(data), f"structure ({choice})"
    elif what == 5:  # nesting
        depth = rng.choice((100, 10_000, 100_000))
        text, label = '{"params": ' + "[" * depth + "]" * depth + "}", f"nested {depth} deep"
    elif what == 6:  # cut short or not JSON
        full = json.dumps(data)
        text = rng.choice((full[:rng.randrange(len(full))], "", "not json", "\x00\x01", "[]", "1e308"))
        label = "broken JSON"
    else:  # a geometry that does not exist together
        data["params"].update(rng.choice(({"L0": 0.3}, {"t0": 0.01}, {"r": 0.6}, {"b": 0.2}, {"n": 1e-5},
                                          {"D0": 1e-7}, {"m": 1e-9}, {"L1": 0.01})))
        text, label = json.dumps(data), f"geometry {list(data['params'].items())[-1]}"
    command = rng.choice(("linearize", "synth", "compare"))
    argv = {"linearize": ["linearize", "--no-fmu", "--params", "m.json", "--out", "out"],
            "synth": ["synth", "knee", "out/s.csv", "--params", "m.json", "--samples", "100", "--rate", "100"],
            "compare": ["compare", "knee.csv", "--params", "m.json", "--out", "out"]}[command]
    return Case("muscle", f"{command} muscle: {label}", argv, {"m.json": text, "knee.csv": files["knee.csv"]})


#: The options fuzzed per command, with the arguments that make a quick valid run around them.
OPTIONS = {
    "synth": (["synth", "knee", "out/s.csv", "--samples", "150", "--rate", "100"],
              ["--seed", "--samples", "--rate", "--noise", "--input-noise", "--noise-tau", "--offset", "--resolution",
               "--hidden c=", "--hidden tau=", "--hidden Fc=", "--param m=", "--param r=", "--param L0="]),
    "synth_isotonic": (["synth", "isotonic", "out/i.csv", "--samples", "150"],
                       ["--seed", "--samples", "--noise", "--input-noise", "--offset", "--hidden Fc=", "--param C1="]),
    "step": (["step", "--no-fmu", "--out", "out", "--duration", "0.5"],
             ["--tau", "--c", "--duration", "--dt", "--small", "--large", "--alpha", "--X", "--pf", "--zeta",
              "--set m=", "--set L1=", "--set vs="]),
    "rootlocus": (["rootlocus", "--out", "out"],
                  ["--c", "--zeta", "--tau", "--alpha", "--pf", "--vary tau --gain", "--vary tau --c", "--vary c --c",
                   "--ti", "--set m="]),
    "linearize": (["linearize", "--no-fmu", "--out", "out"],
                  ["--alpha", "--X", "--pf", "--c", "--tau", "--zeta", "--set r=", "--set Lo=", "--set g="]),
    "sweep": (["sweep", "--out", "out", "--jobs", "0", "--quiet"],
              ["--grid c=0:", "--grid m=1:", "--random", "--seed", "--chunk", "--set tau="]),
}


def option_case(rng: random.Random, files: dict) -> Case:
    """One option of a command given a hostile value (the others valid and quick)."""
    command = rng.choice(sorted(OPTIONS))
    base, options = OPTIONS[command]
    option = rng.choice(options)
    value = _number(rng)
    argv = list(base)
    words = option.split()
    if option.endswith("="):  # NAME=VALUE
        argv += [*words[:-1], words[-1] + value]
    elif option.endswith(":"):  # a grid axis START:STOP:COUNT with one part hostile
        argv += [*words[:-1], words[-1] + f"{value}:{rng.choice(('3', value))}"]
    else:
        argv += [*words, value]
    if command == "sweep" and not any(a.startswith("--grid") for a in argv) and "--random" not in argv:
        argv += ["--grid", "c=0:50:3"]
    if command == "sweep" and "--random" in argv:
        argv += ["--range", "c=0:50"]
    return Case("option", f"{command} {option}{value[:20]}", argv)


#: Lines at the top of a user's file (mechanism or effect file) that change the interpreter mkctl runs in:
#: mkctl puts each back once the file is loaded (mkctl.analysis.effect_files.interpreter_kept).
INTERPRETER_CHANGES = (
    ("import sys\nsys.setrecursionlimit(50)\n", "recursion limit"),
    ("import sys\nsys.stdout = None\n", "stdout None"),
    ("import io, sys\nsys.stderr = io.StringIO()\n", "stderr swallowed"),
    ("import os\nos.chdir('..')\n", "chdir"),
    ("import numpy\nnumpy.seterr(all='raise')\n", "numpy raises"),
    ("import warnings\nwarnings.simplefilter('error')\n", "warnings are errors"),
    ("import sys\nsys.argv[:] = ['x', '--help']\n", "argv changed"),
)

#: An effect file whose description and unit a case makes hostile (its name and parameter stay identifiers).
HOSTILE_EFFECT = '''
def hostile_drag(L, Ldot, P, p, xp):
    return p.c_hostile * Ldot


EFFECTS = [{"name": "hostile_drag", "description": @DESCRIPTION@,
            "parameters": [{"name": "c_hostile", "unit": @UNIT@, "off": 0.0, "lower": 0.0, "upper": 1e4,
                            "typical": 10.0}],
            "term": hostile_drag}]
'''


def _legal_file_name(text: str) -> str:
    """text as a file name this system can hold: no '/', no NUL, not '.' or '..', a suffix kept short."""
    name = text.replace("/", "_").replace("\x00", "")[:120]
    return name if name.strip(".") else f"dots{name}"


def hostile_case(rng: random.Random, files: dict) -> Case:
    """A hostile name where mkctl writes user text into code or markup (issue 30): a record's file name through
    compare, diagnose (with --suggest, then the suggested file is run) or a batch (CSV and JSON); a metadata
    value or comment; a column name; an effect file's description and unit."""
    text = rng.choice(HOSTILE_NAMES)
    base = rng.choice(("knee.csv", "isotonic.csv", "isometric.csv"))
    content = files[base]
    what = rng.randrange(6)
    if what <= 1:  # the record's name
        name = _legal_file_name(text) + ".csv"
        choice = rng.randrange(3)
        if choice == 0:
            argv = ["compare", name, "--out", "out"]
        elif choice == 1:
            argv = ["diagnose", name, "--suggest", "mine.py", "--json", "report.json", "--out", "out", "--quiet"]
        else:
            argv = ["diagnose", name, "other.csv", "--jobs", "0", "--out", "out", "--quiet"]
        extra = {"other.csv": content} if choice == 2 else {}
        return Case("hostile", f"{argv[0]} record named {text!r}", argv, {name: content, **extra})
    lines = content.splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    one_line = " ".join(text.splitlines()) or "x"
    if what == 2:  # a metadata value, or a comment
        key = rng.choice(("experiment", "baseline", "c", "comment", "note", ""))
        lines.insert(header, f"# {key} = {one_line}" if key else f"# {one_line}")
        label = f"metadata {key or 'comment'} = {one_line!r}"
    elif what == 3:  # a column name: an extra column (ignored), or one of the columns renamed
        if rng.random() < 0.5:
            cell = '"' + one_line.replace('"', '""') + '"'
            lines[header] += "," + cell
            for row in range(header + 1, len(lines)):
                lines[row] += ",1"
        else:
            cells = lines[header].split(",")
            cells[rng.randrange(len(cells))] = one_line.replace(",", ";")
            lines[header] = ",".join(cells)
        label = f"column named {one_line!r}"
    else:  # an effect file's description and unit
        effect = HOSTILE_EFFECT.replace("@DESCRIPTION@", repr(text)).replace(
            "@UNIT@", repr(rng.choice((text, "N s/m"))))
        if rng.random() < 0.3:  # and the file changes the interpreter
            code, change = rng.choice(INTERPRETER_CHANGES)
            effect, text = code + effect, f"{text} ({change})"
        command = rng.choice((["compare", base, "--out", "out"], ["diagnose", base, "--out", "out", "--quiet"]))
        return Case("hostile", f"{command[0]} effect described {text!r}", [*command, "--effects", "hostile.py"],
                    {base: content, "hostile.py": effect})
    command = ["compare", base, "--out", "out"] if rng.random() < 0.7 else \
        ["diagnose", base, "--json", "report.json", "--out", "out", "--quiet"]
    return Case("hostile", f"{command[0]} {base}: {label}", command, {base: "\n".join(lines) + "\n"})


#: Values a careless or hostile effect file gives a parameter's number (off, lower, upper, typical).
EFFECT_NUMBERS = ("float('nan')", "float('inf')", "1e308", "-1e308", "10**400", "None", "'1'", "True", "[1]",
                  "-1", "1e-320", "0", "1e4", "20000.0", "5.0")
#: Terms an effect file may hold instead of the drag: untraceable, failing, not off at zero, not finite.
EFFECT_TERMS = (
    ("an if on Ldot", "return p.c_hostile * Ldot if Ldot > 0 else 0.0"),
    ("math.tanh", "return p.c_hostile * __import__('math').tanh(Ldot)"),
    ("not off at zero", "return p.c_hostile * Ldot + 1.0"),
    ("a raise", "raise ValueError('no drag')"),
    ("a division by zero", "return p.c_hostile * Ldot / 0"),
    ("an overflow", "return p.c_hostile * xp.exp(Ldot * 1e6)"),
    ("a huge force", "return p.c_hostile * 1e308 * Ldot"),
    ("NaN", "return p.c_hostile * Ldot * float('nan')"),
    ("an unknown parameter", "return p.c_nothing * Ldot"),
    ("None", "return None"),
    ("a text", "return 'drag'"),
    ("a length term", "return p.c_hostile * (L - p.L0)"),
    ("the square root of a negative", "return p.c_hostile * xp.sqrt(L - 1.0)"),
)


def effect_file_case(rng: random.Random, files: dict) -> Case:
    """An effect file (a linear drag) made bad in one way: a parameter's number, its term (untraceable,
    failing, not off at zero, not finite) or a first line that changes the interpreter; given with
    --effects to compare, diagnose, linearize or synth."""
    text = HOSTILE_EFFECT.replace("@DESCRIPTION@", "'drag'").replace("@UNIT@", "'N s/m'")
    what = rng.randrange(5)
    if what <= 1:
        key, value = rng.choice(("off", "lower", "upper", "typical")), rng.choice(EFFECT_NUMBERS)
        text, label = re.sub(rf'"{key}": [^,}}]+', f'"{key}": {value}', text), f"{key} = {value}"
    elif what <= 3:
        label, body = rng.choice(EFFECT_TERMS)
        text = text.replace("return p.c_hostile * Ldot", body)
    else:
        code, label = rng.choice(INTERPRETER_CHANGES)
        text = code + text
    base = rng.choice(("knee.csv", "isotonic.csv", "isometric.csv"))
    command = rng.choice((["compare", base, "--out", "out"], ["diagnose", base, "--out", "out", "--quiet"],
                          ["linearize", "--no-fmu", "--out", "out"],
                          ["synth", "knee", "out/s.csv", "--samples", "100", "--rate", "100"]))
    return Case("effectfile", f"{command[0]} effect file: {label}", [*command, "--effects", "drag.py"],
                {base: files[base], "drag.py": text})


# --- model-spec 5d records, mechanism files and the pneumatics (issue 30) -------------------------------

#: Code that creates PWNED when it runs: a mechanism file holding it may be named by a record, never loaded
#: because of it (a record never loads code by itself).
MARKER_CODE = 'import pathlib\npathlib.Path("PWNED").write_text("ran")\n'


def _record_command(rng, name, content, label, cam_lever: str) -> Case:
    """compare (mostly, with --mechanism cam_lever.py for the record that names it) or diagnose (which
    refuses mechanism and actuator records in one line) on a mutated 5d record."""
    files = {name: content}
    if rng.random() < 0.2:
        argv = ["diagnose", name, "--out", "out", "--quiet"]
    else:
        argv = ["compare", name, "--out", "out"]
        if name == "mech_cam.csv" or rng.random() < 0.1:
            argv += ["--mechanism", "cam_lever.py"]
            files["cam_lever.py"] = cam_lever
    return Case("record", f"{argv[0]} {name}: {label}", argv, files)


def record_case(rng: random.Random, files: dict) -> Case:
    """A mechanism or actuator record (model-spec 5d) made bad in one way, as measurement_case does, or one
    whose ``# mechanism =`` names something hostile: a missing file, a hostile name, a file that writes PWNED
    when run (present beside the record, never named with --mechanism: it must not run)."""
    name = rng.choice(("mech_cam.csv", "mech_hang.csv", "actuator.csv"))
    if rng.random() < 0.7:
        return measurement_case(rng, files, name, functools.partial(_record_command,
                                                                    cam_lever=files["cam_lever.py"]))
    lines = files[name].splitlines()
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    lines = [line for line in lines[:header] if not line.startswith("# mechanism")] + lines[header:]
    header = next(i for i, line in enumerate(lines) if not line.startswith("#"))
    named = rng.choice(("evil.py", "./evil.py", "pulley_joint", "knee", "missing.py", "hanging_mass",
                        " ".join(rng.choice(HOSTILE_NAMES).splitlines()) or "x", "cam_lever.py", ""))
    lines.insert(header, f"# mechanism = {named}")
    experiment = rng.choice(("mechanism", "actuator", "knee", "Mechanism", "mechanism "))
    lines = [f"# experiment = {experiment}" if line.startswith("# experiment") else line for line in lines]
    command = rng.choice((["compare", name, "--out", "out"], ["diagnose", name, "--out", "out", "--quiet"],
                          ["diagnose", name, "--suggest", "mine.py", "--out", "out", "--quiet"],
                          ["compare", name, "--out", "out", "--mechanism", "cam_lever.py"]))
    case_files = {name: "\n".join(lines) + "\n", "evil.py": MARKER_CODE + files["cam_lever.py"],
                  "cam_lever.py": files["cam_lever.py"]}
    return Case("record", f"{command[0]} {name}: experiment = {experiment!r}, mechanism = {named!r}", command,
                case_files)


#: The length function's body in docs/examples/cam_lever.py, which several edits replace.
CAM_LENGTH = "return (p.L_top - p.r0 * q - 0.5 * p.k_cam * q**2,)"
#: Ways to break a mechanism file: (label, old text, new text) on docs/examples/cam_lever.py; @V@ is a value.
MECHANISM_EDITS = (
    ("default L_top", '"default": 0.2, "lower": 0.05', '"default": @V@, "lower": 0.05'),
    ("bounds of L_top", '"default": 0.2, "lower": 0.05, "upper": 1.0', '"default": 0.2, "lower": @V@, "upper": @V@'),
    ("default r0", '"default": 0.02', '"default": @V@'),
    ("default J_lever", '"default": 0.15', '"default": @V@'),
    ("default m_lever", '"default": 3.0', '"default": @V@'),
    ("stop q_high", '"default": 1.2', '"default": @V@'),
    ("stop q_low", '"default": -0.3', '"default": @V@'),
    ("the length", CAM_LENGTH, "return (@V@,)"),
    ("the inertia", "return p.J_lever\n", "return @V@\n"),
)
#: Lengths that leave 0 < L < b (the paper's b is 0.241 m), or are not a number.
BAD_LENGTHS = ("0.0", "-0.1", "0.241", "0.3", "1e308", "float('nan')", "float('inf')", "1e-300", "p.L_top * 0",
               "p.L_top + q * 10", "p.b", "p.b - 1e-15")
#: Function bodies a tracer cannot follow, or that fail, or that return the wrong thing.
UNTRACEABLE = (
    ("an if on q", CAM_LENGTH,
     "return (p.L_top if q > 0 else p.L_top - 0.01,)"),
    ("float(q)", CAM_LENGTH, "return (p.L_top - p.r0 * float(q),)"),
    ("math.sin", "xp.sin(q)", "__import__('math').sin(q)"),
    ("numpy on a symbol", "xp.sin(q)", "__import__('numpy').sin(q)"),
    ("a raise", "return p.J_lever\n", "raise ValueError('no inertia')\n"),
    ("a ZeroDivisionError", "return p.J_lever\n", "return p.J_lever / 0\n"),
    ("a string length", CAM_LENGTH, "return ('0.2',)"),
    ("two lengths for one muscle", CAM_LENGTH,
     "return (p.L_top, p.L_top)"),
    ("no tuple", CAM_LENGTH, "return None"),
    ("an unknown parameter", "p.J_lever\n", "p.J_nothing\n"),
    ("an unknown xp name", "xp.sin(q)", "xp.sinh2(q)"),
    ("a free variable", "return p.J_lever\n", "return p.J_lever * undefined_name\n"),
    ("stops reversed", "return (p.q_low, p.q_high)", "return (p.q_high, p.q_low)"),
    ("stops not numbers", "return (p.q_low, p.q_high)", "return ('a', None)"),
    ("one stop", "return (p.q_low, p.q_high)", "return (p.q_low,)"),
    ("a syntax error", "def inertia(q, p, xp):", "def inertia(q, p, xp)"),
    ("no MECHANISM", "MECHANISM = {", "NOT_MECHANISM = {"),
    ("MECHANISM a list", "MECHANISM = {", "MECHANISM = [{"),
    ("a parameter named g", '{"name": "r0"', '{"name": "g"'),
    ("a parameter twice", '{"name": "r0"', '{"name": "L_top"'),
    ("a parameter named class", '{"name": "r0"', '{"name": "class"'),
    ("no muscles", '"muscles": ["muscle"]', '"muscles": []'),
    ("three muscles", '"muscles": ["muscle"]', '"muscles": ["a", "b", "c"]'),
    ("unit furlong", '"unit": "rad"}', '"unit": "furlong"}'),
    ("load not callable", '"load": load', '"load": 3.0'),
    ("no lengths", '"lengths": lengths, ', ''),
    ("a huge exponent", "0.5 * p.k_cam * q**2", "0.5 * p.k_cam * q**10**6"),
    ("an import error", "def lengths", "import no_such_module_mkctl\n\n\ndef lengths"),
)
#: The mechanism's texts a hostile colleague sets: name, description, coordinate, a muscle, a unit.
NAMED_FIELDS = (('"name": "cam_lever"', '"name": @S@'), ('"description": "a lever lifted by one muscle over a cam"',
                 '"description": @S@'), ('{"name": "phi", "unit": "rad"}', '{"name": @S@, "unit": "rad"}'),
                ('"muscles": ["muscle"]', '"muscles": [@S@]'), ('"unit": "m/rad"', '"unit": @S@'),
                ('"name": "cam_lever"', '"name": "knee"'), ('"name": "cam_lever"', '"name": "hanging_mass"'))


def mechanism_file_case(rng: random.Random, files: dict) -> Case:
    """A mechanism file made bad in one way (a hostile value, a length outside 0 < L < b, code that cannot be
    traced or fails, hostile names) given with --mechanism to synth, compare, linearize, rootlocus or step; or
    a built-in mechanism with a hostile --pressure."""
    text = files["cam_lever.py"]
    what = rng.randrange(10)
    if what <= 2:
        label, old, new = rng.choice(MECHANISM_EDITS)
        value = rng.choice(BAD_LENGTHS) if label == "the length" else rng.choice(
            ("float('nan')", "float('inf')", "1e308", "-1e308", "1e-320", "0", "-1", "None", "'0.2'", "True",
             "[0.2]", "10**400", *PLAUSIBLE))
        text, label = text.replace(old, new.replace("@V@", value)), f"{label} = {value}"
    elif what <= 5:
        label, old, new = rng.choice(UNTRACEABLE)
        text = text.replace(old, new, 1)
    elif what <= 7:
        old, new = rng.choice(NAMED_FIELDS)
        name = rng.choice(HOSTILE_NAMES)
        shown = repr(name) if "@S@" in new else new
        text, label = text.replace(old, new.replace("@S@", repr(name))), f"{old[:14]}... = {shown}"
    elif what == 8:
        text, label = rng.choice((("", "empty"), ("\x00\x01", "binary"), ("MECHANISM = None", "MECHANISM None"),
                                  (text[:rng.randrange(len(text))], "cut short"),
                                  ("raise SystemExit(0)\n" + text, "SystemExit at import"),
                                  *((code + text, label) for code, label in INTERPRETER_CHANGES)))
    else:  # a built-in (or the file) with a hostile --pressure
        mech = rng.choice(("hanging_mass", "pulley_joint", "cam_lever.py", "knee"))
        pressure = rng.choice((_number(rng), f"{_number(rng)},{_number(rng)}", "300,300,300", "-200", ""))
        command = rng.choice(("linearize", "rootlocus", "step"))
        argv = {"linearize": ["linearize", "--no-fmu", "--out", "out"], "rootlocus": ["rootlocus", "--out", "out"],
                "step": ["step", "--no-fmu", "--out", "out", "--duration", "0.3"]}[command]
        argv += ["--mechanism", mech, "--pressure", pressure]
        return Case("mechfile", f"{command} --mechanism {mech} --pressure {pressure[:30]}", argv,
                    {"cam_lever.py": files["cam_lever.py"]})
    command = rng.choice(("synth", "compare", "linearize", "rootlocus", "step"))
    argv = {"synth": ["synth", "mechanism", "out/s.csv", "--mechanism", "cam_lever.py", "--samples", "100"],
            "compare": ["compare", "mech_cam.csv", "--mechanism", "cam_lever.py", "--out", "out"],
            "linearize": ["linearize", "--no-fmu", "--mechanism", "cam_lever.py", "--out", "out"],
            "rootlocus": ["rootlocus", "--mechanism", "cam_lever.py", "--out", "out"],
            "step": ["step", "--no-fmu", "--mechanism", "cam_lever.py", "--out", "out", "--duration", "0.3"]}[command]
    return Case("mechfile", f"{command} mechanism file: {label}", argv,
                {"cam_lever.py": text, "mech_cam.csv": files["mech_cam.csv"]})


#: AirParams fields at their extremes (issue 30: a closed valve, a leak that empties the muscle, a volume near
#: zero, ...), and values outside their bounds or not numbers.
AIR_EXTREMES = {
    "C_fill": (1e-11, 1e-11, 1e-6, 1e-6, 5e-9, 0.0, 1e-3), "C_exhaust": (0.0, 1e-11, 1e-6, 1e-6, 1e-12, -1.0),
    "P_supply": (1.0, 1e3, 1e5, 3e5, 1e7, 1e7, 0.0, 1e9), "band": (1e3, 1e3, 1e6, 1e6, 1.0),
    "b_cr": (0.0, 0.0, 0.9, 0.9, 0.5, 1.0), "m_sub": (0.3, 1.5, 0.3, 1.5, 3.0), "k_poly": (1.0, 1.4, 1.0, 1.4, 2.0),
    "V_dead": (0.0, 0.0, 1e-15, 1e-12, 1e-3, 1.0), "T_air": (1e-6, 1.0, 1000.0, 1000.0, 5000.0, 0.0),
    "C_leak": (0.0, 1e-9, 1e-6, 1e-6, 1e-7, 1e-3), "tau_heat": (1e-6, 1e-6, 1e-3, 1e4, 1e4, 1e6, -1.0),
}
NOT_NUMBERS = (float("nan"), float("inf"), -float("inf"), None, "1", True, 1e308, -1e308)
#: How often a value is one of NOT_NUMBERS.
NOT_NUMBER_SHARE = 0.04


def _pneumatic_value(rng, choices):
    return rng.choice(NOT_NUMBERS) if rng.random() < NOT_NUMBER_SHARE else rng.choice(choices)


def pneumatic_case(rng: random.Random, files: dict) -> Case:
    """simulate_muscle_pressure (no CLI yet: its Python API, run by :func:`run_pneumatic`) with AirParams at
    their extremes, a command above the supply or below absolute zero, openings outside [-1, 1], a length
    near 0 or b, a free muscle's load, NaN and inf in the inputs."""
    spec = {"air": {}, "kwargs": {}}
    for name in rng.sample(sorted(AIR_EXTREMES), rng.choice((0, 1, 1, 2, 3))):
        spec["air"][name] = _pneumatic_value(rng, AIR_EXTREMES[name])
    duration = rng.choice((0.01, 0.1, 0.5, 2.0, 2.0, 1e-9, 1e3))
    samples = rng.choice((2, 10, 50, 50, 200, 1000)) if rng.random() < 0.97 else 1
    spec["time"] = "linspace" if rng.random() < 0.9 else rng.choice(("reversed", "repeated", "nan"))
    spec["duration"], spec["samples"] = duration, samples
    if rng.random() < 0.5:
        key, values = "command", (0.0, 3e5, 6e5, 2.5e6, 1e9, -1e5, -101325.0, -2e5, 1e308)
    else:
        key, values = "opening", (0.0, 1.0, -1.0, 0.5, -0.5, 1.0000001, -1.5, 2.0, 1e300)
    if rng.random() < 0.5:
        spec["kwargs"][key] = _pneumatic_value(rng, values)
    else:  # a record: steps between two values, one perhaps not a number
        spec["kwargs"][key] = [_pneumatic_value(rng, values), _pneumatic_value(rng, values)]
    where = rng.randrange(6)
    if where == 0:
        spec["kwargs"]["length"] = _pneumatic_value(rng, (0.0, 1e-9, 0.1, 0.2, 0.2409999, 0.241, 0.3, -0.1))
    elif where == 1:
        spec["kwargs"]["length"] = ["ramp", _pneumatic_value(rng, (0.0, 0.15, 0.2, 0.24, 0.3)),
                                    _pneumatic_value(rng, (0.1, 0.2, 0.2409, 0.5))]
    elif where == 2:
        spec["kwargs"]["load"] = _pneumatic_value(rng, (0.0, 10.0, 50.0, 500.0, 1e4, -50.0, 1e9))
    if rng.random() < 0.3:
        spec["kwargs"]["P_start"] = _pneumatic_value(rng, (0.0, -101325.0, -2e5, 1e5, 2e6, 1e9, -1e9))
    if rng.random() < 0.15:
        spec["kwargs"]["method"] = rng.choice(("Radau", "BDF", "RK45", "", "lsoda"))
    label = json.dumps(spec, default=str)
    return Case("pneumatic", f"simulate_muscle_pressure {label[:160]}", ["pneumatic", label],
                runner=run_pneumatic)


def run_pneumatic(argv) -> int:
    """Run one pneumatic case (argv: ["pneumatic", JSON spec]) as a CLI would: a MkctlError is one line on
    stderr and status 2; a result is written to pressure.csv (every output, time first) and summarized."""
    import numpy as np

    from mkctl.errors import MkctlError
    from mkctl.physics.pneumatics import AirParams, simulate_muscle_pressure

    spec = json.loads(argv[1])
    n, duration = spec["samples"], spec["duration"]
    time = {"linspace": np.linspace(0.0, duration, n), "reversed": np.linspace(duration, 0.0, n),
            "repeated": np.zeros(n), "nan": np.full(n, np.nan)}[spec["time"]]
    kwargs = dict(spec["kwargs"])
    for key in ("command", "opening"):
        if isinstance(kwargs.get(key), list):  # two values, switching halfway
            first, second = kwargs[key]
            kwargs[key] = [first] * (n // 2) + [second] * (n - n // 2)
    if isinstance(kwargs.get("length"), list):
        _, start, stop = kwargs["length"]
        kwargs["length"] = [start + (stop - start) * i / max(n - 1, 1) for i in range(n)] \
            if None not in (start, stop) and not isinstance(start, str) and not isinstance(stop, str) else [start, stop]
    try:
        air = AirParams(**spec["air"])
        result = simulate_muscle_pressure(time, air=air, **kwargs)
    except MkctlError as error:
        print(f"mkctl: error: {error}", file=sys.stderr)
        return 2
    table = result.table()
    with open("pressure.csv", "w", encoding="utf-8") as out:
        out.write(",".join(table) + "\n")
        for row in zip(*table.values()):
            out.write(",".join(repr(float(v)) for v in row) + "\n")
    print("\n".join(result.summary_lines()))
    return 0


GENERATORS = {"measurement": measurement_case, "muscle": muscle_case, "option": option_case,
              "hostile": hostile_case, "record": record_case, "mechfile": mechanism_file_case,
              "pneumatic": pneumatic_case, "effectfile": effect_file_case}
#: Each kind's share of the cases.
WEIGHTS = (0.20, 0.07, 0.16, 0.08, 0.14, 0.14, 0.14, 0.07)


def cases(count: int, seed: int, files: dict, weights=WEIGHTS) -> list[Case]:
    """``count`` cases from a generator seeded with ``seed`` (the same seed gives the same cases)."""
    rng = random.Random(seed)
    kinds = rng.choices(list(GENERATORS), weights=weights, k=count)
    return [GENERATORS[kind](rng, files) for kind in kinds]


def run(count: int, seed: int, folder: Path, timeout: float = CASE_TIMEOUT_S, progress=None,
        kinds=None) -> list[Result]:
    """Make the base files in ``folder``, then run ``count`` cases (of ``kinds`` only, when given), each
    in a folder of its own."""
    files = base_files(folder / "base")
    weights = [w if kinds is None or kind in kinds else 0.0 for kind, w in zip(GENERATORS, WEIGHTS)]
    results = []
    for i, case in enumerate(cases(count, seed, files, weights)):
        results.append(run_case(case, folder / f"case{i:05d}", timeout))
        if progress:
            progress(i, results[-1])
    return results


def counts(results: list[Result]) -> dict:
    """{outcome: count} over :data:`OUTCOMES` (every outcome listed), and per kind of case."""
    table = {kind: {o: 0 for o in OUTCOMES} for kind in (*GENERATORS, "all")}
    for r in results:
        table[r.case.kind][r.outcome] += 1
        table["all"][r.outcome] += 1
    return table


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", type=int, default=2000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--timeout", type=float, default=CASE_TIMEOUT_S, help="seconds per case (default %(default)g)")
    parser.add_argument("--show", type=int, default=3, help="examples shown per broken outcome")
    parser.add_argument("--keep", metavar="DIR", default=None, help="keep the cases' folders here")
    parser.add_argument("--kind", action="append", choices=sorted(GENERATORS),
                        help="only cases of this kind (repeat for several; default: all, in WEIGHTS' shares)")
    args = parser.parse_args(argv)
    start = time.perf_counter()
    seen = {}

    def progress(i, result):
        seen[result.outcome] = seen.get(result.outcome, 0) + 1
        if result.outcome not in ("refused", "accepted"):
            print(f"  {result.outcome}: {result.case.label}: {' '.join(map(str, result.case.argv))[:300]}\n"
                  f"      {result.detail[:300]}", file=sys.stderr, flush=True)
        if (i + 1) % 100 == 0:
            print(f"{i + 1} cases, {time.perf_counter() - start:.0f} s: {seen}", file=sys.stderr, flush=True)

    with tempfile.TemporaryDirectory(prefix="mkctl-fuzz-") as temporary:
        folder = Path(args.keep) if args.keep else Path(temporary)
        results = run(args.cases, args.seed, folder, args.timeout, progress, args.kind)
    seconds = time.perf_counter() - start
    table = counts(results)
    print(f"{len(results)} cases (seed {args.seed}) in {seconds:.0f} s, {seconds / max(len(results), 1):.2f} s each")
    print(f"{'outcome':20s}" + "".join(f"{k:>13s}" for k in table))
    for outcome in OUTCOMES:
        print(f"{outcome:20s}" + "".join(f"{table[k][outcome]:13d}" for k in table))
    slowest = max(results, key=lambda r: r.seconds)
    print(f"slowest case: {slowest.seconds:.1f} s ({slowest.case.label})")
    broken = [r for r in results if r.outcome not in ("refused", "accepted")]
    for outcome in OUTCOMES[2:]:
        shown = [r for r in broken if r.outcome == outcome][:args.show]
        for r in shown:
            print(f"  {outcome}: {r.case.label}: mkctl {' '.join(map(str, r.case.argv))[:150]}\n      {r.detail[:400]}")
    return 1 if broken else 0


if __name__ == "__main__":
    sys.exit(main())
