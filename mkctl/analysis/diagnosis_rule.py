"""The diagnosis's acceptance rule, as small pure functions on scores (no simulation in here).

:func:`mkctl.analysis.diagnose.diagnose` fits candidates and hands their errors to these functions; what
is accepted, rejected, dropped or reported as undecidable is decided here alone, so that it can be tested
on hand-built residuals.

A model's :class:`Score` holds its training residual sum of squares, the number n of training samples
compared, the number k of parameters it fitted, and its RMSE on the held-out part. Its Bayesian
information criterion is

    ``BIC = n ln(RSS / n) + k ln n``

(Schwarz 1978; lower is better; a difference of 10 is "very strong" evidence on the scale of Kass &
Raftery 1995, J. Am. Stat. Assoc. 90, 773).

A candidate effect is **accepted** (:func:`decide`) only when all of these hold:

1. it was fitted and is physical: its parameter is not switched off (0) and not on a bound of its search
   range (a value pinned to a bound, like c = 1e5 N s/m freezing the leg, is a symptom, not an
   explanation);
2. it lowers BIC by more than :attr:`Rule.bic_threshold` (``dBIC < -10``);
3. it lowers the held-out RMSE by at least :attr:`Rule.holdout_gain` (2 %);
4. its held-out RMSE beats every other physical candidate's by :attr:`Rule.holdout_margin` (2 %);
5. it gains more than noise alone gives it: its dBIC less what the same candidate gains when refitted on
   the current model's simulation plus the estimated noise (:attr:`Candidate.null_delta_bic`, when that is
   negative) still passes 2;
6. its own force term does not go against the force the model lacks: the correlation of its signature is
   at least :attr:`Rule.min_signature_correlation` (when there is one).

Among the candidates that pass 1-3, 5 and 6, the best BIC is the one judged by 4. When 4 fails, the record cannot
tell the best from its rivals: the verdict is ``"undecided"`` (the loop then tries them together, see
:func:`pair_needed`, and otherwise reports the tie with the experiment that would separate them). After
an acceptance, an earlier effect is dropped (:func:`to_drop`) when removing it costs less than the
threshold in BIC. :func:`forward_selection` runs these rounds for the diagnosis and the calibration
alike. An effect that requires another is tried together with its prerequisite when a round ends
tied or stopped (the combination judged by :func:`decide` like any candidate, a rival joining it by
:func:`extension_needed`).

When the selection is over, :func:`adequacy` says whether the final model leaves only what the noise explains
(a chi-square test with the effective sample count, never stricter than :attr:`Rule.adequate_factor`), over
the whole record and window by window.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from .statistics import bic, effective_samples, forward_stepwise  # each defined there, once


@dataclass(frozen=True)
class Rule:
    """The thresholds of the rule (see the module docstring)."""

    bic_threshold: float = 10.0  #: an effect must lower BIC by more than this
    holdout_gain: float = 0.02  #: ... and the held-out RMSE by at least this fraction
    holdout_margin: float = 0.02  #: ... and beat every other physical candidate's held-out RMSE by this fraction
    holdout_fraction: float = 0.3  #: share of the record (at its end) held out from fitting
    #: experiments whose held-out part is every ``round(1 / holdout_fraction)``-th sample instead
    #: (:func:`mkctl.analysis.statistics.every_kth`): a pressure record's events (a valve's
    #: switches) are brief, and it ends on a plateau every candidate predicts alike
    #: (docs/diagnosis.md, "Split")
    interleaved_holdout: tuple = ("pressure",)
    #: ... and its own force term must not anti-correlate with the force the model lacks (criterion 6)
    min_signature_correlation: float = 0.0
    #: "diagnosed" needs the final residual within this many times the output noise, everywhere ...
    adequate_factor: float = 2.0
    #: ... and not above the noise by a chi-square test at this significance (see :func:`adequacy`)
    adequacy_level: float = 1e-3

    def as_dict(self) -> dict:
        return {"bic_threshold": self.bic_threshold, "holdout_gain": self.holdout_gain,
                "holdout_margin": self.holdout_margin, "holdout_fraction": self.holdout_fraction,
                "interleaved_holdout": list(self.interleaved_holdout),
                "holdout_every": self.holdout_every(),
                "min_signature_correlation": self.min_signature_correlation,
                "adequate_factor": self.adequate_factor, "adequacy_level": self.adequacy_level}

    def split_time(self, start: float, end: float) -> float:
        """The time that ends the training part of a record from ``start`` to ``end`` [s]: the last
        ``holdout_fraction`` is held out."""
        return start + (1.0 - self.holdout_fraction) * (end - start)

    def holdout_every(self) -> int:
        """Every how many samples one is held out on an interleaved record (3 for 30 %)."""
        return max(2, round(1.0 / self.holdout_fraction))

    def passes_bic(self, delta_bic: float) -> bool:
        """Criterion 2: BIC falls by more than the threshold."""
        return bool(delta_bic < -self.bic_threshold)

    def passes_holdout(self, rmse_holdout: float, rmse_holdout_before: float) -> bool:
        """Criterion 3: the held-out RMSE falls by at least the gain."""
        return bool(rmse_holdout < (1.0 - self.holdout_gain) * rmse_holdout_before)

    def beats(self, rmse_holdout: float, rival_rmse_holdout: float) -> bool:
        """Criterion 4: a held-out RMSE better than a rival's by the margin."""
        return bool(rmse_holdout < (1.0 - self.holdout_margin) * rival_rmse_holdout)

    def promising(self, delta_bic: float) -> bool:
        """Worth a joint refit with the effects already added: BIC falls by half the threshold."""
        return bool(delta_bic < -self.bic_threshold / 2)


