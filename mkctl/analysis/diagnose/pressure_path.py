"""The pressure path judged on a knee file's measured bladder pressures: the lag, the dead time and the
exhausting time constant against the commands (model-spec sections 4, 4b).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from ...io.measurements import Measurement
from ...physics.params import Params
from ..diagnosis_rule import RULE, Candidate as Outcome, Rule, Score, at_bound, best_value, decide
from .candidates import CANDIDATES, experiment_to_separate
from ..signals import pressure_path
from ..statistics import covariance, effective_samples, lag_one_correlation

#: The effects of the pressure path (command -> bladder pressure), judged on measured pressures when a knee file
#: has them, in the order they are tried, with their parameter.
PRESSURE_PATH = {"pressure_lag": "tau", "dead_time": "delay", "asymmetric_lag": "tau_exhaust"}


@dataclass(frozen=True)
class _PressureProblem:
    """The measured pressures against the commands through the path: residual [kPa], score, joint fit."""

    measurement: Measurement
    measured: np.ndarray  #: pe then pf [Pa]
    train: np.ndarray  #: bool over both channels: in the training part

    def residual(self, values: dict) -> np.ndarray:
        m = self.measurement
        model = np.concatenate([pressure_path(m.time, m.inputs[c], **values) for c in ("pe_cmd", "pf_cmd")])
        return (self.measured - model) / 1e3  # kPa

    def score(self, r, k: int) -> Score:
        return Score.from_residuals(r[self.train], r[~self.train], k)

    def rss_train(self, values: dict) -> float:
        return float(np.sum(self.residual(values)[self.train] ** 2))

    def fit(self, names, start):
        """The parameters of ``names`` fitted jointly (log space) from ``start``; (values, Outcome)."""
        lows = np.log10([_bounds(e)[0] for e in names])
        highs = np.log10([_bounds(e)[1] for e in names])
        x0 = np.clip(np.log10([max(start.get(PRESSURE_PATH[e], 0.0), 1e-300) for e in names]), lows + 1e-9,
                     highs - 1e-9)
        keys = [PRESSURE_PATH[e] for e in names]
        result = least_squares(lambda x: self.residual(dict(zip(keys, 10.0 ** x)))[self.train], x0,
                               bounds=(lows, highs), diff_step=1e-4, xtol=1e-6, max_nfev=40 * len(names))
        values = dict(zip(keys, (float(v) for v in 10.0 ** result.x)))
        pinned = any(at_bound(values[PRESSURE_PATH[e]], _bounds(e)) for e in names)
        return values, Outcome(names[-1], self.score(self.residual(values), len(names)), at_bound=pinned)

    def alone(self, name: str, off: Score) -> tuple[float, Outcome]:
        """One effect of the path alone: a 1-D search, "off" an option; (value, Outcome)."""
        key = PRESSURE_PATH[name]
        value, _ = best_value(lambda v: self.rss_train({key: v}), _bounds(name), off.rss_train)
        if value == 0.0:
            return value, Outcome(name, dataclasses.replace(off, k=1), switched_off=True)
        return value, Outcome(name, self.score(self.residual({key: value}), 1), at_bound=at_bound(value, _bounds(name)))


def _bounds(name: str) -> tuple[float, float]:
    return CANDIDATES[name].bounds["knee"]


def lag_from_pressures(measurement: Measurement, params: Params, rule: Rule = RULE) -> dict | None:
    """The pressure path judged directly on a knee file's measured bladder pressures, or None without them.

    The measured pe, pf are compared with the commands through a lag ``tau dP/dt = P_cmd - P``, a dead time, or
    both, and a lag that exhausts at its own rate (:func:`mkctl.analysis.signals.pressure_path`, commands held
    between samples): forward selection by the same rule as the motion's candidates
    (:func:`mkctl.analysis.diagnosis_rule.decide`), on the first part of the record, against the commands
    themselves. Round 1 tries the lag and the dead time alone, round 2 adds the other (or the exhausting time
    constant) fitted jointly. Returns {"accepted" (the lag), "tau" [s], "uncertainty" [s], "candidate" (the lag's
    report row, RMSE in kPa), "reason", "path": {"effects", "values", "uncertainty", "undecided"}}; a lag the file
    already declares (tau in the metadata) is not judged.
    """
    m = measurement
    if m.experiment != "knee" or not ("pe" in m.inputs and "pf" in m.inputs) or params.tau > 0:
        return None
    train_one = m.time <= rule.split_time(m.time[0], m.time[-1])
    problem = _PressureProblem(m, np.concatenate([m.inputs["pe"], m.inputs["pf"]]),
                               np.concatenate([train_one, train_one]))
    off = problem.score(problem.residual({}), 0)
    tau, lag_outcome = problem.alone("pressure_lag", off)
    delay, dead_outcome = problem.alone("dead_time", off)
    decision = decide(off, [lag_outcome, dead_outcome], rule)
    path = {"effects": [], "values": {}, "uncertainty": {}, "undecided": []}
    if decision.verdict == "undecided":
        effects_ = [decision.effect, *decision.rivals]
        path["undecided"].append({"effects": effects_, "experiment": experiment_to_separate(effects_),
                                  "text": f"the measured pressures cannot tell "
                                          f"{' from '.join(e.replace('_', ' ') for e in effects_)}: "
                                          f"{decision.reason}"})
    elif decision.verdict == "add":
        first = {"pressure_lag": (lag_outcome, {"tau": tau}), "dead_time": (dead_outcome, {"delay": delay})}
        _later_rounds(problem, decision.effect, *first[decision.effect], path, rule)
        path["uncertainty"] = _path_uncertainty(problem, path["values"], m.samples)
    return _lag_report(problem, decision, off, lag_outcome, tau, path)


def _later_rounds(problem: _PressureProblem, effect: str, outcome: Outcome, values: dict, path: dict,
                  rule: Rule) -> None:
    """Rounds 2 and 3 after ``effect`` was added (its outcome and values): the other effect of the path, or the
    exhausting time constant, fitted jointly with it; then, with both, the exhausting time constant. Fills
    ``path``'s effects and values."""
    path["effects"] = [effect]
    path["values"] = dict(values)
    current_score = outcome.score
    trials = {}
    if effect == "pressure_lag":
        tau = values["tau"]
        trials["dead_time"] = ["pressure_lag", "dead_time"], {"tau": tau, "delay": 1e-2}
        trials["asymmetric_lag"] = ["pressure_lag", "asymmetric_lag"], {"tau": tau, "tau_exhaust": tau}
    else:
        trials["pressure_lag"] = ["dead_time", "pressure_lag"], {"delay": values["delay"], "tau": 1e-2}
    fitted = {name: problem.fit(names, start) for name, (names, start) in trials.items()}
    second = decide(current_score, [outcome for _, outcome in fitted.values()], rule)
    if second.verdict == "add":
        path["effects"].append(second.effect)
        path["values"] = fitted[second.effect][0]
        if "pressure_lag" not in path["effects"][:1] and second.effect == "pressure_lag":
            path["effects"] = ["pressure_lag", "dead_time"]  # the lag first: an asymmetric lag needs it
        current_score = fitted[second.effect][1].score
        if (second.effect == "dead_time" or "dead_time" in path["effects"]) and "pressure_lag" in path["effects"]:
            # round 3: with both, the exhausting time constant
            values3, outcome3 = problem.fit(["pressure_lag", "dead_time", "asymmetric_lag"],
                                            {**path["values"], "tau_exhaust": path["values"]["tau"]})
            third = decide(current_score, [outcome3], rule)
            if third.verdict == "add":
                path["effects"].append("asymmetric_lag")
                path["values"] = values3
    path["values"] = {k: v for k, v in path["values"].items()
                      if any(PRESSURE_PATH[e] == k for e in path["effects"])}


