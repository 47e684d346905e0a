"""The pressure path judged on a knee file's measured bladder pressures, through the shared search.

Each muscle's measured pressure against its command is a pressure record of that muscle
(model-spec 5c): its set-point the command, its output the measured pressure, its length from the
measured motion (:func:`muscle_lengths`). The two muscles share one value of every effect
(model-spec 4), so they are diagnosed as one pressure record (:func:`pressure_record`): the
flexor's record follows the extensor's after a pause long enough for any pressure path the search
can name to settle at the flexor's first command (:data:`SETTLE_FACTOR`), so that the flexor starts
as a muscle that has rested under its first command. That record goes through the same stages as
any pressure record (:func:`mkctl.analysis.diagnose.diagnose`: the candidates of a pressure record
from the effects' own definitions, the rule's interleaved held-out samples, the null test, the air's
identified values), so a lag, an asymmetric lag, a dead time, the valve's flow, a leak and the
air's heat are told apart by the same rule as on a pressure record.

An effect found there that only delays the command (no pressure state: a dead time alone) leaves
the modelled pressure a delayed copy of the command, sample by sample: the pressures place the
delay only to within a sample, and the motion, which follows it continuously, fits it instead
(:attr:`PressurePath.motion`).
"""
from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np

from ...errors import MkctlError
from ...io.measurements import Measurement
from ...physics import actuator, effects, knee
from ...physics.params import Params
from ..diagnosis_rule import RULE, Rule
from ..equation_error import KNEE_SMOOTHING_S
from ..filters import savgol_filter
from .candidates import holds_pressure, path_effect
from .preparation import gap_note

#: Each muscle's command column and measured pressure column of a knee record (model-spec 5).
MUSCLES = (("pe_cmd", "pe"), ("pf_cmd", "pf"))

#: The pause between the two muscles' records, in units of the record's duration (at least
#: :data:`SETTLE_MIN`): a path slower than that could not be told from a drift on the record itself.
SETTLE_FACTOR = 10.0
#: ... and at least this long [s].
SETTLE_MIN = 10.0

__all__ = ["MUSCLES", "PressurePath", "muscle_lengths", "path_from_pressures", "pressure_record",
           "step_share"]


@dataclass(frozen=True)
class PressurePath:
    """What the measured pressures show: the diagnosis of their pressure record, the knee's
    parameters with what it found (for the motion), what is left to the motion, and the report.

    ``report`` is the JSON of the result's ``pressure_lag`` key (docs/diagnosis.md): ``accepted``
    (an effect of the path was found), ``tau`` and ``uncertainty`` (the lag's time constant and its
    standard error, when one was found), ``candidate`` (the best candidate's row of the first
    round, RMSE in kPa), ``reason``, ``path`` (``effects``, ``values``, ``uncertainty``,
    ``undecided``, ``motion``), ``verdict``, ``rmse_kPa``, ``noise_kPa``, ``identified``, ``notes``
    and ``steps``.
    """

    result: object  #: the :class:`~mkctl.analysis.diagnose.result.DiagnosisResult` of the record
    params: Params  #: the knee's parameters with the effects the pressures show
    motion: tuple  #: effects found that only delay the command, left to the motion
    report: dict

    @property
    def simulated(self):
        """The measured pressures as the path found models them: (extensor, flexor) [Pa] over the
        knee record's samples (:func:`pressure_record`'s two parts), or None."""
        curve = self.result.simulated_after
        if curve is None:
            return None
        n = (np.size(curve) - 1) // 2
        return np.vstack([curve[:n], curve[n + 1:]])


def _state_free(effect) -> bool:
    """An effect that only delays the command: no pressure state of its own (a dead time)."""
    return effect.command_delay is not None and not holds_pressure(effect)