#: The rule the diagnosis uses.
RULE = Rule()


@dataclass(frozen=True)
class Score:
    """The errors of one model on the record: training RSS over n samples with k parameters, held-out RMSE."""

    rss_train: float
    n_train: int
    k: int
    rmse_holdout: float
    n_effective: float | None = None  #: effective independent samples (correlated noise), None: n_train

    @classmethod
    def from_residuals(cls, train, holdout, k: int, noise_correlation: float = 0.0) -> "Score":
        """Score from the residuals (measured - simulated) on the training and held-out parts; with the
        noise's lag-one correlation between the samples compared, BIC counts the effective samples."""
        train, holdout = np.asarray(train, dtype=float), np.asarray(holdout, dtype=float)
        n_eff = effective_samples(train.size, noise_correlation) if noise_correlation > 0 else None
        return cls(float(train @ train), int(train.size), int(k), float(np.sqrt(np.mean(holdout * holdout))),
                   n_eff)

    @property
    def bic(self) -> float:
        return bic(self.rss_train, self.n_train, self.k, self.n_effective)

    @property
    def rmse_train(self) -> float:
        return math.sqrt(self.rss_train / self.n_train)


@dataclass(frozen=True)
class Candidate:
    """One candidate's outcome in a round: its score with the effect added (None: could not be simulated)."""

    effect: str
    score: Score | None
    switched_off: bool = False  #: the fit preferred the effect off (value 0)
    at_bound: bool = False  #: the fitted value sits on a bound of its search range
    #: dBIC the same candidate gains when refitted on the current model's simulation plus the estimated noise
    #: (the null test); None: not tested
    null_delta_bic: float | None = None
    #: correlation of the candidate's own force term with the force the model lacks; None: not computed
    signature: float | None = None

    @property
    def physical(self) -> bool:
        return self.score is not None and not self.switched_off and not self.at_bound


@dataclass(frozen=True)
class Judgement:
    """How one candidate fares against the current model (criteria 1-3 of the rule, each alone)."""

    effect: str
    delta_bic: float | None
    passes_bic: bool
    passes_holdout: bool
    physical: bool
    beats_noise: bool = True  #: criterion 5 (True when not tested)
    signature_agrees: bool = True  #: criterion 6 (True when not computed)

    @property
    def eligible(self) -> bool:
        return (self.physical and self.passes_bic and self.passes_holdout and self.beats_noise
                and self.signature_agrees)


