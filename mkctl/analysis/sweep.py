"""The model over many parameter sets: a grid or a random sample, computed in chunks on Dask.

For every point (a parameter set of :data:`mkctl.physics.params.PARAMETER_NAMES`, plus the posture
``alpha_deg`` [deg] and the flexor pressure ``pf_kPa`` [kPa]) :func:`sweep` computes what a designer
asks of a posture held at rest:

- the **equilibrium**: the extensor pressure ``pe_kPa`` that holds the posture
  (:func:`mkctl.physics.stability.equilibrium_pressure`), the hip height ``X_m`` and whether the muscle
  can hold it (``holdable``: pe >= 0; a muscle cannot push);
- ``a1`` [1/s] and ``a2`` [1/s^2] of Eq. 18 (:func:`mkctl.physics.stability.routh_hurwitz_coefficients`)
  and the Routh-Hurwitz ``verdict`` (stable, marginal, unstable);
- the **poles**: the mechanical pair, roots of ``s^2 - a1 s - a2 = 0`` (:func:`mkctl.physics.stability.poles`;
  ``pole1`` has the larger imaginary part), and with a pressure lag (tau > 0) the lag's pole ``-1/tau``
  (``lag_pole``, double: one lag per muscle; NaN without a lag): the analytic linearization of
  :mod:`mkctl.analysis.control` is block-triangular, so in open loop these are all its poles;
- the **damping ratio** ``zeta = -a1 / (2 sqrt(-a2))`` and the natural frequency ``sqrt(-a2) / 2 pi``
  (:func:`mkctl.analysis.control.damping_ratio`; NaN where a2 >= 0: no oscillation to speak of);
- the **settling time** (2 %) and the **overshoot** [%] of the hip height after a small step of the
  extensor command, from the linear model (:func:`step_metrics`). The linearization from pe_cmd to X is
  ``b / (s^2 - a1 s - a2)``, times ``1 / (tau s + 1)`` with a lag: it has no zeros, so both numbers follow
  from the poles alone (they do not depend on the step's size or on the gain b). A posture that is not
  stable never settles: settling time inf, overshoot NaN (no final value).

Points are evaluated in chunks (:func:`evaluate_points`), vectorized with numpy over posture and
pressure for each distinct parameter set, and the chunks run on the engine of
:mod:`mkctl.analysis.batch` (local processes, or a Dask cluster). Before any work, the corners of the
ranges are evaluated here: a range outside the model's domain (a posture beyond the end stops, a
negative pressure, an invalid parameter, an actuator stretched beyond its braid) is one error naming
the point. A point inside the ranges where the model is undefined gets its message in ``error``.

Example
-------
>>> from mkctl.analysis.sweep import sweep
>>> result = sweep({"c": (0, 200, 5), "alpha_deg": (30, 80, 3)}, jobs=0)   # doctest: +SKIP
>>> result.counts                                                          # doctest: +SKIP
{'marginal': 3, 'stable': 12}
"""
from __future__ import annotations

import itertools
import math
import os
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..io.text import write_text_atomic
from ..errors import DomainError, MkctlError, ParameterError, check_memory
from ..physics import knee, stability
from ..physics.params import DEFAULT, PARAMETER_NAMES, UNITS, LiveSequence, Params
from ..results import Result
from .batch import default_jobs, run_batch

#: Sweep names beyond the parameters: the posture and the flexor pressure, with their units and defaults.
POSTURE_NAMES = {"alpha_deg": ("deg", math.degrees(stability.DEFAULT_ALPHA), "posture: kneecap angle alpha"),
                 "pf_kPa": ("kPa", stability.DEFAULT_PF / 1e3, "flexor pressure (the extensor's holds the posture)")}
#: Every name a sweep can vary.
SWEEP_NAMES = LiveSequence(lambda: tuple(name for name in PARAMETER_NAMES if name != "n") + tuple(POSTURE_NAMES))
#: The settling band of :func:`step_metrics` (as python-control's ``step_info``).
SETTLING_BAND = 0.02
#: What each computed column of the knee's rest holds (name: (unit, meaning)).
KNEE_REST = {
    "X_m": ("m", "hip height of the posture"),
    "pe_kPa": ("kPa", "extensor pressure that holds the posture at rest"),
    "holdable": ("", "pe >= 0 (a muscle cannot push)"),
}
#: What each computed column of the linear dynamics at rest holds, for the knee and any mechanism.
DYNAMICS = {
    "a1": ("1/s", "velocity coefficient of Eq. 18 (a1 < 0: Eq. 19 holds)"),
    "a2": ("1/s^2", "position coefficient of Eq. 18 (a2 < 0: Eq. 20 holds)"),
    "verdict": ("", "Routh-Hurwitz: stable, marginal (a1 = 0), unstable; undefined where the model is"),
    "pole1_re": ("1/s", "mechanical pole (larger imaginary part), real part"),
    "pole1_im": ("1/s", "mechanical pole, imaginary part"),
    "pole2_re": ("1/s", "the other mechanical pole, real part"),
    "pole2_im": ("1/s", "the other mechanical pole, imaginary part"),
    "lag_pole": ("1/s", "-1/tau with a pressure lag (a double pole: one lag per muscle), NaN without"),
    "damping_ratio": ("", "zeta = -a1 / (2 sqrt(-a2)); NaN where a2 >= 0"),
    "natural_frequency_hz": ("Hz", "sqrt(-a2) / 2 pi; NaN where a2 >= 0"),
    "settling_time_s": ("s", "2 % settling of X after a pe_cmd step (linear model); inf if not stable"),
    "overshoot_percent": ("%", "overshoot of X after a pe_cmd step (linear model); NaN if not stable"),
    "error": ("", "why the model is undefined at this point (empty where it is defined)"),
}
#: What each computed column of a knee sweep holds (name: (unit, meaning)).
QUANTITIES = {**KNEE_REST, **DYNAMICS}
_VERDICT_CODES = {"stable": 0, "marginal": 1, "unstable": 2, "undefined": 3}


