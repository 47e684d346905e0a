"""The isotonic test of Fig. 5: one actuator under a hanging load, its pressure swept slowly.

The test is quasi-static: the load's inertia is neglected, so at every instant the actuator's
tension balances the load, ``f(L, P, Ldot) = F_load``. Which length that gives depends on the
effects switched on (model-spec section 4):

- no velocity effect: the static length, the root of ``f_static(L, P) = F_load``;
- Coulomb friction: its quasi-static limit, a play operator. The length stays put while the static
  tension lies within +-Fc of the load, and otherwise moves to the edge of that band (lengthening:
  ``f_static = F - Fc``; shortening: ``f_static = F + Fc``). This draws the hysteresis loop of Fig.
  5.
- viscous damping: ``c Ldot = F - f_static - friction``, integrated by backward Euler between
samples.

The pressure is the one measured in the bladder, so the pressure lag plays no part here.

Where no length in the domain carries the load, the muscle goes to its limit instead: a load beyond
what the tension can reach at the braid limit (L -> b, the fibres straight along the axis; for
example model 1 with no pressure under a hanging load) pulls it out to the braid limit, and a load
below the tension of the fully contracted muscle leaves it at its shortest length (the end stop of
the bracket). A record simulated that way goes on; :func:`saturation` says at which samples the
model could not follow.

References: "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator" (the seed
paper), Eq. 7 and 13, Fig. 5 (the isotonic test); model-spec sections 2, 4 and 5.
"""
from __future__ import annotations

import numpy as np
from . import actuator, backend
from ..errors import DomainError
from .params import DEFAULT, Params

#: Most bisection (static_length) or Newton-with-bracket (damped test) steps per length: 60 halvings
#: take the bracket (0, b) below 1e-18 m. mkctl.native compiles the damped test with the same cap.
MAX_ITERATIONS = 60


#: Shortest and longest length of the bisection bracket, as fractions of the braid length b.
SHORTEST, LONGEST = 1e-3, 1 - 1e-9


def length_limits(params: Params = DEFAULT) -> tuple[float, float]:
    """The shortest and longest actuator length the quasi-static solution may take.

    The bisection's bracket on the domain 0 < L < b: ``(SHORTEST b, LONGEST b)``.

    Parameters
    ----------
    params : Params
        The braid length b [m].

    Returns
    -------
    shortest : float
        Shortest length [m] (the fully contracted muscle: the end stop of the bracket).
    longest : float
        Longest length [m] (the braid limit, just short of b).

    References
    ----------
    .. [1] model-spec section 2 (the domain 0 < L < b).
    """
    return params.b * SHORTEST, params.b * LONGEST


def saturation(pressure, load, params: Params = DEFAULT) -> np.ndarray:
    """Where no length in the domain carries the load, and which limit the muscle goes to.

    Parameters
    ----------
    pressure : float or array_like
        Gauge pressure P [Pa].
    load : float or array_like
        Load F [N]; broadcasts with pressure.
    params : Params
        The actuator and its effects.

    Returns
    -------
    numpy.ndarray of int
        -1 (``F < f_static(shortest, P)``: held at its shortest length), +1
        (``F > f_static(longest, P)``: pulled to the braid limit), 0 (a length in the domain carries
        it).

    References
    ----------
    .. [1] model-spec sections 2 and 5 (the isotonic test).
    """
    P, F = np.broadcast_arrays(np.asarray(pressure, dtype=float), np.asarray(load, dtype=float))
    low, high = length_limits(params)
    out = np.zeros(P.shape, dtype=int)
    out[F > actuator.static_tension(np.full(P.shape, high), P, params)] = 1
    out[F < actuator.static_tension(np.full(P.shape, low), P, params)] = -1
    return out


