"""The knee as a nonlinear system and its operating points (python-control's ``nlsys``).

:func:`knee_nlsys` is the knee of model-spec section 3 (with the effects of section 4 and, switched
on, the air of section 4d) as a :class:`control.NonlinearIOSystem`; :func:`operating_point` finds
the rest posture of a pair of pressures (Eq. 20) as a :class:`KneeOperatingPoint`, the value every
linear analysis of :mod:`mkctl.analysis.control` starts from.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field

import control as ct
import numpy as np

from ..physics import actuator, knee, simulate
from ..errors import DomainError, MkctlError
from ..physics.params import DEFAULT, Params
from ..physics.simulate import DEFAULT_PF


#: Input names of every system built here.
INPUT_NAMES = ("pe_cmd", "pf_cmd")
#: Units in which :func:`numerical_linearization` perturbs the signals: python-control's ``linearize``
#: takes one absolute forward step (1e-6) for all of them. So X and V are perturbed by 3e-9 m, m/s (F is
#: curved in X; this step balances truncation and rounding, measured) and the pressures by 1 Pa (F is
#: affine in them; a 1e-6 Pa step would drown in rounding).
LINEARIZE_SCALE = {"X": 3e-3, "V": 3e-3, "Pe": 1e6, "Pf": 1e6, "pe_cmd": 1e6, "pf_cmd": 1e6,
                   "Te": 1e2, "Tf": 1e2}  # the air's temperatures (air_heat) [K]: 0.1 mK steps


class ControlAnalysisError(MkctlError, ValueError):
    """A control analysis that cannot be done as asked (no operating point, a2 >= 0 for a damping ratio, ...)."""


# --- The nonlinear system and its operating points -------------------------------------------------

def knee_nlsys(params: Params = DEFAULT, *, stops: bool = True, scale: dict | None = None,
               name: str = "knee") -> ct.NonlinearIOSystem:
    """Eq. 17 (:func:`mkctl.physics.knee.knee_derivatives`) as a python-control nonlinear I/O system.

    States X, V (+ Pe, Pf with a lag), inputs pe_cmd, pf_cmd, outputs the states, all SI. ``stops``: include
    the mechanical end stops (as :func:`mkctl.physics.simulate.simulate_knee` does). ``scale``: optional unit sizes
    by signal name (a signal's value in the system is its SI value divided by its scale), used to give
    python-control's fixed absolute finite-difference step a sensible size (:data:`LINEARIZE_SCALE`).
    """
    names = knee.state_names(params)
    scale = scale or {}
    sx = np.array([scale.get(s, 1.0) for s in names])
    su = np.array([scale.get(s, 1.0) for s in INPUT_NAMES])
    stop_positions = knee.stop_positions(params) if stops else None

    def update(t, x, u, _params):
        xs, us = np.asarray(x) * sx, np.asarray(u) * su
        return knee.knee_derivatives(xs, us[0], us[1], params, stop_positions) / sx

    def output(t, x, u, _params):
        return np.asarray(x, dtype=float)

    return ct.nlsys(update, output, states=list(names), inputs=list(INPUT_NAMES), outputs=list(names), name=name)


@dataclass(frozen=True)
class KneeOperatingPoint:
    """A posture held at rest: the states and inputs where Eq. 17's right-hand side vanishes."""

    params: Params
    alpha: float  #: kneecap angle [rad]
    X: float  #: hip height [m]
    Pe: float  #: extensor pressure [Pa] (the FMU's output ``Pe``; at rest also the command ``pe_cmd``)
    Pf: float  #: flexor pressure [Pa] (the FMU's output ``Pf``; at rest also the command ``pf_cmd``)
    states: np.ndarray = field(repr=False)  #: SI, in the order of :attr:`state_names`
    inputs: np.ndarray = field(repr=False)  #: (pe_cmd, pf_cmd) [Pa]

    @property
    def pe(self) -> float:
        """The former name of :attr:`Pe` (kept for old callers)."""
        return self.Pe

    @property
    def pf(self) -> float:
        """The former name of :attr:`Pf` (kept for old callers)."""
        return self.Pf

    @property
    def state_names(self) -> tuple[str, ...]:
        return knee.state_names(self.params)

    def with_params(self, **overrides) -> "KneeOperatingPoint":
        """The same posture and pressures with other parameters that do not move the equilibrium.

        Damping, friction, a lag and a dead time act only when something moves or changes, so the rest
        state is unchanged (:func:`mkctl.physics.simulate.rest_independent` reads which parameters those are
        from the effects' definitions).
        """
        bad = set(overrides) - set(simulate.rest_independent())
        if bad:
            raise ControlAnalysisError(f"{sorted(bad)[0]} moves the equilibrium: find a new operating point")
        params = self.params.replace(**overrides)
        states = knee.rest_state(self.X, self.Pe, self.Pf, params)
        return KneeOperatingPoint(params, self.alpha, self.X, self.Pe, self.Pf, states, self.inputs.copy())


def _posture(alpha, X, params) -> tuple[float, float]:
    """(alpha [rad], X [m]) from exactly one of them (:func:`mkctl.physics.knee.posture`); between the end stops."""
    alpha, X = knee.posture(alpha, X, params)
    low, high = knee.ALPHA_STOP_LOW, knee.ALPHA_STOP_HIGH
    if not low < alpha < high:
        raise DomainError(f"posture alpha = {math.degrees(alpha):.4g} deg is outside the end stops "
                          f"({math.degrees(low):g}, {math.degrees(high):g}) deg: it cannot be held at rest")
    return alpha, X


def operating_point(alpha: float | None = None, *, X: float | None = None, Pf: float = DEFAULT_PF,
                    params: Params = DEFAULT, pf: float | None = None) -> KneeOperatingPoint:
    """The rest state of Eq. 17 (V = 0, F = m g) at a posture, found by python-control.

    python-control's ``find_operating_point`` on :func:`knee_nlsys` (X and pf_cmd fixed, pe_cmd and the other
    states free), in the units of :data:`LINEARIZE_SCALE`; a test checks it against the closed form
    :func:`mkctl.physics.stability.equilibrium_pressure`.

    Parameters
    ----------
    alpha : float, optional
        Kneecap angle [rad], strictly between the end stops; or give ``X``, the hip height [m].
    Pf : float
        Flexor gauge pressure (and command) [Pa], >= 0 (``pf``: its former name, still accepted).
    params : Params
        The model.

    Returns
    -------
    KneeOperatingPoint
        alpha [rad], X [m], Pe and Pf [Pa] (pressures equal the commands at rest), the states and inputs.

    Raises
    ------
    DomainError, ControlAnalysisError
        For a posture outside the stops, a bad pf, no solution, or one that needs pe < 0.
    """
    if actuator.air_is_on(params):
        return _air_operating_point(alpha, X, Pf if pf is None else pf, params)
    alpha, X = _posture(alpha, X, params)
    pf = Pf if pf is None else pf
    if not math.isfinite(pf):
        raise DomainError(f"flexor pressure pf = {pf!r} Pa is not a finite number")
    if pf < 0:
        raise DomainError(f"flexor pressure pf = {pf / 1e3:g} kPa is below 0: pressures are gauge pressures, and "
                          "a McKibben muscle below atmospheric pressure does not pull (the model has no vacuum)")
    names = knee.state_names(params)
    sys = knee_nlsys(params, stops=False, scale=LINEARIZE_SCALE)
    sx = np.array([LINEARIZE_SCALE[s] for s in names])
    su = np.array([LINEARIZE_SCALE[s] for s in INPUT_NAMES])
    pe_guess = 1.0e6  # a neutral first guess; the solver finds the pressure
    x_guess = np.array([X, 0.0, pe_guess, pf][: len(names)]) / sx
    u_guess = np.array([pe_guess, pf]) / su
    try:
        found = ct.find_operating_point(sys, x_guess, u_guess, y0=x_guess, iy=[0], iu=[1],
                                        return_result=True)
    except MkctlError as error:
        raise ControlAnalysisError(f"no operating point at alpha = {math.degrees(alpha):.4g} deg, "
                                   f"pf = {pf / 1e3:g} kPa: {error}") from error
    residual = np.abs(sys.dynamics(0.0, found.states, found.inputs)).max() if found.states is not None else np.inf
    if found.result.success and 1e-9 < residual < 1e-6:  # converged but loosely (a stiff friction term): polish
        try:
            found = ct.find_operating_point(sys, found.states, found.inputs, y0=x_guess, iy=[0], iu=[1],
                                            return_result=True)
        except MkctlError as error:
            raise ControlAnalysisError(f"no operating point at alpha = {math.degrees(alpha):.4g} deg, "
                                       f"pf = {pf / 1e3:g} kPa: {error}") from error
        residual = np.abs(sys.dynamics(0.0, found.states, found.inputs)).max()
    if not found.result.success or residual > 1e-9:
        raise ControlAnalysisError(f"no operating point at alpha = {math.degrees(alpha):.4g} deg, pf = {pf / 1e3:g} kPa "
                                   f"({found.result.message.strip()})")
    states, inputs = np.asarray(found.states) * sx, np.asarray(found.inputs) * su
    states[0] = X  # exact, as asked (the solver held it fixed)
    if inputs[0] < 0:
        raise ControlAnalysisError(f"holding alpha = {math.degrees(alpha):.4g} deg with pf = {pf / 1e3:g} kPa needs "
                                   f"an extensor pressure pe = {inputs[0] / 1e3:.4g} kPa below 0 (gauge): "
                                   "a muscle cannot push; raise pf or choose another posture")
    return KneeOperatingPoint(params, alpha, X, float(inputs[0]), float(inputs[1]), states, inputs)


def _air_operating_point(alpha, X, pf, params: Params) -> KneeOperatingPoint:
    """The rest state with the air on (model-spec 4d): the regulators hold their set-points at rest
    (u = 0, P = P_cmd), so it is the rest with the pressures held, found with the air off (the
    regulator's clipped opening has no slope outside its band: python-control's solver stalls there
    from a far guess); with a leak the regulator holds a small error that feeds it, polished from
    there by ``find_operating_point``."""
    air_off = {e.switch_parameter.name: e.switch_parameter.off
               for e in actuator.active_effects(params) if e.moves_air}
    held = operating_point(alpha, X=None if alpha is not None else X, Pf=pf,
                           params=params.replace(**air_off))
    op = KneeOperatingPoint(params, held.alpha, held.X, held.Pe, held.Pf,
                            knee.rest_state(held.X, held.Pe, held.Pf, params), held.inputs.copy())
    rates = knee.knee_derivatives(op.states, *op.inputs, params)
    if np.all(np.abs(rates[2:]) <= 1e-9 * np.maximum(np.abs(op.states[2:]), 1.0)):
        return op
    sys = knee_nlsys(params, stops=False, scale=LINEARIZE_SCALE)
    sx = np.array([LINEARIZE_SCALE[s] for s in knee.state_names(params)])
    su = np.array([LINEARIZE_SCALE[s] for s in INPUT_NAMES])
    found = ct.find_operating_point(sys, op.states / sx, op.inputs / su, y0=op.states / sx, iy=[0],
                                    iu=[1], return_result=True)
    residual = (np.abs(sys.dynamics(0.0, found.states, found.inputs)).max()
                if found.states is not None else np.inf)
    if not found.result.success or residual > 1e-9:
        raise ControlAnalysisError(f"no operating point with the air at alpha = "
                                   f"{math.degrees(held.alpha):.4g} deg, pf = {pf / 1e3:g} kPa "
                                   f"({found.result.message.strip()})")
    states, inputs = np.asarray(found.states) * sx, np.asarray(found.inputs) * su
    states[0] = held.X
    return KneeOperatingPoint(params, held.alpha, held.X, float(states[2]), float(states[3]),
                              states, inputs)