class SweepError(MkctlError, ValueError):
    """A sweep that cannot run as asked: an unknown name, a bad range, a range outside the model's domain."""


# --- What to sweep ----------------------------------------------------------------------------------

def _check_name(name: str, names=None) -> None:
    """Refuse a name that cannot be swept: ``names`` (default :data:`SWEEP_NAMES`, the knee's) lists those
    that can."""
    if name not in (SWEEP_NAMES if names is None else names):
        what = "not a parameter, alpha_deg or pf_kPa" if names is None else "not a name of this sweep"
        raise SweepError(f"cannot sweep {name!r}: {what} (known: {', '.join(names or SWEEP_NAMES)})")


def grid_values(name: str, spec, names=None) -> np.ndarray:
    """The values of one grid axis, sorted: a tuple ``(start, stop, count)`` (evenly spaced, ends included)
    or a list (or array) of values; ``names`` as in :func:`_check_name`."""
    _check_name(name, names)
    if isinstance(spec, tuple) and len(spec) == 3:
        start, stop, count = spec
        if not (math.isfinite(count) and int(count) == count and count >= 1):
            raise SweepError(f"{name}: the number of grid values must be a whole number >= 1, got {count!r}")
        if not (math.isfinite(float(start)) and math.isfinite(float(stop))):
            raise SweepError(f"{name}: the grid's ends must be finite numbers, got {start!r} and {stop!r}")
        _check_points_memory(count, 1)
        values = np.linspace(float(start), float(stop), int(count))
    else:
        values = np.atleast_1d(np.asarray(spec, dtype=float))
    if values.ndim != 1 or values.size == 0 or not np.isfinite(values).all():
        raise SweepError(f"{name}: the values must be finite numbers, got {spec!r}")
    return np.unique(values)


def parse_axis(text: str, random: bool = False, names=None):
    """``"c=0:200:21"`` -> ("c", (0, 200, 21)); ``"c=0,10,40"`` -> ("c", [0, 10, 40]); with ``random``,
    ``"c=0:200"`` -> ("c", (0, 200)) (uniform between the two); ``names`` as in :func:`_check_name`."""
    name, sep, spec = text.partition("=")
    name = name.strip()
    form = "NAME=LOW:HIGH" if random else "NAME=START:STOP:COUNT or NAME=V1,V2,..."
    if not sep or not name or not spec.strip():
        raise SweepError(f"expected {form}, got {text!r}")
    _check_name(name, names)
    try:
        if random:
            low, high = (float(part) for part in spec.split(":"))
            return name, (low, high)
        if ":" in spec:
            start, stop, count = spec.split(":")
            count = float(count)
            return name, (float(start), float(stop), int(count) if math.isfinite(count) and count == int(count)
                          else count)
        return name, [float(part) for part in spec.split(",")]
    except (ValueError, OverflowError):
        raise SweepError(f"{name}: expected {form} with numbers, got {spec!r}") from None


def grid_points(grid: dict, names=None) -> dict:
    """Every combination of the axes' values (the first axis varies slowest): {name: array of points}."""
    axes = [grid_values(name, grid[name], names) for name in grid]
    names = list(grid)
    _check_points_memory(math.prod(a.size for a in axes), len(names))
    mesh = np.meshgrid(*axes, indexing="ij")
    return {name: m.ravel() for name, m in zip(names, mesh)}


def random_points(ranges: dict, count: int, seed: int = 0, names=None) -> dict:
    """``count`` points drawn uniformly in the ranges {name: (low, high)} (numpy ``default_rng(seed)``)."""
    if int(count) != count or count < 1:
        raise SweepError(f"--random needs a whole number of points >= 1, got {count!r}")
    _check_points_memory(count, len(ranges))
    _check_seed(seed)
    rng = np.random.default_rng(seed)
    points = {}
    for name, bounds in ranges.items():
        _check_name(name, names)
        try:
            low, high = (float(v) for v in bounds)
        except (TypeError, ValueError):
            raise SweepError(f"{name}: a random range is (low, high), got {bounds!r}") from None
        if not (math.isfinite(low) and math.isfinite(high)) or high < low:
            raise SweepError(f"{name}: the range {low:g}..{high:g} must be finite with low <= high")
        points[name] = rng.uniform(low, high, int(count))
    return points


