"""An independent pneumatic simulator, written from model-spec section 4d and docs/pneumatics.md
alone.

It imports nothing from mkctl: its own constants, its own ISO 6358 flow (scalar, with if/else), its
own volume, its own mass balance, and for the heat model a different state: the air's mass and
temperature from the energy balance ``d(m c_v T)/dt = c_p T_in q - p dV/dt + m c_v (T_air - T) /
tau_heat`` (the library integrates p and T). Each sample interval is integrated by scipy's solve_ivp
at tight tolerance, the input held over it.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.integrate import solve_ivp

R = 287.05
P_ATM = 101325.0
RHO0 = 1.185
T_REF = 293.15
GAMMA = 1.4
R_LAMINAR = 0.995


def volume(L, b, n, V_dead):
    return (b * b * L - L**3) / (4 * math.pi * n * n) + V_dead


def volume_slope(L, b, n):
    return (b * b - 3 * L * L) / (4 * math.pi * n * n)


def _iso(r, b_cr, m):
    return (1 - ((r - b_cr) / (1 - b_cr)) ** 2) ** m


def _iso_slope(r, b_cr, m):
    s = (r - b_cr) / (1 - b_cr)
    return m * (1 - s * s) ** (m - 1) * (-2 * s / (1 - b_cr))


def phi(r, b_cr, m):
    """ISO 6358-1's flow function; above R_LAMINAR a quadratic in (1 - r) through 0 at r = 1 meeting
    ISO's value and slope at R_LAMINAR (its two coefficients from a 2 x 2 solve)."""
    r = min(max(r, 0.0), 1.0)
    if r <= b_cr:
        return 1.0
    if r <= R_LAMINAR:
        return _iso(r, b_cr, m)
    d = 1 - R_LAMINAR
    # phi = A x + B x^2 (x = 1 - r): phi(d) = iso, dphi/dr = -(A + 2 B d) = iso's slope
    A, B = np.linalg.solve(
        [[d, d * d], [-1.0, -2 * d]], [_iso(R_LAMINAR, b_cr, m), _iso_slope(R_LAMINAR, b_cr, m)]
    )
    x = 1 - r
    return A * x + B * x * x


def orifice(p_u, p_d, C, b_cr, m, T_u, T_d):
    """Mass flow [kg/s] from p_u to p_d (absolute), negative when p_d > p_u (upstream temperature
    T_d then)."""
    if p_u >= p_d:
        return C * RHO0 * p_u * math.sqrt(T_REF / T_u) * phi(p_d / p_u, b_cr, m)
    return -C * RHO0 * p_d * math.sqrt(T_REF / T_d) * phi(p_u / p_d, b_cr, m)


def valve(u, P, a, T):
    """Net flow into the muscle through opening u."""
    p = P + P_ATM
    if u > 0:
        return u * orifice(
            a["P_supply"] + P_ATM, p, a["C_fill"], a["b_cr"], a["m_sub"], a["T_air"], T
        )
    if u < 0:
        C_ex = a["C_exhaust"] if a["C_exhaust"] > 0 else a["C_fill"]
        return u * orifice(p, P_ATM, C_ex, a["b_cr"], a["m_sub"], T, a["T_air"])
    return 0.0


def net_flow(u, P, a, T):
    return valve(u, P, a, T) - RHO0 * a["C_leak"] * P


def opening(mode, value, P, a):
    if mode == "opening":
        return value
    return min(max((value - P) / a["band"], -1.0), 1.0)


def hermite(t, times, L, Ldot):
    """The cubic Hermite curve through (times, L, Ldot): its value and slope at t."""
    i = min(max(np.searchsorted(times, t, side="right") - 1, 0), len(times) - 2)
    h = times[i + 1] - times[i]
    s = (t - times[i]) / h
    h00, h10, h01, h11 = (
        2 * s**3 - 3 * s**2 + 1,
        s**3 - 2 * s**2 + s,
        -2 * s**3 + 3 * s**2,
        s**3 - s**2,
    )
    d00, d10, d01, d11 = 6 * s**2 - 6 * s, 3 * s**2 - 4 * s + 1, -6 * s**2 + 6 * s, 3 * s**2 - 2 * s
    value = h00 * L[i] + h10 * h * Ldot[i] + h01 * L[i + 1] + h11 * h * Ldot[i + 1]
    slope = (d00 * L[i] + d01 * L[i + 1]) / h + d10 * Ldot[i] + d11 * Ldot[i + 1]
    return value, slope


