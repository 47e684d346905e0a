"""The linear view of any mechanism of one coordinate (model-spec 3b), with python-control.

The knee's :mod:`mkctl.analysis.control` for a :class:`~mkctl.physics.mechanism.Mechanism`: an
operating point (each muscle's pressure and the stable rest there,
:func:`mkctl.physics.mechanism.equilibrium`), the stability coefficients a1, a2, the poles and
the Routh-Hurwitz verdict of Eq. 18-20 (:func:`mkctl.physics.mechanism.equilibrium_stability`),
python-control's state-space system (:func:`mkctl.physics.mechanism.linear_system`), root loci
against the damping c, the lag tau or the gain of a proportional controller of the coordinate
through muscle 1's command, and step responses of muscle 1's command, linear against nonlinear
(:func:`mkctl.physics.mechanism.simulate_mechanism`).

Muscle damping c enters a1 linearly (``a1 = a1(0) - c sum_i (dL_i/dq)^2 / M``), so the damping for
a damping ratio zeta is ``c = (-2 zeta sqrt(-a2) - a1(0)) / (a1(1) - a1(0))``
(:func:`damping_for_zeta`), a1(1) the coefficient at c = 1 N s/m.

Example
-------
>>> from mkctl.analysis.mechanism_control import operating_point
>>> from mkctl.physics.mechanism import PULLEY_JOINT
>>> op = operating_point(PULLEY_JOINT, (400e3, 300e3))
>>> op.stability().verdict
'marginal'
"""
from __future__ import annotations

import dataclasses
import math

import control as ct
import numpy as np

from ..errors import MkctlError
from ..physics.mechanism import (Mechanism, equilibrium, equilibrium_stability, linear_system,
                                 muscle_params, sealed_coefficients, simulate_mechanism)
from ..physics.params import DEFAULT
from ..results import Result


class MechanismControlError(MkctlError, ValueError):
    """A mechanism's operating point, locus or step that cannot be made (one line)."""


#: How a coordinate is shown: (unit shown, factor from SI) by its SI unit.
DISPLAY = {"m": ("mm", 1e3), "rad": ("deg", 180.0 / math.pi)}


def display_unit(mechanism: Mechanism) -> tuple[str, float]:
    """(unit, factor from SI) in which the coordinate of ``mechanism`` is shown: mm or deg."""
    return DISPLAY[mechanism.unit]


def shown(value: float, digits: int = 6) -> str:
    """A coordinate for text: rounding noise below 1e-9 shown as 0."""
    return f"{0.0 if abs(value) < 1e-9 else value:.{digits}g}"


@dataclasses.dataclass(frozen=True)
class OperatingPoint:
    """A mechanism at rest: each muscle's pressure [Pa] (its command too), the parameters and the
    coordinate."""

    mechanism: Mechanism
    pressures: tuple  #: [Pa], one per muscle
    params: object  #: MechanismParams (the muscle's and the mechanism's own values)
    q: float  #: [m or rad]

    def with_params(self, **values) -> "OperatingPoint":
        """The same rest with other muscle parameters (c, tau, ...): rest depends neither on the
        velocity effects nor on the pressure dynamics."""
        return dataclasses.replace(self, params=self.mechanism.bind(self.params, **values))

    def stability(self):
        """a1, a2, poles and verdict (:func:`mkctl.physics.mechanism.equilibrium_stability`)."""
        return equilibrium_stability(self.mechanism, self.pressures, self.params, q=self.q)

    def linear_system(self) -> ct.StateSpace:
        """python-control's state space here (:func:`mkctl.physics.mechanism.linear_system`)."""
        return linear_system(self.mechanism, self.pressures, self.params, q=self.q)

    def describe(self) -> str:
        """One line: the coordinate at rest (mm or deg), each muscle's pressure, c and tau."""
        unit, factor = display_unit(self.mechanism)
        muscles = zip(self.mechanism.muscles, self.pressures)
        held = ", ".join(f"{m} {P / 1e3:g} kPa" for m, P in muscles)
        muscle = muscle_params(self.params)
        return (f"{self.mechanism.name}: {self.mechanism.coordinate} = {shown(self.q * factor)} "
                f"{unit} at rest, {held}, c = {muscle.c:.4g} N s/m, tau = {muscle.tau:g} s")