def _check_seed(seed) -> None:
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**63:
        raise SweepError(f"seed must be a whole number in [0, 2^63), got {seed!r}")


def _check_points_memory(count, axes: int) -> None:
    """Refuse up front (with the figure) a sweep whose table would not fit in memory: each point keeps its
    swept values and every quantity, a few times over (chunks, the joined table, the CSV's text)."""
    shown = f"{count:.4g}" if count < 1e300 else "more than 1e300"  # a 400-digit count overflows a float
    check_memory(f"a sweep of {shown} points", count, 4 * 8 * (axes + len(QUANTITIES) + 4))


# --- One chunk of points ------------------------------------------------------------------------------

def _point_params(base: Params, values: dict) -> Params:
    overrides = {k: float(v) for k, v in values.items() if k in PARAMETER_NAMES}  # Params checks whole numbers
    return base.replace(**overrides) if overrides else base


def _mechanics(alpha, pf, params: Params) -> tuple:
    """(X, pe, a1, a2) at postures alpha [rad] with flexor pressures pf [Pa] (arrays), pe holding them at rest."""
    geo = knee.geometry_at_alpha(alpha, params)
    pe = stability.equilibrium_pressure(alpha, pf, params)
    a1, a2 = stability.routh_hurwitz_coefficients(geo.X, pe, pf, 0.0, params)
    return geo.X, pe, a1, a2


def _check_posture(alpha_deg, pf_kpa) -> None:
    low, high = math.degrees(knee.ALPHA_STOP_LOW), math.degrees(knee.ALPHA_STOP_HIGH)
    bad = ~((alpha_deg > low) & (alpha_deg < high))
    if bad.any():
        raise DomainError(f"alpha_deg = {alpha_deg[bad][0]:g} is outside the end stops ({low:g}, {high:g}) deg: "
                          "such a posture cannot be held at rest")
    bad = ~(pf_kpa >= 0)
    if bad.any():
        raise DomainError(f"pf_kPa = {pf_kpa[bad][0]:g} is below 0: pressures are gauge pressures and the model "
                          "has no vacuum")


def evaluate_points(points: dict, fixed: dict | None = None) -> dict:
    """Every quantity of :data:`QUANTITIES` at the points {name: array} (plus ``fixed`` values for all).

    Runs on a worker. Vectorized over posture and pressure for each distinct parameter set; a set where
    the vectorized call fails is done point by point, and a point where the model is undefined gets NaN,
    verdict 'undefined' and its message in ``error``. Returns {column: array}.
    """
    fixed = dict(fixed or {})
    n = len(next(iter(points.values()))) if points else 1
    values = {name: np.broadcast_to(np.asarray(points[name], dtype=float), (n,)) if name in points
              else np.full(n, float(fixed.get(name, default)))
              for name, (_, default, _) in POSTURE_NAMES.items()}
    base = _point_params(DEFAULT, {k: v for k, v in fixed.items() if k in PARAMETER_NAMES})
    swept = [name for name in points if name in PARAMETER_NAMES]
    X, pe, a1, a2, tau = (np.full(n, np.nan) for _ in range(5))
    error = np.full(n, "", dtype=object)
    alpha = np.radians(values["alpha_deg"])
    pf = values["pf_kPa"] * 1e3
    if swept:
        keys = np.column_stack([np.broadcast_to(np.asarray(points[name], dtype=float), (n,)) for name in swept])
        unique, inverse = np.unique(keys, axis=0, return_inverse=True)
        order = np.argsort(inverse.ravel(), kind="stable")
        bounds = np.searchsorted(inverse.ravel()[order], np.arange(unique.shape[0] + 1))
        groups = [(dict(zip(swept, row)), order[bounds[i]:bounds[i + 1]]) for i, row in enumerate(unique)]
    else:
        groups = [({}, np.arange(n))]
    for overrides, where in groups:
        try:
            params = _point_params(base, overrides)
            tau[where] = params.tau
            _check_posture(values["alpha_deg"][where], values["pf_kPa"][where])
            if where.size == 1:  # python floats take the physics' fast scalar path
                i = int(where[0])
                X[i], pe[i], a1[i], a2[i] = (float(v) for v in _mechanics(float(alpha[i]), float(pf[i]), params))
            else:
                X[where], pe[where], a1[where], a2[where] = _mechanics(alpha[where], pf[where], params)
        except MkctlError:
            for i in where:  # find the points that fail, and keep the others
                try:
                    params = _point_params(base, overrides)
                    tau[i] = params.tau
                    _check_posture(values["alpha_deg"][i:i + 1], values["pf_kPa"][i:i + 1])
                    X[i], pe[i], a1[i], a2[i] = (float(v) for v in _mechanics(float(alpha[i]), float(pf[i]), params))
                except MkctlError as exc:
                    error[i] = str(exc)
    with np.errstate(invalid="ignore"):
        rest = {"X_m": X, "pe_kPa": pe / 1e3, "holdable": (error == "") & (pe >= 0)}
    return {**rest, **dynamics_columns(a1, a2, tau, error)}


