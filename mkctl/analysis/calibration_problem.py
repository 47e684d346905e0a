"""The fit problem of a calibration: the parameters, their bounds and scales, the force residual
of every record, bounded least squares from several starts, and the uncertainty of a fit
(model-spec section 5b; fitted step by step in :mod:`mkctl.analysis.calibrate`).

Uncertainty: ``cov = s^2 (J^T J)^-1`` with ``s^2 = RSS / (N - k)`` and J the Jacobian of the force
residuals at the optimum (:func:`mkctl.analysis.statistics.covariance`, white residuals: independent
force points, no widening); two estimates correlated beyond :data:`IDENTIFIABLE_CORRELATION` cannot
be told apart.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from ..errors import DomainError, ParameterError
from ..physics import actuator, effects
from ..physics.isometric import isometric_tension
from ..physics.params import LiveMapping, Params
from .force_records import CalibrationError, ForceRecord
from .statistics import covariance, standard_errors

#: Parameters always fitted (model-spec section 5b: the ones a user cannot measure).
STATIC = ("b", "n", "C1", "C2")
#: Parameters fitted only on request (``fit=``); by default they come from the files' metadata.
OPTIONAL = ("L0", "D0", "t0", "offset")
#: The records whose force a load cell reads (a zero offset can be fitted on them).
FORCE_SENSOR_RECORDS = ("isometric", "actuator")
#: Estimates correlated beyond this cannot be told apart.
IDENTIFIABLE_CORRELATION = 0.99
#: Typical magnitudes: the fit works on value / scale.
SCALES = LiveMapping(lambda: {"b": 0.1, "n": 1.0, "C1": 1e5, "C2": 1e4, "L0": 0.1, "D0": 0.01, "t0": 1e-3,
                               **{q.name: q.scale for q in effects.parameters()}, "offset": 1.0})
#: The steepest braid angle at rest a real braid has [deg]: ``b = L0 / cos(angle)`` stays below L0 / cos of it.
MAX_BRAID_ANGLE = 80.0
B_OVER_L0 = 1.0 / math.cos(math.radians(MAX_BRAID_ANGLE))
#: Default cap on the model evaluations of one least-squares run (per fitted parameter, plus one).
MAX_EVALUATIONS = 200


def merged_metadata(records: list[ForceRecord]) -> dict:
    """The records' metadata parameters, merged; two records that disagree raise :class:`CalibrationError`."""
    merged, where = {}, {}
    for r in records:
        for name, value in r.overrides.items():
            if name in merged and not math.isclose(merged[name], value, rel_tol=1e-9):
                raise CalibrationError(f"{r.source} gives {name} = {value:g} but {where[name]} gives {merged[name]:g}: "
                                       "files of different muscles; calibrate fits one muscle, its files must "
                                       "agree (calibrate each on its own with --each)")
            merged[name], where[name] = value, r.source
    return merged


#: How a note of a default assumed for what the files did not give begins (:attr:`CalibrationResult.assumed`).
ASSUMED = "assumed: "

#: The shortest a braid can pull a muscle, as a fraction of b: cos of the braid angle 54.7 deg (arctan sqrt 2),
#: where a McKibben muscle's force vanishes at any pressure (model-spec section 2: L = b cos theta).
SHORTEST_FRACTION = 1.0 / math.sqrt(3.0)


def check_one_muscle(records: list[ForceRecord]) -> None:
    """Refuse (one line) lengths no single muscle spans: one braid holds force only between b cos 54.7 deg and b,
    so the longest measured length over the shortest is below sqrt(3) = 1.73 for one muscle. Files of different
    muscles (a 300 mm and a 510 mm one) given together fail this; the line names the two files."""
    shortest = min(records, key=lambda r: float(r.length.min()))
    longest = max(records, key=lambda r: float(r.length.max()))
    low, high = float(shortest.length.min()), float(longest.length.max())
    if low > 0 and high * SHORTEST_FRACTION > low:
        where = (f"{shortest.source} and {longest.source}" if shortest is not longest else shortest.source)
        raise CalibrationError(
            f"lengths from {low:g} m to {high:g} m ({where}) cannot belong to one muscle: a braid holds force "
            f"only down to cos 54.7 deg = {SHORTEST_FRACTION:.3f} of its length b (ratio {high / low:.3g} > "
            f"{1 / SHORTEST_FRACTION:.3f}); calibrate each muscle on its own (--each) or check the length units")


