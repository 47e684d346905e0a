"""The entry point :func:`diagnose` and the orchestration: prepare, search, final fit, report.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np

from ...errors import MkctlError
from ...io.measurements import Measurement
from ...physics.params import Params
from ..compare import fit_percent, rmse, simulate_output
from ..discovery import discover
from ..effect_files import discovery_effects
from ..diagnosis_rule import RULE, Rule
from ...physics import effects
from .air import air_parameters, fit_air
from .alternatives import _alternative_models, _best_alternative, _shared_values
from .candidates import candidates_for
from .pressure_path import path_from_pressures
from .noise import QUASI_STATIC
from .preparation import Record, _blocked_problem, _prepare, _with_input_noise, input_noise_through_model
from .problem import Problem, evaluate, joint_fit, fit_problem, with_air_of
from .result import DiagnosisResult, _adequacy_at, verdict_of
from .search import WIDER_SEARCH_FACTOR, Search, _inadequacy


def diagnose(measurement: Measurement, progress: Callable[[str], None] | None = None, fit_offset: bool = False,
             rule: Rule = RULE) -> DiagnosisResult:
    """Find the effects the baseline misses, fit them, and report (see the module docstring).

    Parameters
    ----------
    measurement : Measurement
        The record (:func:`mkctl.io.measurements.read_measurement`).
    progress : callable, optional
        Receives one line per stage (for a long run on the command line).
    fit_offset : bool
        Fit a constant sensor offset of the measured output (profiled out of every residual).
    rule : Rule
        The acceptance rule's thresholds (:data:`mkctl.analysis.diagnosis_rule.RULE`).

    Returns
    -------
    DiagnosisResult
        ``verdict`` is ``"diagnosed"``, ``"nothing missing"``, ``"undecided"`` (the record cannot tell the
        effects in ``undecided`` apart), ``"incomplete"`` (the final model, with what was added or with nothing
        added, leaves many times the output noise: something outside the candidates is missing, or the record
        cannot show which) or ``"not diagnosed"`` (``problems`` says why).
    """
    say = progress or (lambda text: None)
    m = measurement
    # a pressure record whose baseline has the air (a valve driven by openings): its values first
    calibration = fit_air(m, m.params, say, known=m.overrides)
    if calibration is not None:
        m = dataclasses.replace(m, params=calibration.params)
    # a knee's measured pressures: its pressure path, as a pressure record through this diagnosis
    path = path_from_pressures(m, m.params, diagnose, rule, say)
    record = _prepare(m, rule, fit_offset, say, path)
    if record.problems:
        return _not_diagnosed(record, say)
    problem = fit_problem(record.prepared, fit_offset, rule, record.noise)
    problem = _with_input_noise(problem, record, say)
    problem = _blocked_problem(problem, record.start, record.full_before, record.noise.sigma, record.notes, say)
    if calibration is not None:  # the air's values the record moves, refitted with each candidate
        problem = dataclasses.replace(problem, refit=tuple(
            q for q in air_parameters(m.params, m.overrides) if q.name in calibration.moved))
    say(f"{Path(m.source).name}: {m.experiment}, {m.samples} samples, baseline {m.baseline} "
        f"(effects: {', '.join(m.params.effects) or 'none'}); fitting on {problem.grid.size} samples")
    state, offset_before = _select(problem, record, rule, say)
    final = _final_fit(state.problem, record, state, offset_before, say)
    final = _with_air(final, record, calibration, say)
    return _result(record, state, final, offset_before, rule, say)


def _with_air(final: "_Final", record: Record, calibration, say) -> "_Final":
    """The final model with the air's values (:mod:`.air`): the baseline's calibration (a valve
    driven by openings) reported beside what was added, and the air refitted, with what the search
    added, in every value the record identifies (the others held, each with a note in the record's
    notes).
    """
    m = record.measurement
    values, uncertainty = dict(final.values), dict(final.uncertainty)
    if calibration is not None:
        values, uncertainty = {**calibration.values, **values}, {
            **calibration.uncertainty,
            **uncertainty,
        }
        errors = (f"RMSE {calibration.rmse_before * record.to_file:.3g} -> "
                  f"{calibration.rmse_after * record.to_file:.3g} {m.output_unit}")
        record.notes.append(
            "the air in the record's baseline calibrated first (a valve driven by openings): "
            + ", ".join(f"{k} = {v:.4g}" for k, v in calibration.values.items()) + f" ({errors})"
            if calibration.values else
            "the air in the record's baseline (a valve driven by openings) could not be calibrated "
            f"alone ({errors}): the record shows more than the valve, and its values are fitted "
            "with the effects the search adds"
        )
    added_air = any(effects.get(e).moves_air for e in final.added)
    refit = None
    if added_air or calibration is not None and final.added:
        # the air's values and what the search added, refitted together (a dead time the valve's
        # first calibration could only absorb)
        also = [
            effects.get(e).parameter(effects.get(e).fitted)
            for e in final.added
            if not effects.get(e).moves_air
            and effects.get(e).fitted in effects.get(e).parameter_names
        ]
        refit = fit_air(record.prepared, final.params, say, known=m.overrides, also=also)
    # (not worse: the search's joint fits may have refitted the air already; its values and
    # standard errors are the refit's)
    if refit is not None and refit.rmse_after <= refit.rmse_before * (1.0 + 1e-6):
        for name in refit.held:  # held: no value the record identifies, no standard error
            values.pop(name, None)
            uncertainty.pop(name, None)
        values, uncertainty = {**values, **refit.values}, {**uncertainty, **refit.uncertainty}
        for key in refit.identified:  # a conductance whose record identifies only C / V
            uncertainty.pop(key.split("/")[0], None)
        record.notes.extend(refit.notes)
        simulated = simulate_output(record.prepared, refit.params) + final.offset
        return dataclasses.replace(
            final, values=values, uncertainty=uncertainty, simulated=simulated, params=refit.params,
            identified=refit.identified,
        )
    record.notes.extend(calibration.notes if calibration is not None else [])
    identified = calibration.identified if calibration is not None else {}
    for key in identified:
        uncertainty.pop(key.split("/")[0], None)
    return dataclasses.replace(final, values=values, uncertainty=uncertainty, identified=identified)


def _not_diagnosed(record: Record, say) -> DiagnosisResult:
    """The result for a record whose output cannot be this model's (a unit or zero mistake)."""
    for text in record.problems:
        say("not diagnosed: " + text)
    y, sim = record.output, record.full_before * record.to_file
    before, fit_before = rmse(y, sim), fit_percent(y, sim)
    return DiagnosisResult(**record.common, verdict="not diagnosed", missing=[], params={}, uncertainty={},
                           rmse_before=before, rmse_after=before, fit_percent_before=fit_before,
                           fit_percent_after=fit_before, problems=record.problems, notes=record.notes,
                           simulated_before=record.full_before, simulated_after=record.full_before,
                           error_steps=[before], params_after=record.measurement.params)