def muscle_lengths(measurement: Measurement, params: Params):
    """Each muscle's length [m] over the record, from the measured motion (smoothed as the
    equation error smooths it, :data:`~mkctl.analysis.equation_error.KNEE_SMOOTHING_S`), or None
    where the measured motion is outside the knee's geometry.

    Parameters
    ----------
    measurement : Measurement
        A knee record (output ``x`` or ``beta``).
    params : Params
        The knee's lengths (Table II) and the muscle (Table I).

    Returns
    -------
    tuple of numpy.ndarray or None
        The extensor's and the flexor's lengths [m].
    """
    m = measurement
    X = (knee.hip_height(m.output, params) if m.output_quantity == "beta"
         else np.asarray(m.output, float))
    if m.samples > 7:
        dt = float(np.median(np.diff(m.time)))
        window = min(max(5, int(round(KNEE_SMOOTHING_S / dt)) | 1), (m.samples - 2) | 1)
        X = savgol_filter(X, window, 3)
    try:
        geometry = knee.geometry_at_X(X, params, derivatives=False)
        lengths = (np.asarray(geometry.Le, float), np.asarray(geometry.Lf, float))
        for L in lengths:
            actuator.check_length(L, params.b)
    except MkctlError:
        return None
    return lengths


def pressure_record(measurement: Measurement, params: Params) -> Measurement:
    """Both muscles' measured pressures as one pressure record (model-spec 5c; module docstring).

    The extensor's samples, one sample halfway through the pause at which the command steps to the
    flexor's first one, then the flexor's samples. At that sample a path with a state still holds
    the extensor's last pressure, one faster than a sample already the new command: its measured
    value moves from the extensor's last by the share of the step that the record's own pressures
    move at the samples where their commands step (:func:`step_share`), so that it is explained by
    whatever explains the record's own steps. Lengths from the measured motion
    (:func:`muscle_lengths`), else held at L0.

    Parameters
    ----------
    measurement : Measurement
        A knee record with measured pressures ``pe``, ``pf``.
    params : Params
        The knee's parameters: the pressure record's baseline.

    Returns
    -------
    Measurement
        An ``experiment = pressure`` record in kPa, its ``length`` column the muscles' lengths.
    """
    m = measurement
    t = m.time - m.time[0]
    pause = max(SETTLE_FACTOR * float(t[-1]), SETTLE_MIN)
    lengths = muscle_lengths(m, params)
    (first_cmd, first), (second_cmd, second) = MUSCLES
    time = np.concatenate([t, [t[-1] + 0.5 * pause], t + t[-1] + pause])
    command = np.concatenate([m.inputs[first_cmd], [m.inputs[second_cmd][0]], m.inputs[second_cmd]])
    share = step_share([m.inputs[c] for c, _ in MUSCLES], [m.inputs[p] for _, p in MUSCLES])
    pause_value = m.inputs[first][-1] + share * (m.inputs[second_cmd][0] - m.inputs[first_cmd][-1])
    measured = np.concatenate([m.inputs[first], [pause_value], m.inputs[second]])
    inputs = {"p_cmd": command}
    if lengths is not None:
        inputs["length"] = np.concatenate([lengths[0], [lengths[1][0]], lengths[1]])
    return Measurement(
        experiment="pressure", baseline=m.baseline, params=params, overrides=dict(m.overrides),
        time=time, inputs=inputs, output=measured, output_column="p_kPa", output_factor=1e3,
        source=f"{m.source} (measured pressures)", output_quantity="p")


def step_share(commands, pressures) -> float:
    """The share of a command's step that the measured pressure moves at the sample where the
    command steps (least squares over every step of every muscle, within 0..1): 1 for pressures that
    follow their commands within a sample, 0 for a path with a state (a lag, a valve) or a delay.

    Parameters
    ----------
    commands, pressures : sequence of numpy.ndarray
        Each muscle's commands and measured pressures [Pa].

    Returns
    -------
    float
        0 when no command steps.
    """
    moved, stepped = [], []
    for command, pressure in zip(commands, pressures):
        steps = np.flatnonzero(np.diff(command) != 0) + 1
        moved.append(pressure[steps] - pressure[steps - 1])
        stepped.append(command[steps] - command[steps - 1])
    moved, stepped = np.concatenate(moved), np.concatenate(stepped)
    if not stepped.size:
        return 0.0
    return float(np.clip(moved @ stepped / (stepped @ stepped), 0.0, 1.0))


