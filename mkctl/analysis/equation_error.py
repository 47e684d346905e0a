"""The equation error: the force the model lacks at the measured, smoothed states.

Only for explanation (the diagnosis's signatures, :mod:`mkctl.analysis.diagnose`, and the discovery's regression,
:mod:`mkctl.analysis.discovery`): the fits themselves compare simulations with the data, never differentiated
data. Both read it from here, so neither imports the other for it.
"""
from __future__ import annotations

import numpy as np

from ..io.measurements import Measurement
from ..physics import actuator, knee
from ..physics.isometric import isometric_tension
from ..physics.params import Params
from .signals import lagged

#: Savitzky-Golay smoothing window for the signatures: the knee's in seconds, the isotonic test's in samples.
KNEE_SMOOTHING_S = 0.1
ISOTONIC_SMOOTHING_SAMPLES = 11


def missing_force(measurement: Measurement, params: Params):
    """The equation error: the force the model lacks at the measured, smoothed states [N].

    Isotonic (quasi-static): ``F_load - f(L, P, Ldot)``. Knee (Eq. 17): ``m (Xddot + g) - F -
    F_stop`` with X, V, Xddot from a cubic Savitzky-Golay fit of the measured X. A mechanism record
    (model-spec 3b, 5d): its own equation of motion, ``M qddot - F(q, qdot, P) - F_stop``
    (:func:`mechanism_missing_force`). A driven-length record: the measured tension minus the
    model's at the imposed length and rate (:func:`actuator_missing_force`). Only for explanation:
    the fits themselves compare simulations with the data, never differentiated data. Returns
    (missing force, states) with states a dict of the smoothed signals (SI).
    """
    from .filters import savgol_filter

    m = measurement
    if m.experiment == "isometric":  # nothing moves: the measured tension against the model's, point by point
        L, P = m.inputs["length"], m.inputs["pressure"]
        return m.output - isometric_tension(L, P, m.branch, params), {"L": L, "P": P, "branch": m.branch}
    if m.experiment in RECORD_ERRORS:
        return RECORD_ERRORS[m.experiment](m, params)
    n = m.samples
    dt = float(np.mean(np.diff(m.time)))
    window = (ISOTONIC_SMOOTHING_SAMPLES if m.experiment == "isotonic" else int(round(KNEE_SMOOTHING_S / dt)))
    window = max(5, min(window, n - 1 if n % 2 == 0 else n))
    window += 1 - window % 2  # odd
    if window > n:
        window -= 2
    order = min(3, window - 2)
    measured = knee.hip_height(m.output, params) if m.output_quantity == "beta" else m.output
    y = savgol_filter(measured, window, order)
    ydot = savgol_filter(measured, window, order, deriv=1, delta=dt)
    if m.experiment == "isotonic":
        P, F = m.inputs["pressure"], m.inputs["force"]
        states = {"L": y, "Ldot": ydot, "P": P}
        return F - actuator.tension(y, P, ydot, params), states
    yddot = savgol_filter(measured, window, order, deriv=2, delta=dt)
    # the pressures go through the same smoothing as the acceleration, so that a command step does not
    # show up as a force the model lacks while the smoothed acceleration ramps up to it
    pressures = model_pressures(m, params)  # a loop over the samples when there is a lag: once
    Pe, Pf = (savgol_filter(p, window, order) for p in pressures)
    rates = [savgol_filter(p, window, order, deriv=1, delta=dt) for p in pressures]
    states = {"X": y, "V": ydot, "Pe": Pe, "Pf": Pf, "A": yddot, "Pe_rate": rates[0], "Pf_rate": rates[1]}
    return params.m * (yddot + params.g) - knee_force_at(states, params), states


def knee_force_at(states: dict, params: Params, Pe=None, Pf=None):
    """The knee's ground force plus the end stops' [N] at smoothed states (``X``, ``V``; ``Pe``, ``Pf`` unless given)."""
    geo = knee.geometry_at_X(states["X"], params)
    Pe = states["Pe"] if Pe is None else Pe
    Pf = states["Pf"] if Pf is None else Pf
    return (knee.knee_force(geo, states["V"], Pe, Pf, params).F
            + knee.end_stop_force(states["X"], states["V"], params))


