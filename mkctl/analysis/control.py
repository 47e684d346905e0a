"""The linear view of the knee, with python-control: operating points, linearization, damping, lag, loci, steps.

The knee of Eq. 17 as a python-control :class:`control.NonlinearIOSystem` with named signals:

- states ``X`` [m], ``V`` [m/s], and with the pressure lag (tau > 0) ``Pe``, ``Pf`` [Pa];
- inputs ``pe_cmd``, ``pf_cmd`` [Pa] (the commanded gauge pressures); outputs: the states.

Linearized at a posture held at rest (an operating point), with ``G = dF/d(.)`` from
:func:`mkctl.physics.knee.knee_force_partials`::

    A = [[0,        1,        0,          0         ],     B = [[0,     0    ],
         [dF_dX/m,  dF_dV/m,  dF_dPe/m,   dF_dPf/m  ],          [0,     0    ],
         [0,        0,        -1/tau,     0         ],          [1/tau, 0    ],
         [0,        0,        0,          -1/tau    ]]          [0,     1/tau]]

and without the lag ``A = [[0, 1], [a2, a1]]`` (Eq. 18), ``B = [[0, 0], [dF_dPe/m, dF_dPf/m]]``. The lag
block is triangular: in open loop the lag adds the poles -1/tau and leaves the mechanical poles alone; it
costs in closed loop (see :func:`critical_gain`).

The velocity condition (Eq. 19): model 2 alone has a1 = 0, so the poles ``+-j sqrt(-a2)`` sit on the
imaginary axis. Viscous damping gives ``a1 = -c (G_e^2 + G_f^2) / m``, and where a2 < 0 the damping ratio
``zeta = -a1 / (2 sqrt(-a2))``: the damping for a chosen ratio is
``c = 2 zeta m sqrt(-a2) / (G_e^2 + G_f^2)`` (:func:`damping_for_zeta`). That is also an exact root locus:
damping is the velocity feedback ``u = -k V`` on the undamped plant, with loop gain ``k = c (G_e^2+G_f^2)/m``
(:func:`damping_loop`).

Example
-------
>>> import numpy as np
>>> from mkctl.analysis import control as mc
>>> op = mc.operating_point(np.radians(60), Pf=100e3)
>>> sys = mc.analytic_linearization(op)
>>> sys.state_labels, sys.input_labels
(['X', 'V'], ['pe_cmd', 'pf_cmd'])
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, fields
from pathlib import Path

import control as ct
import numpy as np

from . import fmu_probe as probe
from ..physics import actuator, effects, knee, simulate, stability
from ..errors import DomainError, MkctlError, check_memory
from .fmu_probe import FMUAnalysisError, fmu_step_response
from ..physics.params import DEFAULT, Params
from ..results import Result
from .control_defaults import DEFAULT_TAU, DEFAULT_ZETA, STEP_TIME
from ..physics.simulate import DEFAULT_PF, knee_states

__all__ = [
    "ControlAnalysisError", "FMUAnalysisError", "KneeOperatingPoint", "INPUT_NAMES", "knee_nlsys",
    "operating_point", "analytic_linearization", "numerical_linearization", "fmu_linearization",
    "damping_ratio", "natural_frequency", "damping_for_zeta", "damping_loop", "damping_root_locus",
    "height_plant", "height_loop", "closed_loop_poles", "critical_gain", "height_root_locus", "lag_sweep",
    "step_responses", "StepResponses", "velocity_gain", "plot_poles", "plot_damping_locus", "plot_lag_sweep", "plot_gain_locus",
    "plot_step", "DEFAULT_ZETA", "DEFAULT_TAU", "LINEARIZE_SCALE", "AIR_SWEEPS", "AirPoleSweep",
    "with_air", "air_switched_on", "air_pole_sweep", "plot_air_poles",
]

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


# --- Linearizations ------------------------------------------------------------------------------

def _named_ss(A, B, params: Params, name: str) -> ct.StateSpace:
    names = list(knee.linearization_state_names(params))[:A.shape[0]]  # a dead time's Pade states, if any
    n = len(names)
    return ct.ss(A, B, np.eye(n), np.zeros((n, 2)), states=names, inputs=list(INPUT_NAMES), outputs=names,
                 name=name)


def analytic_linearization(op: KneeOperatingPoint, name: str = "knee_linear") -> ct.StateSpace:
    """The linearization at op from the exact partials of :func:`mkctl.physics.knee.linearization`.

    Without a lag ``A = [[0, 1], [a2, a1]]`` (Eq. 18; a2 = dF/dX / m [1/s^2], a1 = dF/dV / m [1/s]) and
    ``B = [[0, 0], [dF/dPe / m, dF/dPf / m]]`` [m/(s^2 Pa)]; with a lag tau [s] the states Pe, Pf follow
    ``tau dP/dt = P_cmd - P`` (model-spec section 4) and the pressure columns move into A (module docstring).

    Parameters: op, the operating point; name of the system. Returns a ``control.StateSpace`` with named
    states (X [m], V [m/s], Pe, Pf [Pa]), inputs (pe_cmd, pf_cmd [Pa]) and outputs (the states).
    References: seed paper Eq. 17-20.
    """
    p = op.params
    # every entry an exact derivative: sympy.diff of the traced effect terms (the lag block included)
    A, B = knee.linearization(op.X, op.Pe, op.Pf, *op.inputs, p)
    return _named_ss(A, B, p, name)


def numerical_linearization(op: KneeOperatingPoint, scale: dict | None = None, eps: float = 1e-6,
                            name: str = "knee_numerical") -> ct.StateSpace:
    """python-control's ``linearize`` of :func:`knee_nlsys` at op, returned in SI units.

    The system is linearized in the units of ``scale`` (default :data:`LINEARIZE_SCALE`) and transformed
    back: ``A = S A_s S^-1``, ``B = S B_s T^-1`` with S, T the diagonal state and input scales.
    """
    scale = LINEARIZE_SCALE if scale is None else scale
    names = op.state_names
    sx = np.array([scale.get(s, 1.0) for s in names])
    su = np.array([scale.get(s, 1.0) for s in INPUT_NAMES])
    sys = knee_nlsys(op.params, stops=False, scale=scale)
    lin = ct.linearize(sys, op.states / sx, op.inputs / su, eps=eps)
    A = lin.A * sx[:, None] / sx[None, :]
    B = lin.B * sx[:, None] / su[None, :]
    return _named_ss(A, B, op.params, name)


def fmu_linearization(op: KneeOperatingPoint, fmu, dt: float = probe.DT,
                      hX: float = probe.HX, hP: float = probe.HP, name: str = "knee_fmu") -> ct.StateSpace:
    """The linearization of the knee FMU itself at op, from its interface only (see :mod:`mkctl.analysis.fmu_probe`).

    A one-step Jacobian of the FMU's flow map (perturbed X0 and inputs, velocity states prepared and
    restored with fmi2Get/SetFMUstate) turned into A, B by a matrix logarithm, dt halved until it is short
    enough for the knee's fastest mode. Runs the FMU in this process. Returns a named ``control.ss`` like
    :func:`analytic_linearization`.
    """
    p = op.params
    A, B, _ = probe.linearize_fmu(fmu, p.as_dict(), op.X, op.inputs, p.tau > 0, dt=dt, hX=hX, hP=hP)
    return _named_ss(A, B, p, name)


# --- Damping: the velocity condition (Eq. 19) --------------------------------------------------------

def natural_frequency(a2) -> np.ndarray:
    """Undamped natural frequency ``w_n = sqrt(-a2)`` [rad/s]; NaN where a2 >= 0 (no oscillation)."""
    a2 = np.asarray(a2, dtype=float)
    return np.sqrt(np.where(a2 < 0, -a2, np.nan))


def damping_ratio(a1, a2) -> np.ndarray:
    """Damping ratio ``zeta = -a1 / (2 sqrt(-a2))`` of ``s^2 - a1 s - a2`` [-]; NaN where a2 >= 0."""
    return -np.asarray(a1, dtype=float) / (2 * natural_frequency(a2))


def velocity_gain(op: KneeOperatingPoint) -> float:
    """``(G_e^2 + G_f^2) / m`` [1/kg]: a1 = -c times this, at the posture of op (from the library's dF/dV)."""
    unit_damping = op.params.replace(c=1.0, Fc=0.0)
    partials = knee.knee_force_partials(knee.geometry_at_X(op.X, unit_damping), 0.0, op.Pe, op.Pf, unit_damping)
    return float(-partials.dF_dV) / op.params.m


def damping_for_zeta(zeta: float, op: KneeOperatingPoint) -> float:
    """The viscous damping c that gives damping ratio zeta at op.

    With ``a1 = -c (G_e^2 + G_f^2) / m`` (model-spec section 4) and ``zeta = -a1 / (2 sqrt(-a2))``:

    .. math:: c = \\frac{2 \\zeta m \\sqrt{-a_2}}{G_e^2 + G_f^2}

    a2 does not depend on c at rest, so this is exact. Parameters: zeta [-], >= 0; op. Returns c [N s/m].
    Raises :class:`ControlAnalysisError` where a2 >= 0 (the posture is not held by a restoring force: no
    damping ratio exists) or zeta < 0. References: seed paper Eq. 18-19.
    """
    if not (math.isfinite(zeta) and zeta >= 0):
        raise ControlAnalysisError(f"damping ratio zeta = {zeta!r} must be a number >= 0")
    _, a2 = stability.routh_hurwitz_coefficients(op.X, op.Pe, op.Pf, 0.0, op.params)
    if not a2 < 0:
        raise ControlAnalysisError(f"a2 = {float(a2):.4g} 1/s^2 >= 0 at alpha = {math.degrees(op.alpha):.4g} deg, "
                                   f"pf = {op.Pf / 1e3:g} kPa: the posture is unstable (Eq. 20 fails) and no damping gives "
                                   "it a damping ratio")
    return 2 * zeta * math.sqrt(-float(a2)) / velocity_gain(op)


def damping_loop(op: KneeOperatingPoint) -> tuple[ct.StateSpace, float]:
    """The damping as an exact velocity-feedback loop: (plant, k per unit c).

    The plant is the undamped mechanical part of the linearization (states X, V; c = 0) with one input
    ``u`` added to dV/dt and output V; closing ``u = -k V`` gives the damped A exactly, with
    ``k = c (G_e^2 + G_f^2) / m``. The lag states are left out: u does not reach them (A is block
    triangular) and their poles stay at -1/tau whatever c is. Returns the SISO plant and ``k / c`` [1/kg].
    """
    undamped = analytic_linearization(op.with_params(c=0.0))
    plant = ct.ss(undamped.A[:2, :2], [[0.0], [1.0]], [[0.0, 1.0]], 0, states=["X", "V"], inputs=["u"],
                  outputs=["V"], name="velocity_loop")
    return plant, velocity_gain(op)


def damping_root_locus(op: KneeOperatingPoint, c_values) -> tuple[np.ndarray, np.ndarray]:
    """python-control's ``root_locus_map`` of :func:`damping_loop` over c [N s/m]: (c_values, loci [1/s]).

    loci[i] are the two mechanical poles at c_values[i] (the lag poles, if any, stay at -1/tau).
    """
    plant, per_c = damping_loop(op)
    c_values = np.asarray(c_values, dtype=float)
    data = ct.root_locus_map(plant, c_values * per_c)
    return c_values, np.asarray(data.loci)


# --- Height control through the extensor pressure --------------------------------------------------

def height_plant(op: KneeOperatingPoint) -> ct.StateSpace:
    """The SISO linear plant from pe_cmd [Pa] to the hip height X [m] at op.

    States X, V and, with the lag, Pe. The flexor lag state Pf is left out: pe_cmd does not reach it,
    so its pole stays at -1/tau in closed loop too (and a transfer function would carry it as a
    cancelling pole-zero pair).
    """
    lin = analytic_linearization(op)
    keep = [0, 1, 2] if op.params.tau > 0 else [0, 1]
    return ct.ss(lin.A[np.ix_(keep, keep)], lin.B[keep, :1], lin.C[:1, keep], 0,
                 states=[lin.state_labels[i] for i in keep], inputs=["pe_cmd"], outputs=["X"], name="height_plant")


def height_loop(op: KneeOperatingPoint, ti: float | None = None) -> ct.StateSpace:
    """Loop transfer of the height controller without its gain: ``L = C(s) G(s)``, SISO, state space.

    The controller is ``pe_cmd = pe0 + K (e + (1/ti) int e dt)``, e = X_ref - X: proportional
    (ti = None) or PI. The closed-loop poles for gain K [Pa/m] are the roots of 1 + K L(s).
    """
    plant = height_plant(op)
    if ti is None:
        return plant
    if not ti > 0:
        raise ControlAnalysisError(f"integral time ti = {ti!r} s must be positive")
    pi = ct.ss([[0.0]], [[1.0]], [[1.0 / ti]], [[1.0]], inputs=["e"], outputs=["pe_cmd"], states=["int_e"],
               name="pi")
    return ct.series(pi, plant)


def closed_loop_poles(loop: ct.StateSpace, gain) -> np.ndarray:
    """Eigenvalues [1/s] of the loop closed by ``u = -K y``: one gain K, or an array of gains (one row each).

    For a strictly proper loop (D = 0, as every loop here) that is ``eig(A - K B C)``; otherwise
    python-control's ``feedback(K L, 1)``.
    """
    gains = np.atleast_1d(np.asarray(gain, dtype=float))
    if np.any(loop.D):
        rows = [ct.feedback(k * loop, 1).poles() for k in gains]
    else:
        BC = loop.B @ loop.C
        rows = [np.linalg.eigvals(loop.A - k * BC) for k in gains]
    rows = [np.sort_complex(r) for r in rows]
    return np.array(rows) if np.ndim(gain) else rows[0]


def critical_gain(loop: ct.StateSpace, k_max: float = 1e12, rtol: float = 1e-9) -> float:
    """The smallest gain K > 0 at which a closed-loop pole of ``1 + K L`` reaches the right half plane.

    Scans a log grid (8 points per decade) for the first unstable gain and refines by bisection on the
    largest real part of the eigenvalues. Returns ``inf`` if the loop stays stable up to k_max, and 0 if
    it is unstable already for vanishing gain.
    """
    def margin(k):
        return float(np.max(closed_loop_poles(loop, k).real))

    k_min = k_max * 1e-18
    if margin(k_min) > 0:
        return 0.0
    grid = np.geomspace(k_min, k_max, 18 * 8 + 1)
    prev = grid[0]
    for k in grid[1:]:
        if margin(k) > 0:
            lo, hi = prev, k
            while hi - lo > rtol * hi:
                mid = 0.5 * (lo + hi)
                lo, hi = (mid, hi) if margin(mid) <= 0 else (lo, mid)
            return 0.5 * (lo + hi)
        prev = k
    return math.inf


def height_root_locus(op: KneeOperatingPoint, gains, ti: float | None = None) -> tuple[np.ndarray, np.ndarray]:
    """python-control's ``root_locus_map`` of :func:`height_loop` over K [Pa/m]: (gains, loci [1/s])."""
    gains = np.asarray(gains, dtype=float)
    data = ct.root_locus_map(height_loop(op, ti), gains)
    return gains, np.asarray(data.loci)


# --- The pressure lag ---------------------------------------------------------------------------

def lag_sweep(op: KneeOperatingPoint, taus, gain: float | None = None, ti: float | None = None):
    """Eigenvalues [1/s] as the lag tau [s] grows: open loop and, with a height gain K [Pa/m], closed loop.

    Returns (taus, open_loop, closed_loop) with one row of eigenvalues per tau (closed_loop None without a
    gain). In open loop the mechanical poles stay put and the lag poles -1/tau approach the origin; in
    closed loop the lag pole and the mechanical pair interact and move right as tau grows.
    """
    taus = np.asarray(taus, dtype=float)
    if np.any(taus <= 0):
        raise ControlAnalysisError("every lag tau of a sweep must be > 0 s")
    open_rows, closed_rows = [], []
    for tau in taus:
        case = op.with_params(tau=float(tau))
        open_rows.append(np.sort_complex(np.linalg.eigvals(analytic_linearization(case).A)))
        if gain is not None:
            closed_rows.append(closed_loop_poles(height_loop(case, ti), gain))
    return taus, np.array(open_rows), (np.array(closed_rows) if gain is not None else None)


# --- Step responses: linear, nonlinear, FMU ------------------------------------------------------

def _response_info(time, y, final=None):
    """python-control's ``step_info`` (2 % settling, 10-90 % rise) of one response, or NaNs if it is flat.

    ``final``: the known final value (else the last sample is taken as final).
    """
    flat = {"RiseTime": math.nan, "Overshoot": math.nan, "SettlingTime": math.nan}
    if not np.any(y):
        return flat
    try:
        info = ct.step_info(y, time, final_output=final)
    except (IndexError, ValueError):  # python-control 0.10: a response that never rises to 10 % of its final value
        return flat
    return {k: float(info[k]) for k in ("RiseTime", "Overshoot", "SettlingTime", "Peak", "SteadyStateValue")}


def describe_response(info: dict) -> str:
    """Rise time, overshoot and settling time of one step response (:func:`_response_info`) in words: a value
    that does not exist is said so ("no settling time: it does not settle within the run"), never printed as nan."""
    rise, overshoot, settling = (info.get(k, math.nan) for k in ("RiseTime", "Overshoot", "SettlingTime"))
    parts = [f"rise {rise:.4g} s" if math.isfinite(rise) else "no rise time (it does not rise to 90 % within the run)",
             f"overshoot {overshoot:.4g} %" if math.isfinite(overshoot) else "no overshoot figure",
             f"settling {settling:.4g} s" if math.isfinite(settling) else
             "no settling time (it does not settle within 2 % in the run: unstable, undamped or too slow)"]
    return ", ".join(parts)


@dataclass(repr=False, eq=False)
class StepResponses(Result):
    """Hip-height responses to one step of pe_cmd, from three models on one time grid (:func:`step_responses`).

    Arrays are X - X_op [m] on ``time`` [s]; ``fmu`` is None when the FMU was not run (``fmu_note`` says why).
    ``info`` holds python-control's ``step_info`` per model present ("RiseTime" [s], "Overshoot" [%],
    "SettlingTime" [s], "Peak" [m], "SteadyStateValue" [m]), measured from the step. ``end_stop`` names the end
    stop the nonlinear model ran onto, and when (None if it stayed between them). ``result[name]`` reads a
    field as the former dict did.
    """

    time: np.ndarray  #: sample times [s]
    linear: np.ndarray  #: the linearization's response X - X_op [m]
    nonlinear: np.ndarray  #: the nonlinear model's response X - X_op [m] (end stops included)
    fmu: np.ndarray | None  #: the knee FMU's response X - X_op [m], or None
    dpe: float  #: the step of pe_cmd [Pa]
    t_step: float  #: when the step comes [s]
    info: dict = field(default_factory=dict)  #: {model: step_info dict}
    end_stop: str | None = None  #: which end stop the nonlinear model reached, and when
    fmu_note: str | None = None  #: why there is no FMU response

    MODELS = ("linear", "nonlinear", "fmu")

    def __getitem__(self, name: str):
        if name not in {f.name for f in fields(self)}:
            raise KeyError(name)
        return getattr(self, name)

    def summary_lines(self) -> list[str]:
        lines = [f"step of pe_cmd by {self.dpe / 1e3:+g} kPa at t = {self.t_step:g} s, {self.time.size} samples "
                 f"to t = {self.time[-1]:g} s"]
        for name in self.MODELS:
            if name in self.info:
                i = self.info[name]
                lines.append(f"{name}: {describe_response(i)}, final X - X_op = {1e3 * self[name][-1]:+.4g} mm")
        lines += [note for note in (self.end_stop and f"note: hit the {self.end_stop}", self.fmu_note) if note]
        return lines

    def table(self) -> dict[str, np.ndarray]:
        """Columns ``time`` [s] and one X - X_op [m] per model present."""
        return {"time": self.time, **{name: self[name] for name in self.MODELS if self[name] is not None}}


#: Most samples of one step response (a million: 1000 s at 1 ms), and about what each takes in memory [bytes]
#: (time, three responses, the nonlinear states and outputs, the plot).
MAX_RESPONSE_SAMPLES = 1e6
RESPONSE_BYTES_PER_SAMPLE = 30 * 8


def step_responses(op: KneeOperatingPoint, dpe: float, duration: float = 2.0, t_step: float = STEP_TIME,
                   dt: float = 1e-3, fmu=None):
    """Hip height response to a step of the extensor command pe_cmd by dpe [Pa] at t_step [s], from rest at op.

    Three models on one time grid: the linearization (:func:`analytic_linearization`, python-control
    ``step_response`` of ``X/pe_cmd``, Eq. 18 with the input column ``dF/dPe / m``), the nonlinear model (Eq. 17,
    :func:`mkctl.physics.simulate.knee_states`, end stops included) and, if ``fmu`` is a path to an existing
    file, the knee FMU through fmpy's ``simulate_fmu`` (model-spec section 7).

    Parameters
    ----------
    op : KneeOperatingPoint
        The rest state the step starts from.
    dpe : float
        Step of pe_cmd [Pa], non-zero; pe + dpe must stay >= 0 (gauge pressure).
    duration : float
        Length of the response [s], > t_step.
    t_step : float
        Time of the step [s] (default :data:`~mkctl.analysis.control_defaults.STEP_TIME`).
    dt : float
        Sampling interval [s].
    fmu : path or None
        The knee FMU, or None to leave it out (a path to a missing file: left out, with a note).

    Returns
    -------
    StepResponses
        ``time`` [s]; ``linear``, ``nonlinear``, ``fmu`` (None without FMU): X - X_op [m]; ``info``: step_info
        of each, measured from t_step, with the known final values (the linear model's DC gain
        ``dpe (dF/dPe) / (-dF/dX)``; the library's stable equilibrium at the new pressure); ``fmu_note``; and
        ``end_stop``. Reads like the former dict: ``result["info"]``.

    Raises
    ------
    ControlAnalysisError
        For a step, duration or dt that cannot be simulated, or when the nonlinear model fails.
    """
    _check_step(op, dpe, duration, t_step, dt)
    p = op.params
    steps = int(round(duration / dt))
    time = np.arange(steps + 1) * dt
    after = time >= t_step - 1e-12
    lin = analytic_linearization(op)
    lin_out = np.zeros_like(time)
    resp = ct.step_response(lin[0, 0], time[after] - time[after][0])  # X per unit pe_cmd
    lin_out[after] = dpe * np.asarray(resp.outputs).ravel()
    try:
        nonlin, _ = knee_states(time, np.where(after, op.Pe + dpe, op.Pe), op.Pf, p, X0=op.X)
    except MkctlError as error:
        raise ControlAnalysisError(f"the nonlinear model failed: {error}") from error
    nonlin = nonlin - op.X
    fmu_out, fmu_note = _fmu_step(op, dpe, fmu, time, t_step, duration, dt)
    result = StepResponses(time, lin_out, nonlin, fmu_out, dpe, t_step, end_stop=_end_stop(time, nonlin + op.X, p),
                           fmu_note=fmu_note)
    # final values: the linear model's DC gain; for the nonlinear model and the FMU the library's stable
    # equilibrium at the new pressure, if the run went there (a leg that falls to a stop ends where it ends)
    settled = _settled_offset(op, dpe, nonlin)
    finals = {"linear": dpe * float(ct.dcgain(lin[0, 0])), "nonlinear": settled, "fmu": settled}
    result.info = {
        name: _response_info(time[after] - t_step, result[name][after], finals[name])
        for name in StepResponses.MODELS if result[name] is not None
    }
    return result


def _check_step(op: KneeOperatingPoint, dpe: float, duration: float, t_step: float, dt: float) -> None:
    """One-line errors for a step, duration or sampling that cannot be simulated (:func:`step_responses`)."""
    if not (math.isfinite(dpe) and dpe != 0):
        raise ControlAnalysisError(f"pressure step dpe = {dpe!r} Pa must be a non-zero number")
    if op.Pe + dpe < 0:
        raise ControlAnalysisError(f"a step by {dpe / 1e3:+g} kPa takes the extensor pressure from {op.Pe / 1e3:.4g} "
                                   f"to {(op.Pe + dpe) / 1e3:.4g} kPa, below 0 (gauge): a muscle cannot push")
    if not (math.isfinite(duration) and duration > 0):
        raise ControlAnalysisError(f"duration {duration!r} s must be a positive number")
    if not (math.isfinite(t_step) and 0 <= t_step < duration):
        raise ControlAnalysisError(f"the step at t_step = {t_step:g} s must come before the end (duration "
                                   f"{duration:g} s)")
    if not (math.isfinite(dt) and 0 < dt < duration):
        raise ControlAnalysisError(f"sampling dt = {dt!r} s must be positive and shorter than the duration "
                                   f"{duration:g} s")
    check_memory(f"a step response of {duration:g} s sampled every {dt:g} s ({duration / dt:.3g} samples)",
                 duration / dt, RESPONSE_BYTES_PER_SAMPLE)
    if not duration / dt <= MAX_RESPONSE_SAMPLES:
        raise ControlAnalysisError(f"a response of {duration:g} s sampled every {dt:g} s has {duration / dt:.3g} "
                                   f"samples, more than {MAX_RESPONSE_SAMPLES:g}: choose a longer interval or a "
                                   "shorter response")


def _fmu_step(op: KneeOperatingPoint, dpe: float, fmu, time, t_step: float, duration: float, dt: float):
    """The knee FMU's response X - X_op [m] on ``time`` (None without an FMU) and the note saying why not."""
    if fmu is None:
        return None, "FMU response not asked for"
    if not Path(fmu).is_file():
        return None, f"FMU {fmu} not found (build it with: python build_fmu.py); FMU response skipped"
    run = fmu_step_response(fmu, {**op.params.as_dict(), "X0": op.X}, op.inputs, (op.Pe + dpe, op.Pf), t_step,
                            duration, dt)
    return np.interp(time, run["time"], run["X"]) - op.X, None


def _settled_offset(op: KneeOperatingPoint, dpe: float, nonlin) -> float | None:
    """X_eq - X_op [m] of the library's stable equilibrium at the new pressure, if the nonlinear run (X - X_op)
    ends near it (within half its travel); None when there is none or the leg went elsewhere (a stop)."""
    try:
        final = stability.equilibrium_hip_height(op.Pe + dpe, op.Pf, op.params) - op.X
    except DomainError:
        return None
    return final if abs(final - nonlin[-1]) <= 0.5 * abs(nonlin[-1] - nonlin[0]) else None


def _end_stop(time, X, params: Params):
    """Which end stop the hip height X [m] reached, and when: "bent stop (alpha = 5 deg) at t = 0.2 s", or None."""
    low, high = knee.stop_positions(params)
    for hit, label, angle in ((X < low, "bent", knee.ALPHA_STOP_LOW), (X > high, "straight", knee.ALPHA_STOP_HIGH)):
        if np.any(hit):
            return f"{label} end stop (alpha = {math.degrees(angle):g} deg) at t = {time[np.argmax(hit)]:.3g} s"
    return None


# --- Plots --------------------------------------------------------------------------------------

def _pole_axes(ax, title):
    ax.axvline(0.0, color="0.5", lw=0.8)
    ax.axhline(0.0, color="0.5", lw=0.8)
    ax.set_xlabel("real part [1/s]")
    ax.set_ylabel("imaginary part [1/s]")
    ax.set_title(title, fontsize=10)
    ax.grid(alpha=0.3)


def plot_damping_locus(op: KneeOperatingPoint, c_values, c_marked: float | None = None, path=None):
    """Root locus of the mechanical poles against c (:func:`damping_root_locus`), c = 0 and c_marked marked."""
    from ..io.plotting import new_figure, save_png

    c_values, loci = damping_root_locus(op, c_values)
    mech = np.isfinite(loci)
    fig, ax = new_figure(figsize=(6.4, 5.2))
    flat_c = np.repeat(c_values[:, None], loci.shape[1], axis=1)[mech]
    sc = ax.scatter(loci[mech].real, loci[mech].imag, c=flat_c, s=6, cmap="viridis")
    fig.colorbar(sc, ax=ax, label="viscous damping c [N s/m]")
    undamped = np.linalg.eigvals(analytic_linearization(op.with_params(c=0.0)).A[:2, :2])
    ax.plot(undamped.real, undamped.imag, "rx", ms=9, label="c = 0: model 2 alone (a1 = 0, Eq. 19 fails)")
    if c_marked is not None:
        marked = np.linalg.eigvals(analytic_linearization(op.with_params(c=c_marked)).A[:2, :2])
        zeta = damping_ratio(-c_marked * velocity_gain(op), analytic_linearization(op).A[1, 0])
        ax.plot(marked.real, marked.imag, "ko", mfc="none", ms=9, label=f"c = {c_marked:.4g} N s/m (zeta = {zeta:.3g})")
    ax.legend(fontsize=8, loc="best")
    _pole_axes(ax, f"Root locus against damping c (velocity feedback), alpha = {math.degrees(op.alpha):.4g} deg, "
                   f"pf = {op.Pf / 1e3:g} kPa")
    return save_png(fig, path) if path else fig


def plot_lag_sweep(op: KneeOperatingPoint, taus, gain: float, ti: float | None = None, path=None):
    """Eigenvalues against tau, open loop (only the lag poles move) and closed loop with height gain K,
    and the critical height gain against tau."""
    from ..io.plotting import new_figure, save_png

    taus, open_loop, closed = lag_sweep(op, taus, gain, ti)
    fig, axes = new_figure(1, 3, figsize=(15, 4.8))
    colour = np.log10(np.repeat(taus[:, None], open_loop.shape[1], axis=1))
    # every pole of the range on the plot: the lag pole -1/tau reaches -1000 1/s at tau = 1 ms, the mechanical
    # poles sit within tens of 1/s of the origin, so the real axis is linear near 0 and logarithmic beyond
    mechanical = float(np.abs(analytic_linearization(op.with_params(tau=0.0)).poles()).max())
    every = np.concatenate([open_loop[np.isfinite(open_loop)], closed[np.isfinite(closed)]])
    left = 1.3 * max(float(-every.real.min()), mechanical)
    right = max(0.3 * mechanical, 1.3 * float(every.real.max()), 1.0)
    top = 1.2 * max(float(np.abs(every.imag).max()), mechanical)
    for ax, rows, title in ((axes[0], open_loop, "open loop: lag poles -1/tau move, mechanical poles stay"),
                            (axes[1], closed, f"closed loop, height P{'I' if ti else ''} gain K = {gain:.3g} Pa/m")):
        cols = colour if rows.shape == colour.shape else np.log10(np.repeat(taus[:, None], rows.shape[1], axis=1))
        sc = ax.scatter(rows.real, rows.imag, c=cols, s=6, cmap="plasma", vmin=colour.min(), vmax=colour.max())
        no_lag = op.with_params(tau=0.0)
        if rows is open_loop:
            mech, label = analytic_linearization(no_lag).poles(), "mechanical poles (any tau)"
        else:
            mech, label = closed_loop_poles(height_loop(no_lag, ti), gain), "same K without lag"
        ax.plot(mech.real, mech.imag, "kx", ms=8, label=label)
        ax.legend(fontsize=8, loc="lower left")
        _pole_axes(ax, title)
        ax.set_xscale("symlog", linthresh=2 * mechanical, linscale=1.5)
        ax.set_xlim(-left, right)
        ax.set_ylim(-top, top)
        ax.set_xlabel("real part [1/s] (linear within +-%.0f, logarithmic beyond)" % (2 * mechanical))
    fig.colorbar(sc, ax=axes[:2], label="log10(tau / s)")
    kc = np.array([critical_gain(height_loop(op.with_params(tau=float(t)), ti)) for t in taus])
    axes[2].loglog(taus, kc, "-", label="critical gain K_crit(tau)")
    axes[2].axhline(gain, color="k", ls="--", lw=1, label=f"K = {gain:.3g} Pa/m (middle panel)")
    axes[2].set_xlabel("lag tau [s]")
    axes[2].set_ylabel("critical gain [Pa/m]")
    axes[2].grid(alpha=0.3, which="both")
    axes[2].legend(fontsize=8)
    axes[2].set_title("the lag's cost: without lag no finite critical gain", fontsize=10)
    fig.suptitle(f"Pressure lag sweep tau = {taus[0]:.3g} .. {taus[-1]:.3g} s at "
                 f"alpha = {math.degrees(op.alpha):.4g} deg, pf = {op.Pf / 1e3:g} kPa, c = {op.params.c:.4g} N s/m",
                 fontsize=10)
    return save_png(fig, path) if path else fig


def plot_gain_locus(op: KneeOperatingPoint, gains, ti: float | None = None, tau: float = DEFAULT_TAU, path=None):
    """Root loci of the height controller against K, without and with the lag tau, critical gains marked."""
    from ..io.plotting import new_figure, save_png

    fig, ax = new_figure(figsize=(7, 5.4))
    summary = {}
    shown = []
    for case, style, label in ((op.with_params(tau=0.0), "tab:blue", "no lag"),
                               (op.with_params(tau=tau), "tab:red", f"lag tau = {tau:g} s")):
        g, loci = height_root_locus(case, gains, ti)
        finite = np.abs(loci) < 1e6
        shown.append(loci[finite])
        kc = critical_gain(height_loop(case, ti))
        summary[label] = kc
        ax.plot(loci[finite].real, loci[finite].imag, ".", ms=2, color=style,
                label=f"{label}: loci" + ("" if math.isfinite(kc) else " (stable for every K)"))
        ol = height_loop(case, ti).poles()
        shown.append(ol)
        ax.plot(ol.real, ol.imag, "x", color=style, ms=8, label=f"{label}: poles at K = 0")
        if math.isfinite(kc):
            at = closed_loop_poles(height_loop(case, ti), kc)
            ax.plot(at.real, at.imag, "o", mfc="none", color=style, ms=9,
                    label=f"{label}: at the critical K = {kc:.4g} Pa/m")
    every = np.concatenate(shown)
    lim = 1.15 * float(np.abs(every).max())
    ax.set_xlim(-lim, max(0.4 * lim, 1.15 * float(every.real.max())))
    ax.set_ylim(-lim, lim)
    ax.legend(fontsize=8, markerscale=1.5)
    _pole_axes(ax, f"Height P{'I' if ti else ''} control through pe_cmd, K = {gains[0]:.3g} .. {gains[-1]:.3g} Pa/m; "
                   f"c = {op.params.c:.4g} N s/m")
    return (save_png(fig, path) if path else fig), summary


def plot_step(result: dict, op: KneeOperatingPoint, path=None):
    """The hip-height step responses of :func:`step_responses`, in mm, with their step_info in the legend."""
    from ..io.plotting import new_figure, save_png

    fig, ax = new_figure(figsize=(7.5, 4.8))
    t = result["time"]
    for name, style in (("nonlinear", "-"), ("fmu", ":"), ("linear", "--")):
        y = result[name]
        if y is None:
            continue
        info = result["info"][name]
        ax.plot(t, 1e3 * y, style, lw=2 if name == "fmu" else 1.4,
                label=f"{name}: rise {info['RiseTime']:.3g} s, overshoot {info['Overshoot']:.3g} %, "
                      f"settling {info['SettlingTime']:.3g} s")
    ax.set_xlabel("time [s]")
    ax.set_ylabel("X - X_op [mm]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title(f"Step of pe_cmd by {result['dpe'] / 1e3:+g} kPa at alpha = {math.degrees(op.alpha):.4g} deg, "
                 f"pf = {op.Pf / 1e3:g} kPa, c = {op.params.c:.4g} N s/m, tau = {op.params.tau:g} s", fontsize=9)
    return save_png(fig, path) if path else fig


def plot_poles(cases: dict, title: str, path=None):
    """Eigenvalues of several linearizations on one pole map: {label: eigenvalues [1/s]}."""
    from ..io.plotting import new_figure, save_png

    fig, ax = new_figure(figsize=(6.4, 5.0))
    markers = iter("xo^sdv*")
    for label, eig in cases.items():
        eig = np.asarray(eig)
        ax.plot(eig.real, eig.imag, next(markers, "."), mfc="none", ms=9, mew=1.5, label=label)
    ax.legend(fontsize=8)
    _pole_axes(ax, title)
    return save_png(fig, path) if path else fig


# --- The air: the pressures as states of the muscles' mass balance (model-spec 4d) ---------------

#: The air's parameters ``mkctl rootlocus --vary`` sweeps, with their unit and the range swept
#: (within the spec's bounds: the valve's conductance, the tubing's dead volume, the regulator's
#: band).
AIR_SWEEPS = {"C_fill": ("m^3/(s Pa)", (2e-11, 1e-6)), "V_dead": ("m^3", (0.0, 1e-4)),
              "band": ("Pa", (1e3, 1e6))}


def air_switched_on() -> dict:
    """The value that switches the air's pressure path on: the switch of the effect whose definition
    gives the valve's opening (``valve_flow``, model-spec 4d), at its on value.

    Returns
    -------
    dict
        ``{switch name: on value}``, its other parameters at their typical values.
    """
    valve = next(e for e in effects.all_effects() if e.valve_opening is not None)
    switch = valve.switch_parameter
    return {switch.name: switch.on_value}


def with_air(op: KneeOperatingPoint, **values) -> KneeOperatingPoint:
    """The same posture and pressures with the air's pressure path switched on (model-spec 4d).

    At rest the regulators hold their set-points (u = 0: P = P_cmd) whatever the valve, so the air's
    values do not move the equilibrium (without a leak, which needs a small error to be fed).

    Parameters
    ----------
    op : KneeOperatingPoint
        The posture held at rest.
    **values : float
        Section 4d's values (C_fill [m^3/(s Pa)], V_dead [m^3], band [Pa], ...).

    Returns
    -------
    KneeOperatingPoint
        With the air on (its typical values unless given) and the states X, V, Pe, Pf
        (and Te, Tf with air_heat).
    """
    params = op.params.replace(**{**air_switched_on(), **values})
    states = knee.rest_state(op.X, op.Pe, op.Pf, params)  # with air_heat: Te, Tf = T_air
    return KneeOperatingPoint(params, op.alpha, op.X, op.Pe, op.Pf, states, op.inputs.copy())


@dataclass(frozen=True, repr=False, eq=False)
class AirPoleSweep(Result):
    """The knee's poles as one of the air's parameters varies (model-spec 4d), and the two limits
    the paper's question asks about: the pressures held (Eq. 18, the paper's assumption) and the
    valves closed (sealed muscles, air springs)."""

    name: str  #: the parameter varied
    unit: str  #: its unit
    values: np.ndarray  #: its values
    poles: np.ndarray  #: len(values) x 4 eigenvalues [1/s], sorted by real part, then imaginary
    held: np.ndarray  #: the poles with the pressures held (Eq. 18) [1/s]
    sealed: np.ndarray  #: the poles of the sealed knee, s^2 - a1 s - a2_sealed [1/s]
    a2_held: float  #: Eq. 18's a2 with the pressures held [1/s^2]
    a2_sealed: float  #: a2 with the valves closed [1/s^2]

    def summary_lines(self) -> list[str]:
        """The sweep's range, and a2 held and sealed.

        Returns
        -------
        list of str
            Two lines.
        """
        return [f"{self.name} from {self.values[0]:.4g} to {self.values[-1]:.4g} {self.unit} "
                f"({self.values.size} values)",
                f"a2 = {self.a2_held:.6g} 1/s^2 with the pressures held, "
                f"{self.a2_sealed:.6g} sealed"]

    def table(self) -> dict[str, np.ndarray]:
        """The value and each pole's real and imaginary part.

        Returns
        -------
        dict of str to numpy.ndarray
            ``<name>`` and ``pole<i>_re``, ``pole<i>_im`` [1/s].
        """
        columns = {self.name: self.values}
        for i in range(self.poles.shape[1]):
            columns[f"pole{i}_re"] = self.poles[:, i].real
            columns[f"pole{i}_im"] = self.poles[:, i].imag
        return columns


def air_pole_sweep(op: KneeOperatingPoint, name: str, values) -> AirPoleSweep:
    """The knee's poles at op with the air on, one of its parameters swept (model-spec 4d).

    Each linearization is :func:`mkctl.physics.knee.linearization` with the pressure states (the
    regulators on their filling side at rest); the held and sealed limits are Eq. 18's poles and
    those of :func:`mkctl.physics.stability.sealed_coefficients`.

    Parameters
    ----------
    op : KneeOperatingPoint
        The posture held at rest (its params: the model; the air switched on here if it is off).
    name : str
        One of :data:`AIR_SWEEPS`: ``C_fill``, ``V_dead`` or ``band``.
    values : array_like
        The values [its unit], within its bounds.

    Returns
    -------
    AirPoleSweep
        The poles at each value, the held and the sealed poles and a2.

    Raises
    ------
    ControlAnalysisError
        For another name.
    ParameterError
        For a value outside the parameter's bounds.
    """
    if name not in AIR_SWEEPS:
        raise ControlAnalysisError(f"--vary {name}: the air's parameters to vary are "
                                   f"{', '.join(AIR_SWEEPS)}")
    values = np.asarray(values, dtype=float)
    air = with_air(op)
    poles = np.empty((values.size, 4), dtype=complex)
    for i, value in enumerate(values):
        varied = air.params.replace(**{name: value})
        A, _ = knee.linearization(op.X, op.Pe, op.Pf, *op.inputs, varied)
        poles[i] = np.sort_complex(np.linalg.eigvals(A))
    a1, a2 = stability.routh_hurwitz_coefficients(op.X, op.Pe, op.Pf, 0.0, air.params)
    s1, s2 = stability.sealed_coefficients(op.X, op.Pe, op.Pf, air.params)
    held = stability.poles(float(a1), float(a2))
    return AirPoleSweep(name, AIR_SWEEPS[name][0], values, poles, held, stability.poles(s1, s2),
                        float(a2), s2)


def plot_air_poles(sweep: AirPoleSweep, title: str = "", path=None):
    """Two pole maps of an :class:`AirPoleSweep`: every pole (the air's on a logarithmic real axis)
    and the motion's poles near the origin, with the pressures-held and the sealed poles marked.

    Parameters
    ----------
    sweep : AirPoleSweep
        The sweep.
    title : str
        A line above both maps (the posture).
    path : str or Path, optional
        Where to save the PNG.

    Returns
    -------
    matplotlib.figure.Figure or Path
        The figure, or the path of the PNG when path is given.
    """
    from matplotlib.colors import LogNorm
    from ..io.plotting import new_figure, save_png

    fig, (every, motion) = new_figure(1, 2, figsize=(11.5, 4.8))
    positive = sweep.values[sweep.values > 0]
    norm = LogNorm(positive.min(), positive.max()) if positive.size > 1 else None
    flat = np.repeat(sweep.values[:, None], sweep.poles.shape[1], axis=1)
    real_axis = sweep.poles.real.ravel()
    colour = np.where(flat.ravel() > 0, flat.ravel(), positive.min() if positive.size else 1.0)
    for ax in (every, motion):
        sc = ax.scatter(real_axis, sweep.poles.imag.ravel(), c=colour, s=7, cmap="viridis",
                        norm=norm)
        ax.plot(sweep.held.real, sweep.held.imag, "rx", ms=10, mew=2,
                label="pressures held (Eq. 18)")
        ax.plot(sweep.sealed.real, sweep.sealed.imag, "ks", mfc="none", ms=10, mew=1.5,
                label="valves closed (sealed: air springs)")
    fig.colorbar(sc, ax=motion, label=f"{sweep.name} [{sweep.unit}]")
    every.set_xscale("symlog", linthresh=1.0)
    _pole_axes(every, "every pole (the air's: real, fast; symlog axis)")
    mechanical = sweep.poles[np.abs(sweep.poles.imag) > 0]
    span = max(np.abs(np.concatenate([sweep.held, sweep.sealed, mechanical])).max() * 1.15, 1.0)
    motion.set_xlim(-span / 2, span / 10)
    motion.set_ylim(-span, span)
    _pole_axes(motion, "the motion's poles")
    motion.legend(fontsize=8, loc="lower left")
    if title:
        fig.suptitle(title, fontsize=10)
    return save_png(fig, path) if path else fig
