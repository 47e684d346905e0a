"""A tie as whole models: each explanation refitted on the whole record, and what they share.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np

from ...errors import MkctlError
from ...physics.params import Params
from ..compare import fit_percent, rmse, simulate_output
from ..diagnosis_rule import Adequacy, Rule
from .candidates import CANDIDATES, _effect_parameters
from .problem import _FAILED, fit_one, joint_fit
from .result import _adequacy_at
from .preparation import Record
from .search import Search


def _tied_rivals(record: Record, state: "Search", rule: Rule, say) -> tuple[list, Adequacy] | None:
    """The best of the tied explanations and its adequacy: the final model refitted on the whole record with each
    (one effect from each tie in ``state.undecided``), the best being one that passes the adequacy test, else the
    one that leaves least. None when none could be fitted (the tie is then left undecided)."""
    alternatives = _alternative_models(record, state, rule, say)
    return _best_alternative(alternatives)


def _best_alternative(alternatives: list) -> tuple[list, Adequacy] | None:
    """(the rivals, the adequacy) of the alternative that passes the adequacy test, else leaves
    least; None."""
    best = None
    for alternative in alternatives:
        fit = alternative.adequacy
        if best is None or (fit.adequate, -fit.ratio) > (best[1].adequate, -best[1].ratio):
            best = (alternative.rivals, fit)
    return best


@dataclass(frozen=True)
class _Alternative:
    """One explanation of a tie as a whole model: the final model refitted on the whole record with
    one effect from each tie (``rivals``): its effects, values, standard errors, simulation over
    every sample [SI] (offset included) and adequacy."""

    rivals: list
    effects: list
    values: dict
    uncertainty: dict
    simulated: np.ndarray
    params: Params
    adequacy: Adequacy
    offset: float = 0.0

    def report(self, record: Record) -> dict:
        """The alternative as the report's JSON gives it (RMSE over every sample, file units)."""
        y = record.output
        return {"effects": list(self.effects), "with": list(self.rivals),
                "params": dict(self.values),
                "uncertainty": dict(self.uncertainty),
                "rmse": rmse(y, self.simulated * record.to_file),
                "fit_percent": fit_percent(y, self.simulated * record.to_file),
                "adequate": self.adequacy.adequate, "noise_ratio": self.adequacy.ratio,
                "text": self.adequacy.text()}


def _alternative_models(record: Record, state: "Search", rule: Rule, say) -> list:
    """Each explanation of the ties in ``state.undecided`` as a whole model (:class:`_Alternative`):
    the effects added (and a pressure path found on measured pressures) with one effect from each
    tie, all refitted jointly on the whole record, with the standard errors of that fit."""
    problem, current = state.problem, state.current
    found = []
    path = (record.lag["path"] if record.lag is not None
            else {"effects": [], "values": {}, "uncertainty": {}})
    for combo in itertools.product(*[u["effects"] for u in state.undecided]):
        rivals = [e for e in dict.fromkeys(combo) if e not in state.added and e in CANDIDATES]
        if not rivals:
            continue
        start = dict(current.values)
        for name in rivals:
            parameter = CANDIDATES[name].parameter
            fit = state.fits.get(name)
            value = fit.values.get(parameter, 0.0) if fit is not None else 0.0
            if not value > 0:  # a tie judged elsewhere (the pressure path): fitted alone against the current model
                value, _ = fit_one(problem, current.params, CANDIDATES[name], current.rss_train, None)
            start[parameter] = value
        if not all(start[CANDIDATES[e].parameter] > 0 for e in rivals):
            continue
        values, errors, _, params = joint_fit(problem, record.start, [*state.added, *rivals],
                                               start, train_only=False)
        on_grid = problem.simulate(params)
        if on_grid is _FAILED:
            continue
        offset = problem.offset(problem.measured - on_grid)
        try:
            simulated = simulate_output(record.prepared, params) + offset
        except MkctlError:
            continue
        fit, _, _ = _adequacy_at(record, params, simulated, offset, rule)
        say(f"  the tie judged with {' and '.join(rivals)}: {fit.text()}")
        on_path = [e for e in path["effects"] if e not in state.added and e not in rivals]
        found.append(_Alternative(rivals, [*on_path, *state.added, *rivals],
                                  {**path["values"], **values}, {**path["uncertainty"], **errors},
                                  simulated, params, fit, offset))
    return found


def _shared_values(alternatives: list) -> tuple[list, dict, dict, list]:
    """What the top level of a tied report holds: the effects every alternative has, and each of
    their parameters on which the alternatives agree (every pair within twice their combined
    standard error), as their inverse-variance mean with a standard error that covers their spread.
    A shared parameter on which they disagree belongs to each alternative alone: it is left out and
    named (returned last)."""
    shared = [e for e in alternatives[0].effects if all(e in a.effects for a in alternatives[1:])]
    params, uncertainty, disputed = {}, {}, []
    for name in alternatives[0].values:
        if not all(name in a.values for a in alternatives):
            continue
        if not any(name in _effect_parameters(e) for e in shared):
            continue
        values = np.array([a.values[name] for a in alternatives])
        errors = np.array([a.uncertainty.get(name, math.inf) for a in alternatives])
        agree = all(abs(values[i] - values[j]) <= 2.0 * math.hypot(errors[i], errors[j])
                    for i in range(values.size) for j in range(i + 1, values.size))
        if not agree or not np.all(np.isfinite(errors)) or not np.all(errors > 0):
            disputed.append(name)
            continue
        weights = 1.0 / errors ** 2
        mean = float(np.sum(weights * values) / np.sum(weights))
        params[name] = mean
        uncertainty[name] = float(max(1.0 / math.sqrt(np.sum(weights)), 0.5 * np.ptp(values)))
    return shared, params, uncertainty, disputed