def dynamics_columns(a1, a2, tau, error) -> dict:
    """The columns of :data:`DYNAMICS` that follow from a1, a2 and tau at rest (vectorized).

    Parameters
    ----------
    a1 : numpy.ndarray
        Velocity coefficient of Eq. 18 [1/s] (NaN where undefined).
    a2 : numpy.ndarray
        Position coefficient of Eq. 18 [1/s^2].
    tau : numpy.ndarray
        Pressure lag time constant [s] (0: none).
    error : numpy.ndarray of str
        Why the model is undefined at a point ("" where it is defined).

    Returns
    -------
    dict
        {column: array} for every name of :data:`DYNAMICS`.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18-20.
    """
    from .control import damping_ratio, natural_frequency

    defined = error == ""
    verdict = np.where(defined, stability.verdict(np.nan_to_num(a1), np.nan_to_num(a2)), "undefined")
    pair = stability.poles(a1, a2)  # NaN where undefined
    swap = pair[:, 1].imag > pair[:, 0].imag
    pair[swap] = pair[swap][:, ::-1]
    lag = np.where(tau > 0, -1.0 / np.where(tau > 0, tau, 1.0), np.nan)
    settling = np.full(a1.shape, np.inf)
    overshoot = np.full(a1.shape, np.nan)
    stable = defined & (verdict == "stable")
    if stable.any():
        poles = np.column_stack([pair[stable], np.where(np.isnan(lag[stable]), 0.0, lag[stable])])
        has_lag = ~np.isnan(lag[stable])
        s_no, o_no = step_metrics(poles[~has_lag, :2]) if (~has_lag).any() else (np.empty(0), np.empty(0))
        s_lag, o_lag = step_metrics(poles[has_lag]) if has_lag.any() else (np.empty(0), np.empty(0))
        s, o = np.empty(poles.shape[0]), np.empty(poles.shape[0])
        s[~has_lag], o[~has_lag], s[has_lag], o[has_lag] = s_no, o_no, s_lag, o_lag
        settling[stable], overshoot[stable] = s, o
    settling[~defined] = np.nan
    with np.errstate(invalid="ignore"):
        return {
            "a1": a1, "a2": a2,
            "verdict": verdict.astype(object), "pole1_re": pair[:, 0].real, "pole1_im": pair[:, 0].imag,
            "pole2_re": pair[:, 1].real, "pole2_im": pair[:, 1].imag, "lag_pole": lag,
            "damping_ratio": damping_ratio(a1, a2), "natural_frequency_hz": natural_frequency(a2) / (2 * np.pi),
            "settling_time_s": settling, "overshoot_percent": overshoot, "error": error,
        }


# --- Step response of an all-pole system, from its poles -------------------------------------------

def _separate(poles: np.ndarray) -> np.ndarray:
    """Nudge coincident poles apart (relative 1e-7) so that the partial fractions exist."""
    poles = poles.astype(complex).copy()
    k = poles.shape[1]
    for i in range(k):
        for j in range(i + 1, k):
            close = np.abs(poles[:, i] - poles[:, j]) <= 1e-7 * np.maximum(np.abs(poles[:, i]), 1e-300)
            poles[close, j] *= 1.0 + 1e-7 * (j - i)
    return poles


def _residues(poles: np.ndarray) -> np.ndarray:
    """r_i of ``y(t) = 1 + sum_i r_i exp(p_i t)``, the unit step response of ``prod(-p) / prod(s - p)``."""
    k = poles.shape[1]
    gain = np.prod(-poles, axis=1)
    r = np.empty_like(poles)
    for i in range(k):
        others = np.prod([poles[:, i] - poles[:, j] for j in range(k) if j != i], axis=0) if k > 1 else 1.0
        r[:, i] = gain / (poles[:, i] * others)
    return r


def _response(poles, residues, t) -> np.ndarray:
    """y at times t (rows: systems; t of shape (rows, m))."""
    return 1.0 + np.einsum("rk,rkm->rm", residues, np.exp(poles[:, :, None] * t[:, None, :])).real


