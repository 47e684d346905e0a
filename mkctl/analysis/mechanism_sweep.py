"""Any mechanism over many parameter sets (model-spec section 3b): ``mkctl sweep --mechanism NAME|FILE.py``.

What :mod:`mkctl.analysis.sweep` computes for the knee, for a mechanism of one coordinate: at every point
(the muscle's parameters in SI, the mechanism's own parameters, and each muscle's gauge pressure ``p1_kPa``,
``p2_kPa`` [kPa], the first muscle's first) the stable **equilibrium** of the coordinate between the stops
(:func:`mkctl.physics.mechanism.equilibrium`), ``a1`` and ``a2`` of Eq. 18 with the Routh-Hurwitz verdict
(:func:`mkctl.physics.mechanism.stability_coefficients`), the poles, the damping ratio, the natural frequency,
and the settling time and overshoot of the coordinate after a small step of the first muscle's command (the
linear model, whose transfer from a command to the coordinate has no zeros, as the knee's: the numbers follow
from the poles alone, :func:`mkctl.analysis.sweep.step_metrics`). A point without a stable equilibrium between
the stops (the mechanism would rest on a stop) gets verdict ``undefined`` and the reason in ``error``.

Example
-------
>>> from mkctl.analysis.mechanism_sweep import sweep_mechanism
>>> from mkctl.physics.mechanism import builtin_mechanism
>>> result = sweep_mechanism(builtin_mechanism("pulley_joint"), {"c": (0, 200, 3)}, jobs=0, progress=False)
>>> result.verdict.tolist()
['marginal', 'stable', 'stable']
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from functools import cached_property

import numpy as np

from ..errors import DomainError, MkctlError, ParameterError
from ..physics.mechanism import Mechanism, equilibrium, stability_coefficients, trace
from ..physics.params import PARAMETER_NAMES, UNITS, Params
from ..physics.tables import TABLE_II
from .sweep import DYNAMICS, SweepError, SweepResult, _corners, dynamics_columns, sweep

#: Each muscle's pressure where a sweep neither varies nor fixes it [kPa].
DEFAULT_PRESSURE_KPA = 300.0


@dataclass(frozen=True)
class MechanismSweep:
    """What a sweep of one mechanism varies and computes (a subject of :func:`mkctl.analysis.sweep.sweep`).

    A value (frozen, picklable with its mechanism): Dask's workers receive it with each chunk.
    """

    mechanism: Mechanism

    @property
    def title(self) -> str:
        return f"{self.mechanism.name}: "

    @property
    def pressure_names(self) -> tuple:
        """``p1_kPa``, ``p2_kPa``: each muscle's gauge pressure, in the mechanism's order of muscles."""
        return tuple(f"p{i + 1}_kPa" for i in range(len(self.mechanism.muscles)))

    @property
    def coordinate_column(self) -> str:
        """The column of the coordinate at rest, named with its unit (``theta_rad``, ``L_m``)."""
        return f"{self.mechanism.coordinate}_{self.mechanism.unit}"

    @cached_property
    def names(self) -> tuple:
        """Its own parameters, the muscle's and its effects', the knee's (Table II) only where the
        mechanism's lengths, mass or load use them (the hanging mass's m and g), then the pressures."""
        lengths, inertia, load = trace(self.mechanism)
        used = {s.name for e in (*lengths, inertia, load) for s in e.free_symbols}
        own = self.mechanism.parameter_names
        muscle = (n for n in PARAMETER_NAMES if n != "n" and n not in own and (n not in TABLE_II or n in used))
        return (*own, *muscle, *self.pressure_names)

    @property
    def quantities(self) -> dict:
        return {self.coordinate_column: (self.mechanism.unit, f"{self.mechanism.coordinate} at rest, the stable "
                                         "equilibrium between the stops"), **DYNAMICS}

    def unit(self, name: str) -> str:
        """The unit of a swept name ("" for none)."""
        if name in self.pressure_names:
            return "kPa"
        own = {q.name: q.unit for q in self.mechanism.parameters}
        unit = own.get(name, UNITS.get(name, ""))
        return "" if unit == "1" else unit

    def _point(self, values: dict):
        """The bound parameters and the pressures [Pa] of one point {name: value}."""
        mech = self.mechanism
        own = {k: v for k, v in values.items() if k in mech.parameter_names}
        muscle = {k: v for k, v in values.items() if k in PARAMETER_NAMES}
        p = mech.bind(Params(**muscle), **own)
        pressures = []
        for name in self.pressure_names:
            kpa = values.get(name, DEFAULT_PRESSURE_KPA)
            if not (math.isfinite(kpa) and kpa >= 0):
                raise DomainError(f"{name} = {kpa:g} is below 0: pressures are gauge pressures and the model "
                                  "has no vacuum")
            pressures.append(kpa * 1e3)
        return p, tuple(pressures)

    def _rest(self, values: dict) -> tuple:
        """(q, a1, a2, tau) at the point's stable equilibrium."""
        p, pressures = self._point(values)
        q = equilibrium(self.mechanism, pressures, p)
        a1, a2 = stability_coefficients(self.mechanism, q, pressures, p)
        return q, float(a1), float(a2), float(p.tau)

    def evaluate_points(self, points: dict, fixed: dict | None = None) -> dict:
        """Every quantity at the points {name: array} (plus ``fixed`` values for all), point by point."""
        fixed = dict(fixed or {})
        n = len(next(iter(points.values()))) if points else 1
        q, a1, a2, tau = (np.full(n, np.nan) for _ in range(4))
        error = np.full(n, "", dtype=object)
        for i in range(n):
            values = {**fixed, **{k: float(np.asarray(v).ravel()[i]) for k, v in points.items()}}
            try:
                q[i], a1[i], a2[i], tau[i] = self._rest(values)
            except MkctlError as exc:
                error[i] = str(exc)
        return {self.coordinate_column: q, **dynamics_columns(a1, a2, np.nan_to_num(tau), error)}

    def check_domain(self, points: dict, fixed: dict) -> None:
        """Refuse ranges whose corners lie outside the parameters' bounds, or a negative pressure (one line).

        A corner without a stable equilibrium is not refused: that is a finding of the sweep (``undefined``)."""
        corners = _corners(points)
        n = len(next(iter(corners.values()))) if corners else 1
        for i in range(n):
            values = {**fixed, **{k: float(v[i]) for k, v in corners.items()}}
            where = ", ".join(f"{k} = {values[k]:g}" for k in corners) or "the fixed values"
            try:
                self._point(values)
            except (ParameterError, DomainError) as error:
                raise SweepError(f"the range is outside the model's domain at {where}: {error}") from None


def sweep_mechanism(mechanism: Mechanism, grid: dict | None = None, **options) -> SweepResult:
    """A mechanism over a grid or a random sample of its parameters, the muscle's and the pressures.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism (a built-in, or one read by :func:`mkctl.analysis.mechanism_files.mechanism`).
    grid : dict, optional
        {name: (start, stop, count) or [values]}: every combination; names of :attr:`MechanismSweep.names`
        (parameters in SI, pressures ``p1_kPa``, ``p2_kPa`` in kPa).
    **options
        As :func:`mkctl.analysis.sweep.sweep`: ``random``, ``ranges``, ``fixed``, ``seed``, ``jobs``,
        ``scheduler``, ``progress``, ``chunk``, ``dashboard``.

    Returns
    -------
    SweepResult
        The points, the coordinate at rest and every quantity of
        :data:`mkctl.analysis.sweep.DYNAMICS` per point.

    Raises
    ------
    SweepError
        For an unknown name, a bad range, or a range outside the parameters' bounds.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18-20.
    .. [2] model-spec section 3b (the stability analysis of any mechanism of one coordinate).
    """
    return sweep(grid, subject=MechanismSweep(mechanism), **options)
