"""Diagnosis: which effect of model-spec section 4 is the model missing, and with what parameter?

Given a measurement (:mod:`mkctl.io.measurements`), :func:`diagnose` checks the record, then starts from
the file's baseline and adds effects one at a time, forward stepwise, while the evidence supports it:

0. **Prepare and check.** Measured inputs are measurements: the noise of each (the isotonic test's
   bladder pressure and load, the knee's measured pressures) is estimated from its high-frequency part
   (:func:`input_noise`), and an input noisier than its file's rounding is smoothed (:func:`smooth_input`)
   before anything is simulated, so that an effect cannot win by filtering sensor noise. A knee record
   whose commands change at many samples (a chirp) is fitted with the commands averaged over short
   blocks, checked against the full commands to stay well below the output noise. Then the baseline is
   simulated; where it leaves its domain it saturates physically (the braid limit, the end stops) and
   the report says where it could not follow. An output whose level or range the model cannot reach
   (a zeroed sensor, metres under a millimetre header) stops the diagnosis with the likely cause
   (verdict ``"not diagnosed"``), unless a constant sensor offset is fitted on request (``fit_offset``).
1. **Split** the record in time: the first 70 % trains, the last 30 % is held out. (Simulations always
   start at the beginning of the record; a held-out error is a prediction from the trained parameters.)
2. **Candidates** are the effects the experiment can show that the model does not have yet
   (:data:`CANDIDATES`): the isotonic test shows elasticity, Coulomb friction and viscous damping (its
   pressure is measured in the bladder, so a lag cannot show); the knee shows all four.
3. **Fit** each candidate's one parameter on simulation error over the training part
   (:func:`mkctl.analysis.diagnosis_rule.best_value`: log-space grid, bounded Brent, "off" as an
   option). From the second round on, each is refitted jointly with the effects already added.
4. **Judge** with the rule of :mod:`mkctl.analysis.diagnosis_rule` and its forward selection: physical
   (not switched off, not on a bound), BIC lower by more than 10 (BIC counting the effective samples when
   the output noise is correlated, :func:`noise_model`), held-out RMSE lower by 2 %, held-out RMSE better
   than every other physical candidate's by 2 %, more gained than the noise alone gives it (the null test:
   refitted on the current model's simulation plus the estimated noise) and a signature that does not go
   against the force the model lacks. When the best does not beat a rival, the two are fitted together:
   if each is needed beside the other both are added, otherwise the diagnosis stops with the verdict
   ``"undecided"``, saying plainly which effects this record cannot tell apart and which experiment
   would (:data:`DISCRIMINATING_EXPERIMENTS`). An effect that requires another (the registry's
   ``requires``) is tried together with its prerequisite when that is tied or a round stops, and in
   the wider search on top of every combination that holds it. After an acceptance, earlier effects
   that no longer earn their place are dropped.
5. **Report** a final joint fit of all added parameters on the whole record, with standard errors from
   the Jacobian of the residuals, ``cov = s^2 (J^T J)^-1``, ``s^2 = RSS / (n - k)``, widened for
   correlated residuals by ``(1 + rho) / (1 - rho)`` (rho: the residual's lag-one autocorrelation).
6. **Verdict** (:func:`verdict_of`): "diagnosed" only when the final model leaves what the noise explains,
   over the whole record and in each tenth of it (:func:`mkctl.analysis.diagnosis_rule.adequacy`: the
   output noise and the measured inputs' noise passed through the model); else "incomplete", and the
   discovery of model-spec section 6b runs. A tie is judged on the best of the tied effects (the final model
   refitted with each, :func:`_tied_rivals`): "undecided" when it reaches the noise, else neither explains the
   record and the verdict is "incomplete" (the tie still reported). Each explanation of a tie is
   reported as a whole model (``alternatives``), and the top level keeps only what they share
   (:func:`_shared_values`).

The result is a :class:`DiagnosisResult`; ``result.to_dict()`` is the JSON of model-spec section 6.
For the knee, fits are evaluated on every ``stride``-th sample (about :data:`FIT_POINTS` points, at most
:data:`MAX_FIT_SPACING` apart), so n in BIC is the number of those samples. RMSE in the steps and before/after
is over every sample. All RMSE are in the units of the file's output column; parameters are SI.

The package's modules are the stages: :mod:`.candidates` (what a record can show),
:mod:`.preparation` (measured inputs, smoothing, commands, gaps, sanity), :mod:`.noise` (the
output's AR(1) noise, the inputs' noise), :mod:`.pressure_path` (the pressure path judged on
measured pressures, through the same search), :mod:`.problem` (the fit problem, evaluation, one and
joint fits), :mod:`.search` (forward selection and the wider search), :mod:`.signatures`,
:mod:`.alternatives` (a tie as whole models), :mod:`.result` (the result and the verdict) and
:mod:`.run` (:func:`diagnose`). The acceptance rule is :mod:`mkctl.analysis.diagnosis_rule`; the
statistics are :mod:`mkctl.analysis.statistics`, the sampled-signal operations
:mod:`mkctl.analysis.signals`. This module re-exports the public API only.
"""
from __future__ import annotations