def step_metrics(poles, band: float = SETTLING_BAND, per_period: int = 40, max_samples: int = 25_000,
                 max_elements: int = 2_000_000):
    """Settling time [s] and overshoot [%] of the unit step response of ``G(s) = prod(-p) / prod(s - p)``.

    ``poles``: array (systems, k) of stable poles (Re < 0), conjugate pairs complete. G has unit static
    gain and no zeros: the knee's linearization from pe_cmd to X, normalized. With distinct poles the
    response is ``y(t) = 1 + sum_i r_i exp(p_i t)``, ``r_i = prod_j(-p_j) / (p_i prod_{j!=i}(p_i - p_j))``.
    It is sampled up to ``T = ln(sum|r_i| / band) / sigma`` (sigma: the slowest decay rate; after T,
    ``|y - 1| <= sum|r_i| exp(-sigma t) <= band`` for sure), at least ``per_period`` samples per period
    of the fastest oscillation; then the last exit from the band is refined by bisection and the peak by
    a golden-section search. Definitions as python-control's ``step_info``: settling time = last time
    ``|y - 1| > band``; overshoot = ``100 max(max_t y - 1, 0)``. Accurate to about 1e-6 relative while
    the oscillation gets its samples per period, i.e. for damping ratios above about 1e-3 (the samples
    per system are capped at ``max_samples``; ``max_elements`` bounds the memory of one block).
    """
    poles = _separate(np.atleast_2d(np.asarray(poles)))
    rows = poles.shape[0]
    settling, overshoot = np.zeros(rows), np.zeros(rows)
    if rows == 0:
        return settling, overshoot
    if not (poles.real < 0).all():
        raise ValueError("step_metrics needs stable poles (Re < 0)")
    residues = _residues(poles)
    sigma = np.min(-poles.real, axis=1)
    total = np.sum(np.abs(residues), axis=1)
    horizon = np.log(np.maximum(total / band, 1.0 + 1e-12)) / sigma
    periods = np.max(np.abs(poles.imag), axis=1) * horizon / (2 * np.pi)
    # clipped before the cast: a nearly undamped system (zeta ~ 1e-19) would ask for more samples than an int holds
    samples = np.clip(per_period * periods + 200, 200, max_samples).astype(int)
    order = np.argsort(samples)
    start = 0
    while start < rows:  # blocks of rows with similar sample counts, at most max_elements values each
        m = samples[order[start]]
        stop = start + 1
        while stop < rows and samples[order[stop]] * (stop + 1 - start) <= max_elements:
            stop += 1
        block = order[start:stop]
        m = samples[block].max()
        settling[block], overshoot[block] = _block_metrics(poles[block], residues[block], horizon[block], m, band)
        start = stop
    return settling, overshoot


def _block_metrics(poles, residues, horizon, m, band):
    fraction = np.linspace(0.0, 1.0, m)
    t = horizon[:, None] * fraction[None, :]
    y = _response(poles, residues, t)
    rows = np.arange(poles.shape[0])
    outside = np.abs(y - 1.0) > band
    # settling: last sample outside the band, then bisect between it and the next one
    last = np.where(outside.any(axis=1), m - 1 - np.argmax(outside[:, ::-1], axis=1), -1)
    settling = np.zeros(poles.shape[0])
    some = last >= 0
    if some.any():
        lo = t[rows[some], last[some]]
        hi = t[rows[some], np.minimum(last[some] + 1, m - 1)]
        p, r = poles[some], residues[some]
        for _ in range(60):
            mid = 0.5 * (lo + hi)
            out = np.abs(_response(p, r, mid[:, None])[:, 0] - 1.0) > band
            lo, hi = np.where(out, mid, lo), np.where(out, hi, mid)
        settling[some] = hi
    # overshoot: the highest sample, then a golden-section search around it
    peak = np.argmax(y, axis=1)
    a = t[rows, np.maximum(peak - 1, 0)]
    b = t[rows, np.minimum(peak + 1, m - 1)]
    golden = (math.sqrt(5) - 1) / 2
    for _ in range(60):
        c, d = b - golden * (b - a), a + golden * (b - a)
        yc = _response(poles, residues, c[:, None])[:, 0]
        yd = _response(poles, residues, d[:, None])[:, 0]
        a, b = np.where(yc >= yd, a, c), np.where(yc >= yd, d, b)
    top = np.maximum(_response(poles, residues, (0.5 * (a + b))[:, None])[:, 0], y.max(axis=1))
    return settling, 100.0 * np.maximum(top - 1.0, 0.0)


# --- The sweep --------------------------------------------------------------------------------------

def _corners(points: dict) -> dict:
    """The corners of the points' bounding box (every min/max combination), at most 2^12 of them."""
    names = list(points)[:12]
    extremes = [sorted({float(np.min(points[n])), float(np.max(points[n]))}) for n in names]
    combos = list(itertools.product(*extremes))
    return {n: np.array([c[i] for c in combos]) for i, n in enumerate(names)}


