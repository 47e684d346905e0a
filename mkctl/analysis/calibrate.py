"""Calibrate a user's own muscle: fit the parameters nobody can measure from blocked-force and isotonic
tests, then add the effects the data support (model-spec section 5b).

:func:`calibrate` takes one or more measurements of the same muscle (``isometric``, ``isotonic``
and/or ``actuator``, model-spec sections 5 and 5d) and works on forces throughout, so that records
of every kind share one error in N:

- isometric: the measured tension against :func:`mkctl.physics.isometric.isometric_tension` at the clamped
  length, the pressure and the branch;
- isotonic: the hanging load against the model's tension at the *measured* length and pressure (the
  quasi-static balance ``f(L, P) = F``, an equation error, cheap and in N). With Coulomb friction the
  balance holds at the edge of the +-Fc band the motion pushes to (lengthening: ``F = f + Fc``); where
  the length does not move (within its noise) the load may lie anywhere inside the band, and only the
  distance outside it counts;
- driven length (``actuator``): the measured tension against the model's with every effect at the
  imposed length, its rate and the measured pressure (:func:`driven_record`). Here the muscle moves
  at speed, so the effects that act only in motion (viscous damping, a user's drag:
  :data:`MOTION_CANDIDATES`) are candidates too.

The fit, step by step (each step's NRMS is shown, and drawn in the error-fall figure):

1. **start**: the files' parameters (metadata, ``--params``, else Table I), nothing fitted.
2. **static fit**: model 2 with ``b, n, C1, C2`` (and any of ``L0, D0, t0, offset`` asked for with
   ``fit=``) by bounded least squares (``scipy.optimize.least_squares``, trust-region reflective) from
   several starting points (:func:`starting_points`); the best is kept. Its NRMS is ``nrms_before``.
3. **effects**, forward stepwise as in model-spec section 6: each candidate (:data:`CANDIDATES`, the registry's
   effects marked ``calibrate``: ``slack``, ``coulomb_friction``, ``pressure_friction``, ``pressure_threshold``
   and any user effect so marked) is fitted *together with the static parameters* on a training part (three of
   every four points of each record; every fourth is held out), scored by
   ``BIC = n ln(RSS / n) + k ln n`` on the training part and by its RMS error on the held-out points,
   and judged by the diagnosis's rule and forward selection (:mod:`mkctl.analysis.diagnosis_rule`): the
   best is added only if it lowers BIC by more than ``Rule.bic_threshold`` (10) and the held-out error by
   at least ``Rule.holdout_gain`` (2 %), and is not switched off (Fc = 0). When the held-out points do
   not separate it from the other candidate by ``Rule.holdout_margin``, the lower BIC is added and a note
   says so. Then all parameters are refitted on every point and the next round starts. ``slack`` is a
   switch, counted as one parameter.

Physical bounds keep every trial muscle a real one: ``b`` above every measured length and below ``L0 / cos 80 deg`` (a braid angle at rest below 80 deg),
``n`` in (0.05, 200), ``C1, C2, Fc >= 0``, ``D0 > 2 t0 > 0``. **n is fitted freely** (not tied to D0 by
model-spec section 2's ``n = sqrt(b^2 - L0^2) / (pi D0)``): with D0 the bladder's measured outer diameter,
the braid's rest diameter ``sqrt(b^2 - L0^2) / (pi n)`` need not equal it (a loose or a tight braid,
the end caps), and tying them would leave the pressure term one degree of freedom short (Tondu and
Lopez's correction factor plays this part in theirs). The result reports that braid diameter next to
D0. ``link_n=True`` ties n to b, L0, D0 as model-spec section 2 does (n is then not fitted).

Once the effects are chosen, the final model is fitted again from every starting point: a run that ends
as well (RSS within ``EQUALLY_GOOD`` s^2 of the best) but more than 3 standard errors away in some
parameter means the data do not pin that parameter down; it is reported in ``ambiguous`` with the other
values, and gets no standard error (typically L0 and D0 when they are fitted too: the rubber's terms
trade them against C1).

Uncertainty: ``cov = s^2 (J^T J)^-1`` with ``s^2 = RSS / (N - k)`` and J the Jacobian of the force
residuals at the optimum; the standard errors are its diagonal's roots. Two fitted parameters whose
estimates correlate by more than ``IDENTIFIABLE_CORRELATION`` (|r| > 0.99) cannot be separated by these
data: they are reported as ``not_identifiable`` (C1 and C2 on force data, typically: the rubber's two
terms have nearly the same shape over the lengths of a blocked-force test) with no standard error for
either, one of the group is held and the rest refitted, so that the numbers in ``params`` remain a usable
muscle: the later one at its starting value (the file's, or Table I's), unless that makes the fit clearly
worse, in which case the one the free fit drives to a bound is held on it (short muscles: C1 at 0), or else
the later one where the free fit put it (:func:`_choose_held`; the note says which and why). A parameter that ends on a
bound is listed in ``at_bound``.

``NRMS`` is the RMS force error divided by the range of the measured forces (max - min over all points).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import DomainError, MkctlError, ParameterError
from ..physics import actuator, effects
from ..physics.isometric import isometric_tension
from ..physics.params import UNITS, LiveMapping, LiveSequence, Params
from ..results import Result, plain
from .diagnosis_rule import RULE, Candidate as Outcome, Rule, Score, forward_selection, judge
from .calibration_problem import (  # noqa: F401 (OPTIONAL, STATIC: re-exported)
    ASSUMED, B_OVER_L0, EQUALLY_GOOD, FORCE_SENSOR_RECORDS, MAX_BRAID_ANGLE, MAX_EVALUATIONS, OPTIONAL,
    STATIC, Fit, ForceModel, ambiguous_values, bounds_of, check_converged, check_one_muscle,
    fit_least_squares, fit_standard_errors, fit_uncertainty, force_nrms, is_offset, merged_metadata,
    offset_names, scale_of, starting_points)
from .force_records import (  # noqa: F401 (re-exported: calibrate's records)
    READING_BRAID, CalibrationError, ForceRecord, check_records, driven_record, force_record,
    isometric_record, motion_direction, read_records, reading_base)
from .calibration_pictures import (  # noqa: F401 (re-exported)
    plot_error_fall, plot_fits, summary)



def _acts_in_motion_only(effect) -> bool:
    """Whether an effect adds to the tension only where the muscle moves (damping, a user's drag):
    not a candidate of the quasi-static tests, one of a driven-length record (model-spec 5d)."""
    return (not effect.calibrate and effect.tension is not None and effect.fitted is not None
            and effect.fitted not in STATIC and not effect.is_switch
            and effect.pressure_rate is None and effect.command_delay is None)


#: The effects calibrate can add (those of the registry marked ``calibrate``, and those that act
#: only in motion, :data:`MOTION_CANDIDATES`), in the order they are tried (switches first), with
#: the parameter each brings (None for a switch).
CANDIDATES = LiveMapping(lambda: {
    e.name: None if e.is_switch else e.fitted
    for e in sorted((e for e in effects.all_effects() if e.calibrate or _acts_in_motion_only(e)),
                    key=lambda e: not e.is_switch)})
#: The candidates only a driven-length record shows (its muscle moved at speed): tried only with
#: one.
MOTION_CANDIDATES = LiveSequence(lambda: [e.name for e in effects.all_effects()
                                          if _acts_in_motion_only(e)])
#: Every point whose index in its record is ``HOLDOUT_EVERY - 1`` modulo this is held out.
HOLDOUT_EVERY = 4




# --- The result --------------------------------------------------------------------------------------

@dataclass(repr=False)
class CalibrationResult(Result):
    """What :func:`calibrate` found: the calibrated muscle, its uncertainty, and the error fall step by step.

    Numbers are SI; NRMS values are fractions (0.02 = 2 % of the measured force range).
    """

    params: Params  #: the calibrated muscle (every section 2 and 4 parameter)
    fitted: dict  #: the fitted values by name (SI), the force offsets [N] included when fitted (:func:`offset_names`)
    stderr: dict  #: standard errors by name; absent for parameters in ``not_identifiable``
    not_identifiable: list  #: groups of names the data cannot separate, e.g. [["C1", "C2"]]
    ambiguous: dict  #: names that another, equally good fit puts elsewhere: {name: [other values]}
    held: dict  #: names held at their starting value because they are not identifiable
    at_bound: list  #: fitted names that ended on a bound
    effects: list  #: effects added, in order
    nrms_start: float | None  #: the files' parameters, nothing fitted (None if they cannot model the data)
    nrms_before: float  #: the static fit, no effects
    nrms_after: float  #: the final fit
    rms_after: float  #: [N]
    steps: list  #: one dict per step: label, effects, nrms, rms [N], and the candidates of each round
    correlation: dict  #: {"names": [...], "matrix": [[...]]} of the final fit's estimates
    braid_diameter: float  #: the braid's rest diameter sqrt(b^2 - L0^2) / (pi n) [m], next to D0
    converged: bool
    evaluations: int  #: model evaluations over all least-squares runs
    sources: list  #: the records' sources
    points: int
    notes: list  #: plain sentences: defaults used, bounds hit, what the data cannot tell
    stopped: dict | None = None  #: why no further effect was added: reason and the candidates of that round
    records: list = field(repr=False, default_factory=list)
    curves: dict = field(repr=False, default_factory=dict)  #: step label -> (Params, each record's offset [N])

    @property
    def assumed(self) -> list[str]:
        """The defaults assumed for what the files did not give (L0, D0, t0 from Table I): each a warning the
        command line prints on stderr, and the muscle file's ``assumed``."""
        return [note.removeprefix(ASSUMED) for note in self.notes if note.startswith(ASSUMED)]

    def summary_lines(self) -> list[str]:
        fitted = ", ".join(f"{k} = {v:.4g}" + (f" +- {self.stderr[k]:.2g}" if k in self.stderr else "")
                           for k, v in self.fitted.items())
        lines = [f"effects {', '.join(self.effects) or 'none'}; NRMS {self.nrms_before:.2%} (static fit) -> "
                 f"{self.nrms_after:.2%}", fitted]
        if self.not_identifiable:
            lines.append("not identifiable: " + "; ".join(" with ".join(g) for g in self.not_identifiable))
        if self.at_bound:
            lines.append("on a bound: " + ", ".join(self.at_bound))
        return lines

    def table(self):
        """The steps: step, effects, NRMS, RMS [N], BIC (training part) and held-out RMS [N] where known."""
        return [{"step": s["label"], "effects": ", ".join(s["effects"]), "nrms": s["nrms"], "rms_N": s["rms"],
                 "bic": s.get("bic"), "rms_holdout_N": s.get("rms_holdout")} for s in self.steps]

    def to_dict(self) -> dict:
        """The muscle file's content (model-spec section 5b), plain JSON values."""
        params = self.params.as_dict()
        return plain({
            "params": params,
            "units": {k: UNITS.get(k, "1") for k in params},
            "effects": list(self.effects),
            "nrms_before": self.nrms_before,
            "nrms_after": self.nrms_after,
            "nrms_start": self.nrms_start,
            "rms_after_N": self.rms_after,
            "fitted": dict(self.fitted),
            "stderr": dict(self.stderr),
            "not_identifiable": [list(g) for g in self.not_identifiable],
            "ambiguous": dict(self.ambiguous),
            "held": dict(self.held),
            "at_bound": list(self.at_bound),
            "correlation": self.correlation,
            "braid_diameter": self.braid_diameter,
            "converged": self.converged,
            "sources": list(self.sources),
            "points": self.points,
            "notes": list(self.notes),
            "assumed": self.assumed,
            "stopped": self.stopped,
            "steps": [{k: v for k, v in s.items()} for s in self.steps],
        })


# --- What the data say on their own ------------------------------------------------------------------

#: The friction-gap check (:func:`hysteresis_growth`) calls a growth real when the slope is this many standard
#: errors from zero and the gap at high pressure is at least this factor times the gap at low pressure.
GROWTH_SIGMAS, GROWTH_FACTOR = 5.0, 1.5


def hysteresis_growth(records: list[ForceRecord], muscle: Params | None = None) -> dict | None:
    """How the gap between the rising and falling branches of the isometric records changes with pressure.

    At a clamped length the measured tension is ``f - Fc`` on the rising branch and ``f + Fc`` on the falling
    one (model-spec section 5), so half the gap between the branches at one pressure is the friction there,
    whatever the static model. The falling branch is interpolated at the rising branch's pressures, length by
    length, and ``half gap = a + b P`` is fitted over all of them by least squares. Returns None without two
    branches to compare, else {"low": (P [Pa], half gap [N]), "high": (P, half gap), "slope": b [N/Pa],
    "slope_stderr", "grows": whether the gap grows clearly (:data:`GROWTH_SIGMAS`, :data:`GROWTH_FACTOR`)}:
    a friction that grows with pressure, which the spec's constant Fc cannot follow; "intercept": a [N].

    ``muscle``: a calibrated muscle with slack on; the points where its rising branch is slack (tension 0) are
    left out, for there the branches are not 2 (Fc + Fc_p P) apart but clipped at zero (a short muscle at low
    pressure), which would bend the line.
    """
    pressures, gaps = [], []
    for r in records:
        if r.experiment != "isometric":
            continue
        for length in np.unique(np.round(r.length, 7)):
            at = np.isclose(r.length, length, rtol=0, atol=1e-7)
            up, down = at & (r.sign > 0), at & (r.sign < 0)
            if up.sum() < 3 or down.sum() < 3:
                continue
            order = np.argsort(r.pressure[down])
            P_down, F_down = r.pressure[down][order], r.force[down][order]
            inside = up & (r.pressure >= P_down[0]) & (r.pressure <= P_down[-1])
            if muscle is not None and muscle.slack:
                inside &= isometric_tension(r.length, r.pressure, 1.0, muscle) > 0
            pressures.append(r.pressure[inside])
            gaps.append(0.5 * (np.interp(r.pressure[inside], P_down, F_down) - r.force[inside]))
    if not pressures:
        return None
    P, gap = np.concatenate(pressures), np.concatenate(gaps)
    if P.size < 6 or np.ptp(P) <= 0:
        return None
    design = np.column_stack([np.ones_like(P), P])
    (a, b), *_ = np.linalg.lstsq(design, gap, rcond=None)
    residual = gap - design @ np.array([a, b])
    sigma2 = float(residual @ residual) / max(P.size - 2, 1)
    stderr = math.sqrt(sigma2 * float(np.linalg.inv(design.T @ design)[1, 1]))
    low, high = float(np.percentile(P, 10)), float(np.percentile(P, 90))
    gap_low, gap_high = float(a + b * low), float(a + b * high)
    grows = bool(b > GROWTH_SIGMAS * stderr and gap_high > GROWTH_FACTOR * max(gap_low, 0.0) and gap_high > 0)
    return {"low": (low, gap_low), "high": (high, gap_high), "slope": float(b), "slope_stderr": stderr,
            "grows": grows, "intercept": float(a)}


# --- The calibration ---------------------------------------------------------------------------------

def calibrate(measurements, fit=(), params: Params | None = None, link_n: bool = False,
              effects=tuple(CANDIDATES), max_evaluations: int = MAX_EVALUATIONS, progress=None,
              rule: Rule = RULE) -> CalibrationResult:
    """Calibrate one muscle on its measurements (see the module docstring for the method).

    Parameters
    ----------
    measurements : list
        Isometric, isotonic and/or driven-length (``actuator``)
        :class:`mkctl.io.measurements.Measurement` (or :class:`ForceRecord`, e.g. from
        :func:`isometric_record`), all of the same muscle.
    fit : iterable of str
        Names fitted besides ``b, n, C1, C2``: any of ``L0, D0, t0`` (else taken from the files' metadata,
        then ``params``, then Table I) and ``offset``, a force sensor's zero offset [N] on isometric records: one
        per isometric record (``offset_1``, ``offset_2``, ... when there are several, see :func:`offset_names`).
    params : Params
        What is known (and the start of the fit); the files' metadata wins over it. Default: Table I.
    link_n : bool
        Tie n to b, L0, D0 (model-spec section 2) instead of fitting it.
    effects : iterable of str
        The candidate effects (default both of :data:`CANDIDATES`); ``()`` fits the static model only.
    max_evaluations : int
        Cap on the model evaluations of each least-squares run, per fitted parameter plus one.
    progress : callable or None
        Called with a line of text at each step.
    rule : Rule
        The acceptance rule's thresholds (:data:`mkctl.analysis.diagnosis_rule.RULE`); the held-out points are
        every :data:`HOLDOUT_EVERY`-th of each record (the points of a quasi-static test have no time order
        to hold out the end of).

    Returns
    -------
    CalibrationResult. Raises :class:`CalibrationError` for unusable records or a fit that does not converge.
    """
    say = progress or (lambda text: None)
    records = [force_record(m) for m in measurements]
    check_records(records)
    extra = _check_arguments(records, fit, effects)
    notes: list = []
    start, names = _starting_muscle(records, params, extra, link_n, notes)
    force = np.concatenate([r.force for r in records])
    force_range = float(np.ptp(force))
    if force_range <= 0:
        raise CalibrationError("every measured force is the same: nothing to calibrate on")
    fitter = _Fitter(records, names, link_n, max_evaluations)
    steps, curves = [], {}
    _record_start(records, start, force_range, steps, curves, say)
    static_starts = starting_points(records, start, names)
    say(f"static fit of {', '.join(names)} from {len(static_starts)} starting points")
    current, current_model, _ = fitter.fit([], start, static_starts)
    check_converged(current, "the static fit", max_evaluations, force_range)
    nrms_before = force_nrms(current.residual, force_range)
    curves["static fit"] = (current.params, current_model.offsets(current.values))
    steps.append({"label": "static fit", "effects": [], "nrms": nrms_before, "rms": nrms_before * force_range,
                  "params": dict(current.values)})
    say(f"static fit: NRMS {nrms_before:.2%}")
    selection = _EffectSelection(fitter, records, static_starts, force_range, rule, steps, curves, notes, say)
    current, current_model, added, stopped = selection.run(current, current_model,
                                                           candidates_for(records, effects))
    current, current_model, uncertainty, ambiguous = _refit_from_every_start(fitter, current, current_model, added,
                                                                             static_starts, force.size, notes)
    current, stderr, correlation, groups, held = _separate(fitter, current, current_model, uncertainty, start,
                                                           ambiguous, notes)
    at_bound = _settle_bounds(records, current, notes)
    _note_hysteresis(records, current, notes, added, stderr, effects)
    nrms_after = force_nrms(current.residual, force_range)
    fitted = {n: current.values[n] for n in (*names, *[CANDIDATES[e] for e in added if CANDIDATES[e]])
              if n in current.values}
    params_final = current.params
    braid = math.sqrt(params_final.b ** 2 - params_final.L0 ** 2) / (math.pi * params_final.n)
    curves["final"] = (params_final, current_model.offsets(current.values))
    if abs(nrms_after - steps[-1]["nrms"]) > 1e-3 * steps[-1]["nrms"]:  # holding a parameter cost something
        steps.append({"label": "final (" + ", ".join(held) + " held)", "effects": list(added), "nrms": nrms_after,
                      "rms": nrms_after * force_range, "params": dict(current.values)})
    return CalibrationResult(
        params=params_final, fitted=fitted, stderr=stderr, not_identifiable=[list(g) for g in groups], ambiguous=ambiguous,
        held=held,
        at_bound=at_bound, effects=list(added), nrms_start=steps[0]["nrms"], nrms_before=nrms_before,
        nrms_after=nrms_after,
        rms_after=nrms_after * force_range, steps=steps, correlation=correlation, braid_diameter=braid,
        converged=current.converged, evaluations=fitter.evaluations, sources=[r.source for r in records],
        points=int(force.size), notes=notes, stopped=stopped, records=records, curves=curves)


def candidates_for(records: list[ForceRecord], chosen=tuple(CANDIDATES)) -> list[str]:
    """The candidates (of ``chosen``) tried on these records, in order: those that act only in
    motion (:data:`MOTION_CANDIDATES`) where a driven-length record moved the muscle."""
    moving = any(r.velocity is not None for r in records)
    return [e for e in CANDIDATES if e in chosen and (moving or e not in MOTION_CANDIDATES)]


def _check_arguments(records: list[ForceRecord], fit, effects) -> tuple:
    """The extra names asked for (``fit``), checked with the effects against what calibrate can do."""
    extra = tuple(dict.fromkeys(fit))
    unknown = [n for n in extra if n not in (*STATIC, *OPTIONAL)]
    if unknown:
        raise CalibrationError(f"cannot fit {unknown[0]!r}: calibrate fits {', '.join(STATIC)} and, on request, "
                               f"{', '.join(OPTIONAL)}")
    bad_effects = [e for e in effects if e not in CANDIDATES]
    if bad_effects:
        raise CalibrationError(f"unknown effect {bad_effects[0]!r} (calibrate can add {', '.join(CANDIDATES)})")
    if "offset" in extra and not any(r.experiment in FORCE_SENSOR_RECORDS for r in records):
        raise CalibrationError("offset is a force sensor's offset on isometric or actuator "
                               "records; there is none here")
    return extra


def _starting_muscle(records: list[ForceRecord], params: Params | None, extra: tuple, link_n: bool,
                     notes: list) -> tuple[Params, tuple]:
    """Step 1: the start (metadata over ``params`` over Table I, a braid around the longest length) and the
    names fitted; notes what was not given."""
    metadata = merged_metadata(records)
    start = (params or Params())
    longest = max(float(r.length.max()) for r in records)
    check_one_muscle(records)
    # L0 is given by a file's metadata, --fit L0, or a muscle file (--params) with a length of its own
    l0_given = "L0" in metadata or "L0" in extra or (params is not None and params.L0 != Params().L0)
    if not l0_given and longest > Params().b:
        raise CalibrationError(
            f"the muscle's length at rest L0 is not given and the measured lengths reach {longest:g} m, beyond "
            f"Table I's braid length b = {Params().b:g} m: this is not Table I's muscle, whose L0 = "
            f"{Params().L0:g} m would be assumed; give its L0 with '# L0 = ...' in each file (or --params "
            f"MUSCLE.json, or fit it with --fit L0)")
    for name in ("L0", "D0", "t0"):
        if params is None and name not in metadata and name not in extra:
            notes.append(f"{ASSUMED}{name} not given (metadata '# {name} = ...' or --params): Table I's "
                         f"{getattr(Params(), name):g} {UNITS[name]} used")
    # every effect calibrate may add starts off (a muscle file's earlier fit included): the steps decide
    off = {q.name: q.off for q in (effects.get(e).switch_parameter for e in CANDIDATES)}
    values = {**metadata, "model": 2, **off}
    if "b" not in metadata:  # the start's braid must fit around these lengths (the fit moves it anyway)
        values["b"] = max(start.b, 1.15 * max(metadata.get("L0", start.L0), longest))
    start = start.replace(**values)
    names = tuple(n for n in STATIC if not (link_n and n == "n")) + tuple(n for n in OPTIONAL if n in extra
                                                                      and n != "offset")
    if "offset" in extra:
        names += tuple(n for n in offset_names(records) if n)
        if sum(1 for n in offset_names(records) if n) > 1:
            notes.append("one force offset per isometric file: " + ", ".join(
                f"{n} for {Path(r.source).name}" for n, r in zip(offset_names(records), records) if n))
    if "L0" not in names and longest >= start.L0 * B_OVER_L0:
        default = "L0" not in metadata and (params is None or params.L0 == Params().L0)
        raise CalibrationError(f"a measured length {longest:g} m is not below the braid length b of any physical braid "
                               f"with L0 = {start.L0:g} m (b < L0 / cos {MAX_BRAID_ANGLE:g} deg = "
                               f"{start.L0 * B_OVER_L0:.4g} m): check the length unit and L0"
                               + (f" (L0 = {start.L0:g} m is Table I's length at rest, a default: give yours with "
                                  f"'# L0 = ...')" if default else ""))
    return start, names


class _Fitter:
    """Fits the static names plus the chosen effects' parameters; counts the model evaluations."""

    def __init__(self, records: list[ForceRecord], names: tuple, link_n: bool, max_evaluations: int):
        self.records, self.names, self.link_n, self.max_evaluations = records, names, link_n, max_evaluations
        self.evaluations = 0

    def fit(self, effect_list, base: Params, starts, mask=None):
        """Fit from each start (on the points in mask); returns (Fit, its ForceModel, k counting slack as one)."""
        switches = [e for e in CANDIDATES if CANDIDATES[e] is None]  # on or off, nothing to fit (slack)
        base = base.replace(**{q.name: q.on_value if e in effect_list else q.off
                               for e, q in ((e, effects.get(e).switch_parameter) for e in switches)})
        fit_names = self.names + tuple(CANDIDATES[e] for e in effect_list if CANDIDATES[e])
        model = ForceModel(self.records, base, fit_names, self.link_n)
        pairs = [bounds_of(n, self.records, base, fit_names) for n in fit_names]
        lows, highs = np.array([p[0] for p in pairs]), np.array([p[1] for p in pairs])
        full_starts = [{n: s.get(n, 0.0 if is_offset(n) else getattr(base, n, 0.0)) for n in fit_names}
                       for s in starts]
        result = fit_least_squares(model, full_starts, lows, highs, mask, self.max_evaluations)
        self.evaluations += result.evaluations
        return result, model, len(fit_names) + sum(1 for e in effect_list if e in switches)


def _record_start(records, start: Params, force_range: float, steps: list, curves: dict, say) -> None:
    """Step 0 of the error fall: the files' parameters, nothing fitted (None outside the model's domain)."""
    try:
        nrms_start = force_nrms(ForceModel(records, start, (), False).residual_values({}), force_range)
    except (DomainError, ParameterError):
        nrms_start = None
    steps.append({"label": "start", "effects": [], "nrms": nrms_start,
                  "rms": None if nrms_start is None else nrms_start * force_range, "params": {}})
    if nrms_start is not None:
        curves["start"] = (start, (0.0,) * len(records))
    say("start (the files' parameters): NRMS " + ("n/a (outside the model's domain)" if nrms_start is None
                                                   else f"{nrms_start:.2%}"))


class _EffectSelection:
    """Step 3: the effects, by the diagnosis's forward selection and rule
    (:func:`mkctl.analysis.diagnosis_rule.forward_selection`), each candidate fitted with the static names on
    the training points."""

    def __init__(self, fitter: _Fitter, records, static_starts, force_range: float, rule: Rule, steps: list,
                 curves: dict, notes: list, say):
        self.fitter, self.records, self.static_starts, self.force_range = fitter, records, static_starts, force_range
        self.rule, self.steps, self.curves, self.notes, self.say = rule, steps, curves, notes, say
        self.holdout = np.concatenate([np.arange(r.size) % HOLDOUT_EVERY == HOLDOUT_EVERY - 1 for r in records])
        self.train = ~self.holdout
        self.added: list[str] = []
        self.rows: dict = {}

    def score(self, fit_train: Fit, k: int) -> Score:
        """The rule's score of a fit on the training points: BIC there, RMS error [N] on the held-out points."""
        r = fit_train.residual
        return Score.from_residuals(r[self.train], r[self.holdout], k)

    def run(self, current: Fit, model: ForceModel, pending: list):
        """Select among ``pending``; returns (final fit, its model, the effects added, the round that stopped)."""
        self.current, self.model, self.pending = current, model, pending
        train_fit, _, k_now = self.fitter.fit([], current.params, [current.values], self.train)
        self.now = self.score(train_fit, k_now)
        self.steps[-1].update({"bic": self.now.bic, "rms_holdout": self.now.rmse_holdout})
        decision = forward_selection(self.now, lambda: [e for e in self.pending if e not in self.added],
                                     self._fit_round, self._add, self.rule, break_tie=self._break_tie)
        stopped = None
        if decision.judgements:
            stopped = self.steps[-1]["stop"] = {"candidates": self.public_rows, "reason": decision.reason}
            self.say(f"  stop: {decision.reason}")
        return self.current, self.model, self.added, stopped

    def _fit_round(self, left: list[str]) -> list[Outcome]:
        current, rows, outcomes = self.current, [], []
        for effect in left:
            starts = _candidate_starts(effect, current, self.records)
            starts += [{**s, **{k: v for k, v in starts[0].items() if k not in s}} for s in self.static_starts]
            fitted_train, _, k = self.fitter.fit([*self.added, effect], current.params, starts, self.train)
            score = self.score(fitted_train, k)
            value = fitted_train.values.get(CANDIDATES[effect]) if CANDIDATES[effect] else 1
            outcome = Outcome(effect, score, switched_off=not value > 0)
            judgement = judge(self.now, outcome, self.rule)
            rows.append({"effect": effect, "bic": score.bic, "delta_bic": judgement.delta_bic,
                         "rms_holdout": score.rmse_holdout,
                         "nrms_train": float(np.sqrt(np.mean(fitted_train.residual[self.train] ** 2))
                                             / self.force_range),
                         "params": ({CANDIDATES[effect]: value} if CANDIDATES[effect]
                                    else effects.get(effect).on_values),
                         "passes_bic": judgement.passes_bic, "passes_holdout": judgement.passes_holdout,
                         "_fit": fitted_train, "_score": score})
            outcomes.append(outcome)
            self.say(f"  candidate {effect}: dBIC {judgement.delta_bic:+.1f}, held-out RMS {score.rmse_holdout:.4g} N "
                     f"(now {self.now.rmse_holdout:.4g} N)")
        rows.sort(key=lambda r: r["bic"])
        self.rows = {r["effect"]: r for r in rows}
        self.public_rows = [{k: v for k, v in r.items() if not k.startswith("_")} for r in rows]
        return outcomes

    def _break_tie(self, decision):
        """The held-out points do not separate the best from a rival: the best BIC is added, with a note."""
        self.notes.append(f"the held-out points do not separate {decision.effect} from {', '.join(decision.rivals)}: "
                          f"{decision.reason}; {decision.effect} (the lower BIC) is added")
        return dataclasses.replace(decision, verdict="add")

    def _add(self, decision) -> Score:
        best = self.rows[decision.effect]
        self.added.append(decision.effect)
        current, model, _ = self.fitter.fit(self.added, self.current.params, [best["_fit"].values, self.current.values])
        check_converged(current, f"the fit with {', '.join(self.added)}", self.fitter.max_evaluations,
                         self.force_range)
        self.current, self.model = current, model
        self.now = best["_score"]
        nrms = force_nrms(current.residual, self.force_range)
        label = "+ " + decision.effect
        self.curves[label] = (current.params, model.offsets(current.values))
        self.steps.append({"label": label, "effects": list(self.added), "nrms": nrms, "rms": nrms * self.force_range,
                           "bic": self.now.bic, "rms_holdout": self.now.rmse_holdout, "params": dict(current.values),
                           "candidates": self.public_rows})
        self.say(f"added {decision.effect}: NRMS {nrms:.2%}")
        return self.now


def _candidate_starts(effect: str, current: Fit, records) -> list[dict]:
    """Where a candidate's fit starts besides the static starts: the current fit with the candidate's parameter
    guessed. A play effect (Coulomb friction, pressure friction: a band of half-width ``value * u(P)``) gets the
    least-squares value of ``-sign * residual = value * u(P)``, the branches' offset from the current fit; any
    other fitted parameter starts at its typical value (the threshold: P0 = 50 kPa) and at its off value."""
    name = CANDIDATES[effect]
    if not name:
        return [dict(current.values)]
    found = effects.get(effect)
    q = found.parameter(name) if name in found.parameter_names else None
    if found.quasi_static == "play" and q is not None:
        P = np.concatenate([r.pressure for r in records])
        sign = np.concatenate([r.sign for r in records])
        try:
            unit = np.broadcast_to(np.asarray(found.play(P, current.params.replace(**{name: q.scale}), np), float),
                                   P.shape) / q.scale
        except (MkctlError, ArithmeticError, ValueError):
            unit = np.zeros_like(P)
        signed = sign * unit
        if signed @ signed > 0:
            guess = float(-(signed @ current.residual) / (signed @ signed))
            return [{**current.values, name: max(guess, 0.01 * q.scale)}]
    starts = [dict(current.values)]
    if q is not None and q.typical is not None:
        starts.append({**current.values, name: q.typical})
    return starts


def _refit_from_every_start(fitter: _Fitter, current: Fit, model: ForceModel, added: list, static_starts: list,
                            points: int, notes: list):
    """The final model fitted once more from every starting point: kept if better; another end that fits as well
    but elsewhere is reported as ambiguous (:func:`ambiguous_values`)."""
    final_starts = [{**s_, **{k: v for k, v in current.values.items() if k not in s_}} for s_ in static_starts]
    again, again_model, _ = fitter.fit(added, current.params, [current.values, *final_starts])
    if again.converged and again.rss < current.rss:
        current, model = again, again_model
    uncertainty = fit_uncertainty(current, model)
    ambiguous = ambiguous_values(current, again.ends, uncertainty[0], points)
    if ambiguous:
        notes.append("another muscle fits these data as well (within 2 standard errors of the fit's RSS): "
                     + "; ".join(f"{k} = {current.values[k]:.4g} or {', '.join(f'{v:.4g}' for v in vs)} "
                                 f"{UNITS.get(k, 'N')}" for k, vs in ambiguous.items())
                     + ": the data do not pin these down, so no standard error is given for them")
    return current, model, uncertainty, ambiguous


def _separate(fitter: _Fitter, current: Fit, model: ForceModel, uncertainty: tuple, start: Params, ambiguous: dict,
              notes: list):
    """What the data cannot separate (``uncertainty``: :func:`fit_uncertainty` of the fit): the later of each group
    is held at its start and the rest refitted. Returns (fit, standard errors, correlation, groups, held values)."""
    stderr, correlation, groups = uncertainty
    stderr = {k: v for k, v in stderr.items() if k not in ambiguous}
    held = {}
    if not groups:
        return current, stderr, correlation, groups, held
    choice = {}
    for group in groups:
        choice.update(_choose_held(fitter, current, model, group, start))
    held = {k: value for k, (value, _) in choice.items()}
    notes.append("the data cannot separate " + "; ".join(" and ".join(g) for g in groups) + ": "
                 + ", ".join(f"{k} held at {v:g} {UNITS.get(k, 'N')} ({why})" for k, (v, why) in choice.items())
                 + " and the rest refitted")
    refit, model = _hold(fitter, current, model, held)
    stderr, _, more = fit_uncertainty(refit, model)
    groups += [g for g in more if g not in groups]  # what the refit still cannot separate
    stderr = {k: v for k, v in stderr.items() if not any(k in g for g in groups) and k not in ambiguous}
    return refit, stderr, correlation, groups, held


def _hold(fitter: _Fitter, current: Fit, model: ForceModel, held: dict):
    """The fit refitted with the names in held fixed at their values (the rest from where they are).
    Returns (fit, its model)."""
    records = fitter.records
    keep = tuple(n for n in model.names if n not in held)
    base = current.params.replace(**{k: v for k, v in held.items() if not is_offset(k)})
    model = ForceModel(records, base, keep, fitter.link_n)
    lows, highs = (np.array(v) for v in zip(*[bounds_of(n, records, base, keep) for n in keep]))
    refit = fit_least_squares(model, [{n: current.values[n] for n in keep}], lows, highs, None, fitter.max_evaluations)
    fitter.evaluations += refit.evaluations
    refit.values.update({k: v for k, v in held.items()})
    return refit, model


def _choose_held(fitter: _Fitter, free: Fit, model: ForceModel, group: list, start: Params) -> dict:
    """Which names of a group the data cannot separate are held, and at what: {name: (value, why)}.

    Holding must not make the fit clearly worse than the free fit (``free``: every name fitted); "clearly" is
    an RSS more than ``EQUALLY_GOOD`` s^2 above it. In this order, the first that does not:

    1. the later ones at their start (the file's or Table I's; a force offset at 0), as a rule;
    2. the one the free fit drives to a bound of its range (its estimate within 2 standard errors of the bound)
       held on that bound: the data ask for none of it, and the others take its share. Blocked-force data of
       short muscles, say, drive C1 to 0 and want C2 of 1.4-1.8 MPa, which C2 held at Table I's 1300 Pa cannot
       give (the cheapest such bound, if several);
    3. otherwise the later ones where the free fit put them (their values are then one of many equally good).

    The reason goes into the note."""
    usual = {n: 0.0 if is_offset(n) else float(getattr(start, n)) for n in group[1:]}
    choice = {n: (v, "its starting value") for n, v in usual.items()}
    points, k = model.size, len(model.names)
    if points <= k:
        return choice
    s2 = free.rss / (points - k)
    usual_fit, _ = _hold(fitter, free, model, usual)
    if usual_fit.rss <= free.rss + EQUALLY_GOOD * s2:
        return choice
    errors = fit_standard_errors(free, model)
    best = None
    for name in (n for n in group if not is_offset(n) and n in errors):
        value, error = free.values[name], errors[name]
        for side, bound in zip(("lower", "upper"), bounds_of(name, fitter.records, free.params, free.names)):
            if not (math.isfinite(bound) and abs(value - bound) <= 2 * error):
                continue
            fit, _ = _hold(fitter, free, model, {name: float(bound)})
            if fit.converged and fit.rss <= free.rss + EQUALLY_GOOD * s2 and (best is None or fit.rss < best[0]):
                best = (fit.rss, name, float(bound), side, value, error)
    rms = lambda rss: f"{math.sqrt(rss / points):.4g} N"  # noqa: E731
    others = ", ".join(f"{n} at its start {v:g} {UNITS.get(n, 'N')}" for n, v in usual.items())
    if best is None:
        return {n: (free.values[n], f"where the free fit put it: holding {others} would leave {rms(usual_fit.rss)} "
                                    f"RMS, not {rms(free.rss)}, and no estimate of the group ends near a bound")
                for n in usual}
    rss, name, bound, side, value, error = best
    return {name: (bound, f"the free fit drove it to its {side} bound ({value:.4g} +- {error:.2g} "
                          f"{UNITS.get(name, 'N')}): the data ask for {'none' if bound == 0 else 'no other value'} of "
                          f"it; holding {others} instead would leave {rms(usual_fit.rss)} RMS, not {rms(rss)}")}


def _settle_bounds(records, current: Fit, notes: list) -> list:
    """The names that ended on a bound of their range, set exactly on it (0, not 4e-14), with a note each."""
    at_bound = []
    lows, highs = (np.array(v) for v in zip(*[bounds_of(n, records, current.params, current.names)
                                              for n in current.names]))
    for name, low, high in zip(current.names, lows, highs):
        value, tolerance = current.values[name], 1e-6 * scale_of(name)
        if value - low <= tolerance or high - value <= tolerance:
            at_bound.append(name)
            current.values[name] = float(low if value - low <= tolerance else high)  # 0, not 4e-14
    if at_bound:
        current.params = current.params.replace(**{n: current.values[n] for n in at_bound if not is_offset(n)})
    for name in at_bound:
        value = current.values[name]
        if value == 0:
            notes.append(f"{name} ended on its lower bound 0: the data show none of it (its standard error says how "
                         "much they would still allow)")
        else:
            notes.append(f"{name} ended on its bound ({value:.4g} {UNITS.get(name, 'N')}): the data push it out of "
                         "the physical range; its standard error means little")
    return at_bound


def plays_growing_with_pressure() -> tuple[str, ...]:
    """The calibration candidates whose quasi-static friction band widens with the pressure (their definition's
    ``play`` at its typical value: larger at 600 kPa than at 100 kPa), in the registry's order: what a branch gap
    that grows with pressure asks for."""
    growing = []
    for name in CANDIDATES:
        effect = effects.get(name)
        if effect.quasi_static != "play" or not CANDIDATES[name]:
            continue
        p = Params().replace(**effect.on_values)
        xp = actuator.math_for(1.0)
        if effect.play(6e5, p, xp) > effect.play(1e5, p, xp):
            growing.append(name)
    return tuple(growing)


def play_growing_with_pressure() -> str | None:
    """The first of :func:`plays_growing_with_pressure` (the built-in one), or None."""
    growing = plays_growing_with_pressure()
    return growing[0] if growing else None


def _note_hysteresis(records, current: Fit, notes: list, added=(), stderr=None, candidates=()) -> None:
    """What the gap between the branches says on its own (:func:`hysteresis_growth`), as a note.

    With ``pressure_friction`` added, the gap is an independent cross-check of the fitted friction: half of it is
    ``Fc + Fc_p P`` whatever the static model, so its line's slope and intercept are printed beside the fitted
    Fc_p and Fc. Without it, a gap that grows with pressure is a friction the constant Fc cannot follow, and the
    note says which candidate would follow it."""
    growth = hysteresis_growth(records, current.params)
    if not growth:
        return
    stderr = stderr or {}

    def value(name):
        error = stderr.get(name)
        return f"{current.values.get(name, 0.0):.3g}" + (f" +- {error:.2g}" if error is not None else "")

    (low, gap_low), (high, gap_high) = growth["low"], growth["high"]
    intercept = growth["intercept"]
    growing = plays_growing_with_pressure()  # the candidates whose friction band widens with pressure
    grows = growing[0] if growing else None
    if any(name in added for name in growing if name != grows):
        return  # another friction growing with pressure (a user's) was added: it follows the gap
    if grows in added:
        notes.append(f"friction that grows with pressure, fitted as {grows}: Fc_p = {value('Fc_p')} N/Pa"
                     + (f" with Fc = {value('Fc')} N" if "Fc" in current.values else "") + "; cross-check from the "
                     f"gap between the rising and falling branches alone (whatever the static model): half of it is "
                     f"{intercept:.3g} N + {growth['slope']:.3g} +- {growth['slope_stderr']:.2g} N/Pa times P")
        return
    if not growth["grows"]:
        return
    if grows in candidates:
        hint = f"the {grows} candidate that follows it was not added (see the steps)"
    else:
        hint = f"the candidate {grows} (Fc + Fc_p P) follows it: add it to the effects tried"
    notes.append(f"the gap between the rising and falling branches grows with pressure: half of it is "
                 f"{gap_low:.2g} N at {low / 1e3:.0f} kPa and {gap_high:.2g} N at {high / 1e3:.0f} kPa. That is "
                 f"friction growing with pressure, which the constant Fc of the model cannot follow"
                 + (f" (the fitted Fc = {current.values['Fc']:.3g} N is an average)" if "Fc" in current.values
                    else "") + f"; expect the largest errors at the extremes of pressure; {hint}")


