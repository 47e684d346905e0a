"""`mkctl diagnose` on the effects a real rig has (model-spec section 4b), on records of the independent rig.

The records come from tests/independent_rig.py: its own tension, knee geometry and Eq. 17 through solve_ivp, the
effects written there (a dead time before the valves, a lag that fills with tau and exhausts with tau_exhaust, a
threshold pressure, friction growing with pressure), coloured output noise (AR(1), 10 ms) and a small model
mismatch mkctl cannot represent (the valves see every command 0.1 ms late). The knee records are 1500 samples at
500 Hz with a known damper (c = 45 N s/m, declared in the file and present in the rig): the leg settles between
the command steps, as a real leg does.

Values are checked against the truth within 3 reported standard errors: the standard errors are the diagnosis'
own (widened for correlated residuals), and 3 of them is the usual band for a single parameter (1 would fail a
third of honest fits). Where the rig's mismatch moves a value by more than its statistical error, the test says
by how much and why, and checks the value on a record without the mismatch too.
"""
import functools
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))
import independent_rig as rig  # noqa: E402

from mkctl.analysis.diagnose import DISCRIMINATING_EXPERIMENTS, diagnose  # noqa: E402
from mkctl.physics import effects  # noqa: E402
from mkctl.physics.params import Params  # noqa: E402

C = 45.0  #: the rig's damper [N s/m], declared in every knee file (part of the baseline)
MISMATCH = 1e-4  #: the rig's default mismatch: every command reaches the valves 0.1 ms late [s]
NEW = ("dead_time", "asymmetric_lag", "pressure_threshold", "pressure_friction")


@functools.lru_cache(maxsize=None)
def knee(hidden: tuple, **options):
    """The diagnosis of a knee record of the rig with ``hidden`` (a tuple of items) besides the known damper."""
    record = rig.knee_record({"c": C, **dict(hidden)}, params=Params(c=C), samples=1500, rate=500.0, **options)
    return diagnose(record)


def within(result, name, truth, standard_errors=3.0, bias=0.0):
    value, se = result.params[name], result.uncertainty[name]
    assert 0 < se < 0.1 * truth, (name, value, se)
    assert abs(value - truth) <= standard_errors * se + bias, (name, value, truth, se, (value - truth) / se)


def first_round(result) -> dict:
    """The first round's candidates by name."""
    rounds = result.steps or [result.stopped]
    return {row["effect"]: row for row in rounds[0]["candidates"]}


def test_every_rig_effect_is_a_diagnosis_candidate_of_the_knee():
    result = knee(())
    assert set(NEW) - {"asymmetric_lag"} <= set(first_round(result))  # asymmetric_lag needs the lag: later rounds
    for name in NEW:
        assert effects.get(name).experiments.get("knee"), name


def test_a_clean_record_gets_none_of_them():
    result = knee(())
    assert result.verdict == "nothing missing", result
    assert result.missing == []


def test_a_dead_time_is_found_and_not_taken_for_a_lag():
    """Hidden 30 ms; the rig's 0.1 ms mismatch is a dead time too, so the truth the record holds is 30.1 ms."""
    result = knee((("delay", 0.03),))
    assert result.verdict == "diagnosed" and result.missing == ["dead_time"], result
    within(result, "delay", 0.03 + MISMATCH)
    rows = first_round(result)  # the lag was tried and lost clearly: told apart, not a tie
    assert rows["pressure_lag"]["delta_bic"] > rows["dead_time"]["delta_bic"] + 100
    assert result.undecided == []


def test_a_dead_time_is_told_from_a_lag_under_heavy_noise():
    """1 mm of output noise (a hundred times the default): the lag still loses, and the delay holds."""
    result = knee((("delay", 0.03),), noise=1e-3)
    assert result.verdict == "diagnosed" and result.missing == ["dead_time"], result
    within(result, "delay", 0.03 + MISMATCH)


def test_an_asymmetric_lag_is_found_with_both_time_constants():
    """Filling 80 ms, exhausting 130 ms: round 1 takes a symmetric lag (a compromise), round 2 the exhausting one."""
    result = knee((("tau", 0.08), ("tau_exhaust", 0.13)))
    assert result.verdict == "diagnosed", result
    assert result.missing == ["pressure_lag", "asymmetric_lag"]
    within(result, "tau", 0.08)
    within(result, "tau_exhaust", 0.13)