def check_domain(points: dict, fixed: dict) -> None:
    """Raise :class:`SweepError` if the model is undefined at a corner of the swept ranges (one line)."""
    for name in fixed:
        _check_name(name)
    corners = _corners(points)
    n = len(next(iter(corners.values()))) if corners else 1
    values = {**{k: np.full(n, float(v)) for k, v in fixed.items()}, **corners}
    base_fixed = {k: v for k, v in fixed.items() if k in PARAMETER_NAMES}
    for i in range(n):
        point = {k: float(v[i]) for k, v in values.items()}
        where = ", ".join(f"{k} = {point[k]:g}" for k in corners) or "the fixed values"
        try:
            params = _point_params(_point_params(DEFAULT, base_fixed), point)
            alpha_deg = np.array([point.get("alpha_deg", POSTURE_NAMES["alpha_deg"][1])])
            pf_kpa = np.array([point.get("pf_kPa", POSTURE_NAMES["pf_kPa"][1])])
            _check_posture(alpha_deg, pf_kpa)
            _mechanics(float(np.radians(alpha_deg[0])), float(pf_kpa[0] * 1e3), params)
        except (ParameterError, DomainError) as error:
            raise SweepError(f"the range is outside the model's domain at {where}: {error}") from None


def _chunks(points: dict, count: int, chunk: int | None, jobs: int) -> list[tuple[int, dict]]:
    size = chunk or int(min(20_000, max(2_000, math.ceil(count / (4 * max(jobs, 1))))))
    return [(start, {k: v[start:start + size] for k, v in points.items()}) for start in range(0, count, size)]


def _evaluate_chunk(payload):
    """A chunk on a worker: (start, points, fixed, subject) -> (start, columns)."""
    start, points, fixed, subject = payload
    return start, subject.evaluate_points(points, fixed)


class KneeSweep:
    """What a sweep of the knee varies and computes (the default subject of :func:`sweep`).

    A subject names what can be swept (``names``), what is computed (``quantities``: {column: (unit,
    meaning)}), the unit of a name (``unit``), and evaluates points (``evaluate_points``) and checks the
    ranges' corners (``check_domain``); :class:`mkctl.analysis.mechanism_sweep.MechanismSweep` is any
    mechanism's.
    """

    title = ""  #: what the maps' titles begin with (the knee's: nothing, as before)

    @property
    def names(self) -> tuple:
        return tuple(SWEEP_NAMES)

    @property
    def quantities(self) -> dict:
        return QUANTITIES

    def unit(self, name: str) -> str:
        """The unit of a swept name ("" for none)."""
        return POSTURE_NAMES[name][0] if name in POSTURE_NAMES else UNITS.get(name, "")

    def evaluate_points(self, points: dict, fixed: dict | None = None) -> dict:
        return evaluate_points(points, fixed)

    def check_domain(self, points: dict, fixed: dict) -> None:
        check_domain(points, fixed)

    def __eq__(self, other):
        return type(other) is KneeSweep

    def __hash__(self):
        return hash(KneeSweep)


@dataclass(repr=False)
class SweepResult(Result):
    """A sweep: the points and every quantity of :data:`QUANTITIES` per point.

    Attributes: ``axes`` ({name: grid values} for a grid, {name: (low, high)} for a random sample),
    ``fixed`` (values held for all points), ``kind`` ('grid' or 'random'), ``points`` (number),
    ``seconds`` (wall time [s]), ``workers``; every column as a numpy array by its name (``result.a1``,
    ``result.verdict``, ``result.c``, ...); ``counts`` (points per verdict).
    """

    axes: dict
    fixed: dict
    kind: str
    columns: dict = field(default_factory=dict)
    seconds: float = 0.0
    workers: str = ""
    subject: object = field(default_factory=KneeSweep)  #: what was swept (KneeSweep or MechanismSweep)

    def __getattr__(self, name):
        columns = self.__dict__.get("columns", {})
        if name in columns:
            return columns[name]
        raise AttributeError(name)

    @property
    def points(self) -> int:
        return len(next(iter(self.columns.values()))) if self.columns else 0

    @property
    def counts(self) -> dict:
        verdicts, counts = np.unique(self.columns["verdict"].astype(str), return_counts=True)
        return {str(v): int(c) for v, c in zip(verdicts, counts)}

    @property
    def points_per_second(self) -> float:
        return self.points / self.seconds if self.seconds > 0 else math.inf

    def table(self) -> dict:
        """One row per point (for :meth:`to_dataframe`): the swept names, then :data:`QUANTITIES`."""
        return self.columns

    def save(self, folder, stem: str = "sweep") -> list[Path]:
        """Write ``<stem>.csv`` and, when pyarrow is installed, ``<stem>.parquet``; returns the paths."""
        folder = Path(folder)
        folder.mkdir(parents=True, exist_ok=True)
        table = self.to_dataframe()
        paths = [folder / f"{stem}.csv"]
        write_text_atomic(paths[0], table.to_csv(index=False))  # written aside and renamed: never half a table
        try:
            import pyarrow  # noqa: F401
        except ImportError:
            return paths
        paths.append(folder / f"{stem}.parquet")
        temporary = folder / f".{stem}.parquet.tmp"
        table.to_parquet(temporary, index=False)
        os.replace(temporary, paths[1])
        return paths

    def plot_map(self, quantity: str = "damping_ratio", x: str | None = None, y: str | None = None, path=None):
        """A map of ``quantity`` over the swept names x and y (default: the first two); returns the Figure.

        A grid is drawn cell by cell (other swept names held at their middle value, said in the title); a
        random sample as coloured points. ``verdict`` is drawn in categories. With one swept name, a curve.
        Saved as PNG at ``path`` if given."""
        return plot_map(self, quantity, x, y, path)

    def summary_lines(self) -> list[str]:
        axes = ", ".join(f"{k}: {len(v)} values {min(v):g}..{max(v):g}" if self.kind == "grid"
                         else f"{k}: {v[0]:g}..{v[1]:g}" for k, v in self.axes.items())
        lines = [f"{self.points} points ({self.kind}; {axes}) in {self.seconds:.2f} s "
                 f"({self.points_per_second:.0f} points/s) on {self.workers}"]
        if self.fixed:
            lines.append("fixed: " + ", ".join(f"{k} = {v:g}" for k, v in self.fixed.items()))
        lines.append("verdicts: " + ", ".join(f"{k} {v}" for k, v in self.counts.items()))
        quantities = self.subject.quantities
        for name in [*list(quantities)[:2], "damping_ratio", "settling_time_s", "overshoot_percent"]:
            if quantities[name][0] == "":  # a flag or a text
                continue
            v = self.columns[name][np.isfinite(self.columns[name])]
            if v.size:
                lines.append(f"{name:<18} {v.min():.4g} .. {v.max():.4g} {quantities[name][0]}")
        return lines


