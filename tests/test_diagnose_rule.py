"""The diagnosis's acceptance rule on hand-built residuals: each criterion alone, its direction, the penalty.

No simulation here: the residuals are made up so that exactly one criterion decides, and the expected
verdict follows from the rule's definition (module docstring of mkctl.analysis.diagnosis_rule), computed
by hand in each test.
"""
import math

import numpy as np
import pytest

from mkctl.analysis import diagnosis_rule as rule
from mkctl.analysis.diagnosis_rule import adequacy, noise_limit
from mkctl.analysis.diagnosis_rule import Candidate, Rule, Score, best_value, decide, pair_needed, to_drop

N = 200  # training samples
NH = 80  # held-out samples


def noise(scale, n, seed):
    r = np.random.default_rng(seed).normal(size=n)
    return scale * r / np.sqrt(np.mean(r * r))  # RMS exactly `scale`


def score(train_rms, holdout_rms, k, seed=0):
    """A score whose training RMS and held-out RMSE are exactly the given values."""
    return Score.from_residuals(noise(train_rms, N, seed), noise(holdout_rms, NH, seed + 1), k)


def rms_for_delta_bic(current: Score, delta: float, k: int) -> float:
    """The training RMS a model with k parameters needs for BIC = current.bic + delta (solved by hand:
    n ln(RSS/n) = current.bic + delta - k ln n)."""
    target = current.bic + delta - k * math.log(N)
    return math.sqrt(math.exp(target / N))


CURRENT = score(1.0, 1.0, 0)


def test_bic_is_n_ln_rss_over_n_plus_k_ln_n():
    assert rule.bic(2.0, 100, 3) == pytest.approx(100 * math.log(0.02) + 3 * math.log(100))
    assert rule.bic(2.0, 100, 0) == pytest.approx(100 * math.log(0.02))
    # the Score's BIC uses its own RSS, n and k
    s = Score.from_residuals(np.full(50, 0.5), np.ones(10), 2)
    assert s.rss_train == pytest.approx(12.5) and s.n_train == 50
    assert s.bic == pytest.approx(50 * math.log(0.25) + 2 * math.log(50))
    assert s.rmse_holdout == pytest.approx(1.0)


def test_a_candidate_that_passes_every_criterion_is_added():
    rms = rms_for_delta_bic(CURRENT, -30.0, 1)
    decision = decide(CURRENT, [Candidate("viscous_damping", score(rms, 0.7, 1))])
    assert decision.verdict == "add" and decision.effect == "viscous_damping"
    j = decision.judgements["viscous_damping"]
    assert j.delta_bic == pytest.approx(-30.0) and j.passes_bic and j.passes_holdout


@pytest.mark.parametrize("delta", [-5.0, 5.0, -9.9])
def test_a_bic_gain_below_the_threshold_is_not_enough(delta):
    # the held-out part would welcome it; BIC alone must refuse (a rule "BIC or held-out" accepts this)
    rms = rms_for_delta_bic(CURRENT, delta, 1)
    decision = decide(CURRENT, [Candidate("viscous_damping", score(rms, 0.5, 1))])
    assert decision.verdict == "stop"
    assert not decision.judgements["viscous_damping"].passes_bic
    assert decision.judgements["viscous_damping"].passes_holdout
    assert "BIC" in decision.reason


def test_the_threshold_is_a_fall_of_bic_by_more_than_ten():
    for delta, passes in [(-10.5, True), (-9.5, False)]:
        rms = rms_for_delta_bic(CURRENT, delta, 1)
        j = rule.judge(CURRENT, Candidate("c", score(rms, 0.5, 1)))
        assert j.passes_bic is passes, delta


def test_the_k_ln_n_penalty_decides_a_small_gain_in_rss():
    # RSS falls by enough for n ln(RSS/n) to drop 13, but one more parameter costs ln 200 = 5.3:
    # dBIC = -7.7, not enough. Without the penalty it would pass.
    rms = math.sqrt(math.exp((CURRENT.bic - 13.0) / N))
    candidate = score(rms, 0.5, 1)
    assert candidate.bic - CURRENT.bic == pytest.approx(-13.0 + math.log(N))
    assert decide(CURRENT, [Candidate("c", candidate)]).verdict == "stop"
    # the same fit with no extra parameter (k = 0) would pass: the penalty is what stops it
    assert decide(CURRENT, [Candidate("c", score(rms, 0.5, 0))]).verdict == "add"


