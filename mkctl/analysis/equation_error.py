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

    Isotonic (quasi-static): ``F_load - f(L, P, Ldot)``. Knee (Eq. 17): ``m (Xddot + g) - F - F_stop``
    with X, V, Xddot from a cubic Savitzky-Golay fit of the measured X. Only for explanation: the fits
    themselves compare simulations with the data, never differentiated data.
    Returns (missing force, states) with states a dict of the smoothed signals (SI).
    """
    from .filters import savgol_filter

    m = measurement
    if m.experiment == "isometric":  # nothing moves: the measured tension against the model's, point by point
        L, P = m.inputs["length"], m.inputs["pressure"]
        return m.output - isometric_tension(L, P, m.branch, params), {"L": L, "P": P, "branch": m.branch}
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
