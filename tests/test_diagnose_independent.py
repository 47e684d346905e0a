"""Diagnosis of records made by an independent simulator written here, not by mkctl's own simulation code.

The records come from right-hand sides written in this file and integrated by ``scipy.integrate.solve_ivp``
(not mkctl's stepping loop, lag formula, backward Euler or play operator), with coloured (first-order
autoregressive) output noise and a small model mismatch the diagnosis cannot represent exactly:

- isotonic: the rubber's tension from the Mooney-Rivlin energy of Eq. 10-12 written here and
  differentiated numerically (mkctl uses its analytic gradient), the load hanging from a damper, the
  pressure varying linearly between samples (mkctl holds it);
- knee: the ground force from mkctl's Eq. 14 (tested against virtual work elsewhere), but the lag, the
  state equation and the start at rest written and integrated here, with a dead time of 2 ms before the
  lag (the commands reach the valves late), which mkctl's model does not have.

Fitted values must lie within a few reported standard errors of the truth (the diagnosis widens them for
correlated residuals), plus, where the mismatch makes one truth impossible, the range the mismatch spans.
"""
import math

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from mkctl.analysis.diagnose import diagnose
from mkctl.analysis.synth import isotonic_inputs, knee_inputs
from mkctl.io.measurements import measurement_from_arrays
from mkctl.physics import knee
from mkctl.physics.params import Params

SE_TOLERANCE = 4.0


def ar1_noise(std, size, rho, seed):
    """Own AR(1) noise: e_k = rho e_{k-1} + sqrt(1 - rho^2) w_k, standard deviation std."""
    w = np.random.default_rng(seed).normal(0.0, 1.0, size)
    e = np.empty(size)
    e[0] = w[0]
    for k in range(1, size):
        e[k] = rho * e[k - 1] + math.sqrt(1 - rho * rho) * w[k]
    return std * e


# --- isotonic ----------------------------------------------------------------------------------------

def tension(L, P, p: Params):
    """Model 2 (Eq. 13) from the energy of Eq. 10-12, differentiated by a central difference here."""
    def energy(x):
        l1 = (x / p.L0) ** 2
        l2 = (p.b ** 2 - x ** 2) / (p.D0 * p.n * math.pi) ** 2
        l3 = 1.0 / (l1 * l2)
        return p.C1 * (l1 + l2 + l3 - 3) + p.C2 * (1 / l1 + 1 / l2 + 1 / l3 - 3)
    h = 1e-7
    volume = math.pi * p.t0 * (p.D0 - p.t0) * p.L0
    return P * (3 * L * L - p.b ** 2) / (4 * math.pi * p.n ** 2) + volume * (energy(L + h) - energy(L - h)) / (2 * h)


def isotonic_record(c, samples=500, noise_mm=0.01, rho=0.6, seed=0):
    p = Params()
    time, pressure, load = isotonic_inputs(samples, loads=(50.0,), cycles=(20.0, 5.0))

    def rhs(t, y):
        P = np.interp(t, time, pressure)
        F = np.interp(t, time, load)
        return [(F - tension(y[0], P, p)) / c]

    L0 = brentq(lambda L: tension(L, pressure[0], p) - load[0], 0.6 * p.b, 0.999 * p.b)
    run = solve_ivp(rhs, (time[0], time[-1]), [L0], t_eval=time, method="Radau", rtol=1e-9, atol=1e-12)
    assert run.success
    length = run.y[0] + ar1_noise(noise_mm * 1e-3, samples, rho, seed)
    return measurement_from_arrays("isotonic", time, {"pressure": pressure, "force": load}, length)


def test_independent_isotonic_damping_is_found_within_its_standard_error():
    c = 300.0
    result = diagnose(isotonic_record(c))
    assert result.missing == ["viscous_damping"], result
    se = result.uncertainty["c"]
    assert 0 < se < 0.2 * c
    assert abs(result.params["c"] - c) < SE_TOLERANCE * se, (result.params["c"], se)


def test_independent_isotonic_record_without_an_effect_gets_nothing():
    # no damper: the length balances the load at every instant, each sample's root found here
    p = Params()
    time, pressure, load = isotonic_inputs(500, loads=(50.0,), cycles=(20.0, 5.0))
    length = np.array([brentq(lambda L: tension(L, P, p) - F, 0.6 * p.b, 0.999 * p.b, xtol=1e-14)
                       for P, F in zip(pressure, load)])
    length = length + ar1_noise(1e-5, length.size, 0.6, 3)
    result = diagnose(measurement_from_arrays("isotonic", time, {"pressure": pressure, "force": load}, length))
    assert result.verdict == "nothing missing", result


