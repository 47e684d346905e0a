"""The result of a diagnosis (:class:`DiagnosisResult`), the adequacy of a final model and the verdict.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...io import diagnosis_report
from ...physics.params import UNITS, Params
from ...results import Result, plain
from ..diagnosis_rule import Adequacy, Rule, adequacy
from .noise import NoiseModel, noise_model
from .preparation import Record


#: Verdicts of a diagnosis.
VERDICTS = ("diagnosed", "nothing missing", "undecided", "incomplete", "not diagnosed")


@dataclass(repr=False)
class DiagnosisResult(Result):
    """What :func:`diagnose` found, in python-control's manner: named attributes, arrays for the pictures.

    ``to_dict()`` gives the JSON of model-spec section 6 (plus context), ``to_dataframe()`` one row per
    candidate per round. RMSE are in the units of the file's output column, parameters SI.
    """

    file: str
    experiment: str
    baseline: str
    baseline_effects: list
    output: str  #: the output column's name (``x_mm``)
    output_unit: str
    samples: int
    verdict: str  #: one of :data:`VERDICTS`
    missing: list  #: effects added, in order
    params: dict  #: their fitted values (final joint fit on the whole record), SI
    uncertainty: dict  #: standard error of each fitted parameter, SI
    rmse_before: float
    rmse_after: float
    fit_percent_before: float
    fit_percent_after: float
    steps: list = field(default_factory=list)  #: one dict per accepted step (see docs/diagnosis.md)
    stopped: dict | None = None  #: the last round, that added nothing: reason, candidates, ties
    undecided: list = field(default_factory=list)  #: [{"effects": [...], "experiment": ...}]
    problems: list = field(default_factory=list)  #: why the record was not diagnosed (sanity checks)
    notes: list = field(default_factory=list)  #: what was done to the record before fitting, in words
    input_noise: dict = field(default_factory=dict)  #: input -> {"sigma", "unit", "smoothed"}
    output_noise: float | None = None  #: estimated noise of the measured output, file units
    output_noise_correlation: float = 0.0  #: its lag-one correlation between samples (0: white)
    adequacy: dict | None = None  #: the final model's residual against the noise (:func:`verdict_of`)
    saturation: dict | None = None  #: where the baseline could not follow (see :func:`saturation_note`)
    offset: float | None = None  #: fitted constant sensor offset, file units (``fit_offset`` only)
    #: the pressure path judged on measured pressures (:class:`~.pressure_path.PressurePath`'s report)
    pressure_lag: dict | None = None
    discovery: dict | None = None  #: spec 6b, when incomplete (:func:`mkctl.analysis.discovery.discover`)
    #: on a tie, each explanation as a whole model: effects, params, uncertainty, rmse, adequate
    #: (see docs/diagnosis.md); the top level then holds only what they share
    alternatives: list = field(default_factory=list)
    rule: dict = field(default_factory=dict)
    #: what the record identifies where a parameter alone is not: ``{"C_fill/V": [value, standard
    #: error]}`` [1/(s Pa)] on a held muscle's pressure record (the conductance alone rests on the
    #: assumed dead volume)
    identified: dict = field(default_factory=dict)
    pictures: dict = field(default_factory=dict)
    # arrays for the pictures (SI), not part of the JSON
    params_after: Params | None = field(default=None, repr=False)  #: the final model's parameters
    simulated_before: np.ndarray | None = field(default=None, repr=False)
    simulated_after: np.ndarray | None = field(default=None, repr=False)
    error_steps: list = field(default_factory=list, repr=False)  #: RMSE after each step, file units
    signatures: dict = field(default_factory=dict, repr=False)  #: first round's signatures
    signature_order: list = field(default_factory=list, repr=False)
    #: each alternative's simulation over every sample [SI]
    alternative_simulated: list = field(default_factory=list, repr=False)
    #: a knee's measured pressures as the path found on them model them: (extensor, flexor) [Pa]
    pressure_path_simulated: np.ndarray | None = field(default=None, repr=False)

    @property
    def units(self) -> dict:
        return {k: UNITS[k] for k in self.params}

    def summary_lines(self) -> list[str]:
        """The repr: file, verdict, what is missing with its values, the error before and after."""
        lines = [f"{Path(self.file).name}: {self.experiment}, verdict {self.verdict!r}, missing {self.missing}"]
        for name, value in self.params.items():
            error = self.uncertainty.get(name)
            lines.append(f"{name} = {value:.4g}" + (f" +- {error:.2g}" if error is not None else "") + f" {UNITS[name]}")
        lines.append(f"RMSE {self.rmse_before:.4g} -> {self.rmse_after:.4g} {self.output_unit}")
        lines += [f"cannot tell {' from '.join(u['effects'])}" for u in self.undecided]
        for a in self.alternatives:
            values = ", ".join(f"{k} = {v:.4g}" for k, v in a["params"].items())
            lines.append(f"alternative: {', '.join(a['effects'])}: {values}")
        lines += [f"problem: {text}" for text in self.problems]
        return lines

    def to_dict(self) -> dict:
        """The report as plain JSON values (model-spec section 6 keys first; NaN and infinity become None)."""
        data = {
            "experiment": self.experiment, "baseline": self.baseline, "output": self.output,
            "rmse_before": self.rmse_before, "rmse_after": self.rmse_after, "missing": list(self.missing),
            "params": dict(self.params), "steps": self.steps,
            "verdict": self.verdict, "undecided": self.undecided, "problems": self.problems,
            "uncertainty": dict(self.uncertainty), "units": self.units,
            "identified": dict(self.identified),
            "fit_percent_before": self.fit_percent_before, "fit_percent_after": self.fit_percent_after,
            "stopped": self.stopped, "notes": self.notes, "input_noise": self.input_noise,
            "output_noise": self.output_noise, "output_noise_correlation": self.output_noise_correlation,
            "adequacy": self.adequacy, "saturation": self.saturation, "offset": self.offset,
            "pressure_lag": self.pressure_lag,
            "discovery": self.discovery, "alternatives": self.alternatives,
            "file": self.file, "baseline_effects": list(self.baseline_effects), "output_unit": self.output_unit,
            "samples": self.samples, "rule": self.rule, "pictures": self.pictures,
        }
        return plain(data)

    def table(self) -> list[dict]:
        """One row per candidate per round (``to_dataframe()``): round, effect, parameter, value, delta_bic,
        rmse_holdout, passes_bic, passes_holdout, physical, at_bound, switched_off, added."""
        rounds = self.steps + ([self.stopped] if self.stopped and self.stopped.get("candidates") else [])
        rows = []
        for number, step in enumerate(rounds, 1):
            added = [step.get("added"), *step.get("added_with", [])]
            for row in step["candidates"]:
                (name, value), = row["params"].items()
                rows.append({"round": number, "effect": row["effect"], "parameter": name, "value": value,
                             "delta_bic": row.get("delta_bic"), "rmse_holdout": row.get("rmse_holdout"),
                             "passes_bic": row.get("passes_bic"), "passes_holdout": row.get("passes_holdout"),
                             "physical": row.get("physical"), "at_bound": row.get("at_bound"),
                             "switched_off": row.get("switched_off"), "added": row["effect"] in added})
        return rows

    def __getitem__(self, key):
        """Dict-style access to the JSON keys (``result["missing"]``), for scripts written against the
        dict this function used to return."""
        return self.to_dict()[key]


def public(result: DiagnosisResult) -> dict:
    """The result as plain JSON values: ``result.to_dict()``."""
    return result.to_dict()


summary = diagnosis_report.summary

save_pictures = diagnosis_report.save_pictures


def verdict_of(added: list, undecided: list, fit: Adequacy, noise_text: str,
               tied: tuple[list, Adequacy] | None = None) -> tuple[str, str | None]:
    """The verdict, and the note that explains an ``"incomplete"`` one (else None): the one place where a
    diagnosis is found incomplete (and handed to the discovery of model-spec section 6b).

    What was added (or the baseline) must leave only what the noise explains
    (:func:`mkctl.analysis.diagnosis_rule.adequacy`, over the whole record and window by window): then
    ``"diagnosed"`` (or ``"nothing missing"``), else ``"incomplete"``. A tie is judged on the best of the tied
    explanations instead of on the model with neither: ``tied`` is (the effects of the best, the adequacy of the
    model refitted with them) (:func:`_tied_rivals`; None when not judged). A tie stays ``"undecided"`` unless
    even the best of them leaves clearly more than the noise: then neither explains the record, and it is
    ``"incomplete"`` (the tie is still reported).
    """
    if undecided and (tied is None or tied[1].adequate):
        return "undecided", None
    if undecided:
        rivals, best = tied
        pairs = "; ".join(" from ".join(e.replace("_", " ") for e in u["effects"]) for u in undecided)
        return "incomplete", (f"this record cannot tell {pairs}, and neither explains it: with the best of them "
                              f"({', '.join(rivals)}) {best.text()} ({noise_text}): something outside the "
                              f"candidates is missing")
    if fit.adequate:
        return ("diagnosed" if added else "nothing missing"), None
    left = f"{fit.text()} ({noise_text})"
    if added:
        return "incomplete", (f"with {', '.join(added)} {left}: something outside the candidates is missing, or "
                              f"effects this record cannot separate; do not trust the values as physical")
    return "incomplete", (f"no candidate passes the rule, yet {left}: something is missing that the candidates do "
                          f"not supply, or this record cannot show which (see why the last round stopped); if this "
                          f"is your own muscle, its static parameters (b, n, C1, C2) may not be the ones assumed "
                          f"here: calibrate it (mkctl calibrate) and diagnose with --params MUSCLE.json")


def _final_noise(record: Record, simulated) -> NoiseModel:
    """The noise a final model (its simulation over every sample [SI]) should leave: the record's estimate, or,
    where the signal changed too fast to resolve it (:attr:`NoiseModel.unresolved`), the estimate on the model's
    residual when that is resolved and larger (the model took the signal out; a residual that still changes with
    the signal stays unresolved)."""
    if not record.noise.unresolved:
        return record.noise
    again = noise_model(record.measurement.output - simulated)
    return again if not again.unresolved and again.sigma > record.noise.sigma else record.noise


def _adequacy_at(record: Record, params: Params, simulated, offset: float,
                 rule: Rule) -> tuple[Adequacy, NoiseModel, float]:
    """The adequacy test of a final model (its simulation over every sample [SI], offset included): (adequacy,
    the output noise it should leave, the measured inputs' noise through it [SI])."""
    floor = record.input_floor(params, simulated - offset)
    noise = _final_noise(record, simulated)
    sigma = math.hypot(noise.sigma, floor)
    return adequacy(record.measurement.output - simulated, sigma, noise.correlation, rule), noise, floor

