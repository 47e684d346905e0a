"""The search: forward selection by the rule (:mod:`mkctl.analysis.diagnosis_rule`), its tie-breaking and
requirements, and the wider search in pairs and threes.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass
from typing import Callable

from ...errors import MkctlError
from ...io import diagnosis_report
from ...io.measurements import Measurement
from ...physics import effects
from ...physics.params import UNITS, Params
from ..compare import rmse
from ..diagnosis_rule import (RULE, Candidate as Outcome, Rule, Score, at_bound, decide,
                              extension_needed, forward_selection, judge, pair_needed, to_drop)
from .air import air_parameters
from .candidates import CANDIDATES, experiment_to_separate
from .noise import NoiseModel
from .problem import Fit, Problem, evaluate, fit_candidate, joint_fit, refitted, with_air_of
from .signatures import signatures


def _row(name: str, fit, value: float, evaluations: int, current: Fit, problem: Problem, sig, to_file: float,
         rule: Rule = RULE):
    """A candidate's line in the report, and its outcome for the rule (its flags are the rule's own judgement)."""
    cand = CANDIDATES[name]
    bounds = cand.bounds[problem.measurement.experiment]
    row = {"effect": name, "params": {cand.parameter: value}, "simulations": evaluations,
           "signature": None if sig is None else {k: sig[k] for k in ("against", "correlation", "estimate")}}
    if fit is None:
        row.update({"rmse": None, "bic": None, "delta_bic": None, "failed": True, "physical": False})
        return row, Outcome(name, None)
    switched_off = fit is current
    score = fit.score if not switched_off else dataclasses.replace(current.score, k=current.score.k + 1)
    pinned = at_bound(value, bounds) and not cand.switch
    outcome = Outcome(name, score, switched_off=switched_off, at_bound=pinned,
                      signature=None if sig is None else sig["correlation"])
    judgement = judge(current.score, outcome, rule)
    row.update({
        "params_with_added": dict(fit.values) if not switched_off else dict(current.values),
        "rmse": rmse(problem.measured, fit.simulated + fit.offset) * to_file,
        "rmse_train": score.rmse_train * to_file,
        "rmse_holdout": score.rmse_holdout * to_file,
        "bic": score.bic,
        "delta_bic": judgement.delta_bic,
        "explained_fraction": 1.0 - score.rss_train / current.rss_train if current.rss_train > 0 else 0.0,
        "switched_off": switched_off,
        "at_bound": pinned,
        "physical": judgement.physical,
        "passes_bic": judgement.passes_bic,
        "passes_holdout": judgement.passes_holdout,
        "signature_agrees": judgement.signature_agrees,
    })
    return row, outcome


#: When what was added leaves more than this many times the output noise, the candidates are tried in pairs and
#: threes.
WIDER_SEARCH_FACTOR = 3.0


def _inadequacy(problem: Problem, fit: Fit, out_sigma: float) -> float:
    """Training RMSE of a fit in units of the estimated output noise (0 when the noise is unknown)."""
    return fit.score.rmse_train / out_sigma if out_sigma > 0 else 0.0


@dataclass(frozen=True)
class Fitting:
    """The fits a search runs, as callables (:mod:`.problem`'s by default; a test passes its own table):
    ``joint(problem, base, effects, start, train_only, rough=False)`` -> (values, errors, result, params),
    ``evaluate(problem, params, values)`` -> :class:`Fit` or None."""

    joint: Callable = joint_fit
    evaluate: Callable = evaluate


class Search:
    """Forward selection with the rule, and the wider search in pairs and threes; collects the report's steps.

    Every attribute is set here or by the search's own methods: what a caller knows beforehand (the inputs
    re-noised for the null test, ties judged elsewhere, values fitted alone) comes in as an argument.
    """

    def __init__(self, problem: Problem, start: Params, pending: list, rule: Rule, to_file: float, say,
                 noise: NoiseModel | None = None, *, renoised: Measurement | None = None,
                 renoised_more: list = (), undecided: list = (), individual: dict | None = None,
                 current: Fit | None = None, fitting: Fitting = Fitting()):
        self.problem, self.start, self.pending_all, self.rule = problem, start, pending, rule
        self.to_file, self.say, self.noise = to_file, say, noise
        self.fitting = fitting
        self.fits: dict = {}
        self.context: dict = {}
        self.renoised = renoised  #: drives the null test's simulation (:func:`renoised_inputs`)
        #: other realisations of it (quasi-static records), each drawn too
        self.renoised_more: list = list(renoised_more)
        self.added: list[str] = []
        self.individual: dict = dict(individual or {})  #: each candidate's value fitted alone in round 1
        self.steps: list[dict] = []
        self.step_params: list = []
        #: ties the record cannot break (those judged on measured pressures first)
        self.undecided: list[dict] = list(undecided)
        self.stopped = None
        self.signatures_first = None
        self.current = current
        self.hints: dict = {}  #: each candidate's value its signature suggests, this round
        self.outcomes: dict = {}  #: this round's outcomes for the rule (null-tested ones included)

    def forward(self, current: Fit) -> None:
        """Forward selection from ``current`` (:func:`mkctl.analysis.diagnosis_rule.forward_selection`): each
        accepted round goes to ``steps``, the round that ended it to ``stopped`` (and a tie to ``undecided``)."""
        self.current = current
        decision = forward_selection(current.score, self._remaining, self._fit_round, self._add, self.rule,
                                     null_test=self._null_test if self.noise is not None else None,
                                     break_tie=self._break_tie,
                                     with_requirements=self._with_requirements)
        self._stop(decision)

    def _remaining(self) -> list[str]:
        """The candidates not added yet whose required effects are on (asymmetric_lag: once pressure_lag is)."""
        on = set(self.start.effects) | set(self.added)
        return [e for e in self.pending_all if e not in self.added and set(effects.get(e).requires) <= on]

    def _fit_round(self, pending: list[str]) -> list[Outcome]:
        """Fit every pending candidate against the current model; keeps the report's rows and the fits."""
        problem, current = self.problem, self.current
        self.say(f"round {len(self.steps) + 1}: fitting {', '.join(pending)}")
        sigs = self._signatures(pending)
        self.hints = {name: sig.get("estimate") for name, sig in sigs.items()}
        rows, outcomes, fits = [], [], {}
        for name in pending:
            fit, value, evaluations, _ = fit_candidate(problem, self.start, current, self.added, self.individual,
                                                        name, self.say, self.rule, self.hints.get(name))
            row, outcome = _row(name, fit, value, evaluations, current, problem, sigs.get(name), self.to_file,
                                self.rule)
            rows.append(row)
            outcomes.append(outcome)
            fits[name] = fit
        rows.sort(key=lambda r: math.inf if r["bic"] is None else r["bic"])
        self.fits = fits
        self.outcomes = {outcome.effect: outcome for outcome in outcomes}
        self.context = {"bic_before": current.score.bic,
                        "rmse_holdout_before": current.score.rmse_holdout * self.to_file, "candidates": rows,
                        "ties": []}
        return outcomes

    def _signatures(self, pending: list[str]) -> dict:
        """The round's signatures (the first round's are kept for the pictures); {} outside the model's domain."""
        problem, current = self.problem, self.current
        try:
            record = problem.measurement if not current.offset else dataclasses.replace(
                problem.measurement, output=problem.measurement.output - current.offset)
            sigs = signatures(record, current.params, pending)
        except MkctlError:  # the measured states lie outside the model's domain: no signatures
            sigs = {}
        if self.signatures_first is None:
            self.signatures_first = (list(pending), sigs)
        return sigs

    def _null_test(self, outcome: Outcome) -> Outcome:
        """The candidate refitted on the current model's own simulation plus the estimated output
        noise: the dBIC it gains there is what noise alone gives it (criterion 5 of the rule). The
        simulation is driven by the measured inputs re-noised (their noise passes through the model
        into the null record); a quasi-static record draws several realisations of both noises and
        the largest gain counts."""
        name, current = outcome.effect, self.current
        gains = []
        realisations = [(self.renoised, self.noise)] + [
            (renoised, dataclasses.replace(self.noise, seed=self.noise.seed + k))
            for k, renoised in enumerate(self.renoised_more, 1)]
        for renoised, noise in realisations:
            output = noise.null_output(self.problem, current, renoised)
            null_problem = dataclasses.replace(self.problem, measurement=dataclasses.replace(
                self.problem.measurement, output=output))
            null_current = self.fitting.evaluate(null_problem, current.params, current.values)
            if null_current is None:
                continue
            fit, _, _, _ = fit_candidate(null_problem, self.start, null_current, self.added, {},
                                          name, None, self.rule, self.hints.get(name))
            k_more = dataclasses.replace(null_current.score, k=null_current.score.k + 1)
            null_score = fit.score if fit is not None and fit is not null_current else k_more
            gains.append(null_score.bic - null_current.score.bic)
        if not gains:
            return outcome
        tested = dataclasses.replace(outcome, null_delta_bic=min(gains))
        self.outcomes[name] = tested
        judgement = judge(current.score, tested, self.rule)
        row = next(r for r in self.context["candidates"] if r["effect"] == name)
        row.update({"null_delta_bic": tested.null_delta_bic, "beats_noise": judgement.beats_noise})
        self.say(f"  null test of {name}: dBIC {tested.null_delta_bic:+.1f} on the model's simulation plus noise")
        return tested

    def _break_tie(self, decision):
        """A tie: the best and each rival fitted together; an ``add`` of both when each is needed."""
        self.context["ties"] = [{"effects": [decision.effect, r], "experiment": experiment_to_separate(
            [decision.effect, r])} for r in decision.rivals]
        pair = _try_pairs(self.problem, self.start, self.added, decision, self.fits, self.say, self.rule,
                          self.fitting)
        if pair is None:
            return decision
        rival, fit = pair
        self.fits[decision.effect] = fit
        return dataclasses.replace(decision, verdict="add", together=(rival,))

    def _joint_with_added(self, names: list, start: dict) -> tuple[Fit | None, bool]:
        """``names`` fitted jointly with the effects already added (training part, full tolerance),
        from the current values and ``start``: (the fit or None, whether a parameter of ``names``
        sits on a bound)."""
        values, _, _, params = self.fitting.joint(self.problem, self.start, [*self.added, *names],
                                          {**self.current.values, **start}, train_only=True)
        fit = self.fitting.evaluate(self.problem, params, values)
        return fit, _pinned(values, names, self.problem.measurement.experiment)

    def _with_requirements(self, decision):
        """A round that ends in a tie or a stop: an effect that requires another (the registry's
        ``requires``) is no candidate until its prerequisite is on, so a prerequisite that is tied
        (or, in a stop, any fitted candidate) is fitted together with each effect that requires it,
        and the combination is judged by the same rule against the current model and the round's
        candidates (:func:`decide`: physical, BIC, held-out gain, held-out margin over every rival);
        the winner is then fitted with each of the prerequisite's rivals in turn, kept when the
        rival passes BIC and the held-out gain beside it
        (:func:`mkctl.analysis.diagnosis_rule.extension_needed`). Returns an ``add`` of the
        prerequisite with the others ``together``, or the decision unchanged."""
        on = set(self.start.effects) | set(self.added)
        undecided = decision.verdict == "undecided"
        tied = [decision.effect, *decision.rivals] if undecided else list(self.fits)
        compounds, rows = {}, []
        for prerequisite in tied:
            fit = self.fits.get(prerequisite)
            if fit is None or fit is self.current:
                continue
            for dependent in dependents(self.pending_all, on, prerequisite):
                names = [prerequisite, dependent]
                start = {CANDIDATES[dependent].parameter: dependent_start(dependent, fit.values)}
                together, pinned = self._joint_with_added(names, {**fit.values, **start})
                if together is None:
                    continue
                key = " + ".join(names)
                compounds[key] = (names, together, pinned)
                own = [CANDIDATES[e].parameter for e in names]
                rows.append({"effects": names, "params": {p: together.values[p] for p in own},
                             "delta_bic": together.score.bic - self.current.score.bic,
                             "rmse_train": together.score.rmse_train * self.to_file,
                             "rmse_holdout": together.score.rmse_holdout * self.to_file,
                             "at_bound": pinned})
                self.say(f"  {key} together: dBIC {rows[-1]['delta_bic']:+.1f}, held-out "
                         f"{rows[-1]['rmse_holdout']:.4g}"
                         + (" (a parameter on its bound)" if pinned else ""))
        if not compounds:
            return decision
        self.context["with_requirements"] = rows
        outcomes = [*self.outcomes.values(), *(Outcome(key, fit.score, at_bound=pinned)
                                               for key, (_, fit, pinned) in compounds.items())]
        second = decide(self.current.score, outcomes, self.rule)
        if second.verdict != "add" or second.effect not in compounds:
            self.say(f"  with what requires it: {second.reason}")
            return decision
        names, fit, _ = compounds[second.effect]
        for rival in (r for r in tied if r not in names and undecided):
            alone = self.fits.get(rival)
            if alone is None or alone is self.current:
                continue
            parameter = CANDIDATES[rival].parameter
            start = {**fit.values, parameter: alone.values[parameter]}
            more, pinned = self._joint_with_added([*names, rival], start)
            if more is not None and not pinned and extension_needed(fit.score, more.score,
                                                                    self.rule):
                names, fit = [*names, rival], more
        for row in rows:
            row["accepted"] = row["effects"] == names[:2]
        self.fits[names[0]] = fit
        self.say(f"  {' and '.join(names)} are added together")
        return dataclasses.replace(second, verdict="add", effect=names[0], rivals=(),
                                   together=tuple(names[1:]),
                                   reason=f"{' + '.join(names)} together pass every criterion")

    def _add(self, decision) -> Score:
        """Adopt the decision's effect(s), drop what no longer earns its place, refit, record the round."""
        name, together = decision.effect, list(decision.together)
        self.added.extend([name, *together])
        self.current = self.fits[name]
        self._refit_air_with(self.current.params)
        dropped = self._drop(len(together) + 1)
        self.current = self._refit(self.current)
        self._record({"added": name, "added_with": together, "dropped": dropped, **self.context})
        return self.current.score

    def _refit_air_with(self, params: Params) -> None:
        """On a pressure record, the air's parameters of what was added (a valve's critical ratio,
        its subsonic index, its regulator's band) join those refitted with every later candidate
        (:attr:`Problem.refit`): held at their typical values, they leave a shape another candidate
        would be credited with (measured: a heat found on a set-point fill that has none)."""
        m = self.problem.measurement
        if m.experiment != "pressure":
            return
        # (not a candidate's own parameter: the joint fits carry those with their effects, and
        # a refitted switch would keep an effect on that the drop step has taken out)
        own = {CANDIDATES[e].parameter for e in self.pending_all}
        more = tuple(q for q in air_parameters(params, m.overrides)
                     if q not in refitted(self.problem) and q.name not in own)
        if more:
            self.problem = dataclasses.replace(self.problem, refit=(*refitted(self.problem), *more))

    def _stop(self, decision) -> None:
        """Record why the selection ended: nothing left, nothing passing, or a tie the record cannot break."""
        if not decision.judgements:
            self.stopped = {"reason": decision.reason, "candidates": [], "ties": []}
            return
        if decision.verdict == "undecided":
            effects = [decision.effect, *decision.rivals]
            text = f"this record cannot tell {' from '.join(e.replace('_', ' ') for e in effects)}: {decision.reason}"
            self.undecided.append({"effects": effects, "experiment": experiment_to_separate(effects), "text": text})
            self.stopped = {"reason": text, **self.context}
            self.say(f"  undecided: {text}")
            return
        self.stopped = {"reason": decision.reason, **self.context}
        self.say(f"  stop: {decision.reason}")

    def _refit(self, fit: Fit) -> Fit:
        """The added effects refitted jointly (full tolerance), so that the next round starts from their
        best values and no later candidate is credited with what a better refit of these would give."""
        start = with_air_of(self.start, fit.params, self.problem)
        # with the air's values beside them (a pressure record) at the candidates' tolerance: the
        # final fits refine them all, and at full tolerance this refit cost half the diagnosis
        rough = {"rough": True} if refitted(self.problem) else {}
        values, _, _, params = self.fitting.joint(self.problem, start, self.added, fit.values,
                                                  train_only=True, **rough)
        refit = self.fitting.evaluate(self.problem, params, values)
        return refit if refit is not None and refit.rss_train < fit.rss_train else fit

    def _drop(self, newest: int) -> list:
        """Drop earlier effects that no longer earn their place (the rule's drop step)."""
        dropped = []
        while len(self.added) > newest:
            without = {}
            for earlier in self.added[:-newest]:
                rest = [e for e in self.added if e != earlier]
                if any(earlier in effects.get(e).requires for e in rest):  # the lag under an asymmetric lag
                    continue
                rest_values = {CANDIDATES[e].parameter: self.current.values[CANDIDATES[e].parameter] for e in rest}
                start = with_air_of(self.start, self.current.params, self.problem)
                rough = {"rough": True} if refitted(self.problem) else {}  # as in _refit
                values, _, _, params = self.fitting.joint(self.problem, start, rest, rest_values,
                                                          train_only=True, **rough)
                without[earlier] = self.fitting.evaluate(self.problem, params, values)
            gone = to_drop(self.current.score, {e: f.score if f else None for e, f in without.items()}, self.rule)
            if gone is None:
                break
            dropped.append(gone)
            self.added.remove(gone)
            self.current = without[gone]
        return dropped

    def _record(self, step: dict) -> None:
        current = self.current
        step.update({"rmse": None, "params": dict(current.values),
                     "rmse_holdout": current.score.rmse_holdout * self.to_file})
        self.steps.append(step)
        self.step_params.append((current.params, current.offset))
        added = [step["added"], *step.get("added_with", [])]
        self.say(f"  added {' and '.join(added)}" + (f", dropped {', '.join(step['dropped'])}" if step["dropped"]
                                                    else "") + ": "
                 + ", ".join(diagnosis_report.parameter_text(k, v) for k, v in current.values.items()))

    def wider(self) -> bool:
        """Fit every pair, then every three, of candidates jointly (from their round-1 values) and judge the best
        (by BIC, not on a bound) against the forward model by the rule; adopt it (replacing what forward
        selection added) when it passes. Three effects at once leave every pair short, and forward selection
        then stops on a tie it cannot break."""
        before = self.current
        best, tried = self._combinations()
        if best is None:
            return False
        combo, fit = _without_spare_effects(best, tried, self.rule)
        # two combinations that explain the record equally well are a finding, not an answer: another that is
        # neither part of the best nor contains it must be beaten on the held-out part by the margin
        rivals = [other for other, other_fit in tried
                  if not (set(other) <= set(combo) or set(combo) <= set(other))
                  and not self.rule.beats(fit.score.rmse_holdout, other_fit.score.rmse_holdout)]
        if rivals:
            self.say(f"  the best combination ({' + '.join(combo)}) does not beat "
                     f"{'; '.join(' + '.join(r) for r in rivals)} on the held-out part by "
                     f"{self.rule.holdout_margin:.0%}")
            return False
        decision = decide(before.score, [Outcome("+".join(combo), fit.score)], self.rule)
        if decision.verdict != "add" or not fit.score.rss_train < before.score.rss_train:
            self.say(f"  the best combination ({' + '.join(combo)}) does not pass the rule against "
                     f"{', '.join(self.added) or 'the baseline'}")
            return False
        replaced = list(self.added)
        self.added = list(combo)
        self._refit_air_with(fit.params)
        self.current = self._refit(fit)
        self.undecided, self.stopped = [], None  # the combination settles what forward selection could not
        self._record({"added": combo[0], "added_with": list(combo[1:]),
                      "dropped": [e for e in replaced if e not in combo], "replaced": replaced,
                      "bic_before": before.score.bic,
                      "rmse_holdout_before": before.score.rmse_holdout * self.to_file,
                      "candidates": [], "ties": [], "wider_search": True})
        return True

    def _combination(self, combo, start) -> tuple[Fit | None, bool]:
        """One combination fitted jointly (training part, rough) from ``start``: (fit or None, on a bound)."""
        values, _, _, params = self.fitting.joint(self.problem, self.start, list(combo), start,
                                                  train_only=True, rough=True)
        fit = self.fitting.evaluate(self.problem, params, values)
        if fit is None:
            return None, False
        pinned = _pinned(values, combo, self.problem.measurement.experiment)
        self.say(f"  {' + '.join(combo)}: training RMSE {fit.score.rmse_train * self.to_file:.4g}, "
                 f"held-out {fit.score.rmse_holdout * self.to_file:.4g}" + (" (on a bound)" if pinned else ""))
        return fit, pinned

    def _combinations(self) -> tuple[tuple | None, list]:
        """Every pair and three of the candidates that fitted alone in round 1, and on top of each the effects
        that require one of them: (the best by BIC not on a bound as (combo, fit), or None; every such
        (combo, fit))."""
        names = [e for e in self.pending_all if self.individual.get(e, 0.0) > 0]
        best, tried = None, []
        base = set(self.start.effects)

        def consider(combo, start):
            nonlocal best
            fit, pinned = self._combination(combo, start)
            if fit is not None and not pinned:
                tried.append((combo, fit))
                if best is None or fit.score.bic < best[1].score.bic:
                    best = (combo, fit)
            return fit

        for size in (2, 3):
            for combo in itertools.combinations(names, size):
                start = {CANDIDATES[e].parameter: self.individual[e] for e in combo}
                fit = consider(combo, start) if set(combo) != set(self.added) else self.current
                # an effect that requires one of these (the registry's requires) is tried on top of
                # them, from their fitted values: it was never a candidate of round 1, so it has no
                # value of its own there
                for prerequisite in combo:
                    for dependent in dependents(self.pending_all, base | set(combo), prerequisite):
                        if fit is None or set((*combo, dependent)) == set(self.added):
                            continue
                        values = dict(fit.values)
                        consider((*combo, dependent), {**values, CANDIDATES[dependent].parameter:
                                                       dependent_start(dependent, values)})
        return best, tried