def sweep(grid: dict | None = None, *, random: int | None = None, ranges: dict | None = None,
          fixed: dict | None = None, seed: int = 0, jobs: int | None = None, scheduler: str | None = None,
          progress: bool = True, chunk: int | None = None, dashboard: str | None = None,
          subject=None) -> SweepResult:
    """The model over a grid or a random sample of parameters, postures and pressures.

    Parameters
    ----------
    grid : {name: (start, stop, count) or [values]}: every combination (names of :data:`SWEEP_NAMES`:
        parameters in SI, ``alpha_deg`` [deg], ``pf_kPa`` [kPa]).
    random, ranges : instead of a grid, ``random`` points drawn uniformly in ``ranges`` {name: (low, high)}
        (with ``seed``).
    fixed : values held for every point (same names); the rest are Table I, II, effects off, alpha = 60
        deg, pf = 100 kPa.
    jobs, scheduler, progress : as in :func:`mkctl.analysis.batch.run_batch` (``jobs=0``: in this process;
        by default a sweep that fits in one chunk runs in this process too).
    chunk : points per task (default: a few tasks per worker, 2000 to 20000 points each).
    dashboard : Dask's dashboard of the local cluster, as in :func:`mkctl.analysis.batch.run_batch`.
    subject : what is swept (default the knee, :class:`KneeSweep`; any mechanism:
        :func:`mkctl.analysis.mechanism_sweep.sweep_mechanism`), with its own names and quantities.

    Returns a :class:`SweepResult`. Raises :class:`SweepError` for an unknown name, a bad range, or a range
    outside the model's domain (checked at the corners of the ranges before any work).
    """
    subject = KneeSweep() if subject is None else subject
    fixed = {k: float(v) for k, v in (fixed or {}).items()}
    if chunk is not None and (isinstance(chunk, bool) or not isinstance(chunk, (int, np.integer)) or chunk < 1):
        raise SweepError(f"chunk must be a whole number of points >= 1, got {chunk!r}")
    _check_seed(seed)
    if (grid is None) == (random is None):
        raise SweepError("give either a grid or a number of random points (with their ranges)")
    if grid is not None:
        if not grid:
            raise SweepError("the grid has no axis: give at least one NAME=START:STOP:COUNT")
        axes = {name: grid_values(name, spec, subject.names) for name, spec in grid.items()}
        points, kind = grid_points(axes, subject.names), "grid"
    else:
        if not ranges:
            raise SweepError("a random sample needs at least one range NAME=LOW:HIGH")
        points, kind = random_points(ranges, random, seed, subject.names), "random"
        axes = {name: (float(min(b)), float(max(b))) for name, b in ranges.items()}
    overlap = sorted(set(points) & set(fixed))
    if overlap:
        raise SweepError(f"{overlap[0]} is both swept and fixed")
    subject.check_domain(points, fixed)
    count = len(next(iter(points.values())))
    workers = 1 if jobs == 0 else (default_jobs() if jobs is None else jobs)
    chunks = _chunks(points, count, chunk, workers)
    if len(chunks) == 1 and jobs is None and not scheduler:
        jobs = 0  # one chunk: starting workers (seconds) would cost more than the work
    from . import control  # noqa: F401 - imported before the clock starts (fmpy, python-control: a second)

    start = time.perf_counter()
    outcomes = run_batch(_evaluate_chunk, [(s, p, fixed, subject) for s, p in chunks], jobs=jobs, scheduler=scheduler,
                         progress=progress, description="chunks", dashboard=dashboard)
    failed = [o for o in outcomes if not o.ok]
    if failed:
        raise SweepError(f"a chunk of the sweep failed: {failed[0].error}")
    parts = sorted((o.value for o in outcomes), key=lambda part: part[0])
    columns = {name: np.asarray(values) for name, values in points.items()}
    for name in subject.quantities:
        columns[name] = np.concatenate([part[1][name] for part in parts])
    seconds = time.perf_counter() - start
    where = ("this process" if jobs == 0 else f"the scheduler at {scheduler}" if scheduler
             else f"{workers} local processes")
    return SweepResult(axes, fixed, kind, columns, seconds, where, subject)