def is_offset(name: str) -> bool:
    """Whether a fitted name is a load cell's zero offset: ``offset``, or ``offset_<k>`` with several files."""
    return name == "offset" or name.startswith("offset_")


def offset_names(records: list[ForceRecord]) -> list:
    """The name of each record's force offset when offsets are fitted: ``offset`` when one record is
    isometric (or driven-length: a load cell reads both), ``offset_1``, ``offset_2``, ... for those
    records in order when several are (each file its own load cell zero: a rig re-tared between
    tests); None for an isotonic record (its force is a hanging load)."""
    isometric = [i for i, r in enumerate(records) if r.experiment in FORCE_SENSOR_RECORDS]
    names = [None] * len(records)
    for k, i in enumerate(isometric, 1):
        names[i] = "offset" if len(isometric) == 1 else f"offset_{k}"
    return names


def scale_of(name: str) -> float:
    return SCALES["offset" if is_offset(name) else name]


def bounds_of(name: str, records: list[ForceRecord], start: Params, fitting=()) -> tuple[float, float]:
    """(lower, upper) of a fitted name [SI]: the physical range (see the module docstring)."""
    longest = max(float(r.length.max()) for r in records)
    if name == "b":
        shortest_braid = longest if "L0" in fitting else max(longest, start.L0)
        return shortest_braid * (1 + 1e-4), B_OVER_L0 * max(longest, start.L0)
    if name == "L0":
        shortest = min(float(r.length.min()) for r in records)
        return 0.5 * shortest, 2.0 * longest
    effect_ranges = {q.name: q.fit_range or (q.lower, q.upper) for q in effects.parameters()}
    return {"n": (0.05, 200.0), "C1": (0.0, 1e8), "C2": (0.0, 1e8), "D0": (1e-4, 1.0), "t0": (1e-6, 0.1),
            **effect_ranges, "offset": (-1e5, 1e5)}["offset" if is_offset(name) else name]


class ForceModel:
    """The force model over the stacked records, with a fixed set of fitted names."""

    def __init__(self, records, base: Params, names: tuple, link_n: bool):
        self.records, self.base, self.names, self.link_n = records, base, tuple(names), link_n
        self.scales = np.array([scale_of(n) for n in self.names])
        self.offset_names = offset_names(records)
        self.force = np.concatenate([r.force for r in records])
        self.size = self.force.size

    def params_at(self, values: dict) -> Params:
        physical = {k: v for k, v in values.items() if not is_offset(k)}
        if self.link_n:
            physical.pop("n", None)
            merged = {**self.base.as_dict(), **physical}
            physical["n"] = math.sqrt(max(merged["b"] ** 2 - merged["L0"] ** 2, 1e-30)) / (math.pi * merged["D0"])
        return self.base.replace(**physical)

    def values_at(self, x) -> dict:
        values = {n: float(v) for n, v in zip(self.names, np.asarray(x) * self.scales)}
        return values

    def offsets(self, values: dict) -> tuple:
        """Each record's force offset [N] in values (0 where none is fitted)."""
        return tuple(values.get(name, 0.0) if name else 0.0 for name in self.offset_names)

    def predict(self, params: Params, offsets=None):
        """The model's force at every point [N], stacked over the records, with each record's offset
        (:meth:`offsets`; None: none) (raises DomainError outside)."""
        parts = []
        for r, offset in zip(self.records, offsets or (0.0,) * len(self.records)):
            if r.experiment == "isometric":
                parts.append(isometric_tension(r.length, r.pressure, r.sign, params) + offset)
            elif r.velocity is not None:  # a driven length: the tension at the imposed motion
                tension = actuator.compose_tension(r.length, r.pressure, r.velocity, params)
                parts.append(tension + offset)
            else:
                f = actuator.compose_tension(r.length, r.pressure, 0.0, params, quasi_static=True)
                width = actuator.play_half_width(r.pressure, params)  # the effects' play band (Fc) [N]
                moving = actuator.apply_limits(f - r.sign * width, params)
                # at rest the load may lie anywhere in [f - Fc, f + Fc]: the model "predicts" the nearest edge
                still = np.clip(r.force, f - width, f + width)
                parts.append(np.where(r.sign != 0, moving, still))
        return np.concatenate(parts)

    def residual_values(self, values: dict):
        params = self.params_at(values)
        return self.force - self.predict(params, self.offsets(values))

    def residual(self, x):
        try:
            return self.residual_values(self.values_at(x))
        except (DomainError, ParameterError):
            return np.full(self.size, 1e6)  # an unphysical trial muscle: far worse than any fit