def model_pressures(m: Measurement, params: Params):
    """The actuator pressures the model sees: the measured ones, the commands, or the commands through the lag."""
    if "pe" in m.inputs and "pf" in m.inputs:
        return m.inputs["pe"], m.inputs["pf"]
    pe, pf = m.inputs["pe_cmd"], m.inputs["pf_cmd"]
    if params.tau <= 0:
        return pe, pf
    return lagged(m.time, pe, params.tau), lagged(m.time, pf, params.tau)


def acceleration_kernels(window: int, dt: float, order: int = 3):
    """(k2, g): the Savitzky-Golay kernel that estimates the acceleration from positions, and the smoothing
    kernel g it applies to the acceleration itself (``k2 * X = g * Xddot``, g = the double running sum of k2
    times dt^2, which sums to 1).

    The equation error ``m (Xddot + g) - F`` must smooth both sides alike: the acceleration estimated by k2
    and the force smoothed by a plain (deriv 0) filter differ wherever the force jumps (a pressure step),
    and the difference looked like a dead time of about 7 ms on every record with a step.
    """
    from .filters import savgol_coeffs

    k2 = savgol_coeffs(window, order, deriv=2, delta=dt)
    g = np.cumsum(np.cumsum(k2)) * dt * dt
    return k2, g[:window - 2]  # the last two entries are zero: the kernel is centred on window - 2 samples


def _smoothing(m: Measurement) -> tuple[int, int, float]:
    """(window, order, dt) of the knee's Savitzky-Golay smoothing for a timed record."""
    n = m.samples
    dt = float(np.mean(np.diff(m.time)))
    window = max(5, min(int(round(KNEE_SMOOTHING_S / dt)), n - 1 if n % 2 == 0 else n))
    window += 1 - window % 2
    if window > n:
        window -= 2
    return window, min(3, window - 2), dt


def record_pressures(m: Measurement, params: Params) -> list:
    """The pressure [Pa] each muscle of a mechanism or driven-length record sees in the model: the
    measured ones when the record holds them (all of them), else the commands through the dead time
    and the pressure dynamics (:func:`mkctl.analysis.compare.commanded_pressure`)."""
    from .compare import commanded_pressure

    inputs = m.inputs
    if m.experiment == "actuator":
        measured, commands = ["pressure"], ["p_cmd"]
    else:
        count = len(m.mechanism.muscles)
        measured = [f"p{i + 1}" for i in range(count)]
        commands = [f"p{i + 1}_cmd" for i in range(count)]
    if muscle_pressures_measured(m):
        return [np.asarray(inputs[name], dtype=float) for name in measured]
    return [commanded_pressure(m.time, inputs[name], params) for name in commands]


def _held_pressures(m: Measurement, params: Params) -> list:
    """The model's pressures as a smoothed sample sees them: commands held from each sample to the
    next without pressure dynamics are averaged over the half-interval on either side of a sample
    (taken as they are, every step came half a sample early), as the discovery does for the knee."""
    pressures = record_pressures(m, params)
    if muscle_pressures_measured(m) or actuator.has_pressure_states(params) or \
            float(actuator.command_delay(params)) > 0:
        return pressures
    return [np.r_[p[0], 0.5 * (p[1:] + p[:-1])] for p in pressures]


def muscle_pressures_measured(m: Measurement) -> bool:
    """Whether a mechanism or driven-length record holds every muscle's measured pressure (which
    then drives its model, :func:`mkctl.analysis.compare.mechanism_output`, ``actuator_output``);
    False for other records."""
    if m.experiment == "actuator":
        return "pressure" in m.inputs
    if m.experiment == "mechanism":
        return all(f"p{i + 1}" in m.inputs for i in range(len(m.mechanism.muscles)))
    return False


