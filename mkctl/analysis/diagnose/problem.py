"""The fit problem: the samples compared, the split of the rule, evaluation, one candidate's fit and the
joint fit of several.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ...errors import MkctlError
from ...io import diagnosis_report
from ...io.measurements import Measurement
from ...physics import effects
from ...physics.params import Params
from ..compare import simulate_output
from ..statistics import covariance, effective_samples, every_kth, lag_one_correlation
from ..diagnosis_rule import RULE, Rule, Score, best_value
from .air import from_search, search_bounds, searchable, to_search
from .candidates import CANDIDATES, Candidate
from .noise import QUASI_STATIC, NoiseModel


# The rule's thresholds (the held-out share, the BIC and held-out gains, the margin) are the fields of
# :class:`mkctl.analysis.diagnosis_rule.Rule`, passed down from :func:`diagnose`: no copies here.
#: About how many samples the knee's fits are evaluated on ...
FIT_POINTS = 200

#: ... but never further apart than this [s]: the knee's transients last a few tenths of a second (its
#: natural period is 0.58 s at the default posture), and a long record thinned to 200 samples would skip them.
MAX_FIT_SPACING = 0.02

#: Tolerance of the one-parameter search, in decades (0.01: 2.3 %; the joint fits refine it).
FIT_XATOL = 0.01

_LN10 = math.log(10.0)

_FAILED = object()


@dataclass(frozen=True)
class Problem:
    """The record as the fits see it: (smoothed, blocked) inputs, the samples compared, the split, and
    whether a constant sensor offset is profiled out of every residual."""

    measurement: Measurement  #: with the inputs the fits use
    grid: np.ndarray  #: sample indices fits are evaluated on
    train: np.ndarray  #: bool over grid: in the training part
    n_train: int  #: samples (of the record) the training simulations run over
    fit_offset: bool = False
    noise_correlation: float = 0.0  #: the output noise's correlation between neighbouring grid samples
    #: the air's parameters (:class:`mkctl.physics.effect.Parameter`) the record moves, refitted
    #: with every candidate (as the calibration refits the statics): a valve calibrated without a
    #: dead time has absorbed it, and a dead time fitted with the valve held finds a third of it
    refit: tuple = ()

    @property
    def measured(self) -> np.ndarray:
        return self.measurement.output[self.grid]

    @property
    def extra_parameters(self) -> int:
        return 1 if self.fit_offset else 0

    def simulate(self, params: Params, train_only: bool = False):
        """Model output [SI] on the grid (the training grid only if train_only), or _FAILED."""
        try:
            if train_only:
                return simulate_output(self.measurement, params, self.grid[self.train], stop=self.n_train)
            return simulate_output(self.measurement, params, self.grid)
        except MkctlError:
            return _FAILED

    def offset(self, residual_train) -> float:
        """The constant sensor offset that the training residual calls for (0 unless fit_offset)."""
        return float(np.mean(residual_train)) if self.fit_offset else 0.0

    def train_residual(self, simulated_train) -> np.ndarray:
        r = self.measured[self.train] - simulated_train
        return r - self.offset(r)

    def score(self, simulated, k: int) -> tuple[Score, float]:
        """The score of a simulation over the whole grid (k effect parameters), and the offset used."""
        r = self.measured - simulated
        offset = self.offset(r[self.train])
        r = r - offset
        return (Score.from_residuals(r[self.train], r[~self.train], k + self.extra_parameters, self.noise_correlation),
                offset)


def knee_stride(time) -> int:
    """Every how many samples the knee's fits compare: about :data:`FIT_POINTS` samples over the record, at most
    :data:`MAX_FIT_SPACING` apart (a 60 s record at 1 kHz: every 20th sample, 3000 in all)."""
    n = len(time)
    interval = float(np.median(np.diff(time))) if n > 1 else 0.0
    widest = max(1, int(MAX_FIT_SPACING / interval)) if interval > 0 else n
    return max(1, min(n // FIT_POINTS, widest))


def fit_problem(measurement: Measurement, fit_offset: bool, rule: Rule = RULE, noise: NoiseModel | None = None) -> Problem:
    """The fitting problem: the grid compared, the time split of the rule, the noise's correlation on the grid."""
    n = measurement.samples
    stride = 1 if measurement.experiment in QUASI_STATIC else knee_stride(measurement.time)
    grid = np.arange(0, n, stride)
    if grid[-1] != n - 1:
        grid = np.append(grid, n - 1)
    t = measurement.time
    if measurement.experiment in rule.interleaved_holdout:
        # every k-th sample held out, the whole record simulated (docs/diagnosis.md, "Split")
        n_train = n
        train = ~every_kth(grid.size, rule.holdout_every())
    else:
        split = rule.split_time(t[0], t[-1])
        n_train = int(np.searchsorted(t, split, side="right"))
        train = grid < n_train
    if train.sum() < 5 or (~train).sum() < 3:
        raise MkctlError(f"{measurement.source}: too few samples to diagnose ({n}); need at least 20")
    correlation = noise.on_grid(stride) if noise is not None else 0.0
    return Problem(measurement, grid, train, n_train, fit_offset, correlation)