@dataclass
class Fit:
    values: dict
    params: Params
    residual: np.ndarray
    rss: float
    result: object
    names: tuple
    converged: bool
    evaluations: int
    ends: list = field(default_factory=list)  #: (rss, values) where each start's run ended


def fit_least_squares(model: ForceModel, starts: list[dict], lows, highs, mask=None, max_evaluations=MAX_EVALUATIONS):
    """The best of bounded least-squares runs from each start (on the points in mask, default all)."""
    best, total, ends = None, 0, []
    keep = slice(None) if mask is None else mask
    for start in starts:
        x0 = np.array([start[n] for n in model.names]) / model.scales
        lo, hi = lows / model.scales, highs / model.scales
        span = hi - lo
        x0 = np.clip(x0, lo + 1e-6 * np.where(np.isfinite(span), span, 1), hi - 1e-6 * np.where(np.isfinite(span), span, 1))
        result = least_squares(lambda x: model.residual(x)[keep], x0, bounds=(lo, hi), x_scale="jac",
                               method="trf", xtol=1e-8, ftol=1e-9, gtol=1e-8,
                               max_nfev=max_evaluations * (len(model.names) + 1))
        total += result.nfev + (result.njev or 0) * len(model.names)  # finite-difference Jacobians included
        rss = float(result.fun @ result.fun)
        ends.append((rss, model.values_at(result.x)))
        if best is None or rss < best[0] - 1e-12 * max(rss, 1.0) or (not best[1].status > 0 and result.status > 0
                                                                      and rss <= best[0] * (1 + 1e-9)):
            best = (rss, result)
    rss, result = best
    values = model.values_at(result.x)
    residual = model.residual_values(values)
    return Fit(values, model.params_at(values), residual, rss, result, model.names, bool(result.status > 0), total,
                ends)


def starting_points(records: list[ForceRecord], start: Params, names: tuple) -> list[dict]:
    """Several starting points: the braid length at 1.05, 1.25 and 1.6 times the longest length, each with
    the turns n that match model 1's force at the highest pressures, and C1 at its start value, a tenth
    and ten times it (C2 at its start value; other names at theirs)."""
    longest = max(float(r.length.max()) for r in records)
    L = np.concatenate([r.length for r in records])
    P = np.concatenate([r.pressure for r in records])
    F = np.concatenate([r.force for r in records])
    base = {n: float(getattr(start, n)) for n in names if not is_offset(n) and n != "Fc"}
    base.update({n: 0.0 for n in names if is_offset(n)})
    base.update({"Fc": start.Fc} if "Fc" in names else {})
    points = []
    b_starts = [max(longest, start.L0) * k for k in (1.05, 1.25, 1.6)] if "b" in names else [start.b]
    for b in b_starts:
        gain = P * (3 * L * L - b * b) / (4 * math.pi)  # model 1 is gain / n^2
        use = (gain > 0) & (P >= np.median(P))
        k = float(F[use] @ gain[use] / (gain[use] @ gain[use])) if use.sum() >= 2 else 0.0
        n0 = 1.0 / math.sqrt(k) if k > 0 else start.n
        for factor in (1.0, 0.1, 10.0) if "C1" in names else (1.0,):
            point = dict(base)
            point.update({"b": b} if "b" in names else {})
            point.update({"n": min(max(n0, 0.1), 100.0)} if "n" in names else {})
            point.update({"C1": max(start.C1, 1e3) * factor} if "C1" in names else {})
            points.append(point)
    return points


def force_nrms(residual, force_range: float) -> float:
    """The RMS of a force residual [N] over the range of the measured forces [N]."""
    return float(np.sqrt(np.mean(residual * residual)) / force_range)