def judge(current: Score, candidate: Candidate, rule: Rule = RULE) -> Judgement:
    """Criteria 1-3, 5 and 6 for one candidate against the current model (4 compares candidates: :func:`decide`)."""
    score = candidate.score
    if score is None:
        return Judgement(candidate.effect, None, False, False, False)
    delta = score.bic - current.bic
    null = candidate.null_delta_bic
    beats_noise = null is None or rule.passes_bic(delta - min(null, 0.0))
    agrees = candidate.signature is None or candidate.signature >= rule.min_signature_correlation
    return Judgement(candidate.effect, delta, rule.passes_bic(delta),
                     rule.passes_holdout(score.rmse_holdout, current.rmse_holdout), candidate.physical,
                     beats_noise, agrees)


@dataclass(frozen=True)
class Decision:
    """The rule's verdict on one round: ``"add"`` one effect, ``"undecided"`` between the best and its
    rivals, or ``"stop"`` (nothing passes); with the reason in words and every candidate's judgement."""

    verdict: str
    effect: str | None = None
    rivals: tuple[str, ...] = ()
    reason: str = ""
    judgements: dict = field(default_factory=dict)
    together: tuple[str, ...] = ()  #: rivals added with the effect (a tie both of whose sides are needed)


def decide(current: Score, candidates: list[Candidate], rule: Rule = RULE) -> Decision:
    """Apply the rule (module docstring) to one round of candidates fitted against ``current``."""
    judgements = {c.effect: judge(current, c, rule) for c in candidates}
    by_effect = {c.effect: c for c in candidates}
    eligible = [c for c in candidates if judgements[c.effect].eligible]
    if not eligible:
        return Decision("stop", reason=_stop_reason(candidates, judgements, rule), judgements=judgements)
    best = min(eligible, key=lambda c: c.score.bic)
    rivals = tuple(c.effect for c in candidates if c is not best and c.physical and judgements[c.effect].beats_noise
                   and judgements[c.effect].signature_agrees
                   and not rule.beats(best.score.rmse_holdout, c.score.rmse_holdout))
    if rivals:
        names = ", ".join(rivals)
        return Decision("undecided", best.effect, rivals,
                        f"{best.effect} does not beat {names} on the held-out part by "
                        f"{rule.holdout_margin:.0%} (held-out RMSE {best.score.rmse_holdout:.4g} vs "
                        + ", ".join(f"{by_effect[r].score.rmse_holdout:.4g}" for r in rivals) + ")",
                        judgements)
    return Decision("add", best.effect, reason=f"{best.effect} passes every criterion", judgements=judgements)


def _stop_reason(candidates: list[Candidate], judgements: dict, rule: Rule) -> str:
    fitted = [c for c in candidates if c.score is not None]
    if not fitted:
        return "no candidate could be simulated on this record"
    best = min(fitted, key=lambda c: c.score.bic)
    j = judgements[best.effect]
    parts = []
    if best.switched_off:
        parts.append(f"the best candidate ({best.effect}) fits best switched off")
    elif best.at_bound:
        parts.append(f"the best candidate ({best.effect}) is pinned on a bound of its search range (not a "
                     f"physical explanation: something else is missing)")
    if not j.passes_bic:
        parts.append(f"{'it' if parts else 'the best candidate (' + best.effect + ')'} changes BIC by only "
                     f"{j.delta_bic:+.1f} (needs < {-rule.bic_threshold:g})")
    if not j.passes_holdout:
        parts.append(f"{'it' if parts else 'the best candidate (' + best.effect + ')'} does not lower the "
                     f"held-out RMSE by {rule.holdout_gain:.0%}")
    if not j.beats_noise:
        parts.append(f"{'it' if parts else 'the best candidate (' + best.effect + ')'} gains no more than it "
                     f"gains on the model's own simulation plus the estimated noise (dBIC {j.delta_bic:+.1f} "
                     f"against {best.null_delta_bic:+.1f} on noise alone)")
    if not j.signature_agrees:
        parts.append(f"{'its' if parts else 'the best candidate (' + best.effect + ')' + chr(39) + 's'} own force "
                     f"term does not go with the force the model lacks (r = {best.signature:+.2f})")
    if not parts:  # the best BIC is fine but not physical/eligible elsewhere
        parts.append("no candidate passes every criterion")
    return "; ".join(parts)