def _select(problem: Problem, record: Record, rule: Rule, say):
    """Steps 1-4: forward selection from the baseline, and the wider search when what it added leaves many
    times the noise. Returns the search (added effects, steps, ties) and the baseline's fitted offset."""
    m, start = record.measurement, record.start
    first = evaluate(problem, m.params, {})
    if first is None:
        raise MkctlError(f"{m.source}: the model cannot simulate this record")
    current = first if start is m.params else evaluate(problem, start, {})
    pending_all = [e for e in candidates_for(m, start) if e not in record.exclude]
    # what the measured pressures could not tell apart comes first among the ties
    tied_on_pressures = record.lag["path"]["undecided"] if record.lag is not None else []
    state = Search(problem, start, pending_all, rule, record.to_file, say, record.noise,
                   renoised=record.renoised, renoised_more=record.renoised_more, undecided=tied_on_pressures)
    state.forward(current)
    if (state.added or state.undecided) and len(pending_all) >= 2:
        # the noise the model should leave includes the measured inputs' noise through it (a
        # quasi-static record passes it on sample by sample): without it, 4 kPa of pressure noise
        # looked like 10 times the output noise
        through_model, _ = input_noise_through_model(record, state.current.params)
        sigma = math.hypot(record.noise.sigma, through_model)
        inadequate = _inadequacy(problem, state.current, sigma)
        if inadequate > WIDER_SEARCH_FACTOR:
            say(f"the model leaves {inadequate:.3g} times the noise (output, and inputs' through "
                f"the model): trying the candidates in pairs and threes")
            if state.wider():
                state.forward(state.current)
    return state, first.offset