def test_a_candidate_that_does_not_lower_the_held_out_error_is_refused():
    rms = rms_for_delta_bic(CURRENT, -200.0, 1)  # overwhelming on the training part
    for holdout in (1.0, 0.99, 1.5):
        decision = decide(CURRENT, [Candidate("c", score(rms, holdout, 1))])
        assert decision.verdict == "stop", holdout
        assert decision.judgements["c"].passes_bic and not decision.judgements["c"].passes_holdout
        assert "held-out" in decision.reason
    assert decide(CURRENT, [Candidate("c", score(rms, 0.97, 1))]).verdict == "add"


def test_a_candidate_on_its_bound_or_switched_off_is_never_accepted():
    rms = rms_for_delta_bic(CURRENT, -200.0, 1)
    pinned = Candidate("viscous_damping", score(rms, 0.5, 1), at_bound=True)
    decision = decide(CURRENT, [pinned])
    assert decision.verdict == "stop" and "bound" in decision.reason
    off = Candidate("viscous_damping", score(rms, 0.5, 1), switched_off=True)
    assert decide(CURRENT, [off]).verdict == "stop"
    # a physical, weaker candidate is then the one accepted
    fine = Candidate("coulomb_friction", score(rms_for_delta_bic(CURRENT, -50.0, 1), 0.6, 1))
    assert decide(CURRENT, [pinned, fine]).effect == "coulomb_friction"


def test_equal_held_out_errors_are_undecided_not_a_pick():
    a = Candidate("viscous_damping", score(rms_for_delta_bic(CURRENT, -80.0, 1), 0.500, 1))
    b = Candidate("coulomb_friction", score(rms_for_delta_bic(CURRENT, -70.0, 1), 0.505, 1))
    decision = decide(CURRENT, [a, b])
    assert decision.verdict == "undecided"
    assert decision.effect == "viscous_damping" and decision.rivals == ("coulomb_friction",)
    # a clear margin on the held-out part decides, whichever order they come in
    b_clear = Candidate("coulomb_friction", score(rms_for_delta_bic(CURRENT, -70.0, 1), 0.60, 1))
    assert decide(CURRENT, [b_clear, a]).verdict == "add"
    # the best BIC that predicts the held-out part worse than a rival is not added either
    b_better = Candidate("coulomb_friction", score(rms_for_delta_bic(CURRENT, -70.0, 1), 0.40, 1))
    decision = decide(CURRENT, [a, b_better])
    assert decision.verdict == "undecided" and decision.rivals == ("coulomb_friction",)


def test_a_pinned_rival_does_not_make_a_tie():
    a = Candidate("viscous_damping", score(rms_for_delta_bic(CURRENT, -80.0, 1), 0.5, 1))
    pinned = Candidate("pressure_lag", score(rms_for_delta_bic(CURRENT, -80.0, 1), 0.5, 1), at_bound=True)
    assert decide(CURRENT, [a, pinned]).verdict == "add"


def test_a_custom_rule_moves_the_thresholds():
    rms = rms_for_delta_bic(CURRENT, -15.0, 1)
    candidate = [Candidate("c", score(rms, 0.9, 1))]
    assert decide(CURRENT, candidate).verdict == "add"
    assert decide(CURRENT, candidate, Rule(bic_threshold=20.0)).verdict == "stop"
    assert decide(CURRENT, candidate, Rule(holdout_gain=0.2)).verdict == "stop"


def test_a_pair_is_added_only_when_each_is_needed_beside_the_other():
    one = score(rms_for_delta_bic(CURRENT, -80.0, 1), 0.5, 1)
    other = score(rms_for_delta_bic(CURRENT, -78.0, 1), 0.5, 1)
    both = score(rms_for_delta_bic(CURRENT, -150.0, 2), 0.3, 2)
    assert pair_needed([one, other], both)
    redundant = score(rms_for_delta_bic(CURRENT, -85.0, 2), 0.49, 2)  # the second adds almost nothing
    assert not pair_needed([one, other], redundant)
    no_holdout = score(rms_for_delta_bic(CURRENT, -150.0, 2), 0.5, 2)
    assert not pair_needed([one, other], no_holdout)