def forward_selection(current: Score, remaining: Callable[[], list[str]],
                      fit_round: Callable[[list[str]], list[Candidate]],
                      add: Callable[[Decision], Score], rule: Rule = RULE,
                      null_test: Callable[[Candidate], Candidate] | None = None,
                      break_tie: Callable[[Decision], Decision] | None = None,
                      with_requirements: Callable[[Decision], Decision] | None = None) -> Decision:
    r"""Forward stepwise selection with the rule, shared by the diagnosis and the calibration.

    Each round fits every candidate not yet in the model (``remaining()``, asked each round: an effect
    dropped again is a candidate again) against the current model (``fit_round(names)`` -> outcomes)
    and :func:`decide`\ s. Before the winner is taken, ``null_test`` (if given) adds what the same
    candidate gains on noise alone (:attr:`Candidate.null_delta_bic`) and the round is decided again, so
    that criterion 5 can refuse it and the next best be judged in turn. A tie goes to ``break_tie`` (which
    returns an ``"add"`` with :attr:`Decision.together`, or the tie). A round that still ends in a
    tie or a stop goes to ``with_requirements`` (if given): an effect that requires another (the
    registry's ``requires``) is never a candidate before its prerequisite is on, so the prerequisite
    is tried together with what requires it (:func:`extension_needed`); it returns an ``"add"`` with
    :attr:`Decision.together`, or the decision unchanged. ``add(decision)`` adopts the effect(s)
    and returns the new current score. Returns the decision that ended the selection (``"stop"`` or
    ``"undecided"``; a ``"stop"`` without judgements when no candidate is left).
    """
    now = [current]  # the current model's score, replaced at each addition

    def judge_round(round_outcomes: list[Candidate]) -> tuple[bool, Decision]:
        outcomes = {c.effect: c for c in round_outcomes}
        decision = decide(now[0], list(outcomes.values()), rule)
        tested: set = set()
        while null_test is not None and decision.verdict != "stop" and decision.effect not in tested:
            tested.add(decision.effect)
            outcomes[decision.effect] = null_test(outcomes[decision.effect])
            decision = decide(now[0], list(outcomes.values()), rule)
        if decision.verdict == "undecided" and break_tie is not None:
            decision = break_tie(decision)
        if decision.verdict != "add" and decision.judgements and with_requirements is not None:
            decision = with_requirements(decision)
        return decision.verdict == "add", decision

    def adopt(decision: Decision) -> None:
        now[0] = add(decision)

    return forward_stepwise(remaining, fit_round, judge_round, adopt,
                            Decision("stop", reason="no candidate effect left for this experiment"))


def pair_needed(singles: list[Score], both: Score, rule: Rule = RULE) -> bool:
    """Two tied candidates are both added when, fitted together, they pass BIC and the held-out gain
    against each of them alone (each is needed beside the other)."""
    return all(rule.passes_bic(both.bic - one.bic) and rule.passes_holdout(both.rmse_holdout, one.rmse_holdout)
               for one in singles)


def extension_needed(model: Score, extended: Score, rule: Rule = RULE) -> bool:
    """A model extended by one more effect (a rival added to a prerequisite and what requires it)
    keeps it when the extension passes criteria 2 and 3 against the model: BIC lower by more than
    the threshold and the held-out RMSE lower by the gain. (Nested models are never each other's
    rivals under criterion 4.)"""
    return rule.passes_bic(extended.bic - model.bic) and rule.passes_holdout(extended.rmse_holdout,
                                                                             model.rmse_holdout)


