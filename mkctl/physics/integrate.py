"""A small adaptive Runge-Kutta integrator (Dormand-Prince 5(4)) for the knee's state equations.

Why our own and not scipy's solve_ivp: an FMU advances one communication step at a time (often 1
ms), and solve_ivp's set-up cost per call would dominate. This stepper carries its step-size
estimate from one call to the next (part of the FMU state), so a 1 ms step costs one or two
Runge-Kutta steps, and a 20 ms step a few more, with the same local error control either way.

A whole record with the commands held over many samples is cheaper still: :func:`integrate` then
steps as far as the error allows (5-25 ms on the default knee, against 1 ms samples) and reads the
samples in between off the method's continuous extension (``dense_times``), a quartic through the
stages it has already evaluated.

References: Dormand & Prince, "A family of embedded Runge-Kutta formulae", J. Comp. Appl. Math. 6
(1980); step-size control as in Hairer, Norsett & Wanner, "Solving ODEs I", Sec. II.4 and II.6
(dense output); the quartic continuous extension of Shampine, "Some practical Runge-Kutta formulas",
Math. Comp. 46 (1986), as scipy's RK45 uses it. Model-spec section 7: the FMUs integrate their
states accurately whatever the communication step.
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from ..errors import DomainError

_C = (0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0)
_A = (
    (),
    (1 / 5,),
    (3 / 40, 9 / 40),
    (44 / 45, -56 / 15, 32 / 9),
    (19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729),
    (9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656),
    (35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84),
)
# 5th-order weights are the last row of _A (first-same-as-last); error = 5th - 4th order solution
_E = (71 / 57600, 0.0, -71 / 16695, 71 / 1920, -17253 / 339200, 22 / 525, -1 / 40)
#: Continuous extension (Shampine 1986): y(t + theta h) = y(t) + h sum_i k_i b_i(theta), with
#: b_i(theta) = sum_j DENSE[i][j] theta^(j+1). At theta = 1 the b_i are the 5th-order weights (the
#: last row of _A, and 0 for the 7th stage), so the quartic meets the step's end; its error is of
#: the order the step's error control already bounds.
DENSE = (
    (1.0, -8048581381 / 2820520608, 8663915743 / 2820520608, -12715105075 / 11282082432),
    (0.0, 0.0, 0.0, 0.0),
    (0.0, 131558114200 / 32700410799, -68118460800 / 10900136933, 87487479700 / 32700410799),
    (0.0, -1754552775 / 470086768, 14199869525 / 1410260304, -10690763975 / 1880347072),
    (0.0, 127303824393 / 49829197408, -318862633887 / 49829197408, 701980252875 / 199316789632),
    (0.0, -282668133 / 205662961, 2019193451 / 616988883, -1453857185 / 822651844),
    (0.0, 40617522 / 29380423, -110615467 / 29380423, 69997945 / 29380423),
)

MAX_STEPS = 100_000
#: Step-size control (Hairer, Norsett & Wanner II.4): safety factor, largest growth and shrink
#: factors, the error exponents after an accepted (-1/5) and a rejected (-1/4) step, and the
#: relative step size below which a rejected step counts as collapsed. mkctl.native generates its C
#: integrator from these.
SAFETY = 0.9
MAX_GROWTH = 5.0
MAX_SHRINK = 0.2
ACCEPT_EXPONENT = -0.2
REJECT_EXPONENT = -0.25
COLLAPSE = 1e-14
#: The integrator's error messages (the compiled integrator reports the same ones).
COLLAPSE_MESSAGE = ("the integrator's step size collapsed: the state left the region the model "
                    "can represent")
TOO_MANY_STEPS_MESSAGE = (f"the integrator needed more than {MAX_STEPS} steps: the model is too "
                          "stiff here (a huge damping or stiffness?)")

# the tableau as arrays: each stage is one small matrix product (far cheaper than a Python loop over
# terms)
_A_ROWS = tuple(np.array(row, dtype=float) for row in _A)
_E_ROW = np.array(_E, dtype=float)
_DENSE = np.array(DENSE, dtype=float)


def dense_state(y, h: float, Q, theta: float) -> np.ndarray:
    """The state at the fraction theta of a step, from the continuous extension (as in C).

    ``y(t + theta h) = y + h theta (Q0 + theta (Q1 + theta (Q2 + theta Q3)))`` with
    ``Q = stages.T @ DENSE``: one matrix per step.

    Parameters
    ----------
    y : numpy.ndarray
        The state at the step's start (SI units, n values).
    h : float
        The step's size [s].
    Q : numpy.ndarray
        ``stages.T @ DENSE``, n x 4 [state units per s].
    theta : float
        The fraction of the step, 0 <= theta <= 1 [-].

    Returns
    -------
    numpy.ndarray
        The state at ``t + theta h``.

    References
    ----------
    .. [1] Shampine, "Some practical Runge-Kutta formulas", Math. Comp. 46 (1986).
    """
    return y + h * (theta * (Q[:, 0] + theta * (Q[:, 1] + theta * (Q[:, 2] + theta * Q[:, 3]))))


def integrate(rhs: Callable[[np.ndarray], np.ndarray], y, duration: float, h_hint: float,
              atol, rtol: float = 1e-9, h_max: float | None = None, *, k1=None,
              full_output: bool = False, dense_times=None, dense_out=None):
    """Integrate the autonomous system ``dy/dt = rhs(y)`` over ``duration`` seconds (DOPRI 5(4)).

    A step is accepted when ``sqrt(mean((err / (atol + rtol max(|y|, |y_new|)))^2)) <= 1``, with err
    the difference of the 5th- and 4th-order solutions; the next step is the last one times
    ``SAFETY err^(-1/5)`` (at most MAX_GROWTH), a rejected one shrinks by ``SAFETY err^(-1/4)`` (at
    least MAX_SHRINK). A trial step whose stages leave the model's domain (a :class:`DomainError`
    from rhs) is rejected and shrunk like a step with a large error.

    Dense output: with ``dense_times`` the steps are not cut at those times; ``dense_out[i]``
    receives the state at ``dense_times[i]`` from the continuous extension (:data:`DENSE`), or the
    step's own end where a time falls on it (always so for ``duration``).

    Parameters
    ----------
    rhs : callable
        ``rhs(y) -> dy/dt`` (an array of the state's size), held constant over the call.
    y : array_like
        The initial state (SI units).
    duration : float
        Time to integrate over [s].
    h_hint : float
        The first step size to try [s] (the last call's next step; not positive: the whole
        duration).
    atol : float or array_like
        Absolute tolerance per state (in the state's units).
    rtol : float
        Relative tolerance [-].
    h_max : float, optional
        Largest step [s].
    k1 : numpy.ndarray, optional
        ``rhs(y)`` if the caller already has it (first-same-as-last: the previous call's last
        derivative, when rhs has not changed).
    full_output : bool
        Also return ``rhs(y at the end)``, to pass as k1 to the next call.
    dense_times : array_like, optional
        Increasing times in (0, duration] [s] at which to read the state.
    dense_out : numpy.ndarray, optional
        Filled in place: ``dense_out[i]`` is the state at ``dense_times[i]`` (len(dense_times) x n).

    Returns
    -------
    y : numpy.ndarray
        The state at the end.
    h : float
        The next step size to try [s].
    steps : int
        The number of accepted steps.
    k_last : numpy.ndarray
        ``rhs(y)`` at the end; only with ``full_output``.

    Raises
    ------
    DomainError
        If the step size collapses (that last domain error if there was one, else the collapse
        message), or after more than :data:`MAX_STEPS` steps (too stiff).

    References
    ----------
    .. [1] Dormand & Prince, "A family of embedded Runge-Kutta formulae", J. Comp. Appl. Math. 6
       (1980).
    .. [2] Hairer, Norsett & Wanner, "Solving ODEs I", Sec. II.4 (step-size control) and II.6.
    .. [3] model-spec section 7 (accurate whatever the communication step).
    """
    y = np.array(y, dtype=float)
    atol = np.asarray(atol, dtype=float)
    t, steps = 0.0, 0
    h = min(h_hint, duration) if h_hint > 0 else duration
    if h_max is not None:
        h = min(h, h_max)
    stages = np.empty((7, y.size))
    stages[0] = rhs(y) if k1 is None else k1
    wanted, n_wanted = 0, 0 if dense_times is None else len(dense_times)
    domain_error = None
    while t < duration:
        last = h >= duration - t
        h_try = duration - t if last else h
        try:
            for i in range(1, 7):
                yi = y + h_try * (_A_ROWS[i] @ stages[:i])
                stages[i] = rhs(yi)
        except DomainError as error:
            # a trial stage outside the domain: reject the step, as too large
            domain_error, err = error, float("inf")
        else:
            err_vec = h_try * (_E_ROW @ stages)
            scale = atol + rtol * np.maximum(np.abs(y), np.abs(yi))
            err = float(np.sqrt(np.mean((err_vec / scale) ** 2)))
        if err <= 1.0:
            y_new = yi  # the 7th stage is evaluated at the 5th-order solution
            t_new = duration if last else t + h_try
            Q = None
            while wanted < n_wanted and (last or dense_times[wanted] <= t_new):
                # on the step's end (the last time is duration itself)
                if dense_times[wanted] >= t_new:
                    dense_out[wanted] = y_new
                else:
                    Q = stages.T @ _DENSE if Q is None else Q
                    dense_out[wanted] = dense_state(y, h_try, Q, (dense_times[wanted] - t) / h_try)
                wanted += 1
            t = t_new
            y = y_new
            stages[0] = stages[6]
            steps += 1
            factor = MAX_GROWTH if err == 0 else min(MAX_GROWTH, SAFETY * err ** ACCEPT_EXPONENT)
            # keep the long step in the hint when only the remainder of a communication step was
            # taken
            h = max(h, h_hint, h_try * factor) if last else h_try * factor
        else:
            h = h_try * max(MAX_SHRINK, SAFETY * err ** REJECT_EXPONENT)  # err = inf: MAX_SHRINK
            # only a rejected step can collapse: an accepted tiny step (a tiny communication step)
            # is fine
            if h < COLLAPSE * max(1.0, duration, t):
                raise domain_error if domain_error is not None else DomainError(COLLAPSE_MESSAGE)
        if h_max is not None:
            h = min(h, h_max)
        if steps > MAX_STEPS:
            raise DomainError(TOO_MANY_STEPS_MESSAGE)
    if full_output:
        return y, h, steps, stages[0].copy()
    return y, h, steps