@dataclass(frozen=True)
class Fit:
    """A model on the problem: its parameters, score and simulation (SI, on the grid)."""

    params: Params
    values: dict  #: fitted parameter values by name
    score: Score
    offset: float  #: the fitted sensor offset [SI] (0 unless fit_offset)
    simulated: np.ndarray  #: grid output [SI]

    @property
    def rss_train(self) -> float:
        return self.score.rss_train


def evaluate(problem: Problem, params: Params, values: dict):
    """Simulate params over the whole record on the grid and score it, or None if it fails."""
    simulated = problem.simulate(params)
    if simulated is _FAILED:
        return None
    score, offset = problem.score(simulated, len(values))
    return Fit(params, dict(values), score, offset, simulated)


def fit_one(problem: Problem, base: Params, candidate: Candidate, rss_off: float, progress,
             hint: float | None = None) -> tuple[float, int]:
    """Best value of the candidate's parameter on the training part, 0 when off does as well.

    ``hint``: the value its signature's slope suggests (:func:`signatures`). The grid of one point per decade
    assumes a cost unimodal in log space; a threshold pressure's is not on the knee (a small P0 weakens the
    flexor at 100 kPa most, a large one the extensor: the hip first rises, then falls through the truth, in a
    valley narrower than a decade). When the hint does better than the grid's best, the search is repeated
    within a quarter decade of it.
    """
    evaluations = [0]

    def cost(value):
        evaluations[0] += 1
        simulated = problem.simulate(candidate.apply(base, value), train_only=True)
        if simulated is _FAILED:
            return math.inf
        r = problem.train_residual(simulated)
        return float(r @ r)

    bounds = candidate.bounds[problem.measurement.experiment]
    value, best = best_value(cost, bounds, rss_off, xatol=FIT_XATOL)
    if hint is not None and math.isfinite(hint) and bounds[0] < hint < bounds[1] and not candidate.switch \
            and abs(math.log10(hint) - math.log10(value if value > 0 else bounds[0])) > 0.25:
        near = (max(bounds[0], hint / 10 ** 0.25), min(bounds[1], hint * 10 ** 0.25))
        if cost(hint) < best:
            around, cost_around = best_value(cost, near, rss_off, points_per_decade=4.0, xatol=FIT_XATOL,
                                             early_stop=False)
            if around > 0 and cost_around < best:
                value = around
    if progress:
        progress(f"    {candidate.effect}: {diagnosis_report.parameter_text(candidate.parameter, value)} "
                 f"({evaluations[0]} simulations)")
    return value, evaluations[0]


def joint_fit(problem: Problem, base: Params, effects: list[str], start: dict, train_only: bool,
               rough: bool = False):
    """Refit the parameters of ``effects`` jointly by least squares in log space.

    ``rough``: looser tolerances and fewer evaluations, for ranking candidates.
    Returns (values, standard errors (dict), the least_squares result, the fitted Params)."""
    experiment = problem.measurement.experiment
    cands = [CANDIDATES[e] for e in effects]
    own = {c.parameter for c in cands}
    # the air's values the record identifies, refitted beside them (their starts: base's)
    # (not one at 0 in base: the switch of an effect off there, a dropped one's)
    air = [q for q in refitted(problem)
           if q.name not in own and searchable(q, getattr(base, q.name))]
    air_start = [getattr(base, q.name) for q in air]
    air_bounds = [search_bounds(q, v) for q, v in zip(air, air_start)]
    lows = np.concatenate([np.log10([c.bounds[experiment][0] for c in cands]),
                           [b[0] for b in air_bounds]])
    highs = np.concatenate([np.log10([c.bounds[experiment][1] for c in cands]),
                            [b[1] for b in air_bounds]])
    x0 = np.clip(np.concatenate([np.log10([max(start[c.parameter], 1e-300) for c in cands]),
                                 [to_search(q, v) for q, v in zip(air, air_start)]]),
                 lows + 1e-9, highs - 1e-9)
    size = int(problem.train.sum()) if train_only else problem.grid.size

    def params_at(x):
        params = base
        for c, value in zip(cands, x):
            params = c.apply(params, 10.0 ** value)
        if air:
            params = params.replace(**{q.name: from_search(q, v)
                                       for q, v in zip(air, x[len(cands):])})
        return params

    def residual(x):
        simulated = problem.simulate(params_at(x), train_only=train_only)
        if simulated is _FAILED:
            return np.full(size, 1.0)  # 1 m everywhere: far worse than any fit
        if train_only:
            return problem.train_residual(simulated)
        r = problem.measured - simulated
        return r - problem.offset(r)

    tolerance = 1e-4 if rough else 1e-6
    result = least_squares(residual, x0, bounds=(lows, highs), x_scale=1.0, diff_step=1e-4, xtol=tolerance,
                           ftol=tolerance * 1e-2,
                           max_nfev=(6 if rough else 25) * (len(cands) + 1))
    values = {c.parameter: float(10.0 ** v) for c, v in zip(cands, result.x)}
    n, k = size, x0.size + problem.extra_parameters
    errors = {}
    if n > k:
        # widened for correlated residuals (statistics.covariance's rule, n_eff of AR(1) at their lag-one
        # correlation)
        n_eff = effective_samples(n, lag_one_correlation(result.fun))
        cov = covariance(result.jac, result.fun, k, n_eff)
        for i, c in enumerate(cands):
            errors[c.parameter] = float(values[c.parameter] * _LN10 * math.sqrt(max(cov[i, i], 0.0)))
    return values, errors, result, params_at(result.x)