@dataclass(frozen=True)
class _Final:
    """The final model: the added effects (with a lag judged on pressures first), their values and standard
    errors from the joint fit on the whole record, its offset and its simulation over every sample [SI]."""

    added: list
    values: dict
    uncertainty: dict
    offset: float
    simulated: np.ndarray
    params: Params
    #: what a held muscle's record identifies of a conductance: "C_fill/V" -> (value, error)
    identified: dict = dataclasses.field(default_factory=dict)


def _final_fit(problem: Problem, record: Record, state: "Search", offset_before: float, say) -> _Final:
    """Step 5: the added parameters fitted jointly on the whole record, with their standard errors (widened by
    the spread a lag found on the pressures brings)."""
    m, start, lag = record.measurement, record.start, record.lag
    added = list(state.added)
    uncertainty: dict = {}
    final_params, final_values, offset = start, {}, offset_before
    if added:
        say("final fit of " + ", ".join(added) + " on the whole record")
        final_values, uncertainty, _, final_params = joint_fit(
            problem, with_air_of(start, state.current.params, problem), added, state.current.values,
            train_only=False)
        offset = problem.offset(problem.measured - problem.simulate(final_params)) if problem.fit_offset else 0.0
    simulated = (simulate_output(record.prepared, final_params) + offset if (added or start is not m.params)
                 else record.full_before + offset_before)
    if added and m.experiment in QUASI_STATIC and record.renoised is not None:
        # the measured inputs' noise moves the values too (a friction follows the wiggles the
        # smoothed pressure leaves): refitted with the model driven by other realisations of the
        # inputs' noise, the values' RMS shift is added (in quadrature) to their standard errors
        shifts = []
        for renoised in [record.renoised, *record.renoised_more]:
            moved = dataclasses.replace(problem, measurement=dataclasses.replace(
                problem.measurement, inputs=renoised.inputs))
            values, _, _, _ = joint_fit(moved, start, added, final_values, train_only=False,
                                         rough=True)
            shifts.append(values)
        for name in final_values:
            rms = math.sqrt(sum((v[name] - final_values[name]) ** 2 for v in shifts) / len(shifts))
            uncertainty[name] = math.hypot(uncertainty.get(name, 0.0), rms)
    path = lag["path"] if lag is not None else {"values": {}, "uncertainty": {}}
    if added and path["uncertainty"]:
        # the path's values were fixed from the pressures: their own uncertainty moves the motion's
        # parameters too (first order: refit at each value -+ its standard error, add the spread in
        # quadrature)
        for name, error in path["uncertainty"].items():
            value = path["values"].get(name)
            if not error or value is None:
                continue
            spread = []
            for sign in (-1.0, 1.0):
                try:
                    shifted = start.replace(**{name: max(value + sign * error, 1e-3 * value)})
                except MkctlError:  # beyond its bounds: the spread is not measured
                    break
                values, _, _, _ = joint_fit(problem, shifted, added, final_values, train_only=False,
                                            rough=True)
                spread.append(values)
            if len(spread) < 2:
                continue
            for key in final_values:
                moved = 0.5 * abs(spread[1][key] - spread[0][key])
                uncertainty[key] = math.hypot(uncertainty.get(key, 0.0), moved)
    if lag is not None and lag["path"]["effects"]:
        path = lag["path"]
        added = [*path["effects"], *added]
        final_values = {**path["values"], **final_values}
        uncertainty = {**path["uncertainty"], **uncertainty}
    return _Final(added, final_values, uncertainty, offset, simulated, final_params)


def _steps_rmse(record: Record, state: Search, offset_before: float) -> list:
    """The RMSE before and after each step over every sample [file units], also written into the steps."""
    to_file, y = record.to_file, record.output
    steps_rmse = [rmse(y, (record.full_before + offset_before) * to_file)]
    for params, offset in state.step_params:
        steps_rmse.append(rmse(y, (simulate_output(record.prepared, params) + offset) * to_file))
    for step, value in zip(state.steps, steps_rmse[1:]):
        step["rmse"] = value
    return steps_rmse


def _noise_text(noise, floor: float, to_file: float, unit: str) -> str:
    """The noise a final model should leave, in words (file units)."""
    return f"estimated output noise {noise.sigma * to_file:.2g} {unit}" + (
        f", correlated {noise.correlation:.2f} between samples" if noise.correlation else "") + (
        f", and {floor * to_file:.2g} {unit} of the measured inputs' noise through the model" if floor else "")