def load_length(P, load, b, n):
    """Model 1's length under a load: P (3 L^2 - b^2) / (4 pi n^2) = load, and its dL/dP."""
    L = math.sqrt((4 * math.pi * n * n * load / P + b * b) / 3)
    return L, -(4 * math.pi * n * n * load / (P * P)) / (6 * L)


def simulate(time, mode, values, a, b, n, P_start, length=None, length_rate=None, load=None):
    """Gauge pressure, temperature and net mass flow at the sample times.

    mode: "command" (a regulator, u = clip((P_cmd - P) / band)) or "opening"; values held over each
    interval. The muscle: ``length`` a number (held), arrays ``length``/``length_rate`` (moving), or
    ``load`` (model 1's quasi-static length). ``a``: a dict of section 4d's values.
    """
    heat = a["tau_heat"] > 0
    k = a["k_poly"]

    def geometry(t, P):
        if load is not None:
            L, dL_dP = load_length(P, load, b, n)
            return L, 0.0, dL_dP
        if np.ndim(length) == 0:
            return float(length), 0.0, 0.0
        L, Ldot = hermite(t, time, length, length_rate)
        return L, Ldot, 0.0

    def rhs_pressure(t, y, value):
        P = y[0]
        L, Ldot, dL_dP = geometry(t, P)
        V, dVdL = volume(L, b, n, a["V_dead"]), volume_slope(L, b, n)
        q = net_flow(opening(mode, value, P, a), P, a, a["T_air"])
        # dP/dt = k/V (R T q - p (dVdL Ldot + dVdL dL_dP dP/dt))
        return [
            k
            / V
            * (R * a["T_air"] * q - (P + P_ATM) * dVdL * Ldot)
            / (1 + k * (P + P_ATM) * dVdL * dL_dP / V)
        ]

    def rhs_energy(t, y, value):
        m, T = y  # the air's mass and temperature; p from the gas law
        L, Ldot, _ = geometry(t, None)
        V, dVdL = volume(L, b, n, a["V_dead"]), volume_slope(L, b, n)
        p = m * R * T / V
        P = p - P_ATM
        q = net_flow(opening(mode, value, P, a), P, a, T)
        cv = R / (GAMMA - 1)
        cp = cv + R
        T_in = a["T_air"] if q > 0 else T
        dU = cp * T_in * q - p * dVdL * Ldot + m * cv * (a["T_air"] - T) / a["tau_heat"]
        # U = m cv T: dT = (dU - cv T q) / (m cv)
        return [q, (dU - cv * T * q) / (m * cv)]

    if heat:
        if load is not None:
            raise ValueError(
                "the independent simulator's heat model holds or moves the length, no load"
            )
        L0 = geometry(time[0], None)[0]
        y = [(P_start + P_ATM) * volume(L0, b, n, a["V_dead"]) / (R * a["T_air"]), a["T_air"]]
        rhs = rhs_energy
    else:
        y = [P_start]
        rhs = rhs_pressure
    out = np.empty((2, len(time)))
    flows = np.empty(len(time))

    def record(i, state):
        if heat:
            L = geometry(time[i], None)[0]
            T = state[1]
            P = state[0] * R * T / volume(L, b, n, a["V_dead"]) - P_ATM
        else:
            P, T = state[0], a["T_air"]
        out[:, i] = P, T
        flows[i] = net_flow(opening(mode, values[i], P, a), P, a, T)

    record(0, y)
    for i in range(len(time) - 1):
        sol = solve_ivp(
            rhs,
            (time[i], time[i + 1]),
            y,
            method="Radau",
            args=(values[i],),
            rtol=1e-12,
            atol=[1e-9 if not heat else 1e-18, 1e-10][: len(y)],
        )
        assert sol.success, sol.message
        y = sol.y[:, -1]
        record(i + 1, y)
    return out[0], out[1], flows