def test_an_earlier_effect_that_no_longer_earns_its_place_is_dropped():
    current = score(rms_for_delta_bic(CURRENT, -100.0, 2), 0.5, 2)
    cheap = score(rms_for_delta_bic(CURRENT, -95.0, 1), 0.5, 1)  # removing it costs BIC 5 < 10
    dear = score(rms_for_delta_bic(CURRENT, -40.0, 1), 0.5, 1)  # removing it costs 60
    assert to_drop(current, {"viscous_damping": cheap, "pressure_lag": dear}) == "viscous_damping"
    assert to_drop(current, {"pressure_lag": dear}) is None
    cheaper = score(rms_for_delta_bic(CURRENT, -98.0, 1), 0.5, 1)
    assert to_drop(current, {"viscous_damping": cheap, "coulomb_friction": cheaper}) == "coulomb_friction"


def test_best_value_switches_the_effect_off_when_nothing_beats_off():
    cost = lambda v: (math.log10(v) - math.log10(3.0)) ** 2 + 1.0  # noqa: E731  minimum 1.0 at v = 3
    value, best = best_value(cost, (1e-2, 1e4), cost_off=0.5)
    assert value == 0.0 and best == 0.5
    value, best = best_value(cost, (1e-2, 1e4), cost_off=5.0)
    assert value == pytest.approx(3.0, rel=1e-2) and best == pytest.approx(1.0, abs=1e-4)
    # failed simulations (infinite cost) in part of the range do not stop the search
    value, _ = best_value(lambda v: math.inf if v > 100 else cost(v), (1e-2, 1e4), cost_off=5.0)
    assert value == pytest.approx(3.0, rel=1e-2)


def test_at_bound_is_relative_to_each_end_of_the_range():
    assert rule.at_bound(1e5, (1e-2, 1e5)) and rule.at_bound(1.0001e-2, (1e-2, 1e5))
    assert not rule.at_bound(45.0, (1e-2, 1e5)) and not rule.at_bound(0.0, (1e-2, 1e5))


def test_best_value_stops_the_grid_once_the_cost_rises_twice():
    calls = []

    def cost(v):
        calls.append(v)
        return (math.log10(v) - 1.0) ** 2  # minimum at 10, rising beyond
    value, _ = best_value(cost, (1e-2, 1e6), cost_off=50.0)
    assert value == pytest.approx(10.0, rel=1e-2)
    grid = [v for v in calls if abs(math.log10(v) - round(math.log10(v))) < 1e-9]
    assert max(grid) == pytest.approx(1e3)  # 1e2 and 1e3 rise above 1e1: 1e4 .. 1e6 are never simulated
    calls.clear()
    best_value(cost, (1e-2, 1e6), cost_off=50.0, early_stop=False)
    assert max(calls) == pytest.approx(1e6)


def test_best_value_walks_past_a_small_bump_at_small_values():
    """A light damper first raises the cost a little (it shifts the phase of an oscillation it barely calms);
    the minimum lies two decades further up. The early stop must not end the walk on such a bump (it did:
    damping came out "off" on a knee record with a rest at its end)."""
    def cost(v):
        bump = 0.06 * math.exp(-(math.log10(v) - 0.0) ** 2)  # +6 % around 1
        return 1.0 + bump - 0.999 * math.exp(-4.0 * (math.log10(v) - math.log10(30.0)) ** 2)
    value, best = best_value(cost, (1e-2, 1e4), cost_off=1.0)
    assert value == pytest.approx(30.0, rel=1e-2) and best < 0.01


def test_stop_reasons_name_the_best_candidate_and_each_criterion_it_failed():
    weak = Candidate("viscous_damping", score(rms_for_delta_bic(CURRENT, -5.0, 1), 1.0, 1))
    worse = Candidate("coulomb_friction", score(rms_for_delta_bic(CURRENT, 3.0, 1), 1.0, 1))
    assert decide(CURRENT, [worse, weak]).reason == (
        "the best candidate (viscous_damping) changes BIC by only -5.0 (needs < -10); "
        "it does not lower the held-out RMSE by 2%")
    training_only = Candidate("pressure_lag", score(rms_for_delta_bic(CURRENT, -50.0, 1), 1.0, 1))
    assert decide(CURRENT, [training_only]).reason == ("the best candidate (pressure_lag) does not lower the "
                                                       "held-out RMSE by 2%")
    off = Candidate("elasticity", score(rms_for_delta_bic(CURRENT, 5.3, 1), 1.0, 1), switched_off=True)
    assert decide(CURRENT, [off]).reason == (
        "the best candidate (elasticity) fits best switched off; it changes BIC by only +5.3 (needs < -10); "
        "it does not lower the held-out RMSE by 2%")
    pinned = Candidate("viscous_damping", score(rms_for_delta_bic(CURRENT, -50.0, 1), 0.5, 1), at_bound=True)
    assert decide(CURRENT, [pinned]).reason == (
        "the best candidate (viscous_damping) is pinned on a bound of its search range (not a physical "
        "explanation: something else is missing)")
    assert decide(CURRENT, [Candidate("c", None)]).reason == "no candidate could be simulated on this record"
    assert decide(CURRENT, []).verdict == "stop"