from ..equation_error import ISOTONIC_SMOOTHING_SAMPLES, KNEE_SMOOTHING_S
from .candidates import (CANDIDATES, DISCRIMINATING_EXPERIMENTS, Candidate, candidates_for,
                         experiment_to_separate)
from .noise import (MAX_NOISE_CORRELATION, MAX_NOISE_WINDOW, NOISE_WINDOW, NOISE_WINDOW_PER_TIME,
                    NOISE_WINDOWS_NEEDED, QUASI_STATIC, QUASI_STATIC_NULL_REALISATIONS,
                    SIGNAL_LEAK_CORRELATION, WHITE_NOISE_CORRELATION, NoiseModel, input_noise,
                    noise_model, output_noise, quantization_step)
from .preparation import (GAP_FACTOR, INPUT_NOISE_FLOOR, INPUT_SMOOTHING_SAMPLES, MAX_COMMAND_CHANGES,
                          PLATEAU_NOISE_FACTOR, block_commands, input_noise_through_model, command_changes, gap_note, measured_inputs,
                          output_quantity, output_range, prepare_inputs, renoised_inputs, sanity_problems,
                          saturation_note, smooth_input, time_gaps)
from .pressure_path import PressurePath, path_from_pressures, pressure_record
from .problem import FIT_POINTS, FIT_XATOL, MAX_FIT_SPACING
from .result import VERDICTS, DiagnosisResult, public, save_pictures, summary, verdict_of
from .run import diagnose
from .search import WIDER_SEARCH_FACTOR
from .signatures import signatures
# (after the stage .pressure_path: the name is the signal's function, as before)
from ..signals import pressure_path  # noqa: E402

__all__ = [
    "CANDIDATES", "DISCRIMINATING_EXPERIMENTS", "FIT_POINTS", "FIT_XATOL", "GAP_FACTOR",
    "INPUT_NOISE_FLOOR", "INPUT_SMOOTHING_SAMPLES", "ISOTONIC_SMOOTHING_SAMPLES",
    "KNEE_SMOOTHING_S", "MAX_COMMAND_CHANGES", "MAX_FIT_SPACING", "MAX_NOISE_CORRELATION",
    "MAX_NOISE_WINDOW", "NOISE_WINDOW", "NOISE_WINDOWS_NEEDED", "NOISE_WINDOW_PER_TIME",
    "PLATEAU_NOISE_FACTOR", "PressurePath", "QUASI_STATIC", "QUASI_STATIC_NULL_REALISATIONS",
    "SIGNAL_LEAK_CORRELATION", "VERDICTS", "WHITE_NOISE_CORRELATION", "WIDER_SEARCH_FACTOR",
    "Candidate", "DiagnosisResult", "NoiseModel", "block_commands", "candidates_for",
    "command_changes", "diagnose", "experiment_to_separate", "gap_note", "input_noise",
    "input_noise_through_model", "path_from_pressures", "measured_inputs",
    "noise_model",
    "output_noise", "output_quantity", "output_range", "prepare_inputs", "pressure_path",
    "pressure_record",
    "public", "quantization_step", "renoised_inputs", "sanity_problems", "saturation_note",
    "save_pictures", "signatures", "smooth_input", "summary", "time_gaps", "verdict_of",
]
