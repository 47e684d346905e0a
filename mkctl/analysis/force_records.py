"""The records calibrate fits, as force points (model-spec sections 5, 5b and 5d).

Blocked-force (``isometric``), isotonic and driven-length (``actuator``) records of one muscle become
:class:`ForceRecord` s that share one error in N: the measured tension at a clamped length, the hanging
load at the measured length, or the measured tension at an imposed length and rate. Read here, checked
here (one line for a record no muscle can be calibrated on); fitted in :mod:`mkctl.analysis.calibrate`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np

from ..errors import MkctlError
from ..physics.params import Params
from .statistics import robust_sigma


class CalibrationError(MkctlError):
    """Measurements calibrate cannot use, or a fit that does not converge."""


# --- The data, as forces ----------------------------------------------------------------------------

@dataclass(frozen=True)
class ForceRecord:
    """One record as force points (SI): what :func:`calibrate` fits.

    ``sign`` is the friction sign: the model's tension is ``f - sign Fc`` (isometric: the branch, +1
    up, -1 down; isotonic: +1 shortening, -1 lengthening, 0 not moving; driven length: minus the
    sign of the imposed rate). ``velocity``: a driven-length record's imposed rate [m/s] (None for
    the others).
    """

    experiment: str
    source: str
    length: np.ndarray  #: clamped (isometric) or measured (isotonic) length [m]
    pressure: np.ndarray  #: [Pa]
    force: np.ndarray  #: measured tension (isometric) or hanging load (isotonic) [N]
    sign: np.ndarray
    overrides: dict = field(default_factory=dict)  #: the record's metadata parameters (SI)
    time: np.ndarray | None = None
    velocity: np.ndarray | None = None  #: imposed lengthening rate [m/s] (driven-length records)

    @property
    def size(self) -> int:
        return int(self.force.size)


def isometric_record(length, pressure, force, branch, overrides: dict | None = None,
                     source: str = "<arrays>") -> ForceRecord:
    """An isometric record from arrays: lengths [m], pressures [Pa], forces [N], branch (+1 up / -1 down)."""
    arrays = [np.asarray(a, dtype=float).ravel() for a in (length, pressure, force, branch)]
    if len({a.size for a in arrays}) != 1:
        raise CalibrationError(f"{source}: length, pressure, force and branch must have the same size")
    if not np.isin(arrays[3], (1.0, -1.0)).all():
        raise CalibrationError(f"{source}: branch must be +1 (up) or -1 (down)")
    return ForceRecord("isometric", source, *arrays, overrides=dict(overrides or {}))


def force_record(measurement) -> ForceRecord:
    """A :class:`ForceRecord` from a measurement of :mod:`mkctl.io.measurements` (isometric or isotonic)."""
    if isinstance(measurement, ForceRecord):
        return measurement
    m = measurement
    if m.experiment == "isometric":
        return ForceRecord("isometric", str(m.source), np.asarray(m.inputs["length"], float),
                           np.asarray(m.inputs["pressure"], float), np.asarray(m.output, float),
                           np.asarray(m.branch, float), dict(m.overrides), np.asarray(m.time, float))
    if m.experiment == "isotonic":
        length = np.asarray(m.output, float)
        return ForceRecord("isotonic", str(m.source), length, np.asarray(m.inputs["pressure"], float),
                           np.asarray(m.inputs["force"], float), -motion_direction(m.time, length),
                           dict(m.overrides), np.asarray(m.time, float))
    if m.experiment == "actuator":
        return driven_record(m)
    if m.experiment == "pressure":  # no force in it: the air is diagnosed, not calibrated (model-spec 5c)
        raise CalibrationError(f"{m.source}: a pressure record shows the air, not the muscle's force: calibrate "
                               f"fits the statics from isometric, isotonic or actuator records; read its valve "
                               f"and volume with 'mkctl diagnose {m.source}'")
    raise CalibrationError(f"{m.source}: calibrate needs isometric, isotonic or actuator records, "
                           f"not {m.experiment!r}")


def driven_record(m) -> ForceRecord:
    """A driven-length record (``experiment = actuator``, model-spec 5d) as force points: the
    imposed length, its rate (``numpy.gradient``, as :func:`mkctl.analysis.compare.actuator_output`
    takes it), the measured pressure, or the command through the pressure path the file's own values
    give (no lag is fitted here), and the measured tension."""
    from .compare import commanded_pressure

    time = np.asarray(m.time, float)
    length = np.asarray(m.inputs["length"], float)
    velocity = np.gradient(length, time) if length.size > 1 else np.zeros(length.size)
    if "pressure" in m.inputs:
        pressure = np.asarray(m.inputs["pressure"], float)
    else:
        pressure = np.asarray(commanded_pressure(time, m.inputs["p_cmd"], m.params), float)
    return ForceRecord("actuator", str(m.source), length, pressure, np.asarray(m.output, float),
                       -np.sign(velocity), dict(m.overrides), time, velocity)


def motion_direction(time, length, window: int = 11):
    """+1 where the measured length grows, -1 where it shrinks, 0 where it does not move beyond its noise.

    The slope is a Savitzky-Golay (order 1) slope over ``window`` samples; "moving" means more than three
    times the slope's noise, estimated from the scatter of the length about its smoothed self, over the
    whole window around the point (near a start or a stop of the motion the window straddles both, and
    the point counts as not moving: its load may lie anywhere in the friction band).
    """
    from .filters import savgol_filter

    time, length = np.asarray(time, float), np.asarray(length, float)
    n = length.size
    window = max(3, min(window, n - (1 - n % 2)))
    window += 1 - window % 2
    if n < 3 or window > n:
        return np.zeros(n)
    dt = float(np.median(np.diff(time)))
    slope = savgol_filter(length, window, 1, deriv=1, delta=dt)
    scatter = length - savgol_filter(length, window, 1)
    sigma = robust_sigma(scatter)
    slope_noise = sigma * math.sqrt(12.0 / (window ** 3 - window)) / dt
    threshold = max(3.0 * slope_noise, 1e-12)
    sign = np.where(slope > threshold, 1.0, np.where(slope < -threshold, -1.0, 0.0))
    # the smoothing window straddles each start and stop of the motion: near one, the sign is not to be
    # trusted, so a point counts as moving only if its whole window moves the same way
    half = window // 2
    padded = np.pad(sign, half, constant_values=0.0)
    steady = np.ones(n, dtype=bool)
    for shift in range(2 * half + 1):
        steady &= padded[shift:shift + n] == sign
    return np.where(steady, sign, 0.0)


#: The braid length of the base a file is read against (:func:`read_records`): long enough for any muscle, so
#: that a file giving only its L0 (longer than Table I's b) is not judged against Table I's braid.
READING_BRAID = 100.0


def reading_base(params: Params | None = None) -> Params:
    """The parameter set calibrate reads files against: ``params`` (default Table I) with a braid of
    :data:`READING_BRAID`, because b is what calibrate fits, not something the file must agree with."""
    return (params or Params()).replace(b=READING_BRAID, n=None)


def read_records(paths, params: Params | None = None) -> list:
    """Read measurement files for :func:`calibrate` (see :func:`reading_base`)."""
    from ..io.measurements import read_measurement

    base = reading_base(params)
    return [read_measurement(path, base=base) for path in paths]


def check_records(records: list[ForceRecord]) -> None:
    """Raise :class:`CalibrationError` for records no muscle can be calibrated on (one line each)."""
    if not records:
        raise CalibrationError("no measurement to calibrate on")
    for r in records:
        if r.size < 3:
            raise CalibrationError(f"{r.source}: only {r.size} points; calibrate needs more")
        finite = np.isfinite(r.length) & np.isfinite(r.pressure) & np.isfinite(r.force)
        if not finite.all():
            raise CalibrationError(f"{r.source}: point {int(np.flatnonzero(~finite)[0]) + 1} is not a finite number")
        if (r.length <= 0).any():
            raise CalibrationError(f"{r.source}: length {r.length[r.length <= 0][0]:g} m is not positive: no braid "
                                   "has such a length")
        if r.experiment == "isometric" and np.unique(r.pressure).size < 2:
            raise CalibrationError(f"{r.source}: every point has the same pressure ({r.pressure[0] / 1e3:g} kPa): "
                                   "a blocked-force test must step the pressure to show how the force grows with it")