def _path_uncertainty(problem: _PressureProblem, values: dict, n: int) -> dict:
    """Standard errors: each parameter by a central difference of the whole record's residual, the others held
    (:func:`mkctl.analysis.statistics.covariance` of that one column, widened by the residual's correlation)."""
    r = problem.residual(values)
    n_eff = effective_samples(r.size, lag_one_correlation(r[:n]))
    errors = {}
    for key, value in values.items():
        step = value * 1e-3
        jac = (problem.residual({**values, key: value + step}) - problem.residual({**values, key: value - step})) \
            / (2 * step)
        errors[key] = float(math.sqrt(covariance(jac, r, len(values), n_eff)[0, 0]))
    return errors


def _lag_report(problem: _PressureProblem, decision, off: Score, lag_outcome: Outcome, tau: float,
                path: dict) -> dict:
    """The report of :func:`lag_from_pressures`: the lag's row and whether it was accepted, and the path."""
    accepted = "pressure_lag" in path["effects"]
    tau_found = path["values"].get("tau", tau)
    j = decision.judgements["pressure_lag"]
    lag_row_score = (problem.score(problem.residual(path["values"]), len(path["values"])) if path["effects"]
                     else lag_outcome.score)
    row = {"effect": "pressure_lag", "params": {"tau": tau_found}, "rmse_train_kPa": lag_row_score.rmse_train,
           "rmse_holdout_kPa": lag_row_score.rmse_holdout, "rmse_holdout_before_kPa": off.rmse_holdout,
           "delta_bic": j.delta_bic, "passes_bic": j.passes_bic, "passes_holdout": j.passes_holdout,
           "switched_off": lag_outcome.switched_off, "at_bound": lag_outcome.at_bound}
    reason = decision.reason if not accepted or decision.effect == "pressure_lag" else "found with a dead time"
    if path["effects"] == ["dead_time"]:
        # without a lag the modelled pressure is the delayed command, sample by sample: the pressures place
        # the delay only within a sample, and the motion, which follows it continuously, fits it instead
        path["motion"] = "dead_time"
        path["effects"], path["values"], path["uncertainty"] = [], {}, {}
    return {"accepted": accepted, "tau": tau_found,
            "uncertainty": path["uncertainty"].get("tau") if accepted else None, "candidate": row,
            "reason": reason, "path": path}