# --- knee --------------------------------------------------------------------------------------------

def rest_height(p: Params, pe: float, pf: float) -> float:
    """The stable rest of the leg under constant pressures: where F(X) - m g falls through zero (found on
    a grid between the end stops, then by Brent)."""
    def excess(X):
        return knee.ground_force(X, pe, pf, 0.0, p) - p.m * p.g
    low, high = knee.stop_positions(p)
    grid = np.linspace(low + 1e-6, high - 1e-6, 400)
    values = np.array([excess(X) for X in grid])
    falls = np.flatnonzero((values[:-1] > 0) & (values[1:] <= 0))
    assert falls.size == 1
    i = falls[0]
    return brentq(excess, grid[i], grid[i + 1], xtol=1e-14)


def knee_record(c, tau, delay, samples=600, rate=200.0, noise_mm=0.01, rho=0.5, seed=1):
    """The knee with damping c and a lag tau on both pressures, each command reaching the valves ``delay``
    seconds late (a dead time: the mismatch, which mkctl's model cannot represent)."""
    p = Params().replace(c=c)
    time, pe_cmd, pf_cmd = knee_inputs(samples, rate, p)
    g = p.g

    def rhs(t, y, pe, pf):
        X, V, Pe, Pf = y
        force = knee.ground_force(X, Pe, Pf, V, p)
        return [V, force / p.m - g, (pe - Pe) / tau, (pf - Pf) / tau]

    X0 = rest_height(p, pe_cmd[0], pf_cmd[0])
    y = np.array([X0, 0.0, pe_cmd[0], pf_cmd[0]])
    X = [X0]
    for k in range(1, samples):  # commands held from each sample to the next, arriving `delay` late
        old = max(k - 2, 0)
        pieces = [(time[k - 1], time[k - 1] + delay, old), (time[k - 1] + delay, time[k], k - 1)]
        for start, stop, j in pieces:
            run = solve_ivp(rhs, (start, stop), y, args=(pe_cmd[j], pf_cmd[j]), method="LSODA",
                            rtol=1e-10, atol=[1e-10, 1e-10, 1e-4, 1e-4])
            assert run.success
            y = run.y[:, -1]
        X.append(y[0])
    X = np.array(X) + ar1_noise(noise_mm * 1e-3, samples, rho, seed)
    return measurement_from_arrays("knee", time, {"pe_cmd": pe_cmd, "pf_cmd": pf_cmd}, X)


def test_independent_knee_damping_and_lag_are_found_within_their_standard_errors():
    c, tau, delay = 40.0, 0.030, 0.002
    result = diagnose(knee_record(c, tau, delay))
    assert sorted(result.missing) == ["pressure_lag", "viscous_damping"], result
    se_c, se_tau = result.uncertainty["c"], result.uncertainty["tau"]
    assert 0 < se_c < 0.2 * c and 0 < se_tau < 0.2 * tau
    # a first-order lag stands in for lag + dead time: to first order tau + delay (same mean delay)
    assert tau - SE_TOLERANCE * se_tau < result.params["tau"] < tau + delay + SE_TOLERANCE * se_tau
    # the dead time moves the damping a little: allowed, on top of the standard errors, as much relative
    # error in c as the dead time is of the lag (damping and lag trade off against each other)
    assert abs(result.params["c"] - c) < SE_TOLERANCE * se_c + delay / tau * c


def test_independent_knee_without_effects_gets_nothing():
    result = diagnose(knee_record_plain())
    assert result.verdict == "nothing missing", result


def knee_record_plain(samples=600, rate=200.0):
    """The knee without damping or lag (the lag states are left out: no stiff 1e-9 s lag)."""
    p = Params()
    time, pe_cmd, pf_cmd = knee_inputs(samples, rate, p)

    def rhs(t, y, pe, pf):
        return [y[1], knee.ground_force(y[0], pe, pf, y[1], p) / p.m - p.g]

    X0 = rest_height(p, pe_cmd[0], pf_cmd[0])
    y = np.array([X0, 0.0])
    X = [X0]
    for k in range(1, samples):
        run = solve_ivp(rhs, (time[k - 1], time[k]), y, args=(pe_cmd[k - 1], pf_cmd[k - 1]), method="LSODA",
                        rtol=1e-10, atol=1e-10)
        y = run.y[:, -1]
        X.append(y[0])
    X = np.array(X) + ar1_noise(1e-5, samples, 0.5, 4)
    return measurement_from_arrays("knee", time, {"pe_cmd": pe_cmd, "pf_cmd": pf_cmd}, X)