def to_drop(current: Score, without: dict, rule: Rule = RULE) -> str | None:
    """The earlier effect to drop after an acceptance, or None.

    ``without`` maps each earlier effect to the score of the model refitted without it. An effect whose
    removal raises BIC by less than the threshold no longer earns its place; of several, the cheapest
    to remove goes first (call again after refitting).
    """
    costs = {effect: score.bic - current.bic for effect, score in without.items() if score is not None}
    cheap = {e: cost for e, cost in costs.items() if cost < rule.bic_threshold}
    return min(cheap, key=cheap.get) if cheap else None


def at_bound(value: float, bounds: tuple[float, float], tolerance: float = 1e-3) -> bool:
    """Whether a fitted value (> 0) lies on a bound of its (log-space) search range, within a relative
    ``tolerance`` of it."""
    low, high = bounds
    return bool(value > 0 and (value <= low * (1 + tolerance) or value >= high * (1 - tolerance)))


#: The early stop of :func:`best_value` needs the cost this many times above the best so far: a light damper can
#: first raise the cost by a few per cent (it shifts the phase of an oscillation it barely calms) before the
#: right value lowers it by orders of magnitude (seen: +6 % at c = 1 N s/m, the minimum at 30).
EARLY_STOP_RISE = 1.25


def best_value(cost: Callable[[float], float], bounds: tuple[float, float], cost_off: float,
               points_per_decade: float = 1.0, xatol: float = 1e-3, early_stop: bool = True) -> tuple[float, float]:
    """Minimise a one-parameter cost between bounds in log space, with "switched off" as an option.

    A grid of ``points_per_decade`` points per decade (bounds included), then bounded Brent between the
    neighbours of the best grid point. ``cost_off`` is the cost with the effect switched off (value 0):
    when no value does better, the result is 0. Infinite costs (failed simulations) are allowed.
    ``early_stop``: the grid is walked upwards and left once two points in a row rise, both more than
    :data:`EARLY_STOP_RISE` times the best so far (the cost of one effect's parameter is taken as unimodal in
    log space but for small bumps); the large values it skips are the stiff, slow simulations (a damper of
    1e4 N s/m). Returns (value, its cost).
    """
    from scipy.optimize import minimize_scalar

    lo_log, hi_log = math.log10(bounds[0]), math.log10(bounds[1])
    count = max(2, int(round((hi_log - lo_log) * points_per_decade)) + 1)
    logs = np.linspace(lo_log, hi_log, count)
    costs = []
    for x in logs:  # upwards; stop once two points in a row rise clearly above the best (the cost is unimodal)
        costs.append(cost(10.0 ** x))
        if early_stop and len(costs) >= 3:
            best = min(costs[:-2])
            if math.isfinite(best) and costs[-2] > EARLY_STOP_RISE * best and costs[-1] > costs[-2]:
                break
    logs = logs[:len(costs)]
    costs = np.array(costs)
    finite = np.isfinite(costs)
    if not finite.any():
        return (0.0, cost_off) if math.isfinite(cost_off) else (math.nan, math.inf)
    penalty = 10.0 * float(np.max(np.abs(costs[finite]))) + 1.0  # Brent needs finite values
    i = int(np.argmin(np.where(finite, costs, np.inf)))
    lo, hi = logs[max(i - 1, 0)], logs[min(i + 1, logs.size - 1)]
    result = minimize_scalar(lambda x: min(cost(10.0 ** x), penalty), bounds=(lo, hi), method="bounded",
                             options={"xatol": xatol})
    best_cost, best_log = (float(result.fun), float(result.x)) if result.fun <= costs[i] else (float(costs[i]),
                                                                                            float(logs[i]))
    if not best_cost < cost_off:  # the effect switched off does at least as well
        return 0.0, cost_off
    return 10.0 ** best_log, best_cost


