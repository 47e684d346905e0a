"""Compare a model with a measurement: simulate the file's inputs, and score the error.

The simulation is the library's: :func:`mkctl.physics.isotonic.simulate_isotonic` for the isotonic
test, :func:`mechanism_output` (:func:`mkctl.physics.mechanism.simulate_mechanism`) for a mechanism
record, :func:`actuator_output` (the tension with every effect at the imposed length and its rate)
for a driven-length test, and the knee's :class:`mkctl.physics.simulate.KneeSimulator` for the knee,
started at rest in the stable equilibrium of the first commands, exactly as
:func:`mkctl.physics.simulate.simulate_knee` starts it. For the knee, :func:`simulate_output` may
ask for the output at a subset of the samples only: the integrator then takes one communication step
from each sample it needs (or each change of the commands) to the next, which gives the same values
(to the integrator's tolerance) at a fraction of the cost. The diagnosis fits on such a subset.

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
from ..io.diagnosis_report import (fit_text, input_panels, plot_isometric,  # noqa: F401
                                   plot_overlay, plot_residuals)  # (re-exported)
from ..physics import actuator, knee, pneumatics, simulate
from ..physics.mechanism import simulate_mechanism
from ..physics.simulate import knee_states


def _measured_pressure_params(params):
    """The parameters that a record's measured pressures drive: the lag off (the measured
    pressures are what any lag already made of the commands), as :func:`knee_drive` does it."""
    return params.replace(tau=0.0) if params.tau > 0 else params


def knee_drive(measurement: Measurement, params: Params, stop: int | None = None):
    """(pe, pf [Pa], params) that drive the knee model over a record: the commands, or, when the file holds
    measured bladder pressures ``pe``, ``pf``, those pressures with the model's lag switched off (the
    measured pressures are what any lag already made of the commands)."""
    n = measurement.samples if stop is None else int(stop)
    inputs = measurement.inputs
    if "pe" in inputs and "pf" in inputs:
        return inputs["pe"][:n], inputs["pf"][:n], _measured_pressure_params(params)
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
    if measurement.experiment in RECORD_OUTPUTS:
        values, rates = RECORD_OUTPUTS[measurement.experiment](measurement, params, n)
        return (values[at], rates[at]) if velocity else values[at]
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


def mechanism_output(measurement: Measurement, params: Params, stop: int | None = None):
    """A mechanism record's model output over its first ``stop`` samples (default all).

    :func:`mkctl.physics.mechanism.simulate_mechanism` with the record's mechanism and own values,
    from rest in the equilibrium of the first commands (or at the record's ``q0``); a record with
    every measured pressure (``p1``, ...) is driven by them, the lag off (:func:`knee_drive`'s
    rule).

    Parameters
    ----------
    measurement : Measurement
        An ``experiment = mechanism`` record (model-spec 5d).
    params : Params
        The muscle's parameters and effects (one set for every muscle).
    stop : int, optional
        Samples to simulate.

    Returns
    -------
    q, qdot : numpy.ndarray
        The coordinate [m or rad] and its rate [per s] at the samples.
    """
    n = measurement.samples if stop is None else int(stop)
    mechanism, inputs = measurement.mechanism, measurement.inputs
    count = len(mechanism.muscles)
    measured = [f"p{i + 1}" for i in range(count)]
    if all(name in inputs for name in measured):
        drive, params = measured, _measured_pressure_params(params)
    else:
        drive = [f"p{i + 1}_cmd" for i in range(count)]
    p = mechanism.bind(params, **measurement.mechanism_values)
    commands = tuple(inputs[name][:n] for name in drive)
    run = simulate_mechanism(measurement.time[:n], commands, mechanism, p, q0=measurement.q0)
    return run.q, run.qdot


def commanded_pressure(time, command, params: Params):
    """The pressure [Pa] a muscle holds under a command [Pa] held from each sample to the next.

    Through the dead time (:func:`mkctl.physics.simulate.delayed_commands`) and the pressure
    dynamics of ``params`` (:func:`mkctl.physics.actuator.pressure_after` over each held piece),
    as the knee's muscles see theirs, from a steady start at the first command.
    """
    time, command = np.asarray(time, dtype=float), np.asarray(command, dtype=float)
    delay = float(actuator.command_delay(params))
    if delay > 0 and time.size > 1:
        grid, seen, _, at = simulate.delayed_commands(time, command, command, delay)
    else:
        grid, seen, at = time, command, np.arange(time.size)
    if not actuator.has_pressure_states(params):
        return seen[at].copy()
    pressure = np.empty(grid.size)
    pressure[0] = seen[0]
    for k in range(grid.size - 1):
        step = grid[k + 1] - grid[k]
        pressure[k + 1] = float(actuator.pressure_after(pressure[k], float(seen[k]), step, params))
    return pressure[at]


def actuator_output(measurement: Measurement, params: Params, stop: int | None = None):
    """A driven-length record's model output over its first ``stop`` samples (default all).

    ``f = compose_tension(L, P, Ldot)`` (:func:`mkctl.physics.actuator.compose_tension`: every
    effect) at the imposed length L, its rate Ldot (``numpy.gradient`` of L over time:
    second-order central differences) and the measured pressure, or the command through the dead
    time and the lag (:func:`commanded_pressure`).

    Parameters
    ----------
    measurement : Measurement
        An ``experiment = actuator`` record (model-spec 5d).
    params : Params
        The muscle's parameters and effects.
    stop : int, optional
        Samples to compute.

    Returns
    -------
    f, fdot : numpy.ndarray
        Tension [N] and its finite-difference rate [N/s].
    """
    n = measurement.samples if stop is None else int(stop)
    time, inputs = measurement.time[:n], measurement.inputs
    length = inputs["length"][:n]
    rate = np.gradient(length, time) if n > 1 else np.zeros(n)
    if "pressure" in inputs:
        pressure = inputs["pressure"][:n]
    else:
        pressure = commanded_pressure(time, inputs["p_cmd"][:n], params)
    force = np.asarray(actuator.compose_tension(length, pressure, rate, params), dtype=float)
    return force, (np.gradient(force, time) if n > 1 else np.zeros(n))


#: Tolerances of the air's integration on a record [-, Pa]: below a pressure sensor's
#: resolution (0.76 kPa on the rigs of issue 28) at a twentieth of the cost of rtol = 1e-7.
RECORD_RTOL, RECORD_ATOL = 1e-6, 1.0


#: At most this many samples before a valve record's first change of its opening set its start.
START_SAMPLES = 20


def start_pressure(measurement: Measurement) -> float:
    """The pressure [Pa] a record driven by valve openings starts at: the mean of its measured
    pressure before its opening first changes (at most :data:`START_SAMPLES` samples: one sample
    would carry its noise and quantisation into the whole record), its first sample when the
    opening changes at once.

    Parameters
    ----------
    measurement : Measurement
        A pressure record with a ``valve`` column.

    Returns
    -------
    float
        The start's gauge pressure [Pa].
    """
    opening, measured = measurement.inputs["valve"], measurement.output
    changes = np.flatnonzero(np.diff(opening) != 0)
    held = int(changes[0]) + 1 if changes.size else measured.size
    if held < 3 or opening[0] != 0:  # a valve open from the start: the pressure moves at once
        return float(measured[0])
    return float(np.mean(measured[: min(held, START_SAMPLES)]))


def pressure_output(measurement: Measurement, params: Params, stop: int | None = None):
    """A pressure record's model output over its first ``stop`` samples (default all).

    With an effect that moves the air on (``valve_flow``, model-spec 4d), the air's mass balance
    (:func:`mkctl.physics.pneumatics.simulate_air`): driven by the regulator's set-points or the
    valve's openings, the muscle held at the record's ``length`` (default L0), moving (its length
    column) or free under its ``load``; a record driven by set-points starts at its first command,
    one driven by openings at its measured start (:func:`start_pressure`). Otherwise the section 4
    pressure path (:func:`commanded_pressure`: the dead time and the lags of ``params``).

    Parameters
    ----------
    measurement : Measurement
        An ``experiment = pressure`` record (model-spec 5c).
    params : Params
        The muscle and its effects.
    stop : int, optional
        Samples to simulate.

    Returns
    -------
    P, Pdot : numpy.ndarray
        Gauge pressure [Pa] and its finite-difference rate [Pa/s].

    Raises
    ------
    MkctlError
        For a record driven by openings without the air (the valve is part of its baseline).
    """
    n = measurement.samples if stop is None else int(stop)
    time, inputs, settings = measurement.time[:n], measurement.inputs, measurement.settings
    if actuator.air_is_on(params):
        if "length" in inputs:
            muscle = {"length": inputs["length"][:n]}
        elif "load" in settings:
            muscle = {"load": settings["load"]}
        else:
            muscle = {"length": settings.get("length", params.L0)}
        if "p_cmd" in inputs:
            drive = {"command": inputs["p_cmd"][:n]}
        else:
            drive = {"opening": inputs["valve"][:n], "P_start": start_pressure(measurement)}
        run = pneumatics.simulate_air(
            time, params, **drive, **muscle, rtol=RECORD_RTOL, atol=RECORD_ATOL
        )
        pressure = run.P
    elif "valve" in inputs:
        raise MkctlError(
            "a record driven by valve openings needs the valve (valve_flow) in its model"
        )
    else:
        pressure = commanded_pressure(time, inputs["p_cmd"][:n], params)
    return pressure, (np.gradient(pressure, time) if n > 1 else np.zeros(n))


#: The records whose output is a function (measurement, params, stop) -> (output, its rate).
RECORD_OUTPUTS = {"mechanism": mechanism_output, "actuator": actuator_output,
                  "pressure": pressure_output}

#: How an output quantity is named on a picture.
OUTPUT_NAMES = {"force": "tension", "length": "length", "x": "hip height X",
                "beta": "knee angle beta", "p": "gauge pressure"}


def output_name(measurement: Measurement) -> str:
    """What a record's output is, for labels: a mechanism's coordinate, or the quantity's name."""
    if measurement.experiment == "mechanism":
        return f"{measurement.mechanism.name} {measurement.mechanism.coordinate}"
    return OUTPUT_NAMES.get(measurement.output_quantity, measurement.output_quantity)


def record_panels(measurement: Measurement) -> list:
    """The inputs of a mechanism, actuator or pressure record to draw under its overlay:
    ``[(label, [(values, name), ...]), ...]``, pressures in kPa, lengths in mm
    (:func:`mkctl.io.diagnosis_report.input_panels`)."""
    return input_panels(measurement)


def plot_record_overlay(measurement: Measurement, curves: dict, path=None, title: str = ""):
    """A mechanism or actuator record's measured output and the model's curves over time.

    ``curves``: label -> SI array; drawn in the file's unit, the inputs in panels below
    (:func:`record_panels`). Saves a PNG at ``path`` and returns it (the figure without a path).
    """
    from ..io.plotting import new_figure, save_png

    panels = record_panels(measurement)
    fig, axes = new_figure(1 + len(panels), 1, figsize=(9, 5.0 + 1.3 * len(panels)), sharex=True,
                           height_ratios=(3.2,) + (1,) * len(panels), squeeze=False)
    top = axes[0, 0]
    colours = ("tab:blue", "tab:orange", "tab:green", "tab:purple")
    for (label, values), colour in zip(curves.items(), colours):
        top.plot(measurement.time, measurement.to_file_units(values), lw=1.4, color=colour,
                 label=label, zorder=2)
    every = max(1, -(-measurement.samples // 400))
    measured = measurement.to_file_units(measurement.output)
    top.plot(measurement.time[::every], measured[::every], "o", ms=3.2, mfc="none", mew=0.7,
             color="k", alpha=0.6, zorder=3, label="measured")
    top.set_ylabel(f"{output_name(measurement)} [{measurement.output_unit}]")
    top.legend(loc="best", fontsize=8)
    top.set_title(title or f"{measurement.experiment}: model vs measurement", fontsize=10)
    for ax, (label, lines) in zip(axes[1:, 0], panels):
        for (values, name), colour in zip(lines, ("k", "tab:red")):
            ax.plot(measurement.time, values, color=colour, lw=1, label=name)
        ax.set_ylabel(label, fontsize=8)
        if len(lines) > 1:
            ax.legend(loc="best", fontsize=7)
    axes[-1, 0].set_xlabel("time [s]")
    return save_png(fig, path) if path else fig


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
