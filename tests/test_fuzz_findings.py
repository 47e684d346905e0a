"""What the fuzzer of bench/fuzz.py found in the new surfaces of issue 30, each pinned to its fix.

- simulate_muscle_pressure took a command or a start pressure at absolute zero (a division by zero
  in the orifice's pressure ratio and the gas law, with RuntimeWarnings), below it (a silent result
  at a negative absolute pressure) and at 1e308 (overflow); now a one-line DomainError each.
- A moving length whose samples leave 0 < L < b after the first was integrated without end (the
  air's volume negative or the braid past its length): now refused before the integration.
- A mechanism file whose length overflows (q**10**6), or is so short (1e-300 m) that the tension divides
  by zero, printed numpy's RuntimeWarning before its
  one-line refusal; now only the refusal.
- A mechanism file that raises SystemExit at import ended mkctl with status 0 and nothing done; now a
  one-line refusal.
- A mechanism file's ``sys.setrecursionlimit(50)`` stayed after loading (every later sympy trace a
  RecursionError traceback), and so did a user file's ``sys.stdout = None``, ``os.chdir``,
  ``numpy.seterr(all="raise")``, ...: loading an effect or mechanism file now restores them.
- An isometric record at 1e-320 mm (inside 0 < L < b) ended ``compare`` in a ZeroDivisionError from the
  rubber's Eq. 13: now a one-line DomainError of mkctl.physics.braid.
- An effect file's bound of 10**400 was an OverflowError traceback; a term that divides by zero or
  overflows printed numpy's warnings before its refusal.
"""
from __future__ import annotations

import os
import signal
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

from mkctl.errors import MkctlError
from mkctl.physics import pneumatics as pn

ROOT = Path(__file__).resolve().parents[1]
TIME = np.linspace(0.0, 0.1, 50)