# --- Adequacy: does the final model leave only what the noise explains? -------------------------------

#: The record is cut into this many windows of equal length for the step-by-step test of :func:`adequacy`.
ADEQUACY_WINDOWS = 10


def noise_limit(n_effective: float, rule: Rule = RULE, tests: int = 1) -> float:
    """The largest ratio RMS(residual) / sigma that noise of standard deviation sigma explains over
    ``n_effective`` independent samples: ``max(adequate_factor, sqrt(chi2_(1 - level / tests)(m) / m))``.

    Under the noise alone, ``m RMS^2 / sigma^2`` follows a chi-square law with m degrees of freedom, so the
    quantile bounds the ratio at the rule's significance (Bonferroni over ``tests`` windows). It matters for
    few effective samples (coloured noise, short windows: m = 10 allows 1.7 at level 1e-3); for many, the
    rule's ``adequate_factor`` (2) stands instead, because sigma is itself an estimate whose systematic error
    (a signal's kinks, a smoothed input's residue) no chi-square knows of.
    """
    from scipy.special import gammaincinv  # chi2.ppf(q, m) = 2 gammaincinv(m / 2, q), without scipy.stats

    m = max(float(n_effective), 1.0)
    return max(rule.adequate_factor, math.sqrt(float(2.0 * gammaincinv(m / 2, 1.0 - rule.adequacy_level / tests)) / m))


@dataclass(frozen=True)
class Adequacy:
    """The final model's residual against the output noise, over the whole record and window by window."""

    adequate: bool
    ratio: float  #: RMS residual / sigma over the whole record
    limit: float  #: what noise explains there (:func:`noise_limit`)
    worst: dict  #: the window of largest ratio / limit: {"start", "stop" (sample indices), "ratio", "limit"}

    def text(self) -> str:
        where = self.worst
        if self.ratio > self.limit:
            return (f"the model leaves {self.ratio:.3g} times the output noise over the whole record, more than the "
                    f"{self.limit:.3g} noise explains")
        if where and where["ratio"] > where["limit"]:
            return (f"the model leaves {where['ratio']:.3g} times the output noise in one part of the record (more "
                    f"than the {where['limit']:.3g} noise explains there), {self.ratio:.3g} over the whole record")
        return f"the model leaves {self.ratio:.3g} times the output noise (noise explains up to {self.limit:.3g})"


def adequacy(residual, sigma: float, correlation: float = 0.0, rule: Rule = RULE,
             windows: int = ADEQUACY_WINDOWS) -> Adequacy:
    """Whether a residual (measured - model, every sample) is what the noise (sigma, AR(1) ``correlation``
    between neighbouring samples) explains: over the whole record and in each of ``windows`` equal parts
    (an error that sits in one part of a record, such as the steps before a quiet end, must not pass
    because the rest is quiet). sigma <= 0 (unknown noise): adequate, ratio 0."""
    r = np.asarray(residual, dtype=float)
    if not sigma > 0 or r.size == 0:
        return Adequacy(True, 0.0, math.inf, {})
    ratio = float(np.sqrt(np.mean(r * r)) / sigma)
    limit = noise_limit(effective_samples(r.size, correlation), rule)
    worst, adequate = {}, ratio <= limit
    for part in np.array_split(np.arange(r.size), min(windows, r.size)):
        part_ratio = float(np.sqrt(np.mean(r[part] ** 2)) / sigma)
        part_limit = noise_limit(effective_samples(part.size, correlation), rule, windows)
        if not worst or part_ratio / part_limit > worst["ratio"] / worst["limit"]:
            worst = {"start": int(part[0]), "stop": int(part[-1]), "ratio": part_ratio, "limit": part_limit}
    adequate = adequate and worst["ratio"] <= worst["limit"]
    return Adequacy(bool(adequate), ratio, limit, worst)