def static_length(pressure, load, params: Params = DEFAULT, saturate: bool = False):
    """Length at which the static tension (model 1 or 2) equals the load: ``f_static(L, P) = F``.

    Solved by bisection on 0 < L < b (:data:`MAX_ITERATIONS` halvings), where the static tension
    rises with L for P >= 0.

    Parameters
    ----------
    pressure : float or array_like
        Gauge pressure P [Pa].
    load : float or array_like
        Load F [N]; broadcasts with pressure.
    params : Params
        The actuator and its effects (model 1, Eq. 7, or model 2, Eq. 13).
    saturate : bool
        Where no length in the domain carries the load, return the limit the muscle goes to
        (:func:`length_limits`: the braid limit for a load too heavy, the shortest length for one
        too light) instead of raising.

    Returns
    -------
    L : numpy.ndarray
        Actuator length [m], shaped like the broadcast of pressure and load.

    Raises
    ------
    DomainError
        For a pressure or load that is not finite, and without ``saturate`` where no length in the
        domain carries the load (for example model 1 with no pressure).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 7 and
    13.
    .. [2] model-spec section 2.
    """
    P, F = np.broadcast_arrays(np.asarray(pressure, dtype=float), np.asarray(load, dtype=float))
    actuator.check_pressure(P)
    actuator.check_pressure(F)
    shortest, longest = length_limits(params)
    low = np.full(P.shape, shortest)
    high = np.full(P.shape, longest)
    f_low = actuator.static_tension(low, P, params)
    f_high = actuator.static_tension(high, P, params)
    unreachable = ~((f_low <= F) & (F <= f_high))
    if saturate:
        too_heavy, too_light = F > f_high, F < f_low
    elif np.any(unreachable):
        i = np.flatnonzero(unreachable)[0]
        raise DomainError(f"no actuator length carries the load {F.flat[i]:g} N at pressure "
                          f"{P.flat[i]:g} Pa (the tension can only range from {f_low.flat[i]:.4g} "
                          f"to {f_high.flat[i]:.4g} N)")
    for _ in range(MAX_ITERATIONS):
        mid = 0.5 * (low + high)
        too_long = actuator.static_tension(mid, P, params) > F
        high = np.where(too_long, mid, high)
        low = np.where(too_long, low, mid)
    length = 0.5 * (low + high)
    if saturate:
        length = np.where(too_heavy, longest, np.where(too_light, shortest, length))
    return length


def play_operator(start, lower, upper):
    """Backlash (play) operator: ``y_k = clip(y_{k-1}, lower_k, upper_k)`` with ``y_{-1} = start``.

    The output stays put while it lies in the band and is dragged along by the band's edge
    otherwise: Coulomb friction's quasi-static limit, which draws the hysteresis loop of Fig. 5.

    Parameters
    ----------
    start : float
        The output before the first sample (a length [m] in the isotonic test).
    lower, upper : numpy.ndarray
        The band's edges at each sample, same length (and unit) as the output.

    Returns
    -------
    numpy.ndarray
        The output at each sample.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Fig. 5.
    .. [2] model-spec section 4 (coulomb_friction: a play operator in a quasi-static test).
    """
    out = np.empty(len(lower))
    y = float(start)
    for k, (lo, hi) in enumerate(zip(lower.tolist(), upper.tolist())):
        y = min(max(y, lo), hi)
        out[k] = y
    return out


def simulate_isotonic(time, pressure, load, params: Params = DEFAULT, L_start: float | None = None,
                      saturate: bool = True):
    """Actuator length over an isotonic record (quasi-static, see the module docstring).

    ``f(L, P, Ldot) = F_load`` at every sample: the static length without a velocity effect, the
    play operator between ``f_static = F - Fc`` and ``f_static = F + Fc`` with Coulomb friction,
    backward Euler on ``c Ldot = F - f_static - friction`` with viscous damping.

    Parameters
    ----------
    time : array_like
        Sample times [s], increasing.
    pressure : array_like
        Gauge pressure measured in the bladder [Pa], one per sample.
    load : array_like
        The hanging load's weight [N], one per sample.
    params : Params
        The actuator and its effects.
    L_start : float, optional
        Length before the first sample [m]; default: the static length of the first sample, as after
        a long rest.
    saturate : bool
        Where no length carries the load, the muscle goes to its limit (default) instead of raising.

    Returns
    -------
    L : numpy.ndarray
        Actuator length [m] at every sample.

    Raises
    ------
    DomainError
        For a pressure or load that is not finite, and without ``saturate`` where no length carries
        the load.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 7, 13 and Fig. 5.
    .. [2] model-spec sections 4 and 5 (the isotonic experiment).
    """
    time = np.asarray(time, dtype=float)
    P = np.asarray(pressure, dtype=float)
    F = np.asarray(load, dtype=float)
    if L_start is None:
        L_start = float(static_length(P[0], F[0], params, saturate))
    if actuator.viscous_coefficient(params) > 0:
        return _damped_isotonic(time, P, F, params, L_start, saturate)
    width = actuator.play_half_width(P, params)  # the effects' play band (Fc) [N]
    if np.any(width):
        # lengthening stops where f_static = F - Fc, shortening where f_static = F + Fc
        return play_operator(L_start, static_length(P, F - width, params, saturate),
                             static_length(P, F + width, params, saturate))
    return static_length(P, F, params, saturate)


