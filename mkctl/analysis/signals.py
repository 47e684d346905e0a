"""Operations on a sampled signal, each defined once: hold, delay, lag (model-spec 4, 4b, 5).

A sampled command is held from its sample to the next, as the simulation holds it (model-spec
section 5).

- :func:`held_at`: the value held at given instants;
- :func:`delayed`: the held signal ``delay`` late, at the samples;
- :func:`lagged`: the held signal through the lag ``tau dP/dt = P_in - P`` (the actuator's exact
  step, :func:`mkctl.physics.actuator.lagged_pressure`);
- :func:`pressure_path`: the held command through a dead time and a lag that may exhaust at its own
  rate.

Smoothing and differentiation (Savitzky-Golay) are :mod:`mkctl.analysis.filters`'.
"""
from __future__ import annotations

import math

import numpy as np

from ..physics import actuator


def held_at(time, values, at) -> np.ndarray:
    """The signal held from each sample to the next, read at the instants ``at`` (the first value
    before the first sample)."""
    time, values = np.asarray(time, dtype=float), np.asarray(values, dtype=float)
    return values[np.clip(np.searchsorted(time, at, side="right") - 1, 0, time.size - 1)]


def delayed(time, values, delay: float) -> np.ndarray:
    """A signal held from each sample to the next, ``delay`` [s] late, at its samples (the first
    value held before)."""
    time = np.asarray(time, dtype=float)
    return held_at(time, values, time - delay + 1e-12)


def lagged(time, values, tau: float) -> np.ndarray:
    """A signal held from each sample to the next, through the lag ``tau dP/dt = P_in - P``,
    ``P(0) = P_in(0)``, at its samples (tau [s])."""
    time = np.asarray(time, dtype=float)
    out = np.empty(time.size)
    out[0] = values[0]
    dt = np.diff(time)
    for k in range(1, time.size):
        out[k] = actuator.lagged_pressure(out[k - 1], values[k - 1], tau, dt[k - 1])
    return out


def pressure_path(time, command, tau: float = 0.0, delay: float = 0.0,
                  tau_exhaust: float = 0.0) -> np.ndarray:
    """The bladder pressure a command gives through a dead time and the lag [Pa] (model-spec
    sections 4, 4b).

    The command is held from its sample to the next and reaches the lag ``delay`` late (the first
    command held before that); ``tau dP/dt = P_cmd - P`` while filling, ``tau_exhaust`` instead
    while exhausting when it is given; P(0) = P_cmd(0). Exact between the instants the delayed
    command changes; no lag: the delayed command.
    """
    time, command = np.asarray(time, dtype=float), np.asarray(command, dtype=float)
    seen_from = time + delay  # command[j] acts from time[j] + delay on
    if tau <= 0:
        acting = np.searchsorted(seen_from, time + 1e-12, side="right") - 1
        return command[np.clip(acting, 0, time.size - 1)]
    out = np.empty(time.size)
    P = out[0] = command[0]
    j = 0  # the command acting now
    for k in range(1, time.size):
        t, stop = time[k - 1], time[k]
        while t < stop:
            while j + 1 < time.size and seen_from[j + 1] <= t + 1e-12:
                j += 1
            until = min(stop, seen_from[j + 1]) if j + 1 < time.size else stop
            target = command[j]
            rate_tau = tau_exhaust if (tau_exhaust > 0 and target < P) else tau
            P = target + (P - target) * math.exp(-(until - t) / rate_tau)
            t = until
        out[k] = P
    return out