# --- Maps --------------------------------------------------------------------------------------------

def _label(name: str, subject) -> str:
    if name in POSTURE_NAMES:
        return f"{name.rsplit('_', 1)[0]} [{POSTURE_NAMES[name][0]}]"
    unit = subject.quantities[name][0] if name in subject.quantities else subject.unit(name)
    return f"{name} [{unit}]" if unit else name


def plot_map(result: SweepResult, quantity: str = "damping_ratio", x: str | None = None, y: str | None = None,
             path=None):
    """See :meth:`SweepResult.plot_map`."""
    from matplotlib.colors import BoundaryNorm, ListedColormap

    from ..io.plotting import new_figure, save_png

    names = list(result.axes)
    if quantity not in result.columns:
        raise SweepError(f"no quantity {quantity!r} to map (known: {', '.join(result.subject.quantities)})")
    x = x or names[0]
    y = y if y is not None else (names[1] if len(names) > 1 and names[1] != x else None)
    for name in (x, y):
        if name is not None and name not in names:
            raise SweepError(f"{name!r} is not swept (swept: {', '.join(names)})")
    values = result.columns[quantity]
    categorical = quantity == "verdict"
    if categorical:
        values = np.array([_VERDICT_CODES[str(v)] for v in values], dtype=float)
        cmap = ListedColormap(["tab:green", "gold", "tab:red", "0.75"])
        norm = BoundaryNorm([-0.5, 0.5, 1.5, 2.5, 3.5], cmap.N)
    else:
        values = np.asarray(values, dtype=float)
        cmap, norm = "viridis", None
        finite = values[np.isfinite(values)]
        if quantity == "settling_time_s" and finite.size and finite.min() > 0 and finite.max() > 10 * finite.min():
            from matplotlib.colors import LogNorm

            norm = LogNorm(finite.min(), finite.max())
    title = f"{result.subject.title}{quantity}" + ("" if categorical or np.isfinite(values).all() else " (blank: never settles or undefined)")
    keep = np.ones(values.size, dtype=bool)
    if result.kind == "grid":
        held = []
        for name in names:
            if name in (x, y):
                continue
            axis = result.axes[name]
            middle = axis[len(axis) // 2]
            keep &= result.columns[name] == middle
            held.append(f"{name} = {middle:g}")
        if held:
            title += " at " + ", ".join(held)
    fig, ax = new_figure(figsize=(6.0, 4.6))
    if y is None:
        xs = result.columns[x][keep]
        order = np.argsort(xs)
        ax.plot(xs[order], values[keep][order], ".-")
        ax.set_ylabel(_label(quantity, result.subject) if not categorical else "verdict")
        if categorical:
            ax.set_yticks(list(_VERDICT_CODES.values()), list(_VERDICT_CODES))
    else:
        if result.kind == "grid":
            xv, yv = result.axes[x], result.axes[y]
            ix = np.searchsorted(xv, result.columns[x][keep])
            iy = np.searchsorted(yv, result.columns[y][keep])
            image = np.full((yv.size, xv.size), np.nan)
            image[iy, ix] = values[keep]
            image = np.ma.masked_invalid(image)
            mesh = ax.pcolormesh(_edges(xv), _edges(yv), image, cmap=cmap, norm=norm, shading="flat")
        else:
            mesh = ax.scatter(result.columns[x], result.columns[y], c=values, s=8, cmap=cmap, norm=norm)
        bar = fig.colorbar(mesh, ax=ax)
        if categorical:
            bar.set_ticks(list(_VERDICT_CODES.values()), labels=list(_VERDICT_CODES))
        else:
            bar.set_label(_label(quantity, result.subject))
        ax.set_ylabel(_label(y, result.subject))
    ax.set_xlabel(_label(x, result.subject))
    ax.set_title(title, fontsize=9)
    if path is not None:
        save_png(fig, path)
    return fig


def _edges(axis: np.ndarray) -> np.ndarray:
    """Cell edges around sorted grid values (half-way between neighbours)."""
    axis = np.asarray(axis, dtype=float)
    if axis.size == 1:
        return np.array([axis[0] - 0.5, axis[0] + 0.5])
    middle = 0.5 * (axis[1:] + axis[:-1])
    return np.concatenate([[2 * axis[0] - middle[0]], middle, [2 * axis[-1] - middle[-1]]])
