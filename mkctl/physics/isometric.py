"""The isometric (blocked-force) test: the muscle clamped at a fixed length, its pressure stepped or
swept slowly, the tension it pulls with measured (model-spec section 5, round 2).

The test is quasi-static and the length does not move, so of the effects of model-spec section 4
only these act:

- elasticity: model 2 (Eq. 13) instead of model 1 (Eq. 7);
- Coulomb friction: at zero motion the play operator of section 4 leaves the tension anywhere within
  +-Fc of the static one; in a test that steps the pressure one way the tension sits at the edge the
  pressure pushes it to. The measured tension is ``f - Fc`` on the ``up`` branch (pressure rising)
  and ``f + Fc`` on the ``down`` branch (pressure falling), which draws the hysteresis between the
  branches;
- slack: ``max(f, 0)``, applied last to the whole tension: a clamped muscle too short for its
pressure
  goes slack and carries nothing instead of pushing.

Viscous damping and the pressure lag have no effect (no motion; the pressure is the measured one).

References: "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator" (the seed
paper), Eq. 7 and 13; model-spec sections 2, 4, 4b (pressure_friction) and 5 (the isometric test).

Example
-------
>>> from mkctl.physics.isometric import isometric_tension
>>> from mkctl.physics.params import Params
>>> round(float(isometric_tension(0.18, 300e3, +1, Params(Fc=2.0))), 6)  # model 2 minus Fc
73.248131
"""
from __future__ import annotations

import numpy as np

from . import actuator
from ..errors import DomainError
from .params import DEFAULT, Params

#: The branch codes: +1 while the pressure rises (``up``), -1 while it falls (``down``).
UP, DOWN = 1, -1


def check_branch(branch):
    """Check a pressure branch: +1 while the pressure rises (``up``), -1 while it falls (``down``).

    Parameters
    ----------
    branch : float or array_like
        The branch code(s), +1 or -1.

    Returns
    -------
    float or numpy.ndarray
        The branch as a float (for a scalar) or a float array of +1 / -1.

    Raises
    ------
    DomainError
        For any value other than +1 or -1 (NaN too).

    References
    ----------
    .. [1] model-spec section 5 (the ``branch`` column of an isometric file).
    """
    values = np.asarray(branch, dtype=float)
    bad = np.abs(values) != 1  # neither +1 nor -1 (NaN too)
    if np.any(bad):
        raise DomainError(f"branch must be +1 (up: pressure rising) or -1 "
                          f"(down: pressure falling), got {values[bad].flat[0]!r}")
    return values if values.ndim else float(values)


def hysteresis_tension(f, branch, Fc: float):
    """Coulomb friction's limit at a clamped length: ``f - branch Fc``.

    That is ``f - Fc`` on the up branch and ``f + Fc`` on the down branch: at zero motion the play
    operator leaves the tension at the edge of its band the pressure pushes it to.

    Parameters
    ----------
    f : float or array_like
        Static tension [N].
    branch : float or array_like
        +1 (up: pressure rising) or -1 (down: pressure falling).
    Fc : float
        Friction force [N], >= 0 (the play band's half-width).

    Returns
    -------
    float or array
        The measured tension [N].

    Raises
    ------
    DomainError
        For a branch other than +1 or -1.

    References
    ----------
    .. [1] model-spec sections 4 (coulomb_friction's play operator) and 5 (the isometric test).
    """
    return f - check_branch(branch) * Fc


def isometric_tension(L, P, branch=UP, params: Params = DEFAULT):
    """Tension of a muscle clamped at length L under gauge pressure P, on a pressure branch.

    ``f = slack(f_static(L, P) - branch Fc)`` with ``f_static`` the static share of
    :func:`mkctl.physics.actuator.compose_tension` (model 1, Eq. 7, or model 2, Eq. 13, as
    ``params.model`` says), Fc the half-width of the effects' play band
    (:func:`mkctl.physics.actuator.play_half_width`: the Coulomb friction ``params.Fc``, plus
    ``Fc_p P`` with pressure_friction) and the final limits (``slack(f) = max(f, 0)`` when
    ``params.slack`` is 1).

    Parameters
    ----------
    L : float or array_like
        Clamped length [m], 0 < L < b.
    P : float or array_like
        Gauge pressure in the bladder [Pa].
    branch : float or array_like
        +1 while the pressure rises (``up``), -1 while it falls (``down``).
    params : Params
        The actuator: b, L0, D0, t0 [m], n [-], C1, C2 [Pa], model, Fc [N], slack.

    Returns
    -------
    f : float or array
        The measured tension [N] (positive when it pulls); arrays broadcast.

    Raises
    ------
    DomainError
        For L outside (0, b), a pressure that is not finite, or a branch other than +1 or -1.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 7 and
    13.
    .. [2] model-spec sections 2 (its reference table), 4, 4b and 5.
    """
    f = actuator.static_tension(L, P, params)
    width = actuator.play_half_width(P, params)
    if type(width) is not float or width:
        # the play band's edge the pressure pushes the tension to
        f = f - check_branch(branch) * width
    else:
        check_branch(branch)
    return actuator.apply_limits(f, params)