#: Two fits whose RSS differ by less than this many times the noise variance s^2 fit equally well.
EQUALLY_GOOD = 4.0


def ambiguous_values(fit: Fit, ends: list, stderr: dict, points: int) -> dict:
    """Names whose value differs by more than 3 standard errors between the fit and another run's end that
    fits as well (RSS within EQUALLY_GOOD s^2): {name: [other values]}."""
    k = len(fit.names)
    if points <= k:
        return {}
    s2 = fit.rss / (points - k)
    out: dict = {}
    for rss, values in ends:
        if rss - fit.rss > EQUALLY_GOOD * s2:
            continue
        for name, error in stderr.items():
            other = values.get(name)
            if other is not None and abs(other - fit.values[name]) > 3 * error:
                if all(abs(other - v) > 3 * error for v in out.get(name, [])):
                    out.setdefault(name, []).append(float(other))
    return out


def check_converged(fit: Fit, what: str, max_evaluations: int, force_range: float) -> None:
    """Raise :class:`CalibrationError` naming the best point reached when no least-squares run converged."""
    if fit.converged:
        return
    best = ", ".join(f"{k} = {v:.4g}" for k, v in fit.values.items())
    raise CalibrationError(f"{what} did not converge within {max_evaluations} evaluations per parameter and run; the "
                           f"best it reached: NRMS {force_nrms(fit.residual, force_range):.2%} with {best}")


def fit_covariance(fit: Fit, model: ForceModel):
    """``cov = s^2 (J^T J)^-1`` of the scaled estimates (value / scale) and their standard deviations, with
    ``s^2 = RSS / (N - k)`` and J the Jacobian of the force residuals on every point; None when there is none."""
    J = np.asarray(fit.result.jac, dtype=float) if fit.result.jac is not None else None
    n, k = model.size, len(model.names)
    if J is None or n <= k:
        return None
    # the Jacobian of the residual on every point (least_squares's may be of the training part only)
    if J.shape[0] != n:
        J = residual_jacobian(model, fit.result.x)
    # white residuals: independent force points, no widening (statistics.covariance)
    cov_x = covariance(J, parameters=k, rss=fit.rss)
    return cov_x, standard_errors(cov_x)


def fit_standard_errors(fit: Fit, model: ForceModel) -> dict:
    """Every fitted name's standard error [its unit], those the data cannot separate included (there it is the
    whole range the data allow along the group, large)."""
    covariance = fit_covariance(fit, model)
    if covariance is None:
        return {}
    return {name: float(s * scale) for name, s, scale in zip(model.names, covariance[1], model.scales)}


def fit_uncertainty(fit: Fit, model: ForceModel):
    """Standard errors, the correlation matrix and the groups of names whose estimates cannot be separated."""
    names = list(model.names)
    k = len(names)
    covariance = fit_covariance(fit, model)
    if covariance is None:
        return {}, {"names": names, "matrix": None}, []
    cov_x, sd_x = covariance
    stderr = {name: float(s * scale) for name, s, scale in zip(names, sd_x, model.scales)}
    with np.errstate(invalid="ignore", divide="ignore"):
        corr = cov_x / np.outer(sd_x, sd_x)
    corr = np.where(np.isfinite(corr), corr, 0.0)
    groups: list[list[str]] = []
    for i in range(k):
        for j in range(i + 1, k):
            if abs(corr[i, j]) > IDENTIFIABLE_CORRELATION:
                a, b = names[i], names[j]
                home = next((g for g in groups if a in g or b in g), None)
                if home is None:
                    groups.append([a, b])
                else:
                    for name in (a, b):
                        if name not in home:
                            home.append(name)
    groups = [sorted(g, key=names.index) for g in groups]
    # a parameter the residual does not depend on at all cannot be determined either
    return ({k_: v for k_, v in stderr.items() if not any(k_ in g for g in groups)},
            {"names": names, "matrix": corr.tolist()}, groups)


def residual_jacobian(model: ForceModel, x):
    x = np.asarray(x, dtype=float)
    base = model.residual(x)
    J = np.empty((base.size, x.size))
    for i in range(x.size):
        h = 1e-6 * max(abs(x[i]), 1e-3)
        step = x.copy()
        step[i] += h
        J[:, i] = (model.residual(step) - base) / h
    return J