def mechanism_missing_force(m: Measurement, params: Params):
    """A mechanism record's equation error: the generalized force the model lacks [N or N m].

    ``M (k2 * q) - g * (F(q, qdot, P) + F_stop(q, qdot))``

    with F by virtual work (:func:`mkctl.physics.mechanism.mechanism_force`), F_stop the end stops'
    contact, at the measured coordinate q, its Savitzky-Golay rate and the model's pressures; k2 the
    cubic Savitzky-Golay kernel of the acceleration and g the smoothing it applies, so that both
    sides are smoothed alike (:func:`acceleration_kernels`: the knee's discovery does the same).

    Parameters
    ----------
    m : Measurement
        An ``experiment = mechanism`` record.
    params : Params
        The muscle's parameters and effects.

    Returns
    -------
    missing : numpy.ndarray
        [N or N m].
    states : dict
        ``q``, ``V`` (its rate), ``A`` (its second derivative), ``pressures`` and ``rates`` (one
        array per muscle [Pa, Pa/s]), ``P``, ``P_rate`` (the first muscle's), and what
        :func:`generalized_force_at` reads.

    References
    ----------
    .. [1] model-spec sections 3b (the equation of motion) and 6 (the signatures).
    """
    from .filters import savgol_filter

    window, order, dt = _smoothing(m)
    k2, kernel = acceleration_kernels(window, dt, order)
    q = np.asarray(m.output, dtype=float)
    V = savgol_filter(q, window, order, deriv=1, delta=dt)
    # the kernel k2 itself inside; at the record's ends the filter's polynomial fit (np.convolve
    # would read zeros beyond them)
    A = savgol_filter(q, window, order, deriv=2, delta=dt)
    pressures = _held_pressures(m, params)
    rates = [savgol_filter(p, window, order, deriv=1, delta=dt) for p in pressures]
    states = {"q": q, "V": V, "A": A, "pressures": pressures, "rates": rates, "P": pressures[0],
              "P_rate": rates[0], "measurement": m, "kernel": kernel}
    inertia = mechanism_force_at(states, params).M
    return inertia * A - generalized_force_at(states, params), states


def mechanism_force_at(states: dict, params: Params, pressures=None):
    """The mechanism's :class:`mkctl.physics.mechanism.MechanismForce` at the states (``pressures``
    in place of the states' own when given), unsmoothed."""
    from ..physics.mechanism import mechanism_force

    m = states["measurement"]
    pressures = states["pressures"] if pressures is None else pressures
    p = m.mechanism.bind(params, **m.mechanism_values)
    return mechanism_force(m.mechanism, states["q"], states["V"], tuple(pressures), p)


def generalized_force_at(states: dict, params: Params, pressures=None):
    """The mechanism's generalized force plus its end stops' at the states, smoothed as the
    acceleration is (:func:`mechanism_missing_force`) [N or N m]."""
    from types import SimpleNamespace

    m = states["measurement"]
    force = mechanism_force_at(states, params, pressures)
    p = m.mechanism.bind(params, **m.mechanism_values)
    inertia = SimpleNamespace(m=force.M)  # the stops' damping is critical for the inertia
    stops = knee.end_stop_force(states["q"], states["V"], inertia, m.mechanism.stop_positions(p))
    return smoothed_alike(force.F + stops, states)


def smoothed_alike(values, states: dict) -> np.ndarray:
    """A force at a mechanism record's samples smoothed as its acceleration is
    (:func:`mechanism_missing_force`), the ends held beyond the record as the acceleration's fit
    holds them."""
    values = np.broadcast_to(values, states["q"].shape)
    kernel = states["kernel"]
    return np.convolve(np.pad(values, kernel.size // 2, mode="edge"), kernel, mode="valid")


def actuator_missing_force(m: Measurement, params: Params):
    """A driven-length record's equation error: the tension the model lacks at the muscle itself
    [N].

    ``F_measured - f(L, Ldot, P)``

    at the imposed length L, its rate (``numpy.gradient``, as the model's output takes it) and the
    model's pressure (:func:`record_pressures`); no mechanism stands in the way.

    Returns
    -------
    missing : numpy.ndarray
        [N].
    states : dict
        ``L``, ``Ldot``, ``P`` (the model's pressure, smoothed when a command drives it) and
        ``P_rate``.

    References
    ----------
    .. [1] model-spec sections 5d and 6.
    """
    from .filters import savgol_filter

    L = np.asarray(m.inputs["length"], dtype=float)
    Ldot = np.gradient(L, m.time)
    (P,) = record_pressures(m, params)
    window, order, dt = _smoothing(m)
    rate = savgol_filter(P, window, order, deriv=1, delta=dt)
    states = {"L": L, "Ldot": Ldot, "P": P, "P_rate": rate, "pressures": [P], "rates": [rate]}
    return m.output - actuator.tension(L, P, Ldot, params), states


#: The equation error of the records whose model is not the knee's or a quasi-static test's.
RECORD_ERRORS = {"mechanism": mechanism_missing_force, "actuator": actuator_missing_force}