def refitted(problem) -> tuple:
    """The air's parameters refitted with every candidate (:attr:`Problem.refit`); none for a
    stand-in of the problem (a test's table of fits, :class:`.search.Fitting`)."""
    return getattr(problem, "refit", ())


def with_air_of(base: Params, fitted: Params, problem: Problem) -> Params:
    """``base`` with the air's values (:attr:`Problem.refit`) of ``fitted``: a joint fit from
    ``base`` then starts the air where the last fit left it, not where the calibration did."""
    if not refitted(problem):
        return base
    return base.replace(**{q.name: getattr(fitted, q.name) for q in refitted(problem)})


def fit_candidate(problem: Problem, baseline: Params, current: Fit, added: list, individual: dict, name: str,
                   say, rule: Rule = RULE, hint: float | None = None):
    """Fit one candidate against the current model; returns (fit or None, value, simulations, values).

    ``hint``: the value its signature suggests (see :func:`fit_one`). A candidate that refines an effect
    already added (asymmetric_lag: the lag's exhausting time constant) is always refitted jointly with it: with
    tau held at the compromise the symmetric lag found, tau_exhaust alone gains little.
    """
    cand = CANDIDATES[name]
    value, evaluations = fit_one(problem, current.params, cand, current.rss_train, say, hint)
    if not added:
        individual[name] = value
    values = {**current.values, cand.parameter: value}
    if math.isnan(value):
        return None, value, evaluations, values
    fit = current if value == 0.0 else evaluate(problem, cand.apply(current.params, value), values)
    refines = bool(set(effects.get(name).requires) & set(added))
    promising = fit is not None and fit is not current and (rule.promising(fit.score.bic - current.score.bic)
                                                            or refines)
    if refitted(problem) and fit is not None and fit is not current:
        # with the air's values refitted beside it (Problem.refit): a candidate judged with the
        # valve held at values that absorbed what the candidate explains is judged short
        start = with_air_of(baseline, current.params, problem)
        joint_values, _, result, params = joint_fit(problem, start, [*added, name], values,
                                                     train_only=True, rough=True)
        evaluations += result.nfev + 1
        joint = evaluate(problem, params, joint_values)
        if joint is not None and joint.rss_train < fit.rss_train:
            fit, values = joint, joint_values
    elif added and promising:
        # effects interact (damping and a lag both calm the leg): refit jointly with the effects already
        # added, from this round's value and from the values each took alone in round 1
        starts = [values] if value > 0 else []
        alone = {CANDIDATES[e].parameter: individual.get(e, 0.0) for e in [*added, name]}
        if all(v > 0 for v in alone.values()) and alone != values:
            starts.append(alone)
        for start in starts:
            joint_values, _, result, params = joint_fit(problem, baseline, [*added, name], start, train_only=True,
                                                         rough=True)
            evaluations += result.nfev + 1
            joint = evaluate(problem, params, joint_values)
            if joint is not None and joint.rss_train < fit.rss_train:
                fit, values = joint, joint_values
    if fit is not None and fit is not current:
        value = values[cand.parameter]
    return fit, value, evaluations + 1, values

