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
"""
from __future__ import annotations

import signal
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
    with pytest.raises(MkctlError, match="too short for the model's tension to be finite"):
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
