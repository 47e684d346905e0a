"""Compare a model with a measurement: simulate the file's inputs, and score the error.

The simulation is the library's: :func:`mkctl.physics.isotonic.simulate_isotonic` for the isotonic test, and
the knee's :class:`mkctl.physics.simulate.KneeSimulator` for the knee, started at rest in the stable equilibrium
of the first commands, exactly as :func:`mkctl.physics.simulate.simulate_knee` starts it. For the knee,
:func:`simulate_output` may ask for the output at a subset of the samples only: the integrator then
takes one communication step from each sample it needs (or each change of the commands) to the next,
which gives the same values (to the integrator's tolerance) at a fraction of the cost. The diagnosis
fits on such a subset.

Scores, in the units of the file's output column:

- ``rmse = sqrt(mean((y - yhat)^2))``;
- ``fit = 100 (1 - |y - yhat| / |y - mean(y)|)`` [%] (2-norms; 100 is perfect, 0 is no better than
  the mean, as in MATLAB's ``compare``). A constant measured output has no fit (NaN; :func:`fit_text`
  says "fit undefined").
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from ..errors import MkctlError
from ..physics.isometric import isometric_tension
from ..physics.isotonic import simulate_isotonic
from ..io.measurements import Measurement
from ..physics.params import Params
from ..io.diagnosis_report import (fit_text, input_axis, plot_isometric, plot_overlay,  # noqa: F401 (re-exported)
                                   plot_residuals)
from ..physics import knee
from ..physics.simulate import knee_states


def knee_drive(measurement: Measurement, params: Params, stop: int | None = None):
    """(pe, pf [Pa], params) that drive the knee model over a record: the commands, or, when the file holds
    measured bladder pressures ``pe``, ``pf``, those pressures with the model's lag switched off (the
    measured pressures are what any lag already made of the commands)."""
    n = measurement.samples if stop is None else int(stop)
    inputs = measurement.inputs
    if "pe" in inputs and "pf" in inputs:
        return inputs["pe"][:n], inputs["pf"][:n], params.replace(tau=0.0) if params.tau > 0 else params
    return inputs["pe_cmd"][:n], inputs["pf_cmd"][:n], params


def simulate_output(measurement: Measurement, params: Params, at=None, stop: int | None = None,
                    velocity: bool = False):
    """The model's output [SI] for the measurement's inputs, at the sample indices ``at`` (default all).

    The output is the file's measured quantity: the actuator length [m] (isotonic), the hip height X [m]
    or the interior knee angle beta [rad] (knee, ``beta_deg`` files). A knee file with measured bladder
    pressures is driven by them (:func:`knee_drive`). ``stop``: simulate only the first ``stop`` samples
    (``at`` must lie below it). With ``velocity=True`` returns (output, rate of the output [SI/s]) instead;
    for the isotonic test the rate is the finite-difference slope of the simulated length.
    """
    n = measurement.samples if stop is None else int(stop)
    at = np.arange(n) if at is None else np.asarray(at, dtype=int)
    time = measurement.time[:n]
    if measurement.experiment == "isometric":  # quasi-static, no motion: the tension at each point [N]
        force = isometric_tension(measurement.inputs["length"][at], measurement.inputs["pressure"][at],
                                  measurement.branch[at], params)
        return (force, np.zeros(force.size)) if velocity else force
    if measurement.experiment == "isotonic":
        length = simulate_isotonic(time, measurement.inputs["pressure"][:n], measurement.inputs["force"][:n], params)
        if not velocity:
            return length[at]
        return length[at], np.gradient(length, time)[at]
    pe, pf, drive = knee_drive(measurement, params, n)
    X, V = knee_states(time, pe, pf, drive, at=at)
    if measurement.output_quantity == "beta":
        beta = knee.beta_from_X(X, params)
        return (beta, V * X / (params.Lo * params.Lu * np.sin(beta))) if velocity else beta
    return (X, V) if velocity else X


def rmse(measured, simulated) -> float:
    """Root-mean-square error, in the units of the arguments."""
    error = np.asarray(measured, dtype=float) - np.asarray(simulated, dtype=float)
    return float(np.sqrt(np.mean(error * error)))


def fit_percent(measured, simulated) -> float:
    """``100 (1 - |y - yhat| / |y - mean(y)|)`` [%] with 2-norms (NaN for a constant record)."""
    y = np.asarray(measured, dtype=float)
    if np.ptp(y) == 0:  # not "spread == 0": the mean of equal values is off by rounding
        return float("nan")
    spread = np.linalg.norm(y - y.mean())
    return float(100.0 * (1.0 - np.linalg.norm(y - np.asarray(simulated, dtype=float)) / spread))


@dataclass(frozen=True)
class Comparison:
    """A model's simulation of a measurement, with its scores in the file's output units."""

    measurement: Measurement
    params: Params
    simulated: np.ndarray  #: the model's output, SI [m]
    rmse: float  #: file units
    fit_percent: float  #: [%]

    @property
    def residual(self) -> np.ndarray:
        """Measured minus simulated, in the file's output units."""
        return self.measurement.to_file_units(self.measurement.output - self.simulated)


def compare(measurement: Measurement, params: Params | None = None) -> Comparison:
    """Simulate ``params`` (default: the file's baseline) on the measurement's inputs and score it."""
    params = measurement.params if params is None else params
    try:
        simulated = simulate_output(measurement, params)
    except MkctlError as error:
        raise MkctlError(f"{measurement.source}: the model cannot simulate this record: {error}") from None
    y, yhat = measurement.to_file_units(measurement.output), measurement.to_file_units(simulated)
    return Comparison(measurement, params, simulated, rmse(y, yhat), fit_percent(y, yhat))