def test_the_undecided_reason_gives_both_held_out_errors():
    a = Candidate("viscous_damping", score(rms_for_delta_bic(CURRENT, -80.0, 1), 0.5, 1))
    b = Candidate("coulomb_friction", score(rms_for_delta_bic(CURRENT, -70.0, 1), 0.505, 1))
    assert decide(CURRENT, [a, b]).reason == ("viscous_damping does not beat coulomb_friction on the held-out part "
                                              "by 2% (held-out RMSE 0.5 vs 0.505)")


def test_a_candidate_that_could_not_be_simulated_fails_every_criterion():
    j = rule.judge(CURRENT, Candidate("c", None))
    assert (j.delta_bic, j.passes_bic, j.passes_holdout, j.physical, j.eligible) == (None, False, False, False, False)


def test_rule_fields_and_training_rmse():
    assert Rule().as_dict() == {"bic_threshold": 10.0, "holdout_gain": 0.02, "holdout_margin": 0.02,
                                "holdout_fraction": 0.3, "min_signature_correlation": 0.0, "adequate_factor": 2.0,
                                "adequacy_level": 1e-3, "interleaved_holdout": ["pressure"],
                                "holdout_every": 3}
    assert rule.RULE == Rule()
    s = Score.from_residuals(np.array([3.0, 4.0]), np.array([1.0]), 0)
    assert s.rmse_train == pytest.approx(math.sqrt(12.5))


def test_best_value_when_every_simulation_fails():
    assert best_value(lambda v: math.inf, (1e-2, 1e2), cost_off=3.0) == (0.0, 3.0)
    value, cost = best_value(lambda v: math.inf, (1e-2, 1e2), cost_off=math.inf)
    assert math.isnan(value) and cost == math.inf


def test_best_value_grid_density_and_tolerance():
    calls = []

    def cost(v):
        calls.append(v)
        return (math.log10(v) - 0.37) ** 2
    best_value(cost, (1e-2, 1e4), cost_off=50.0, points_per_decade=2.0, early_stop=False)
    grid = calls[:13]
    assert np.allclose(np.log10(grid), np.linspace(-2, 4, 13))
    cusp = lambda v: abs(math.log10(v) - 0.37) ** 0.5  # noqa: E731  no parabola fits it: xatol decides
    coarse, _ = best_value(cusp, (1e-2, 1e4), 50.0, xatol=0.3)
    fine, _ = best_value(cusp, (1e-2, 1e4), 50.0, xatol=1e-5)
    assert abs(math.log10(fine) - 0.37) < 1e-4 < 1e-2 < abs(math.log10(coarse) - 0.37) < 0.3
    # the minimum on the grid itself (no better point between its neighbours) is kept
    value, _ = best_value(lambda v: abs(math.log10(v) - 1.0), (1e-2, 1e4), 50.0)
    assert value == pytest.approx(10.0, rel=1e-3)


def test_at_bound_tolerance():
    assert rule.at_bound(1.0005e-2, (1e-2, 1e5)) and not rule.at_bound(1.002e-2, (1e-2, 1e5))
    assert rule.at_bound(0.9995e5, (1e-2, 1e5)) and not rule.at_bound(0.998e5, (1e-2, 1e5))
    assert rule.at_bound(1.002e-2, (1e-2, 1e5), tolerance=0.01)