@pytest.fixture
def no_warning():
    """Any warning inside the test is recorded; the test asserts there is none."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        yield caught


@pytest.fixture
def time_limit():
    """A hang becomes a failure after 20 s (the fuzzer's hang, here in the suite)."""
    def alarm(*_):
        raise AssertionError("hung for over 20 s")

    previous = signal.signal(signal.SIGALRM, alarm)
    signal.alarm(20)
    yield
    signal.alarm(0)
    signal.signal(signal.SIGALRM, previous)


@pytest.mark.parametrize("inputs, words", [
    (dict(command=-pn.P_ATM), "absolute zero"),
    (dict(command=-2e5), "absolute zero"),
    (dict(command=[3e5] * 25 + [-2e5] * 25), "absolute zero"),
    (dict(opening=0.5, P_start=-pn.P_ATM), "absolute zero"),
    (dict(opening=-1.0, P_start=-2e5), "absolute zero"),
    (dict(command=1e308), "largest supply"),
    (dict(opening=0.0, P_start=1e308), "at most"),
])
def test_a_pressure_at_or_below_absolute_zero_or_beyond_any_supply_is_one_line(inputs, words, no_warning):
    with pytest.raises(MkctlError, match=words) as raised:
        pn.simulate_muscle_pressure(TIME, **inputs)
    assert "\n" not in str(raised.value)
    assert not no_warning, [str(w.message) for w in no_warning]


def test_pressures_just_inside_the_domain_still_run(no_warning):
    """The limits refuse only what is outside: just above absolute zero, and a command at the largest
    supply (above this supply: the valve stays open, the pressure rises towards the supply)."""
    low = pn.simulate_muscle_pressure(TIME, opening=0.0, P_start=-pn.P_ATM + 1.0)
    high = pn.simulate_muscle_pressure(TIME, command=[0.0] * 10 + [1e7] * 40, air=pn.AirParams(P_supply=1e5))
    assert np.all(np.isfinite(low.P)) and np.all(np.isfinite(high.P))
    assert high.P[-1] <= 1e5 + 1.0  # never above a supply below the command
    assert not no_warning, [str(w.message) for w in no_warning]


@pytest.mark.parametrize("stop", [0.5, 0.241, 0.0, -1e308])
def test_a_moving_length_that_leaves_the_braid_is_refused_not_integrated(stop, no_warning, time_limit):
    length = np.linspace(0.2, stop, 2) if stop != -1e308 else np.array([0.15, -1e308])
    with pytest.raises(MkctlError, match="outside the model's domain 0 < L < b"):
        pn.simulate_muscle_pressure(np.array([0.0, 0.01]), opening=-0.5, length=length)
    assert not no_warning, [str(w.message) for w in no_warning]


def test_a_mechanism_file_that_overflows_is_refused_without_a_warning(tmp_path, no_warning):
    from mkctl.analysis.mechanism_files import load_mechanism_file

    text = (ROOT / "docs" / "examples" / "cam_lever.py").read_text(encoding="utf-8")
    assert "0.5 * p.k_cam * q**2" in text
    path = tmp_path / "huge.py"
    path.write_text(text.replace("0.5 * p.k_cam * q**2", "0.5 * p.k_cam * q**10**6"), encoding="utf-8")
    with pytest.raises(MkctlError, match="length L = -inf m") as raised:
        load_mechanism_file(path)
    assert "\n" not in str(raised.value)
    assert not no_warning, [str(w.message) for w in no_warning]


def test_a_mechanism_length_too_short_for_a_finite_tension_is_refused_at_load(tmp_path, no_warning):
    """L = 1e-300 m lies inside 0 < L < b, but L**3 underflows in the braid's tension: refused when the
    file is read (before: linearize and step printed numpy's divide-by-zero warnings)."""
    from mkctl.analysis.mechanism_files import load_mechanism_file

    text = (ROOT / "docs" / "examples" / "cam_lever.py").read_text(encoding="utf-8")
    old = "return (p.L_top - p.r0 * q - 0.5 * p.k_cam * q**2,)"
    assert old in text
    path = tmp_path / "tiny.py"
    path.write_text(text.replace(old, "return (1e-300 + 0 * q,)"), encoding="utf-8")
    with pytest.raises(MkctlError, match="too near 0 for the rubber.s elastic energy"):
        load_mechanism_file(path)
    assert load_mechanism_file(ROOT / "docs" / "examples" / "cam_lever.py").name == "cam_lever"
    assert not no_warning, [str(w.message) for w in no_warning]


@pytest.mark.parametrize("exit_code", ["0", "3", "'bye'"])
def test_a_mechanism_file_that_exits_at_import_is_refused_not_a_silent_success(tmp_path, exit_code):
    """Before: ``raise SystemExit(0)`` in the file ended ``mkctl rootlocus --mechanism`` with status 0 and
    nothing done; now a one-line MechanismFileError."""
    from mkctl.analysis.mechanism_files import load_mechanism_file

    text = (ROOT / "docs" / "examples" / "cam_lever.py").read_text(encoding="utf-8")
    path = tmp_path / "exits.py"
    path.write_text(f"raise SystemExit({exit_code})\n" + text, encoding="utf-8")
    with pytest.raises(MkctlError, match="running it failed: SystemExit"):
        load_mechanism_file(path)


def test_a_mechanism_parameter_too_large_for_a_float_is_one_line(tmp_path):
    """Before: a default of 10**400 (a Python int) raised OverflowError with a traceback."""
    from mkctl.analysis.mechanism_files import load_mechanism_file

    text = (ROOT / "docs" / "examples" / "cam_lever.py").read_text(encoding="utf-8")
    path = tmp_path / "big.py"
    path.write_text(text.replace('"default": 0.15', '"default": 10**400'), encoding="utf-8")
    with pytest.raises(MkctlError, match="default must be a finite number"):
        load_mechanism_file(path)


# --- a user's file that changes the interpreter (bench/fuzz.py: INTERPRETER_CHANGES) ---------------------

#: Lines at the top of a user's file that change the interpreter mkctl runs in, and how to read the setting.
CHANGES = {
    # (relative to the stack it is loaded from: a pytest-xdist worker's is deeper than a script's)
    "recursion limit": ("import inspect, sys\nsys.setrecursionlimit(len(inspect.stack()) + 60)\n",
                        lambda: sys.getrecursionlimit()),
    "stdout": ("import sys\nsys.stdout = None\n", lambda: sys.stdout),
    "stderr": ("import io, sys\nsys.stderr = io.StringIO()\n", lambda: sys.stderr),
    "working folder": ("import os\nos.chdir('..')\n", lambda: os.getcwd()),
    "numpy errors": ("import numpy\nnumpy.seterr(all='raise')\n", lambda: np.geterr()),
    "warning filters": ("import warnings\nwarnings.simplefilter('error')\n", lambda: list(warnings.filters)),
    "argv": ("import sys\nsys.argv[:] = ['x', '--help']\n", lambda: list(sys.argv)),
    "int digits": ("import sys\nsys.set_int_max_str_digits(640)\n", lambda: sys.get_int_max_str_digits()),
}

#: A valid effect file (a linear drag) for the effect-file loader.
DRAG_EFFECT = '''
def fuzz_drag(L, Ldot, P, p, xp):
    return p.c_fuzz_drag * Ldot


EFFECTS = [{"name": "fuzz_drag", "parameters": [{"name": "c_fuzz_drag", "unit": "N s/m", "off": 0.0,
            "lower": 0.0, "upper": 1e4, "typical": 10.0}], "term": fuzz_drag}]
'''


def _load_user_file(kind: str, prelude: str, folder: Path):
    """Write a valid mechanism or effect file that starts with ``prelude`` into folder/sub and load it
    with folder/sub as the working folder; returns the setting readers' values before and after."""
    from mkctl.analysis.effect_files import load_effect_file
    from mkctl.analysis.mechanism_files import load_mechanism_file

    sub = folder / "sub"
    sub.mkdir()
    if kind == "mechanism":
        text, load = (ROOT / "docs" / "examples" / "cam_lever.py").read_text(encoding="utf-8"), load_mechanism_file
    else:
        text, load = DRAG_EFFECT, load_effect_file
    path = sub / "user.py"
    path.write_text(prelude + text, encoding="utf-8")
    cwd = os.getcwd()
    os.chdir(sub)
    try:
        with warnings.catch_warnings():  # the test's own guard, whatever mkctl does
            before = {name: read() for name, (_, read) in CHANGES.items()}
            loaded = load(path)
            after = {name: read() for name, (_, read) in CHANGES.items()}
    finally:
        os.chdir(cwd)
        sys.setrecursionlimit(before["recursion limit"])
        sys.stdout, sys.stderr = before["stdout"], before["stderr"]
        np.seterr(**before["numpy errors"])
        sys.argv[:] = before["argv"]
        sys.set_int_max_str_digits(before["int digits"])
    return loaded, before, after


@pytest.mark.parametrize("kind", ["mechanism", "effect"])
@pytest.mark.parametrize("setting", sorted(CHANGES))
def test_a_user_file_that_changes_the_interpreter_is_loaded_and_the_change_undone(kind, setting, tmp_path):
    """Before: a mechanism file's ``sys.setrecursionlimit(50)`` stayed after loading, and every later sympy
    trace (step, the next file) was a RecursionError traceback; ``sys.stdout = None`` made mkctl's own report
    a traceback. Now the file loads (its setting did no harm while it ran) and the setting is as before."""
    prelude, _ = CHANGES[setting]
    loaded, before, after = _load_user_file(kind, prelude, tmp_path)
    assert loaded  # the file itself is valid
    assert after == before


def test_the_interpreter_check_sees_a_change_left_behind(tmp_path, monkeypatch):
    """The check above can fail: without mkctl's guard the file's stdout, folder and argv stay (its
    recursion limit would make the load itself fail)."""
    import contextlib

    from mkctl.analysis import effect_files, mechanism_files

    monkeypatch.setattr(effect_files, "interpreter_kept", contextlib.nullcontext)
    monkeypatch.setattr(mechanism_files, "interpreter_kept", contextlib.nullcontext)
    prelude = "".join(CHANGES[name][0] for name in ("stdout", "working folder", "argv"))
    _, before, after = _load_user_file("effect", prelude, tmp_path)
    assert after["stdout"] is None
    assert after["working folder"] == str(tmp_path) != before["working folder"]
    assert after["argv"][1:] == ["--help"] != before["argv"][1:]  # (runpy restores argv[0] itself)


def test_a_mechanism_file_that_lowers_the_recursion_limit_steps_like_any_other(tmp_path, capsys):
    """The fuzzer's case: ``mkctl step --mechanism`` on such a file traced the model with the limit at 50
    (a RecursionError traceback); now it runs, and prints its report."""
    from mkctl.cli import main

    text = (ROOT / "docs" / "examples" / "cam_lever.py").read_text(encoding="utf-8")
    path = tmp_path / "low.py"
    # a limit just above the depth the file runs at (50 itself may already be below it: refused)
    low = "import inspect, sys\nsys.setrecursionlimit(len(inspect.stack()) + 40)\n"
    path.write_text(low + CHANGES["stdout"][0] + text, encoding="utf-8")
    limit = sys.getrecursionlimit()
    status = main(["step", "--no-fmu", "--mechanism", str(path), "--out", str(tmp_path / "out"),
                   "--duration", "0.3"])
    assert status == 0
    assert sys.getrecursionlimit() == limit
    assert "wrote" in capsys.readouterr().out


# --- a length so short that the rubber's energy is not finite (mkctl.physics.braid) -------------------

@pytest.mark.parametrize("function", ["strain_energy_density", "strain_energy_gradient",
                                      "strain_energy_curvature"])
@pytest.mark.parametrize("L", [1e-323, 1e-200, np.array([0.2, 1e-320, 0.15])])
def test_a_length_too_short_for_a_finite_rubber_energy_is_a_domain_error(function, L, no_warning):
    """Before: L = 1e-320 mm (inside 0 < L < b) raised ZeroDivisionError from Eq. 13 (Python floats) or gave
    inf with numpy's warnings (arrays); now a one-line DomainError that names the length."""
    from mkctl.errors import DomainError
    from mkctl.physics import braid
    from mkctl.physics.params import DEFAULT

    with pytest.raises(DomainError, match=r"L = 1e-\d+ m is too near 0 for the rubber's elastic energy"):
        getattr(braid, function)(L, DEFAULT)
    assert not no_warning, [str(w.message) for w in no_warning]


def test_the_rubber_energy_keeps_its_values_inside_the_domain_and_passes_nan_through():
    """The check changes no value: the energy at 0.1-0.24 m against the formula written out here (Eq. 10-12),
    lengths just inside b finite, NaN still NaN (the callers' own checks name it), sympy still traced."""
    import sympy

    from mkctl.physics import braid
    from mkctl.physics.params import DEFAULT as p

    L = np.array([0.1, 0.18, 0.2, 0.24])
    l1sq, l2sq = (L / p.L0) ** 2, (p.b**2 - L**2) / (p.D0 * p.n * np.pi) ** 2
    l3sq = 1 / (l1sq * l2sq)
    W = p.C1 * (l1sq + l2sq + l3sq - 3) + p.C2 * (1 / l1sq + 1 / l2sq + 1 / l3sq - 3)
    np.testing.assert_allclose(braid.strain_energy_density(L, p), W, rtol=1e-12)
    assert [braid.strain_energy_density(float(x), p) for x in L] == pytest.approx(W, rel=1e-12)
    assert np.isfinite(braid.strain_energy_gradient(float(np.nextafter(p.b, 0)), p))
    assert np.isnan(braid.strain_energy_gradient(float("nan"), p))
    assert np.isnan(braid.strain_energy_gradient(np.array([0.2, np.nan]), p)).tolist() == [False, True]
    assert isinstance(braid.strain_energy_gradient(sympy.Symbol("L"), p), sympy.Expr)


def test_compare_on_an_isometric_record_at_1e_320_mm_is_one_line(tmp_path, capsys):
    """The fuzzer's case: ``mkctl compare`` on an isometric record with a length of 1e-320 mm ended in a
    ZeroDivisionError traceback (the plot's tension at that length); now exit 2 and one line."""
    from mkctl.analysis.synth import synthesize, write_synthetic
    from mkctl.cli import main

    path, _ = write_synthetic(tmp_path / "iso.csv", synthesize("isometric", ["slack"], seed=1, samples=20),
                              truth_file=False)
    lines = path.read_text(encoding="utf-8").splitlines()
    row = next(i for i, line in enumerate(lines) if line[:1].isdigit()) + 5
    cells = lines[row].split(",")
    cells[1] = "1e-320"  # length_mm
    lines[row] = ",".join(cells)
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")
    assert main(["compare", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "too near 0" in err, err


@pytest.mark.parametrize("key", ["off", "lower", "upper", "typical"])
def test_an_effect_parameter_too_large_for_a_float_is_one_line(key, tmp_path):
    """Before: a bound of 10**400 (a Python int) in an effect file raised OverflowError with a traceback (the
    mechanism files' fix of the same, not yet shared); now both file kinds check their parameters' numbers with
    one function, and this is a one-line EffectFileError."""
    from mkctl.analysis.effect_files import EffectFileError, load_effect_file

    path = tmp_path / "big.py"
    path.write_text(DRAG_EFFECT.replace(f'"{key}": ', f'"{key}": 10**400 or '), encoding="utf-8")
    with pytest.raises(EffectFileError, match=f"{key} must be a finite number, got 1000") as raised:
        load_effect_file(path)
    assert "\n" not in str(raised.value) and len(str(raised.value)) < 300


@pytest.mark.parametrize("term, words", [
    # on floats first (the one rule of every effect, mkctl.physics.model): Python's own error, in one line
    ("p.c_fuzz_drag * Ldot / 0", "cannot be evaluated on floats .ZeroDivisionError: float division by zero"),
    ("p.c_fuzz_drag * xp.exp(Ldot * 1e6)", "cannot be evaluated on floats .OverflowError: math range error"),
    ("p.c_fuzz_drag * 1e308 * Ldot * 1e10", "not finite at the typical values"),
])
def test_an_effect_term_that_divides_by_zero_or_overflows_is_refused_without_a_warning(term, words, tmp_path,
                                                                                        no_warning):
    """The fuzzer's effect-file kind: numpy's divide-by-zero and overflow warnings were printed before the
    one-line refusal of such a term; now only the refusal."""
    from mkctl.analysis.effect_files import EffectFileError, load_effect_file

    path = tmp_path / "drag.py"
    path.write_text(DRAG_EFFECT.replace("return p.c_fuzz_drag * Ldot", f"return {term}"), encoding="utf-8")
    with pytest.raises(EffectFileError, match=words):
        load_effect_file(path)
    assert not no_warning, [str(w.message) for w in no_warning]


def test_a_sensor_resolution_of_1e_308_is_one_line(no_warning):
    """The fuzzer's case ``synth knee --resolution 1e-308``: the output divided by it overflowed (numpy's
    RuntimeWarning, then a record of infinities rounded back); now refused in one line, and a real encoder's
    resolution still rounds the output to its multiples."""
    from mkctl.analysis.synth import synthesize
    from mkctl.errors import ParameterError

    with pytest.raises(ParameterError, match="resolution = 1e-308 is below") as raised:
        synthesize("knee", {"c": 45.0}, seed=1, samples=50, rate=100.0, resolution=1e-308)
    assert "\n" not in str(raised.value)
    encoder = 360 / 2**12
    record = synthesize("knee", {"c": 45.0}, seed=1, samples=50, rate=100.0, output="beta_deg",
                        resolution=encoder)
    steps = np.degrees(record.output) / encoder  # the output in SI (rad)
    np.testing.assert_allclose(steps, np.round(steps), atol=1e-6)
    assert not no_warning, [str(w.message) for w in no_warning]


def test_a_mechanism_whose_inertia_is_1e_320_is_one_line_in_compare(tmp_path, monkeypatch, capsys):
    """The fuzzer's case: a mechanism file whose inertia is 1e-320 (positive: accepted at load) sent the
    integrator to q ~ 1e277, where Python's math raised OverflowError (a traceback); now the mechanism's
    evaluation says where it is not finite, and compare refuses the record in one line."""
    from mkctl.cli import main

    monkeypatch.chdir(tmp_path)
    text = (ROOT / "docs" / "examples" / "cam_lever.py").read_text(encoding="utf-8")
    assert "    return p.J_lever\n" in text
    Path("cam_lever.py").write_text(text, encoding="utf-8")
    assert main(["synth", "mechanism", "m.csv", "--mechanism", "cam_lever.py", "--samples", "200",
                 "--no-truth"]) == 0
    Path("cam_lever.py").write_text(text.replace("    return p.J_lever\n", "    return 1e-320\n"),
                                    encoding="utf-8")
    capsys.readouterr()
    assert main(["compare", "m.csv", "--mechanism", "cam_lever.py", "--out", "out"]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "is not a finite number" in err, err