def test_a_symmetric_lag_is_not_taken_for_an_asymmetric_one_nor_for_a_dead_time():
    result = knee((("tau", 0.08),))
    assert result.verdict == "diagnosed" and result.missing == ["pressure_lag"], result
    within(result, "tau", 0.08)
    tried = {row["effect"]: row for row in result.stopped["candidates"]}
    assert "asymmetric_lag" in tried and "dead_time" in tried  # both tried beside the lag, and rejected
    assert not tried["asymmetric_lag"]["passes_bic"]


def test_a_threshold_pressure_is_found():
    """P0 = 100 kPa. Without the rig's mismatch it lies within 3 standard errors (2.4 Pa); with it, the 0.1 ms
    late commands move it by +13 to +23 Pa on seeds 0-2 (2e-4 of P0, outside the statistical error, which knows
    nothing of a mismatch), so that record is checked to 3 standard errors plus 3e-4 of P0."""
    exact = knee((("P0", 1e5),), mismatch_delay=0.0)
    assert exact.verdict == "diagnosed" and exact.missing == ["pressure_threshold"], exact
    within(exact, "P0", 1e5)
    result = knee((("P0", 1e5),))
    assert result.verdict == "diagnosed" and result.missing == ["pressure_threshold"], result
    within(result, "P0", 1e5, bias=3e-4 * 1e5)


def test_pressure_friction_is_found_and_not_taken_for_constant_friction():
    result = knee((("Fc_p", 5e-6),))
    assert result.verdict == "diagnosed" and result.missing == ["pressure_friction"], result
    within(result, "Fc_p", 5e-6)
    rows = first_round(result)
    assert rows["coulomb_friction"]["delta_bic"] > rows["pressure_friction"]["delta_bic"] + 10


def test_constant_friction_is_not_taken_for_pressure_friction():
    result = knee((("Fc", 2.0),))
    assert result.verdict == "diagnosed" and result.missing == ["coulomb_friction"], result
    within(result, "Fc", 2.0)


def test_an_undecided_pair_names_the_registrys_separating_experiment():
    """Where a record cannot tell the neighbours apart, the report's experiment is the one each effect's definition
    gives (its ``separation``): the same words, so the user reads what would settle it."""
    for a, b in (("dead_time", "pressure_lag"), ("asymmetric_lag", "pressure_lag"),
                 ("pressure_friction", "coulomb_friction"), ("pressure_threshold", "elasticity")):
        text = effects.get(a).separation[b]
        assert DISCRIMINATING_EXPERIMENTS[frozenset({a, b})] == text
        assert len(text) > 40


# --- with the bladder pressures measured (0.5 kPa of white sensor noise): the pressure path is judged on them ---

def test_measured_pressures_show_a_dead_time_not_a_lag():
    """A lag fitted to these pressures (about 30 ms) was taken as the answer before the dead time was judged on
    them: "diagnosed" with the wrong effect. Without a lag the pressures place the delay only to a sample (2 ms),
    so the motion fits it."""
    result = knee((("delay", 0.03),), pressures=True)
    assert result.verdict == "diagnosed" and result.missing == ["dead_time"], result
    within(result, "delay", 0.03 + MISMATCH)


def test_measured_pressures_show_an_asymmetric_lag():
    result = knee((("tau", 0.08), ("tau_exhaust", 0.13)), pressures=True)
    assert result.verdict == "diagnosed" and result.missing == ["pressure_lag", "asymmetric_lag"], result
    within(result, "tau", 0.08 + MISMATCH)  # the 0.1 ms late commands lengthen the fitted lag by about that
    within(result, "tau_exhaust", 0.13 + MISMATCH)


def test_measured_pressures_show_a_dead_time_before_a_lag():
    result = knee((("tau", 0.05), ("delay", 0.03)), pressures=True)
    assert result.verdict == "diagnosed" and sorted(result.missing) == ["dead_time", "pressure_lag"], result
    within(result, "tau", 0.05)
    within(result, "delay", 0.03 + MISMATCH)


def test_measured_pressures_of_a_plain_lag_add_nothing_else():
    result = knee((("tau", 0.08),), pressures=True)
    assert result.verdict == "diagnosed" and result.missing == ["pressure_lag"], result
    within(result, "tau", 0.08 + MISMATCH)