def test_bic_of_a_small_rss_and_the_decisions_carry_their_judgements():
    assert rule.bic(0.5, 10, 0) == pytest.approx(10 * math.log(0.05))
    assert rule.bic(0.0, 10, 0) == pytest.approx(10 * math.log(1e-301))
    a = Candidate("viscous_damping", score(rms_for_delta_bic(CURRENT, -80.0, 1), 0.5, 1))
    b = Candidate("coulomb_friction", score(rms_for_delta_bic(CURRENT, -70.0, 1), 0.505, 1))
    c = Candidate("pressure_lag", score(rms_for_delta_bic(CURRENT, -60.0, 1), 0.506, 1))
    undecided = decide(CURRENT, [a, b, c])
    assert undecided.rivals == ("coulomb_friction", "pressure_lag")
    assert undecided.reason.endswith("(held-out RMSE 0.5 vs 0.505, 0.506)")
    assert set(undecided.judgements) == {"viscous_damping", "coulomb_friction", "pressure_lag"}
    added = decide(CURRENT, [a])
    assert added.reason == "viscous_damping passes every criterion" and set(added.judgements) == {"viscous_damping"}


# --- round 3: effective samples, the null test, the signature, one forward selection, adequacy ---------------

def test_bic_counts_effective_samples_under_correlated_noise():
    assert rule.effective_samples(1000, 0.0) == 1000 and rule.effective_samples(1000, 0.5) == pytest.approx(1000 / 3)
    r = np.random.default_rng(0).standard_normal(400)
    white = Score.from_residuals(r[:300], r[300:], 1)
    coloured = Score.from_residuals(r[:300], r[300:], 1, noise_correlation=0.5)
    assert white.bic == pytest.approx(rule.bic(white.rss_train, 300, 1))
    assert coloured.bic == pytest.approx(100 * math.log(white.rss_train / 300) + math.log(100))


BEFORE = Score(rss_train=100.0, n_train=1000, k=0, rmse_holdout=1.0)


def gaining(delta_bic: float, **fields) -> Candidate:
    rss = 1000 * math.exp((BEFORE.bic + delta_bic - math.log(1000)) / 1000)
    return Candidate("coulomb_friction", Score(rss, 1000, 1, 0.5), **fields)


def test_a_candidate_that_gains_as_much_on_noise_alone_is_refused():
    assert decide(BEFORE, [gaining(-40.0, null_delta_bic=-35.0)]).verdict == "stop"
    assert decide(BEFORE, [gaining(-40.0, null_delta_bic=-20.0)]).verdict == "add"
    assert decide(BEFORE, [gaining(-40.0, null_delta_bic=+3.0)]).verdict == "add"  # noise alone loses BIC
    reason = decide(BEFORE, [gaining(-40.0, null_delta_bic=-35.0)]).reason
    assert "noise alone" in reason and "-35.0" in reason


def test_a_candidate_whose_signature_goes_against_the_missing_force_is_refused():
    assert decide(BEFORE, [gaining(-40.0, signature=-0.4)]).verdict == "stop"
    assert decide(BEFORE, [gaining(-40.0, signature=0.3)]).verdict == "add"
    assert "r = -0.40" in decide(BEFORE, [gaining(-40.0, signature=-0.4)]).reason


def test_forward_selection_runs_the_null_test_on_the_winner_and_judges_the_next():
    """The winner fails the null test: the next best is judged instead, and only then added."""
    scores = {"viscous_damping": gaining(-60.0).score, "coulomb_friction": gaining(-40.0).score}
    added, tested = [], []

    def fit_round(names):
        return [Candidate(name, scores[name]) for name in names]

    def null_test(candidate):
        tested.append(candidate.effect)
        null = -58.0 if candidate.effect == "viscous_damping" else 0.0
        return Candidate(candidate.effect, candidate.score, null_delta_bic=null)

    def add(decision):
        added.append(decision.effect)
        return BEFORE if len(added) < 1 else Score(0.01, 1000, 2, 0.01)

    decision = rule.forward_selection(BEFORE, lambda: [n for n in scores if n not in added], fit_round, add,
                                      null_test=null_test)
    assert added[0] == "coulomb_friction" and tested[:2] == ["viscous_damping", "coulomb_friction"]
    assert decision.verdict == "stop"


# --- adequacy ----------------------------------------------------------------------------------------------