def operating_point(mechanism: Mechanism, pressures, params=DEFAULT, q=None) -> OperatingPoint:
    """The rest of ``mechanism`` under ``pressures`` [Pa] (one per muscle).

    At ``q`` [m or rad], or the stable equilibrium between its stops
    (:func:`mkctl.physics.mechanism.equilibrium`); a one-line :class:`MechanismControlError` where
    there is none.
    """
    try:
        p = mechanism.bind(params)
        pressures = tuple(float(P) for P in pressures)
        if len(pressures) != len(mechanism.muscles):
            raise MechanismControlError(
                f"mechanism {mechanism.name} has {len(mechanism.muscles)} muscle(s) "
                f"({', '.join(mechanism.muscles)}); got {len(pressures)} pressure(s)")
        q = equilibrium(mechanism, pressures, p) if q is None else float(q)
    except MechanismControlError:
        raise
    except MkctlError as error:
        raise MechanismControlError(str(error)) from None
    return OperatingPoint(mechanism, pressures, p, q)


def damping_for_zeta(zeta: float, op: OperatingPoint) -> float:
    """The muscle damping c [N s/m] that gives the mechanical poles the damping ratio ``zeta``
    (module docstring); 0 when the mechanism's own damping already exceeds it."""
    a2 = op.stability().a2
    if not a2 < 0:
        raise MechanismControlError(f"a2 = {a2:.6g} 1/s^2 >= 0 at {op.describe()}: no restoring "
                                    "force, no damping ratio")
    a1_0 = op.with_params(c=0.0).stability().a1
    slope = op.with_params(c=1.0).stability().a1 - a1_0
    if not slope < 0:
        raise MechanismControlError(f"muscle damping does not damp {op.mechanism.name} here "
                                    "(no moment arm)")
    return max(0.0, (-2.0 * zeta * math.sqrt(-a2) - a1_0) / slope)


def locus(op: OperatingPoint, name: str, values) -> np.ndarray:
    """The poles [1/s] with the muscle parameter ``name`` (c or tau) at each of ``values``.

    One row per value, sorted, padded with NaN (the lag adds a pole per muscle where tau > 0).
    """
    rows = [np.sort_complex(op.with_params(**{name: float(v)}).linear_system().poles())
            for v in values]
    width = max(r.size for r in rows)
    return np.array([np.concatenate([r, np.full(width - r.size, np.nan)]) for r in rows])


def air_pole_sweep(op: OperatingPoint, name: str, values):
    """The mechanism's poles with the air's pressure states, one of its values swept (model-spec
    4d), with the pressures-held and the sealed poles.

    As the knee's :func:`mkctl.analysis.air_poles.air_pole_sweep`: the air switched on
    (:func:`mkctl.analysis.air_poles.air_switched_on`, its typical values unless op's params give
    others), each linearization :func:`mkctl.physics.mechanism.linearization` (the regulators on
    their filling side at rest), the sealed limit
    :func:`mkctl.physics.mechanism.sealed_coefficients`.

    Parameters
    ----------
    op : OperatingPoint
        The rest (at rest the regulators hold their set-points: the air does not move it).
    name : str
        One of :data:`mkctl.analysis.air_poles.AIR_SWEEPS` (C_fill, V_dead, band).
    values : array_like
        Its values [its unit].

    Returns
    -------
    mkctl.analysis.air_poles.AirPoleSweep
        The poles at each value (2 + muscles per row, sorted), held and sealed poles, a2 both ways.

    Raises
    ------
    MechanismControlError
        For another name.
    """
    from . import air_poles
    from ..physics.stability import poles as pair_poles

    if name not in air_poles.AIR_SWEEPS:
        raise MechanismControlError(f"--vary {name}: the air's parameters to vary are "
                                    f"{', '.join(air_poles.AIR_SWEEPS)}")
    values = np.asarray(values, dtype=float)
    air = op.with_params(**air_poles.air_switched_on())
    poles = np.array([np.sort_complex(air.with_params(**{name: float(v)}).linear_system().poles())
                      for v in values])
    held = air.stability()
    s1, s2 = sealed_coefficients(op.mechanism, op.q, op.pressures, air.params)
    return air_poles.AirPoleSweep(name, air_poles.AIR_SWEEPS[name][0], values, poles,
                           np.asarray(held.poles, dtype=complex), pair_poles(s1, s2),
                           float(held.a2), s2)


