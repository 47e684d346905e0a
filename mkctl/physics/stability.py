"""Local stability of the knee (paper Section VI, Eq. 18-25).

Linearizing Eq. 17 about a posture gives ``d/dt (X, V) = [[0, 1], [a2, a1]] (X, V)`` (Eq. 18) with

- ``a2 = (1/m) dF/dX`` (position condition, Eq. 20: a2 < 0),
- ``a1 = (1/m) dF/dV`` (velocity condition, Eq. 19: a1 < 0),

and by Routh-Hurwitz the posture is asymptotically stable iff a1 < 0 and a2 < 0. Because X grows
with alpha, Eq. 20 is equivalent to ``h(alpha, Pe, Pf) = d/dalpha (G_e f_e - G_f f_f) < 0``
(Eq. 21-23).

Model 2 alone has a1 = 0: the poles sit on the imaginary axis ("marginal"), which is the paper's
point. Viscous damping gives ``a1 = -c (G_e^2 + G_f^2) / m < 0`` (spec section 4).

The pressures enter h and F affinely (not with the pressure threshold of model-spec section 4b), so
the equilibrium set (F = m g, V = 0) and the h = 0 surface are both closed-form surfaces
``Pe(alpha, Pf)``; see :func:`equilibrium_pressure` and :func:`h_zero_pressure`, which check the
closed form on the exact force and bisect where it misses (the threshold, a slack extensor). The
pressure lag adds the decoupled poles -1/tau and does not change a1, a2.

References: "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator" (the seed
paper), Section VI, Eq. 18-25 and Fig. 7; model-spec sections 3 and 4.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from . import knee
from ..errors import DomainError
from .params import DEFAULT, Params

#: The default posture of the FMU, the examples and the analyses: alpha = 60 deg (model-spec
#: section 7)...
DEFAULT_ALPHA = float(np.radians(60.0))
#: ... held with this flexor pressure [Pa] (the extensor pressure follows from the equilibrium).
DEFAULT_PF = 100e3


def routh_hurwitz_coefficients(X, Pe, Pf, V=0.0, params: Params = DEFAULT):
    """The coefficients of the linearized knee, Eq. 18: ``d/dt (X, V) = [[0, 1], [a2, a1]] (X, V)``.

    .. math:: a_1 = \\frac{1}{m} \\frac{\\partial F}{\\partial V}, \\qquad
              a_2 = \\frac{1}{m} \\frac{\\partial F}{\\partial X}

    with F the ground force of Eq. 14 that drives Eq. 17
    (:func:`mkctl.physics.knee.knee_force_partials`). The end stops are not included: a1, a2
    describe what the muscles alone do at that posture.

    Parameters
    ----------
    X : float or array_like
        Hip height [m].
    Pe, Pf : float or array_like
        Extensor and flexor gauge pressures [Pa].
    V : float or array_like
        Hip velocity [m/s] (0 at an equilibrium).
    params : Params
        The model; a1 = 0 without damping or friction (model 2 alone).

    Returns
    -------
    a1 : float or array
        Velocity coefficient [1/s]; Eq. 19 asks a1 < 0.
    a2 : float or array
        Position coefficient [1/s^2]; Eq. 20 asks a2 < 0.

    Raises
    ------
    DomainError
        Where X, a pressure or an actuator length is outside the model's domain.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Section VI, Eq. 18-20.
    .. [2] model-spec section 4 (a1 = -c (G_e^2 + G_f^2) / m with damping c).
    """
    partials = knee.knee_force_partials(knee.geometry_at_X(X, params), V, Pe, Pf, params)
    return partials.dF_dV / params.m, partials.dF_dX / params.m


def sealed_coefficients(X, Pe, Pf, params: Params = DEFAULT):
    """Eq. 18's a1, a2 of the knee whose valves are closed: sealed muscles, air springs.

    With both valves closed (u = 0) and no leak each muscle's air mass is constant, so its pressure
    follows its length, ``dP/dL = -k_poly p (dV_b/dL) / V``
    (:func:`mkctl.physics.pneumatics.sealed_stiffness`, model-spec 4d). Through ``dLe/dX = -G_e``
    and ``dLf/dX = G_f`` this adds to Eq. 23's ``h`` (and to a2):

    .. math:: a_2^{sealed} = a_2 - \\frac{1}{m}\\left(G_e^2 \\frac{\\partial f_e}{\\partial P}
              \\frac{dP_e}{dL} + G_f^2 \\frac{\\partial f_f}{\\partial P} \\frac{dP_f}{dL}\\right)

    more negative than with the pressures held in the working range (dP/dL > 0, df/dP > 0): the
    sealed knee is stiffer. a1 is unchanged. The linearization with the pressure states and the
    valves closed (:func:`mkctl.physics.knee.linearization` with ``sealed``) has the poles of
    ``s^2 - a1 s - a2_sealed`` and two at 0 (each muscle's air mass, conserved).

    Parameters
    ----------
    X : float
        Hip height [m].
    Pe, Pf : float
        Extensor and flexor gauge pressures at the moment the valves close [Pa].
    params : Params
        The model; section 4d's k_poly, V_dead.

    Returns
    -------
    a1 : float
        Velocity coefficient [1/s].
    a2 : float
        Position coefficient with the air springs [1/s^2].

    Raises
    ------
    DomainError
        Where X, a pressure or an actuator length is outside the model's domain.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 18-23; its conclusion (the air's dynamics, left open there).
    .. [2] model-spec section 4d (the sealed muscle).
    """
    from .air import sealed_stiffness
    p = params
    geo = knee.geometry_at_X(X, p)
    d = knee.knee_force_partials(geo, 0.0, Pe, Pf, p)
    stiff_e = sealed_stiffness(geo.Le, Pe, p.b, p.n, p.V_dead, p.k_poly)
    stiff_f = sealed_stiffness(geo.Lf, Pf, p.b, p.n, p.V_dead, p.k_poly)
    # dF/dPe dPe/dX + dF/dPf dPf/dX, dPe/dX = stiff_e dLe/dX = -G_e stiff_e, dPf/dX = G_f stiff_f
    spring = d.dF_dPe * (-geo.G_e * stiff_e) + d.dF_dPf * (geo.G_f * stiff_f)
    return float(d.dF_dV / p.m), float((d.dF_dX + spring) / p.m)


def h_function(alpha, Pe, Pf, params: Params = DEFAULT):
    """The position condition in the paper's form: ``h = d/dalpha (G_e f_e - G_f f_f)`` at V = 0.

    Computed from the analytic derivatives, ``h = dF/dX dX/dalpha``. X grows with alpha, so h < 0 is
    equivalent to a2 < 0 (Eq. 20, 21).

    Parameters
    ----------
    alpha : float or array_like
        Kneecap angle [rad].
    Pe, Pf : float or array_like
        Extensor and flexor gauge pressures [Pa] (Pe', Pf' of the paper). All three broadcast.
    params : Params
        The model.

    Returns
    -------
    h : float or array
        [N/rad]; h < 0: the posture is held by a restoring force.

    Raises
    ------
    DomainError
        Where alpha, a pressure or an actuator length is outside the model's domain.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Section VI-B, Eq. 21-23.
    """
    geo = knee.geometry_at_alpha(alpha, params)
    partials = knee.knee_force_partials(geo, 0.0, Pe, Pf, params)
    return partials.dF_dX * geo.dX_dbeta / geo.dalpha_dbeta


def h_slope(alpha, Pe, Pf, params: Params = DEFAULT, step: float = 1e-5):
    """dh/dalpha by a central difference of the analytic :func:`h_function`.

    ``dh/dalpha = (h(alpha + step) - h(alpha - step)) / (2 step)``. Used to check the paper's "h
    decreases monotonically along alpha" (Section VI-B).

    Parameters
    ----------
    alpha : float or array_like
        Kneecap angle [rad].
    Pe, Pf : float or array_like
        Extensor and flexor gauge pressures [Pa]; all three broadcast.
    params : Params
        The model.
    step : float
        Half the difference's span [rad].

    Returns
    -------
    float or array
        The slope dh/dalpha [N/rad^2].

    Raises
    ------
    DomainError
        Where alpha +- step, a pressure or an actuator length is outside the model's domain.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Section VI-B, Eq. 23 and Fig. 7.
    """
    return ((h_function(alpha + step, Pe, Pf, params) - h_function(alpha - step, Pe, Pf, params))
            / (2 * step))


def equilibrium_pressure(alpha, Pf, params: Params = DEFAULT):
    """Extensor pressure that holds the hip at rest: the equilibrium set (V = 0, F = m g) of Fig. 7.

    F is affine in Pe, so

    .. math:: P_e = \\frac{m g - F(\\alpha, V = 0, P_e = 0, P_f)}{\\partial F / \\partial P_e}

    With slack (model-spec section 4) the extensor that holds the hip is taut, so its tension stays
    affine in Pe; only the flexor may be slack: its tension is ``max(f_f, 0)``. The pressure
    threshold (model-spec section 4b, ``P_eff = P - P0 (1 - exp(-P / P0))``) makes F nonlinear in
    Pe: with P0 > 0 the affine step alone missed (at alpha = 60 deg, Pf = 100 kPa, P0 = 100 kPa it
    gave 1.598 MPa, where F - m g = -7.6 N). So the step is checked on the exact force (to a
    relative 1e-9) and, where it misses, the root of ``F(Pe) - m g`` is bracketed and bisected:
    F rises monotonically with Pe where the extensor pulls (1.698 MPa in that example).

    Parameters
    ----------
    alpha : float or array_like
        Kneecap angle [rad].
    Pf : float or array_like
        Flexor gauge pressure [Pa]; broadcasts with alpha.
    params : Params
        The model: the hip mass m [kg], g [m/s^2], the actuators and the effects.

    Returns
    -------
    Pe : float or array
        Extensor gauge pressure [Pa]: negative where the flexor alone would lift the hip, infinite
        where the extensor's pressure gain vanishes.

    Raises
    ------
    DomainError
        Where alpha, Pf or an actuator length is outside the model's domain; where F is not affine
        in Pe and no extensor pressure holds the hip.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 17 and Fig. 7.
    .. [2] model-spec section 4 (slack).
    """
    geo = knee.geometry_at_alpha(alpha, params)
    taut = params.replace(slack=0) if params.slack else params
    partials = knee.knee_force_partials(geo, 0.0, 0.0, Pf, taut)
    F = partials.F
    if params.slack:
        F = F + geo.G_f * np.minimum(partials.ff, 0.0)  # a slack flexor does not push the hip up
    mg = params.m * params.g
    Pe = (mg - F) / partials.dF_dPe
    # The affine step is exact unless F bends in Pe (the pressure threshold, P0 > 0): check it on
    # the exact force, and where it misses, find the root of the exact F(Pe) - m g by bisection.

    def excess(alpha_, Pe_, Pf_):
        # the check at the guess is at alpha itself: its geometry is already known
        at = geo if alpha_ is alpha else knee.geometry_at_alpha(alpha_, params)
        return knee.knee_force(at, 0.0, Pe_, Pf_, params).F - mg

    scale = mg + np.abs(F) + np.abs(partials.dF_dPe * np.where(np.isfinite(Pe), Pe, 0.0))
    return _refined(excess, alpha, Pf, Pe, scale, np.isfinite(Pe),
                    "no extensor pressure holds the hip at rest", "F - m g [N]",
                    "the extensor's pressure gain does not lift the hip there")


def h_zero_pressure(alpha, Pf, params: Params = DEFAULT, where_none: float | None = None):
    """Extensor pressure on the surface h(alpha, Pe, Pf) = 0 of Fig. 7.

    h is affine in Pe, so ``Pe = -h(alpha, 0, Pf) / (h(alpha, 1 Pa, Pf) - h(alpha, 0, Pf))``. Not so
    with the pressure threshold (model-spec section 4b: P0 > 0), where that secant missed the
    surface (h = 1.5e7 N/rad at its result with P0 = 100 kPa, alpha = 60 deg, Pf = 100 kPa), nor
    where the extensor is slack at 0 and 1 Pa (slack = 1 with model 2), where the secant divided
    by zero (a ZeroDivisionError for floats, inf for arrays). So the secant is checked on h itself
    (to a relative 1e-9) and, where it misses, the pressure at which h changes sign is bracketed
    and bisected (h is monotone in Pe). With slack, h does not depend on Pe while the extensor is
    slack and may jump through zero where it turns taut: the result is then that pressure.

    Parameters
    ----------
    alpha : float or array_like
        Kneecap angle [rad].
    Pf : float or array_like
        Flexor gauge pressure [Pa]; broadcasts with alpha.
    params : Params
        The model.
    where_none : float, optional
        What to return where h does not change sign at any extensor pressure: None (default)
        raises DomainError; a caller that maps the surface and leaves its gaps blank asks for
        ``numpy.nan`` here.

    Returns
    -------
    Pe : float or array
        Extensor gauge pressure [Pa] at which h changes sign (h = 0 there where h is continuous in
        Pe). Which side is stable (h < 0) depends on the posture: in the default model h rises
        with Pe below alpha = 57 deg (h < 0 below the result) and falls with Pe above it.

    Raises
    ------
    DomainError
        Where alpha, Pf or an actuator length is outside the model's domain; with where_none None,
        where h does not change sign at any extensor pressure (e.g. a slack extensor at
        alpha = 60 deg, Pf = 100 kPa, model 2, where h < 0 at every Pe).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 22-23 and Fig. 7.
    """
    h0 = h_function(alpha, 0.0, Pf, params)
    h1 = h_function(alpha, 1.0, Pf, params)
    slope = np.asarray(h1 - h0)
    # The secant through 0 and 1 Pa is exact where h is affine in Pe. Elsewhere (the pressure
    # threshold bends h; a slack extensor makes h flat in Pe, slope 0) the root of h(Pe) itself is
    # bracketed and bisected; where h has no sign change at all, a DomainError (or where_none).
    if np.all(slope != 0):
        Pe = -h0 / (h1 - h0)
    else:
        with np.errstate(divide="ignore", invalid="ignore"):
            Pe = -np.asarray(h0) / slope
    finite_Pe = np.where(np.isfinite(Pe), Pe, 0.0)
    scale = np.abs(h0) + np.abs(slope * finite_Pe)

    def h_at(alpha_, Pe_, Pf_):
        return h_function(alpha_, Pe_, Pf_, params)

    return _refined(h_at, alpha, Pf, Pe, scale, np.ones(np.shape(Pe), dtype=bool),
                    "h does not change sign at any extensor pressure", "h [N/rad]",
                    "where the extensor is slack, h does not depend on Pe", where_none)


#: Relative residual below which a closed-form pressure (affine in Pe) is taken as exact.
_AFFINE_TOLERANCE = 1e-9
#: Largest extensor pressure magnitude [Pa] the bracket search of :func:`_refined` tries.
_PE_SEARCH_LIMIT = 1e12


def _refined(fun, alpha, Pf, Pe, scale, check, failure: str, what: str, why: str,
             where_none: float | None = None):
    """The boundary in Pe between ``fun(alpha, Pe, Pf) < 0`` and ``>= 0``, from the guess Pe.

    The closed-form guess is kept, bit for bit, where ``|fun| <= _AFFINE_TOLERANCE scale`` (fun
    affine in Pe) or where check is False (an infinite guess the caller documents). Elsewhere the
    boundary is bracketed around the guess (fun is monotone in Pe) and bisected to rounding: where
    fun is continuous, its root; where it jumps through zero or is zero over an interval (a muscle
    turning taut), the pressure at which its sign changes. Where the sign does not change for |Pe|
    up to _PE_SEARCH_LIMIT [Pa]: where_none, or (None) a DomainError that says so.
    """
    if np.ndim(Pe) == 0:  # one posture: Python floats keep the equations on their fast path
        finite = math.isfinite(float(Pe))
        at_guess = float(Pe) if finite else 0.0
        residual = float(fun(alpha, at_guess, Pf)) if finite else math.inf
        if not (bool(check) and not abs(residual) <= _AFFINE_TOLERANCE * float(scale)):
            return Pe
        off = np.asarray(True)
    else:
        finite = np.isfinite(Pe)
        at_guess = np.where(finite, Pe, 0.0)
        residual = np.where(finite, fun(alpha, at_guess, Pf), np.inf)
        off = np.asarray(np.broadcast_to(check, np.shape(Pe))
                         & ~(np.abs(residual) <= _AFFINE_TOLERANCE * scale))
        if not off.any():
            return Pe
    alphas, Pfs, guesses = (np.broadcast_to(v, off.shape)[off].astype(float)
                            for v in (alpha, Pf, at_guess))
    half = np.maximum(np.abs(guesses), 1e5)
    low, high = guesses - half, guesses + half
    f_low, f_high = fun(alphas, low, Pfs), fun(alphas, high, Pfs)
    lost = np.zeros(guesses.shape, dtype=bool)  # no sign change: where_none
    while True:
        open_ = ((f_low < 0) == (f_high < 0)) & ~lost
        if not open_.any():
            break
        beyond = open_ & (half > _PE_SEARCH_LIMIT)
        if beyond.any() and where_none is not None:
            lost |= beyond
            continue
        if beyond.any():
            i = int(np.argmax(beyond))
            raise DomainError(
                f"{failure} at alpha = {np.degrees(alphas[i]):.4g} deg, Pf = {Pfs[i]:g} Pa: "
                f"{what} is {float(f_low[i]):.4g} at Pe = {low[i]:.3g} Pa and "
                f"{float(f_high[i]):.4g} at {high[i]:.3g} Pa ({why})")
        half = np.where(open_, 4 * half, half)
        low, high = np.where(open_, guesses - half, low), np.where(open_, guesses + half, high)
        f_low = np.where(open_, fun(alphas, low, Pfs), f_low)
        f_high = np.where(open_, fun(alphas, high, Pfs), f_high)
    negative_low = f_low < 0
    for _ in range(200):
        middle = 0.5 * (low + high)
        if np.all((middle <= low) | (middle >= high)):  # bisected to rounding
            break
        same = (fun(alphas, middle, Pfs) < 0) == negative_low
        low, high = np.where(same, middle, low), np.where(same, high, middle)
    result = np.array(Pe, dtype=float)
    result[off] = np.where(lost, where_none if where_none is not None else np.nan,
                           0.5 * (low + high))
    return float(result) if np.ndim(Pe) == 0 else result


def verdict(a1, a2) -> np.ndarray:
    """Routh-Hurwitz verdict for the characteristic polynomial ``s^2 - a1 s - a2`` of Eq. 18.

    Parameters
    ----------
    a1 : float or array_like
        Velocity coefficient [1/s].
    a2 : float or array_like
        Position coefficient [1/s^2]; broadcasts with a1.

    Returns
    -------
    numpy.ndarray of str
        'stable' (a1 < 0 and a2 < 0, Eq. 19-20), 'marginal' (a1 = 0, a2 < 0: poles on the imaginary
        axis, the paper's model 2) or 'unstable'.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18-20.
    """
    a1, a2 = np.asarray(a1), np.asarray(a2)
    return np.where((a1 < 0) & (a2 < 0), "stable",
                    np.where((a1 == 0) & (a2 < 0), "marginal", "unstable"))


def poles(a1, a2) -> np.ndarray:
    """The eigenvalues of Eq. 18's matrix [[0, 1], [a2, a1]]: ``s = (a1 +- sqrt(a1^2 + 4 a2)) / 2``.

    Parameters
    ----------
    a1 : float or array_like
        Velocity coefficient [1/s].
    a2 : float or array_like
        Position coefficient [1/s^2]; broadcasts with a1.

    Returns
    -------
    numpy.ndarray of complex
        The poles [1/s], shape (..., 2): the ``+`` root first.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18.
    """
    disc = np.sqrt(np.asarray(a1 * a1 + 4 * a2, dtype=complex))
    return np.stack([(a1 + disc) / 2, (a1 - disc) / 2], axis=-1)


@dataclass(frozen=True)
class PostureStability:
    """Everything the paper's stability analysis says about one posture."""

    alpha: float  #: kneecap angle [rad]
    X: float  #: hip height [m]
    Pe: float  #: extensor pressure [Pa]
    Pf: float  #: flexor pressure [Pa]
    a1: float  #: velocity coefficient, Eq. 19 [1/s]
    a2: float  #: position coefficient, Eq. 20 [1/s^2]
    h: float  #: Eq. 22 [N/rad]
    poles: tuple[complex, complex]  #: eigenvalues of Eq. 18 [1/s]
    verdict: str  #: 'stable', 'marginal' or 'unstable'
    #: whether F = m g at (X, Pe, Pf) to a relative 1e-9: the posture is a rest state (checked on
    #: the exact force, whether Pe was given or found by :func:`equilibrium_pressure`)
    in_equilibrium: bool


def posture_stability(alpha=None, *, X=None, Pf: float = DEFAULT_PF, Pe: float | None = None,
                      params: Params = DEFAULT) -> PostureStability:
    """Everything the paper's stability analysis (Eq. 18-23) says about one posture.

    Parameters
    ----------
    alpha : float, optional
        Kneecap angle [rad], 0 < alpha < pi/2; give exactly one of alpha and X.
    X : float, optional
        Hip height [m], instead of alpha.
    Pf : float
        Flexor gauge pressure [Pa].
    Pe : float, optional
        Extensor gauge pressure [Pa]; None: the one that holds the posture at rest
        (:func:`equilibrium_pressure`).
    params : Params
        The model.

    Returns
    -------
    PostureStability
        The posture, its pressures, a1 [1/s], a2 [1/s^2], h [N/rad], the poles [1/s], the verdict
        ('stable', 'marginal', 'unstable') and whether F = m g there (checked on the exact force).

    Raises
    ------
    ParameterError
        Unless exactly one of alpha and X is given.
    DomainError
        For a posture or a pressure outside the model's domain; with Pe None, where no extensor
        pressure holds the posture.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Section VI, Eq. 18-23.
    .. [2] model-spec sections 3 and 4.
    """
    alpha, X = knee.posture(alpha, X, params)
    if Pe is None:
        Pe = float(equilibrium_pressure(alpha, Pf, params))
    mg = params.m * params.g
    excess = float(knee.ground_force(X, Pe, Pf, 0.0, params)) - mg
    in_equilibrium = abs(excess) <= _AFFINE_TOLERANCE * mg
    a1, a2 = (float(v) for v in routh_hurwitz_coefficients(X, Pe, Pf, 0.0, params))
    return PostureStability(float(alpha), X, float(Pe), float(Pf), a1, a2,
                            float(h_function(alpha, Pe, Pf, params)),
                            tuple(complex(s) for s in poles(a1, a2)), str(verdict(a1, a2)),
                            in_equilibrium)


def equilibrium_hip_height(Pe: float, Pf: float, params: Params = DEFAULT, X_range=None,
                           samples: int = 400):
    """The hip height of a stable equilibrium: ``F(X, V = 0, Pe, Pf) = m g`` with dF/dX < 0.

    The root is bracketed on a grid of X (where F - m g falls through zero as X grows) and refined
    by Brent's method to 1e-13 m.

    Parameters
    ----------
    Pe, Pf : float
        Extensor and flexor gauge pressures [Pa].
    params : Params
        The model.
    X_range : tuple of float, optional
        (low, high) hip heights [m] to search; default: between the end stops
        (:func:`mkctl.physics.knee.stop_positions`).
    samples : int
        Points of the bracketing grid.

    Returns
    -------
    X : float
        Hip height [m] of the stable root nearest the upper stop.

    Raises
    ------
    DomainError
        If there is no stable equilibrium in range (the leg would rest on an end stop).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 17 and 20.
    """
    # imported here, not at the top: the FMUs import this module, and a host that loads an FMU
    # should not have to load scipy (and a second OpenBLAS) for a function the FMU never calls
    from scipy.optimize import brentq

    low, high = X_range if X_range is not None else knee.stop_positions(params)
    grid = np.linspace(low, high, samples)
    excess = knee.ground_force(grid, Pe, Pf, 0.0, params) - params.m * params.g
    crossings = np.nonzero((excess[:-1] > 0) & (excess[1:] <= 0))[0]  # + to -: dF/dX < 0, stable
    if crossings.size == 0:
        raise DomainError(f"no stable equilibrium for Pe = {Pe:g} Pa, Pf = {Pf:g} Pa between "
                          f"X = {low:.4f} and {high:.4f} m (the leg would rest on an end stop)")
    i = crossings[-1]
    return brentq(lambda x: float(knee.ground_force(x, Pe, Pf, 0.0, params)) - params.m * params.g,
                  grid[i], grid[i + 1], xtol=1e-13)