def _result(record: Record, state: "Search", final: _Final, offset_before: float, rule: Rule,
            say) -> DiagnosisResult:
    """The report: the error after each step over every sample, the adequacy of the final model, the verdict."""
    m, to_file, y = record.measurement, record.to_file, record.output
    steps_rmse = _steps_rmse(record, state, offset_before)
    before = record.full_before + offset_before
    fit, noise, floor = _adequacy_at(record, final.params, final.simulated, final.offset, rule)
    sigma = math.hypot(noise.sigma, floor)
    noise_text = _noise_text(noise, floor, to_file, m.output_unit)
    # a tie is judged on the best of the tied explanations, not on the model with neither (issue
    # 21); each explanation is reported as a whole model, and the top level holds only what they
    # share (issue 32)
    alternatives = _alternative_models(record, state, rule, say) if state.undecided else []
    tied = _best_alternative(alternatives) if alternatives and not fit.adequate else None
    undecided = [{**u, "explains": tied[1].adequate} if tied else dict(u) for u in state.undecided]
    verdict, note = verdict_of(final.added, undecided, fit, noise_text, tied)
    notes = list(record.notes)
    if note:
        notes.append(note)
        say(note)
    missing, values, uncertainty = final.added, final.values, final.uncertainty
    simulated, params_after = final.simulated, final.params
    without_tied = None
    if len(alternatives) >= 2:
        without_tied = {"adequate": fit.adequate, "ratio": fit.ratio, "limit": fit.limit,
                        "text": fit.text()}
        missing, values, uncertainty, disputed = _shared_values(alternatives)
        best = min(alternatives, key=lambda a: (not a.adequacy.adequate, a.adequacy.ratio))
        fit, simulated, params_after = best.adequacy, best.simulated, best.params
        per_alternative = "; ".join(
            ", ".join(f"{k} = {a.values[k]:.4g}" for k in disputed)
            + f" with {' and '.join(a.rivals)}" for a in alternatives)
        text = (f"the record holds {len(alternatives)} explanations that it cannot tell apart, "
                f"each reported as a whole model under 'alternatives'; the top level keeps only "
                f"what they share" + (f" ({', '.join(missing)})" if missing else " (nothing)")
                + (f", without {', '.join(disputed)}, whose value depends on the explanation: "
                   f"{per_alternative}" if disputed else "")
                + f"; its error after is the best explanation's ({' and '.join(best.rivals)})")
        notes.append(text)
        say(text)
    # spec 6b: what the baseline cannot explain is regressed on a library of physical terms (registered effects
    # it lacks show as their own terms, "matches" naming them)
    # (a pressure record's: its missing pressure rate on the pneumatic terms)
    found = discover(record.prepared, record.start, progress=say, effects=discovery_effects()) \
        if verdict == "incomplete" else None
    worst = dict(fit.worst)
    if worst:
        worst.update({"from_s": float(m.time[worst.pop("start")]), "to_s": float(m.time[worst.pop("stop")])})
    order, sigs = state.signatures_first if state.signatures_first else ([], {})
    return DiagnosisResult(
        **record.common, discovery=found, verdict=verdict, missing=missing, params=values,
        uncertainty=uncertainty, identified={k: list(v) for k, v in final.identified.items()},
        alternatives=[a.report(record) for a in alternatives],
        alternative_simulated=[a.simulated for a in alternatives],
        rmse_before=rmse(y, before * to_file), rmse_after=rmse(y, simulated * to_file),
        fit_percent_before=fit_percent(y, before * to_file),
        fit_percent_after=fit_percent(y, simulated * to_file),
        steps=state.steps, stopped=state.stopped, undecided=undecided, notes=notes,
        offset=final.offset * to_file if record.fit_offset else None,
        adequacy={"adequate": fit.adequate, "ratio": fit.ratio, "limit": fit.limit, "worst_window": worst,
                  "noise": sigma * to_file, "input_noise_through_model": floor * to_file,
                  "text": fit.text(), **({"without_tied": without_tied} if without_tied else {})},
        simulated_before=before, simulated_after=simulated, error_steps=steps_rmse,
        params_after=params_after,
        signatures=sigs, signature_order=order)