def path_from_pressures(measurement: Measurement, params: Params, diagnose, rule: Rule = RULE,
                        progress=None) -> PressurePath | None:
    """The pressure path judged on a knee record's measured pressures (module docstring), or None
    without them, or when the record's baseline already has an effect on the path (its file
    declares it: the measured pressures then drive the motion).

    Parameters
    ----------
    measurement : Measurement
        A knee record.
    params : Params
        Its baseline.
    diagnose : callable
        The diagnosis of a pressure record, ``diagnose(record, progress=..., rule=...)``
        (:func:`mkctl.analysis.diagnose.diagnose`, which calls this: handed in, not imported).
    rule : Rule
        The acceptance rule (:data:`mkctl.analysis.diagnosis_rule.RULE`).
    progress : callable, optional
        Receives the pressure record's progress lines.

    Returns
    -------
    PressurePath or None
    """
    m = measurement
    columns = [name for pair in MUSCLES for name in pair]
    if m.experiment != "knee" or not all(name in m.inputs for name in columns):
        return None
    if any(path_effect(e) for e in actuator.active_effects(params)):
        return None
    record = pressure_record(m, params)
    say = progress or (lambda text: None)
    try:
        result = diagnose(record, progress=lambda text: say("  pressures: " + text), rule=rule)
    except MkctlError as error:  # the measured pressures then drive the motion as they are
        say(f"  pressures: not judged ({error})")
        return None
    found = list(result.missing)
    motion = tuple(e for e in found if all(_state_free(effects.get(f)) for f in found))
    path_params = result.params_after if result.params_after is not None else params
    if motion:
        path_params = params
    # the pause between the muscles is no gap of the user's record
    notes = [text for text in result.notes if text != gap_note(record)]
    result = dataclasses.replace(result, notes=notes)
    return PressurePath(result, path_params, motion, _report(result, motion))


def _report(result, motion: tuple) -> dict:
    """The JSON of :class:`PressurePath` (its docstring)."""
    effects_ = [] if motion else list(result.missing)
    values = {} if motion else dict(result.params)
    uncertainty = {} if motion else dict(result.uncertainty)
    rounds = result.steps or ([result.stopped] if result.stopped else [])
    rows = rounds[0].get("candidates", []) if rounds else []
    best = next((r for r in rows if r.get("effect") == (result.missing or [None])[0]), None) or \
        (rows[0] if rows else None)
    candidate = None
    if best is not None:
        candidate = {"effect": best["effect"], "params": dict(best.get("params", {})),
                     "rmse_train_kPa": best.get("rmse_train"),
                     "rmse_holdout_kPa": best.get("rmse_holdout"),
                     "delta_bic": best.get("delta_bic"), "passes_bic": best.get("passes_bic"),
                     "passes_holdout": best.get("passes_holdout"),
                     "switched_off": best.get("switched_off"), "at_bound": best.get("at_bound")}
    reason = (result.stopped or {}).get("reason") if not result.missing else \
        f"{' + '.join(result.missing)} found on the measured pressures (verdict {result.verdict})"
    lag_parameter = _lag_parameter(result.missing)
    return {
        "accepted": bool(result.missing),
        "tau": values.get(lag_parameter) if lag_parameter else None,
        "uncertainty": uncertainty.get(lag_parameter) if lag_parameter else None,
        "candidate": candidate, "reason": reason,
        "path": {"effects": effects_, "values": values, "uncertainty": uncertainty,
                 "undecided": [dict(u) for u in result.undecided], "motion": list(motion)},
        "verdict": result.verdict, "rmse_kPa": result.rmse_after,
        "rmse_before_kPa": result.rmse_before, "noise_kPa": result.output_noise,
        "identified": dict(result.identified), "notes": list(result.notes), "steps": result.steps,
    }


def _lag_parameter(found) -> str | None:
    """The time constant of a first-order lag among the effects found (an effect with an exact
    pressure step and a fitted time constant), for the report's ``tau``."""
    for name in found:
        effect = effects.get(name)
        if effect.pressure_step is not None and effect.fitted and not effect.requires:
            return effect.fitted
    return None