def _without_spare_effects(best: tuple, tried: list, rule: Rule) -> tuple:
    """The best combination less each effect whose removal costs less than the rule's BIC threshold (the
    rule's drop step), as long as the smaller combination was tried: a spurious fourth effect (a friction
    beside damping, a lag and its exhausting time constant) cannot then make the best combination one that a
    rival of equal error ties."""
    tried_sets = {frozenset(c): (c, f) for c, f in tried}
    smaller = True
    while smaller:
        smaller = False
        for effect in best[0]:
            without = tried_sets.get(frozenset(best[0]) - {effect})
            if without is not None and not rule.passes_bic(best[1].score.bic - without[1].score.bic):
                best, smaller = without, True
                break
    return best


def dependents(pending: list, on: set, prerequisite: str) -> list[str]:
    """The candidates of ``pending`` that require ``prerequisite`` (the registry's ``requires``) and
    become possible once it is on beside the effects ``on``."""
    return [e for e in pending if e not in on and prerequisite in effects.get(e).requires
            and set(effects.get(e).requires) <= on | {prerequisite}]


def dependent_start(name: str, values: dict) -> float:
    """Where a dependent effect's parameter starts a joint fit: at its prerequisite's fitted value
    when that has the same unit (an exhausting time constant at the lag's tau: the symmetric lag),
    else at the parameter's typical value (the registry's), else the middle of its search range in
    log space."""
    effect, parameter = effects.get(name), CANDIDATES[name].parameter
    for required in effect.requires:
        other = CANDIDATES[required].parameter if required in CANDIDATES else None
        same_unit = other is not None and UNITS.get(other) == UNITS.get(parameter)
        if same_unit and values.get(other, 0.0) > 0:
            return float(values[other])
    return CANDIDATES[name].typical_start()