def position_loop(op: OperatingPoint) -> ct.StateSpace:
    """The coordinate per muscle 1's command, its sign made so that a positive gain K in
    ``u1 = K (q_ref - q)`` is negative feedback."""
    plant = op.linear_system()[0, 0]
    sign = 1.0 if float(np.real(ct.dcgain(plant))) >= 0 else -1.0
    return sign * plant


def gain_locus(op: OperatingPoint, gains) -> np.ndarray:
    """The closed-loop poles [1/s] of ``u1 = K (q_ref - q)`` at each gain K [Pa/m or Pa/rad]."""
    loop = position_loop(op)
    return np.array([np.sort_complex(np.linalg.eigvals(loop.A - K * loop.B @ loop.C))
                     for K in gains])


def critical_gain(op: OperatingPoint, top: float = 1e12) -> float:
    """The smallest gain at which :func:`gain_locus` has a pole in the right half-plane.

    Found on a geometric grid from 1 to ``top`` and refined by bisection; inf when there is none up
    to ``top``, 0 when the loop is unstable already at K = 0.
    """
    def unstable(gain):
        return np.max(gain_locus(op, [gain])[0].real) > 1e-9

    if unstable(0.0):
        return 0.0
    grid = np.geomspace(1.0, top, 241)
    flags = [np.max(r.real) > 1e-9 for r in gain_locus(op, grid)]
    if not any(flags):
        return math.inf
    first = flags.index(True)
    low, high = (grid[first - 1], grid[first]) if first else (0.0, grid[0])
    for _ in range(60):
        mid = math.sqrt(low * high) if low > 0 else 0.5 * high
        low, high = (low, mid) if unstable(mid) else (mid, high)
    return high


@dataclasses.dataclass(repr=False, eq=False)
class MechanismStep(Result):
    """A mechanism's responses to a step of muscle 1's command: q - q_op [m or rad] on ``time``."""

    mechanism: str
    coordinate: str
    unit: str
    time: np.ndarray  #: [s]
    linear: np.ndarray  #: the linear system's response [m or rad]
    nonlinear: np.ndarray  #: the nonlinear model's response [m or rad]
    dp: float  #: the step [Pa]
    t_step: float  #: [s]
    info: dict = dataclasses.field(default_factory=dict)  #: python-control's step_info per model
    end_stop: str | None = None

    def __getitem__(self, name):
        return getattr(self, name)

    def summary_lines(self):
        """The step, then each model's final offset in mm or deg."""
        unit, factor = DISPLAY[self.unit]
        first = (f"{self.mechanism}: muscle 1 stepped by {self.dp / 1e3:+g} kPa at "
                 f"t = {self.t_step:g} s")
        return [first] + [f"{name}: final {self.coordinate} - op = "
                          f"{factor * self[name][-1]:+.4g} {unit}"
                          for name in ("linear", "nonlinear")]

    def table(self):
        """Columns time [s], linear and nonlinear [m or rad]."""
        return {"time": self.time, "linear": self.linear, "nonlinear": self.nonlinear}


