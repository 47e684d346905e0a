"""The air's own parameters on a pressure record: what the record identifies, and what it holds.

The shared search (:mod:`.search`) fits one parameter per effect (``valve_flow``: ``C_fill``). An
effect that moves the air (model-spec 4d) has more values a pressure record can show: the valve's
critical ratio ``b_cr`` and subsonic index ``m_sub`` (the bend near the supply), the regulator's
``band`` (where the valve stops choking), and the leak's and the heat's values. :func:`fit_air`
refits them jointly by least squares on the whole record (log space for conductances and time
constants, linear for the ratios), from sensible starts (``C_fill`` from the record's initial slope,
:func:`mkctl.physics.air.choked_fill_rate`), with standard errors ``s^2 (J^T J)^+`` widened for
correlated residuals (:func:`mkctl.analysis.statistics.covariance`). A value the record does not
identify (a relative standard error above :data:`IDENTIFIED`, a fit on its bound, or a column the
record does not move) is held at its start with a note, never reported as a confident value: the
rig's numbers (``V_dead``, the supply, ``T_air``, ``k_poly``) are never fitted, so on a held
muscle a conductance ``C`` stands for ``C / V`` (:func:`identified_ratios`), reported as such.

It runs before the search on a record whose baseline already has the valve (a record driven by
openings: the valve's calibration, model-spec 5c), and after it when the search added the valve.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from ...errors import MkctlError
from ...io.measurements import Measurement
from ...physics import actuator
from ...physics.air import air_volume, choked_fill_rate
from ...physics.params import Params
from ..compare import simulate_output
from ..statistics import covariance, effective_samples, lag_one_correlation

#: A value whose standard error exceeds this share of it (or of its range, for a ratio) is held.
IDENTIFIED = 0.3
#: At most this many samples enter the fit (every k-th sample of a longer record).
FIT_SAMPLES = 1500


@dataclass(frozen=True)
class AirFit:
    """The air's refit: the parameter set, the identified values and their standard errors (SI),
    the values held (name -> why), the notes in words and the RMSE before and after [Pa]."""

    params: Params
    values: dict
    uncertainty: dict
    held: dict = field(default_factory=dict)
    notes: list = field(default_factory=list)
    rmse_before: float = math.nan
    rmse_after: float = math.nan
    #: what the record moves (held or not): what a candidate effect is refitted beside
    moved: tuple = ()
    #: what a held muscle's record identifies of a conductance: ``"C_fill/V"`` -> (value, standard
    #: error) [1/(s Pa)] (:func:`identified_ratios`)
    identified: dict = field(default_factory=dict)


def air_parameters(params: Params, known=()) -> list:
    """The parameters of the effects that move the air in ``params`` that a record may identify.

    Not a switch, not the rig's own (``rig``), not a setting (``fitted`` False), not a value the
    record states (``known``), and not one at 0 that means "the same as another" (``C_exhaust``:
    its off value 0 while its effect is on by another switch).

    Parameters
    ----------
    params : Params
        The parameter set.
    known : collection of str
        Parameters the record gives.

    Returns
    -------
    list of Parameter
        In the registry's order.
    """
    chosen = []
    for effect in actuator.active_effects(params):
        if not effect.moves_air:
            continue
        for q in effect.parameters:
            if q.switch or q.rig or not q.fitted or q.name in known:
                continue
            if q is not effect.switch_parameter and getattr(params, q.name) == q.off == 0:
                continue
            chosen.append(q)
    return chosen


def _log_space(q) -> bool:
    """Conductances and time constants (lower bound 0 or positive, spanning decades): log space."""
    return q.lower >= 0 and (q.upper / max(q.lower, q.smallest_on, 1e-300) > 100 or q.lower == 0)


def to_search(q, value: float) -> float:
    """A parameter's value as the fits search it: log10 for a conductance or a time constant
    (:func:`_log_space`), value / scale for a ratio."""
    return math.log10(value) if _log_space(q) else value / q.scale


def searchable(q, value: float) -> bool:
    """Whether a value can be searched as :func:`to_search` does (not 0 on a log scale: an effect
    switched off)."""
    return value > 0 or not _log_space(q)


def from_search(q, x: float) -> float:
    """The inverse of :func:`to_search`."""
    return 10.0 ** x if _log_space(q) else x * q.scale


def search_bounds(q, value: float) -> tuple[float, float]:
    """The search range in x: the parameter's bounds (its fit range), four decades around the value
    where a bound is 0 or infinite."""
    high = q.fit_range[1] if q.fit_range else q.upper
    if not math.isfinite(high):
        high = value * 1e4
    if not _log_space(q):
        return to_search(q, q.lower), to_search(q, high)
    low = max(q.lower, q.smallest_on, value * 1e-4)
    return to_search(q, low), to_search(q, high)


def start_from_slope(measurement: Measurement, params: Params) -> float | None:
    """``C_fill`` from the record's initial fill slope, or None when the record has no choked fill.

    Where the valve is fully open to the supply (an opening of 1, or a set-point more than three
    bands above the pressure) and the flow chokes (``p / p_supply <= b_cr``), ``dP/dt`` is
    :func:`mkctl.physics.air.choked_fill_rate`, linear in ``C_fill``: the median slope over those
    samples divided by the rate per unit conductance.

    Parameters
    ----------
    measurement : Measurement
        A pressure record.
    params : Params
        Its parameter set (the supply, b_cr, the volume at its length).

    Returns
    -------
    float or None
        The conductance [m^3/(s Pa)].
    """
    m, P = measurement, measurement.output
    if "valve" in m.inputs:
        full = m.inputs["valve"] >= 1.0
    else:
        full = m.inputs["p_cmd"] - P > 3.0 * params.band
    p_abs, supply = P + 101325.0, params.P_supply + 101325.0
    choked = full & (p_abs / supply <= params.b_cr)
    index = np.flatnonzero(choked[:-1] & choked[1:])
    if index.size < 3:
        return None
    slope = float(np.median(np.diff(P)[index] / np.diff(m.time)[index]))
    length = (
        m.inputs["length"][index] if "length" in m.inputs else m.settings.get("length", params.L0)
    )
    volume = float(
        np.median(air_volume(np.asarray(length, dtype=float), params.b, params.n, params.V_dead))
    )
    per_unit = float(choked_fill_rate(volume, 1.0, params.P_supply, params.k_poly, params.T_air))
    return slope / per_unit if slope > 0 and per_unit > 0 else None


def record_volume(measurement: Measurement, params: Params) -> float:
    """The muscle's air volume V [m^3] at the record's (median) length (Eq. 6 plus ``V_dead``).

    Parameters
    ----------
    measurement : Measurement
        A pressure record.
    params : Params
        The parameter set (``b``, ``n``, ``V_dead``).

    Returns
    -------
    float
    """
    m = measurement
    length = (
        np.median(m.inputs["length"])
        if "length" in m.inputs
        else m.settings.get("length", params.L0)
    )
    return float(air_volume(float(length), params.b, params.n, params.V_dead))


#: The unit of a conductance that fills or drains the muscle's volume (a valve's, a leak's).
CONDUCTANCE_UNIT = "m^3/(s Pa)"


def volume_unknown(measurement: Measurement, known=()) -> bool:
    """Whether a record leaves the muscle's volume to the assumed dead volume: a held muscle (no
    measured length, no load) whose record does not give ``V_dead``. Its pressure depends on a
    conductance only through ``C / V`` (model-spec 4d: ``dP/dt = k R T q_m / V`` with ``q_m``
    linear in C)."""
    m = measurement
    return "length" not in m.inputs and "load" not in m.settings and "V_dead" not in known


def identified_ratios(measurement: Measurement, params: Params, values: dict, errors: dict,
                      units: dict) -> dict:
    """``C / V`` and its standard error for each fitted conductance (unit :data:`CONDUCTANCE_UNIT`)
    of ``values``: what a held muscle's record identifies when V rests on an assumed dead volume.

    Parameters
    ----------
    measurement : Measurement
        A pressure record.
    params : Params
        The fitted parameter set (its ``V_dead``, ``b``, ``n``).
    values, errors : dict
        Fitted values and their standard errors [SI].
    units : dict
        Each fitted parameter's unit.

    Returns
    -------
    dict
        ``"C_fill/V"`` -> (value, standard error) [1/(s Pa)].
    """
    ratios = {}
    for name, value in values.items():
        if units.get(name) != CONDUCTANCE_UNIT:
            continue
        volume = record_volume(measurement, params)
        error = errors.get(name)
        ratios[f"{name}/V"] = (value / volume, None if error is None else float(error / volume))
    return ratios


def fit_air(measurement: Measurement, params: Params, say=None, known=(), also=()) -> AirFit | None:
    """Refit the air's parameters of ``params`` on a pressure record (see the module docstring).

    Parameters
    ----------
    measurement : Measurement
        The pressure record (its inputs as the fits use them).
    params : Params
        The parameter set with an effect that moves the air on.
    say : callable, optional
        Progress lines.
    known : collection of str
        Parameters the record gives (not fitted).
    also : sequence of Parameter
        Parameters of other effects refitted with them (a dead time the search added).

    Returns
    -------
    AirFit or None
        None when there is nothing to fit or the model cannot simulate the record.
    """
    say = say or (lambda text: None)
    m = measurement
    names = air_parameters(params, known)
    if not names or m.experiment != "pressure":
        return None
    names += [q for q in also if q not in names]
    starts = {q.name: getattr(params, q.name) for q in names}
    slope_start = start_from_slope(m, params) if "C_fill" in starts else None
    stride = max(1, m.samples // FIT_SAMPLES)
    at = np.arange(0, m.samples, stride)
    scale = max(float(np.std(np.diff(m.output))), 1.0)

    def simulate(p):
        try:
            return simulate_output(m, p, at)
        except MkctlError:
            return None

    def params_at(active, x):
        return params.replace(**{q.name: from_search(q, v) for q, v in zip(active, x)})

    def solve(active, start):
        low, high = (np.array(v) for v in zip(*(search_bounds(q, start[q.name]) for q in active)))
        x0 = np.clip([to_search(q, start[q.name]) for q in active], low + 1e-9, high - 1e-9)

        def residual(x):
            y = simulate(params_at(active, x))
            return np.full(at.size, 1e3) if y is None else (y - m.output[at]) / scale

        return (
            least_squares(
                residual,
                x0,
                bounds=(low, high),
                diff_step=1e-4,
                x_scale=1.0,
                xtol=1e-8,
                ftol=1e-10,
                max_nfev=40 * (len(active) + 1),
            ),
            low,
            high,
        )

    before = simulate(params)
    if before is None:
        return None
    rmse_before = float(np.sqrt(np.mean((before - m.output[at]) ** 2)))
    if slope_start is not None:  # the choked slope: a start the search converges from
        candidate = params.replace(C_fill=min(max(slope_start, 1e-11), 1e-6))
        y = simulate(candidate)
        if y is not None and np.mean((y - m.output[at]) ** 2) < rmse_before**2:
            starts["C_fill"] = candidate.C_fill
    active, held, unmoved = list(names), {}, set()
    for _ in range(len(names)):
        say("    air: fitting " + ", ".join(q.name for q in active) + " on the whole record")
        result, low, high = solve(active, starts)
        n = at.size
        k = len(active)
        n_eff = effective_samples(n, lag_one_correlation(result.fun))
        cov = covariance(result.jac, result.fun, k, n_eff)
        unheld = []
        for i, q in enumerate(active):
            x, sd = result.x[i], math.sqrt(max(cov[i, i], 0.0))
            column = float(np.linalg.norm(result.jac[:, i]))
            relative = sd * math.log(10.0) if _log_space(q) else sd * q.scale / (q.upper - q.lower)
            if column < 1e-9:
                held[q.name] = "the record does not move it"
                unmoved.add(q.name)
            elif min(x - low[i], high[i] - x) < 1e-3 * (high[i] - low[i]):
                held[q.name] = f"the fit ran to its bound ({from_search(q, x):.3g} {q.unit})"
            elif not relative <= IDENTIFIED:
                held[q.name] = f"its standard error is {relative:.0%} of " + (
                    "it" if _log_space(q) else "its range"
                )
            else:
                unheld.append(q)
        if len(unheld) == len(active) or not unheld:
            break
        active = unheld  # refit without the held ones, at their start values
    values = {
        q.name: float(from_search(q, x)) for q, x in zip(active, result.x) if q.name not in held
    }
    fitted = params.replace(**values, **{name: starts[name] for name in held})
    errors = {}
    for i, q in enumerate(active):
        if q.name in values:
            sd = math.sqrt(max(cov[i, i], 0.0))
            errors[q.name] = float(
                values[q.name] * math.log(10.0) * sd if _log_space(q) else sd * q.scale
            )
    after = simulate(fitted)
    if after is None:
        return None
    rmse_after = float(np.sqrt(np.mean((after - m.output[at]) ** 2)))
    notes = [f"{name} held at {starts[name]:.4g}: {why}" for name, why in held.items()]
    identified = {}
    if volume_unknown(m, known):
        units = {q.name: q.unit for q in names}
        identified = identified_ratios(m, fitted, values, errors, units)
        volume = record_volume(m, fitted)
        for key, (ratio, error) in identified.items():
            name = key.split("/")[0]
            errors.pop(name, None)  # the conductance alone is as uncertain as the assumed V_dead
            notes.append(
                f"the record identifies {name} / V = {ratio:.4g} +- {error:.2g} 1/(s Pa) (V = "
                f"{volume * 1e6:.4g} cm^3 at its length, with V_dead = "
                f"{fitted.V_dead * 1e6:.3g} cm^3 as assumed): a held muscle cannot tell {name} "
                f"and V_dead apart, so {name} = {values[name]:.4g} {q_unit(names, name)} "
                "holds only for that V_dead"
            )
    for text in notes:
        say("    air: " + text)
    moved = tuple(q.name for q in names if q.name not in unmoved)
    return AirFit(fitted, values, errors, held, notes, rmse_before, rmse_after, moved, identified)


def q_unit(parameters, name: str) -> str:
    """The unit of the parameter ``name`` among ``parameters``."""
    return next(q.unit for q in parameters if q.name == name)