def _pinned(values: dict, effects, experiment: str) -> bool:
    """Whether a joint fit left a parameter of ``effects`` on a bound of its search range (switches excepted)."""
    return any(at_bound(values[CANDIDATES[e].parameter], CANDIDATES[e].bounds[experiment]) and not CANDIDATES[e].switch
               for e in effects)


def _try_pairs(problem: Problem, baseline: Params, added: list, decision, fits: dict, say, rule: Rule = RULE,
               fitting: Fitting = Fitting()):
    """Fit the best candidate together with each rival; (rival, fit) of the first pair that needs both."""
    best = decision.effect
    for rival in decision.rivals:
        if fits.get(best) is None or fits.get(rival) is None:
            continue
        effects = [*added, best, rival]
        start = {**fits[best].values, **fits[rival].values}
        if any(start.get(CANDIDATES[e].parameter, 0.0) <= 0 for e in effects):
            continue
        values, _, _, params = fitting.joint(problem, baseline, effects, start, train_only=True)
        both = fitting.evaluate(problem, params, values)
        if both is None:
            continue
        pinned = _pinned(values, effects, problem.measurement.experiment)
        say(f"  {best} and {rival} together: dBIC {both.score.bic - fits[best].score.bic:+.1f} against {best} "
            f"alone" + (" (a parameter on its bound)" if pinned else ""))
        if not pinned and pair_needed([fits[best].score, fits[rival].score], both.score, rule):
            return rival, both
    return None