def step_responses(op: OperatingPoint, dp: float, duration: float = 2.0, t_step: float = 0.1,
                   dt: float = 1e-3) -> MechanismStep:
    """q - q_op after a step of muscle 1's command by ``dp`` [Pa] at ``t_step`` [s].

    The linear system's (python-control ``step_response``) and the nonlinear model's
    (:func:`mkctl.physics.mechanism.simulate_mechanism`, stops on), sampled every ``dt`` [s] to
    ``duration`` [s], with python-control's ``step_info`` of each.
    """
    from .control import _response_info

    if not (math.isfinite(dp) and dp != 0 and op.pressures[0] + dp >= 0):
        raise MechanismControlError(f"the step {dp / 1e3:+g} kPa must be non-zero and keep muscle "
                                    f"1's pressure >= 0 (it is {op.pressures[0] / 1e3:g} kPa)")
    if not (math.isfinite(dt) and 0 < dt < duration - t_step and duration / dt <= 1e6):
        raise MechanismControlError(f"dt = {dt!r} s must be positive, shorter than the response "
                                    "after the step and give at most 1e6 samples")
    time = np.arange(int(round(duration / dt)) + 1) * dt
    after = time >= t_step - 1e-12
    plant = op.linear_system()[0, 0]
    linear = np.zeros_like(time)
    response = ct.step_response(plant, time[after] - time[after][0])
    linear[after] = dp * np.asarray(response.outputs).ravel()
    commands = [np.where(after, op.pressures[0] + dp, op.pressures[0])]
    commands += [np.full(time.size, P) for P in op.pressures[1:]]
    try:
        run = simulate_mechanism(time, tuple(commands), op.mechanism, op.params, q0=op.q)
    except MkctlError as error:
        raise MechanismControlError(f"the nonlinear model failed: {error}") from None
    nonlinear = run.q - op.q
    low, high = op.mechanism.stop_positions(op.params)
    hit = (run.q <= low) | (run.q >= high)
    end_stop = f"an end stop at t = {time[np.argmax(hit)]:.3g} s" if hit.any() else None
    result = MechanismStep(op.mechanism.name, op.mechanism.coordinate, op.mechanism.unit, time,
                           linear, nonlinear, dp, t_step, end_stop=end_stop)
    finals = {"linear": dp * float(np.real(ct.dcgain(plant))), "nonlinear": None}
    result.info = {name: _response_info(time[after] - t_step, result[name][after], finals[name])
                   for name in ("linear", "nonlinear")}
    return result


# --- pictures -------------------------------------------------------------------------------------

def plot_locus(op: OperatingPoint, values, poles, what: str, unit: str, path=None, marked=None):
    """Poles [1/s] against a parameter (a row of ``poles`` per value), coloured by its value; the
    first value and ``marked`` (nearest row) marked. Saves a PNG at ``path`` and returns it (the
    figure without a path)."""
    from ..io.plotting import new_figure, save_png
    from .control import pole_axes

    values = np.asarray(values, dtype=float)
    poles = np.asarray(poles)
    fig, ax = new_figure(figsize=(6.4, 5.2))
    finite = np.isfinite(poles)
    flat = np.repeat(values[:, None], poles.shape[1], axis=1)[finite]
    dots = ax.scatter(poles[finite].real, poles[finite].imag, c=flat, s=6, cmap="viridis")
    fig.colorbar(dots, ax=ax, label=f"{what} [{unit}]")
    ax.plot(poles[0].real, poles[0].imag, "kx", ms=9, label=f"{what} = {values[0]:.4g} {unit}")
    if marked is not None:
        row = poles[int(np.argmin(np.abs(values - marked)))]
        ax.plot(row.real, row.imag, "ro", mfc="none", ms=9, label=f"{what} = {marked:.4g} {unit}")
    ax.legend(fontsize=8)
    unit_q, factor = display_unit(op.mechanism)
    pole_axes(ax, f"{op.mechanism.name}: poles against {what} at {op.mechanism.coordinate} = "
                   f"{shown(op.q * factor, 4)} {unit_q}")
    return save_png(fig, path) if path else fig


def plot_step(result: MechanismStep, op: OperatingPoint, path=None):
    """The step responses of :func:`step_responses` in mm or deg, their step_info in the legend;
    saves a PNG at ``path`` and returns it (the figure without a path)."""
    from ..io.plotting import new_figure, save_png

    unit, factor = DISPLAY[result.unit]
    fig, ax = new_figure(figsize=(7.5, 4.8))
    for name, style in (("nonlinear", "-"), ("linear", "--")):
        info = result.info[name]
        ax.plot(result.time, factor * result[name], style, lw=1.4,
                label=f"{name}: rise {info['RiseTime']:.3g} s, overshoot "
                      f"{info['Overshoot']:.3g} %, settling {info['SettlingTime']:.3g} s")
    ax.set_xlabel("time [s]")
    ax.set_ylabel(f"{result.coordinate} - {result.coordinate}_op [{unit}]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    muscle = muscle_params(op.params)
    ax.set_title(f"{result.mechanism}: {op.mechanism.muscles[0]} stepped by {result.dp / 1e3:+g} "
                 f"kPa at {result.coordinate} = {shown(op.q * factor, 4)} {unit}, "
                 f"c = {muscle.c:.4g} N s/m, tau = {muscle.tau:g} s", fontsize=9)
    return save_png(fig, path) if path else fig
