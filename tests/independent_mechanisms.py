"""An independent simulator of one-coordinate mechanisms, written from model-spec section 3b in the
tests.

Each mechanism's lengths and moment arms are derived here by hand (not traced), its equation of
motion is the spec's ``M qdd = sum_i (-dL_i/dq) f_i(L_i, Ldot_i, P_i) + Q(q, qdot)`` with the end
stops of section 3 written out (a one-sided spring k = 2e5 per unit of q with critical damping 2
sqrt(k M), never pulling), the pressure lag of section 4 (``tau dP/dt = P_cmd - P``) as states, and
it is integrated by scipy's ``solve_ivp`` (DOP853) at tight tolerances, the commands held from each
sample to the next. The only thing taken from mkctl is the muscle's tension ``f(L, P, Ldot)``
(:func:`mkctl.physics.actuator.tension`).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np
from scipy.integrate import solve_ivp
from scipy.optimize import brentq

from mkctl.physics.actuator import tension

STOP_STIFFNESS = 2.0e5  # model-spec section 3's contact, as the knee's: N/m or N m/rad


@dataclass(frozen=True)
class HandMechanism:
    """geometry(q) -> (lengths, moment arms dL/dq), each a list; inertia(q); load(q, qdot); stops
    (low, high)."""

    geometry: Callable
    inertia: Callable
    load: Callable
    stops: tuple


def hanging_mass(params) -> HandMechanism:
    """One muscle, top fixed, mass m: L = q, dL/dq = 1, M = m, Q = +m g; stops at 0.6 b and 0.97
    b."""
    return HandMechanism(lambda q: ([q], [1.0]), lambda q: params.m,
                         lambda q, qd: params.m * params.g, (0.6 * params.b, 0.97 * params.b))


def pulley_joint(params, r_p=0.02, J=0.015, L1_0=0.19, L2_0=0.19, m_arm=0.5, l_arm=0.15,
                 low=-0.8, high=0.8):
    """L1 = L1_0 - r_p q, L2 = L2_0 + r_p q (arms -r_p, +r_p), M = J, Q = -m_arm g l_arm sin(q)."""
    return HandMechanism(lambda q: ([L1_0 - r_p * q, L2_0 + r_p * q], [-r_p, r_p]), lambda q: J,
                         lambda q, qd: -m_arm * params.g * l_arm * math.sin(q), (low, high))


def cam_lever(params, L_top, r0, k_cam, J_lever, m_lever, l_lever, c_joint, low, high):
    """The test's cam lever: L = L_top - r0 q - k_cam q^2 / 2, so dL/dq = -(r0 + k_cam q); M =
    J_lever; Q = -m_lever g l_lever sin(q) - c_joint qdot (a damped joint)."""
    return HandMechanism(lambda q: ([L_top - r0 * q - 0.5 * k_cam * q * q], [-(r0 + k_cam * q)]),
                         lambda q: J_lever,
                         lambda q, qd: -m_lever * params.g * l_lever * math.sin(q) - c_joint * qd,
                         (low, high))


def generalized_force(mech: HandMechanism, q, qd, pressures, params) -> float:
    """sum_i (-dL_i/dq) f_i(L_i, (dL_i/dq) qdot, P_i) + Q(q, qdot), stops excluded."""
    lengths, arms = mech.geometry(q)
    F = mech.load(q, qd)
    for L, arm, P in zip(lengths, arms, pressures):
        F -= arm * float(tension(L, P, arm * qd, params))
    return F


def stop_force(mech: HandMechanism, q, qd) -> float:
    k, (low, high) = STOP_STIFFNESS, mech.stops
    d = 2.0 * math.sqrt(k * mech.inertia(q))
    if q < low:
        return max(k * (low - q) - d * qd, 0.0)
    if q > high:
        return -max(k * (q - high) + d * qd, 0.0)
    return 0.0


def rest(mech: HandMechanism, pressures, params, bracket=None) -> float:
    """The coordinate where F(q, 0) = 0 in bracket (default: the stops)."""
    low, high = bracket or mech.stops
    return brentq(lambda q: generalized_force(mech, q, 0.0, pressures, params), low, high,
                  xtol=1e-14)


def simulate(mech: HandMechanism, time, commands, params, q0=None, rtol=1e-11, atol=1e-12):
    """(q, qdot, pressures) at the sample times: commands (samples x muscles) [Pa] held from each
    sample to the next, the motion starting at rest at q0 (default: :func:`rest` of the first
    commands)."""
    time = np.asarray(time, float)
    commands = np.asarray(commands, float).reshape(time.size, -1)
    k = commands.shape[1]
    tau = params.tau
    q0 = rest(mech, commands[0], params) if q0 is None else q0
    y = np.array([q0, 0.0, *(commands[0] if tau > 0 else [])], float)
    out = np.empty((time.size, y.size))
    out[0] = y
    moved = np.flatnonzero(np.any(commands[1:] != commands[:-1], axis=1)) + 1
    changes = [0, *moved, time.size - 1]
    for start, end in zip(changes[:-1], changes[1:]):
        if end <= start:
            continue
        held = commands[start]

        def rhs(t, s, held=held):
            P = s[2:] if tau > 0 else held
            F = generalized_force(mech, s[0], s[1], P, params) + stop_force(mech, s[0], s[1])
            rates = [s[1], F / mech.inertia(s[0])]
            if tau > 0:
                rates += list((held - s[2:]) / tau)
            return rates

        sol = solve_ivp(rhs, (time[start], time[end]), y, method="DOP853", rtol=rtol,
                        atol=atol * np.r_[1.0, 1.0, [1e6] * (y.size - 2)],
                        t_eval=time[start:end + 1])
        out[start + 1:end + 1] = sol.y[:, 1:].T
        y = sol.y[:, -1]
    P = out[:, 2:] if tau > 0 else commands
    return out[:, 0], out[:, 1], P[:, :k]