def _damped_isotonic(time, P, F, params: Params, L_start: float, saturate: bool = True):
    """Backward Euler on ``c Ldot = F - f_static(L, P) - Fc sign(Ldot)`` (friction in its play
    limit; c the effects' viscous coefficient, Fc their play half-width).

    Runs in the compiled core (:mod:`mkctl.native`, the same algorithm in C) when one is installed
    (:mod:`mkctl.physics.backend`); the loop below is the fallback, and it also runs again after a
    fault of the compiled run, to raise its own error."""
    core = backend.compiled_core(params) if time.size else None
    if core is not None:
        L = core.isotonic_damped(params, time, P, F, L_start, saturate)
        if L is not None:
            return L
    L = np.empty(time.size)
    previous = L_start
    dt = np.diff(time, prepend=time[0])
    for k in range(time.size):
        if dt[k] <= 0:
            L[k] = previous
            continue
        pressure = float(P[k])
        excess = float(F[k]) - float(actuator.static_tension(previous, pressure, params))
        width = float(actuator.play_half_width(pressure, params))
        if abs(excess) <= width:  # friction holds
            L[k] = previous
        else:
            load = float(F[k]) - np.sign(excess) * width
            L[k] = _backward_euler_length(previous, pressure, load,
                                          actuator.viscous_coefficient(params) / dt[k], params,
                                          saturate)
        previous = L[k]
    return L


def _backward_euler_length(previous: float, pressure: float, load: float, gain: float,
                           params: Params, saturate: bool = True) -> float:
    """Root of ``g(x) = load - f_static(x, P) - gain (x - previous)`` [m], gain = c / dt [N/m].

    Where the root lies beyond the domain, the length stops at the limit (saturate) or raises.

    g falls with x (the static tension rises with L for P >= 0), so the root lies on the side of
    ``previous`` that g(previous) points to. Newton steps with the analytic slope, kept inside a
    bracket that shrinks with every evaluation (bisection when a step leaves it).
    """
    def g(x):
        return load - float(actuator.static_tension(x, pressure, params)) - gain * (x - previous)

    value = g(previous)
    if value == 0:
        return previous
    # bracket [low, high] with g(low) > 0 > g(high)
    shortest, longest = length_limits(params)
    if value > 0:
        low, high = previous, longest
        if g(high) > 0:
            if saturate:
                return longest
            static_length(pressure, load, params)  # raises the DomainError that explains it
    else:
        low, high = shortest, previous
        if g(low) < 0:
            if saturate:
                return shortest
            static_length(pressure, load, params)
    x = previous
    for _ in range(MAX_ITERATIONS):
        slope = float(actuator.static_tension_dL(x, pressure, params)) + gain
        # (no slope: a step that leaves the bracket, so bisect)
        step = value / slope if slope > 0 else 2 * (high - low)
        if abs(step) < 1e-15:  # converged (1 fm): nothing left to gain
            return x + step if low <= x + step <= high else x
        candidate = x + step
        x = candidate if low < candidate < high else 0.5 * (low + high)
        value = g(x)
        if value == 0:
            return x
        if value > 0:
            low = x
        else:
            high = x
        if high - low < 1e-15:
            break
    return x


def contraction(L, params: Params = DEFAULT):
    """Contraction ratio ``(L0 - L) / L0`` of Fig. 5 (positive when shorter than at rest).

    Parameters
    ----------
    L : float or array_like
        Actuator length [m].
    params : Params
        The resting length L0 [m].

    Returns
    -------
    float or numpy.ndarray
        Contraction [-].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Fig. 5.
    """
    return (params.L0 - np.asarray(L)) / params.L0