def test_noise_limit_is_the_chi_square_quantile_or_the_rules_factor():
    from scipy.stats import chi2

    assert noise_limit(1e5) == 2.0  # many samples: the rule's factor
    assert noise_limit(4) == pytest.approx(math.sqrt(chi2.ppf(0.999, 4) / 4))  # few: the chi-square quantile
    assert noise_limit(4) > 2.0
    assert noise_limit(4, tests=10) > noise_limit(4)  # Bonferroni over windows
    assert noise_limit(4, Rule(adequacy_level=0.1)) < noise_limit(4)


def test_adequacy_over_the_whole_record_and_window_by_window():
    rng = np.random.default_rng(2)
    noise = rng.standard_normal(2000)
    assert adequacy(noise, 1.0).adequate
    assert not adequacy(3.0 * noise, 1.0).adequate  # between 3 and 10 times the noise: now said
    local = noise.copy()
    local[:200] *= 5.0  # the error sits in one tenth: 1.9 times the noise overall
    fit = adequacy(local, 1.0)
    assert fit.ratio < 2.0 and not fit.adequate and fit.worst["start"] == 0 and fit.worst["ratio"] > 4.0
    assert "in one part" in fit.text()
    # correlated noise has fewer independent samples: the same window is judged more leniently
    assert adequacy(local, 1.0, correlation=0.98).worst["limit"] > fit.worst["limit"]



def test_the_rules_own_criteria_as_methods():
    r = Rule(bic_threshold=10.0, holdout_gain=0.02, holdout_margin=0.05, holdout_fraction=0.25)
    assert r.split_time(2.0, 10.0) == pytest.approx(8.0)
    assert r.passes_bic(-10.01) and not r.passes_bic(-10.0)
    assert r.passes_holdout(0.979, 1.0) and not r.passes_holdout(0.98, 1.0)
    assert r.beats(0.949, 1.0) and not r.beats(0.95, 1.0)
    assert r.promising(-5.01) and not r.promising(-5.0)


def test_effective_samples_and_bic_clamp_them():
    assert rule.effective_samples(100, -0.3) == 100.0
    assert rule.effective_samples(100, 1.0) == pytest.approx(100 * 0.01 / 1.99)  # correlation capped at 0.99
    assert rule.bic(10.0, 100, 1, n_effective=1e6) == pytest.approx(rule.bic(10.0, 100, 1))  # never above n
    assert rule.bic(10.0, 100, 1, n_effective=0.1) == pytest.approx(math.log(0.1))  # never below 1


def test_forward_selection_stops_when_nothing_is_left_and_adds_a_tie_broken_together():
    assert rule.forward_selection(BEFORE, lambda: [], None, None).reason == "no candidate effect left for this experiment"
    a, b = gaining(-80.0).score, Score(gaining(-78.0).score.rss_train, 1000, 1, 0.505)
    added = []

    def fit_round(names):
        return [Candidate(n, {"viscous_damping": a, "coulomb_friction": b}[n]) for n in names]

    def break_tie(decision):
        assert decision.verdict == "undecided" and decision.rivals == ("coulomb_friction",)
        return rule.Decision("add", decision.effect, decision.rivals, together=decision.rivals)

    def add(decision):
        added.extend([decision.effect, *decision.together])
        return Score(1e-3, 1000, 2, 1e-3)

    names = ["viscous_damping", "coulomb_friction"]
    last = rule.forward_selection(BEFORE, lambda: [n for n in names if n not in added], fit_round, add,
                                  break_tie=break_tie)
    assert added == ["viscous_damping", "coulomb_friction"] and last.verdict == "stop"
    undecided = rule.forward_selection(BEFORE, lambda: names, fit_round, add)
    assert undecided.verdict == "undecided"


def test_adequacy_without_a_noise_estimate_and_its_texts():
    assert adequacy(np.ones(10), 0.0) == rule.Adequacy(True, 0.0, math.inf, {})
    fit = adequacy(np.ones(1000), 1.0)
    assert fit.adequate and fit.ratio == pytest.approx(1.0) and "noise explains up to 2" in fit.text()
    assert "over the whole record, more than" in adequacy(3 * np.ones(1000), 1.0).text()
    assert adequacy(np.full(1000, 1.999), 1.0).adequate and not adequacy(np.full(1000, 2.001), 1.0).adequate
    assert adequacy(np.ones(1000), 1.0, rule=Rule(adequate_factor=0.5)).limit == pytest.approx(
        noise_limit(1000, Rule(adequate_factor=0.5)))
