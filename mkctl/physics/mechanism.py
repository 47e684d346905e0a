"""Mechanisms as values: one coordinate, one or two muscles, an inertia, a load, end stops
(model-spec section 3b).

A :class:`Mechanism` maps one generalized coordinate ``q`` (m or rad) to the length of each of its
one or two muscles, ``L_i(q)``, and has an inertia ``M(q)`` and a load ``Q(q, qdot)`` (a generalized
force: gravity, a spring). Its motion follows by virtual work, exactly as the knee's Eq. 14-17 do
with ``q = X``:

======================  ===========================================================================
moment arm               ``dL_i/dq``: ``sympy.diff`` of the traced length, never written by hand
muscle rate              ``Ldot_i = (dL_i/dq) qdot``
equation of motion       ``M qdd = sum_i (-dL_i/dq) f_i(L_i, Ldot_i, P_i) + Q(q, qdot)
                         + F_stop(q, qdot)``
tension                  ``f_i``: :func:`mkctl.physics.actuator.compose_tension` (Eq. 7/13 and
                         every effect params switch on, applied to each muscle alike, as for
                         the knee)
pressures                the commands, or with a pressure effect (a lag) states ``dP_i/dt`` of
                         :func:`mkctl.physics.actuator.pressure_derivative`
end stops                :func:`mkctl.physics.knee.end_stop_force` (the knee's contact law,
                         called with the mechanism's inertia in place of the hip mass)
linearization (Eq. 18)   ``a2 = (dF/dq) / M``, ``a1 = (dF/dqdot) / M`` at rest, stops excluded;
                         stable iff both < 0
======================  ===========================================================================

The functions of a mechanism are written on the math namespace ``xp``
(:func:`mkctl.physics.actuator.math_for`): the same function runs on floats, numpy arrays and sympy
symbols. The symbolic trace (lengths, their first and second derivatives, inertia, load and its
partials) is made and lambdified once per mechanism and kept on it (:attr:`Mechanism.traced`), not
in a global registry.

``p`` in a mechanism's functions is a :class:`MechanismParams`: the muscle's
:class:`~mkctl.physics.params.Params` joined with the mechanism's own parameter values, by
attribute.

Example
-------
>>> from mkctl.physics.mechanism import PULLEY_JOINT, equilibrium_stability
>>> equilibrium_stability(PULLEY_JOINT, (300e3, 300e3)).verdict
'marginal'
"""
from __future__ import annotations

import dataclasses
import functools
import math
from types import MappingProxyType
from typing import Callable, NamedTuple

import numpy as np

from ..errors import DomainError, ParameterError
from ..results import Result
from . import actuator, backend, knee, simulate
from .effects import Parameter
from .integrate import integrate
from .params import DEFAULT, PARAMETER_NAMES, Params
from .stability import poles as _poles
from .stability import verdict as _verdict

#: Names a mechanism's own parameter may not take besides mkctl's (the trace's coordinate and rate
#: symbols).
RESERVED_NAMES = ("q", "qdot")


# --- The parameter view ---------------------------------------------------------------------------

class MechanismParams:
    """``p`` of a mechanism's functions: its own parameter values, then the muscle's, by attribute.

    Immutable and hashable. ``muscle_params(p)`` is the muscle's
    :class:`~mkctl.physics.params.Params` (what the tension and the effects read);
    :meth:`Mechanism.bind` makes one with the defaults filled in and checked.

    Parameters
    ----------
    params : Params
        The muscle's parameters and effects (model-spec sections 2 and 4), shared by every muscle.
    own : mapping of str to float, optional
        The mechanism's own parameter values, each in its parameter's unit (model-spec section 3b);
        they shadow the muscle's names (which :class:`Mechanism` forbids them to take). Not
        checked here: :meth:`Mechanism.bind` checks them.

    References
    ----------
    .. [1] model-spec section 3b (a mechanism's own parameters).
    """

    __slots__ = ("_params", "_own")

    def __init__(self, params=DEFAULT, own=None):
        object.__setattr__(self, "_params", params)
        object.__setattr__(self, "_own", MappingProxyType(dict(own or {})))

    def __getattr__(self, name):
        if name.startswith("_"):
            raise AttributeError(name)
        own = object.__getattribute__(self, "_own")
        if name in own:
            return own[name]
        return getattr(object.__getattribute__(self, "_params"), name)

    def __setattr__(self, name, value):
        raise AttributeError("MechanismParams are immutable: use Mechanism.bind(...) for another "
                             "set")

    def __eq__(self, other):
        if not isinstance(other, MechanismParams):
            return NotImplemented
        return self._params == other._params and dict(self._own) == dict(other._own)

    def __hash__(self):
        return hash((self._params, tuple(sorted(self._own.items()))))

    def __reduce__(self):
        return (MechanismParams, (self._params, dict(self._own)))

    def __repr__(self):
        own = ", ".join(f"{k}={v!r}" for k, v in self._own.items())
        return f"MechanismParams({own}; muscle {self._params!r})"


def muscle_params(p) -> Params:
    """The muscle's parameter set of a :class:`MechanismParams` (p itself for anything else).

    Parameters
    ----------
    p : MechanismParams or Params
        A mechanism's parameter view, or a muscle's parameter set.

    Returns
    -------
    Params
        What the tension and the effects read (model-spec sections 2 and 4).
    """
    return p._params if isinstance(p, MechanismParams) else p


class _Inertia(NamedTuple):
    """What :func:`mkctl.physics.knee.end_stop_force` reads of its parameters: the mass (here: the
    inertia M) that makes its damping critical."""

    m: float


# --- The mechanism --------------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True)
class Mechanism:
    """One mechanism of one coordinate (model-spec section 3b), a value: frozen, hashable,
    picklable.

    Fields: ``name``; ``coordinate`` and ``unit`` of q ("m" or "rad"); ``muscles``, one or two
    names; ``parameters``, its own (:class:`mkctl.physics.effects.Parameter`: name, unit, default,
    bounds); ``lengths(q, p, xp)`` -> one length [m] per muscle; ``inertia(q, p, xp)`` -> M [kg or
    kg m^2]; ``load(q, qdot, p, xp)`` -> Q [N or N m]; ``stops(p)`` -> (q_min, q_max);
    ``description``; ``source`` (where it was defined); ``reload`` (for a mechanism read from a
    file: (loader, arguments), how a pickle makes it again).
    """

    name: str
    coordinate: str
    unit: str
    muscles: tuple
    parameters: tuple
    lengths: Callable
    inertia: Callable
    load: Callable
    stops: Callable
    description: str = ""
    source: str = "built-in"
    reload: tuple = dataclasses.field(default=(), compare=False, repr=False)

    def __post_init__(self):
        if not 1 <= len(self.muscles) <= 2:
            raise ParameterError(f"mechanism {self.name!r}: it needs one or two muscles, "
                                 f"got {len(self.muscles)}")
        if len(set(self.muscles)) != len(self.muscles):
            raise ParameterError(f"mechanism {self.name!r}: two muscles are named alike")
        names = [q.name for q in self.parameters]
        if len(set(names)) != len(names):
            raise ParameterError(f"mechanism {self.name!r}: a parameter is named twice")
        clash = [n for n in names
                 if n in PARAMETER_NAMES or n in RESERVED_NAMES or n.startswith("_")]
        if clash:
            raise ParameterError(f"mechanism {self.name!r}: parameter {clash[0]!r} is an mkctl "
                                 f"name; choose another")

    # --- parameters ---
    @property
    def parameter_names(self) -> tuple:
        return tuple(q.name for q in self.parameters)

    @property
    def defaults(self) -> dict:
        """Every own parameter at its default value."""
        return {q.name: float(q.start) for q in self.parameters}

    def bind(self, params=DEFAULT, **values) -> MechanismParams:
        """The :class:`MechanismParams` of this mechanism, its own values checked against bounds.

        Own parameters are at their defaults unless given in ``values`` (or already in a
        MechanismParams handed in as params); names of mkctl's parameters in ``values`` change the
        muscle's set.

        Parameters
        ----------
        params : Params or MechanismParams
            The muscle's parameters and effects; a MechanismParams also brings its own values.
        **values : float
            Own parameters (each in its unit, model-spec section 3b) or mkctl's (their units,
            :class:`~mkctl.physics.params.Params`) by name.

        Returns
        -------
        MechanismParams
            Own values as floats, each within its bounds.

        Raises
        ------
        ParameterError
            For an own value that is not a finite number or lies outside its bounds, or an mkctl
            parameter that is invalid.

        References
        ----------
        .. [1] model-spec section 3b.
        """
        own = self.defaults
        if isinstance(params, MechanismParams):
            own.update({k: v for k, v in params._own.items() if k in own})
            params = params._params
        muscle = {k: v for k, v in values.items() if k not in own}
        if muscle:
            params = params.replace(**muscle)
        own.update({k: v for k, v in values.items() if k in own})
        for q in self.parameters:
            value = own[q.name]
            number = isinstance(value, (int, float)) and not isinstance(value, bool)
            if not (number and math.isfinite(value)):
                raise ParameterError(f"parameter {q.name} of mechanism {self.name} must be a "
                                     f"finite number, got {value!r}")
            q.check(value)
            own[q.name] = float(value)
        return MechanismParams(params, own)

    def stop_positions(self, p) -> tuple[float, float]:
        """(q_min, q_max) of the end stops at p, checked: finite and q_min < q_max.

        Parameters
        ----------
        p : MechanismParams
            :meth:`bind`'s parameters (the stops may depend on them).

        Returns
        -------
        q_min, q_max : float
            The end stops [m or rad, the coordinate's unit].

        Raises
        ------
        ParameterError
            Unless both are finite and q_min < q_max.

        References
        ----------
        .. [1] model-spec section 3b (end stops at the mechanism's limits).
        """
        low, high = (float(v) for v in self.stops(p))
        if not (math.isfinite(low) and math.isfinite(high) and low < high):
            raise ParameterError(f"mechanism {self.name}: its stops ({low:g}, {high:g}) "
                                 f"{self.unit} are not an interval (q_min < q_max)")
        return low, high

    # --- the symbolic trace, kept on the value ---
    @functools.cached_property
    def traced(self) -> "Traced":
        """The mechanism traced on sympy symbols, differentiated and lambdified: made once, kept.

        Kept on this value, not in a global registry (see the module docstring).
        """
        return _trace(self)

    def __getstate__(self):
        # the fields only, not the lambdified cache
        return {f.name: getattr(self, f.name) for f in dataclasses.fields(self)}

    def __setstate__(self, state):
        for key, value in state.items():
            object.__setattr__(self, key, value)

    def __reduce_ex__(self, protocol):
        if self.reload:
            return (self.reload[0], tuple(self.reload[1:]))
        return super().__reduce_ex__(protocol)


class Traced(NamedTuple):
    """A mechanism's symbolic trace: q, qdot symbols, the expressions, their lambdified versions."""

    q: object  #: the coordinate's symbol
    qdot: object  #: its rate's symbol
    lengths: tuple  #: L_i(q)
    arms: tuple  #: dL_i/dq
    curvatures: tuple  #: d2L_i/dq2
    inertia: object  #: M(q)
    load: object  #: Q(q, qdot)
    load_dq: object  #: dQ/dq
    load_dqdot: object  #: dQ/dqdot
    names: tuple  #: the parameter names the expressions use, in the lambdified functions' order
    symbols: tuple  #: their sympy symbols, in the same order
    state: dict  #: {"math" | "numpy": f(q, qdot, *values) -> (L..., dL/dq..., M, Q)}
    partials: dict  #: {"math" | "numpy": f(q, qdot, *values) -> (d2L/dq2..., dQ/dq, dQ/dqdot)}


def symbolic_params(mechanism: Mechanism) -> MechanismParams:
    """A :class:`MechanismParams` of sympy symbols, mkctl's and the mechanism's own.

    mkctl's are :class:`mkctl.physics.actuator.SymbolicParams`; the mechanism's own are each a real
    symbol named after its parameter.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism whose own parameters get symbols.

    Returns
    -------
    MechanismParams
        Symbols in place of every parameter value (what a trace and generated code evaluate on).

    References
    ----------
    .. [1] model-spec section 3b (traced into the compiled core and the native FMUs).
    """
    import sympy
    own = {q.name: sympy.Symbol(q.name, real=True) for q in mechanism.parameters}
    return MechanismParams(actuator.SymbolicParams(), own)


def trace(mechanism: Mechanism, q=None, qdot=None):
    """(lengths, inertia, load) of the mechanism on sympy symbols.

    The mechanism's functions run on q, qdot and :func:`symbolic_params` with the sympy namespace
    (:func:`mkctl.physics.xp.symbolic_math`); their domain checks are recorded, not raised.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism to trace.
    q, qdot : sympy expression, optional
        The coordinate [m or rad] and its rate [per s]; default real symbols named ``q`` and
        ``qdot``.

    Returns
    -------
    lengths : tuple of sympy expression
        L_i(q) [m], one per muscle.
    inertia : sympy expression
        M(q) [kg or kg m^2].
    load : sympy expression
        Q(q, qdot) [N or N m].

    Raises
    ------
    ParameterError
        If lengths gives another number of lengths than the mechanism has muscles; and whatever the
        mechanism's own functions raise.

    References
    ----------
    .. [1] model-spec section 3b (a file that cannot be traced ends with a one-line error).
    """
    import sympy
    q = sympy.Symbol("q", real=True) if q is None else q
    qdot = sympy.Symbol("qdot", real=True) if qdot is None else qdot
    sp, xp = symbolic_params(mechanism), actuator.symbolic_math()
    with actuator.tracing_domain_checks():  # the domain checks of a trace are no caller's
        lengths = tuple(sympy.sympify(L) for L in mechanism.lengths(q, sp, xp))
        inertia = sympy.sympify(mechanism.inertia(q, sp, xp))
        load = sympy.sympify(mechanism.load(q, qdot, sp, xp))
    if len(lengths) != len(mechanism.muscles):
        raise ParameterError(f"mechanism {mechanism.name}: lengths gives {len(lengths)} lengths "
                             f"for {len(mechanism.muscles)} muscles")
    return lengths, inertia, load


def _trace(mechanism: Mechanism) -> Traced:
    import sympy
    q, qdot = sympy.Symbol("q", real=True), sympy.Symbol("qdot", real=True)
    lengths, inertia, load = trace(mechanism, q, qdot)
    # the derivative of a Max: Python's branch, as the tension's partials
    step = actuator._heaviside_as_step
    arms = tuple(step(sympy.diff(L, q)) for L in lengths)
    curvatures = tuple(step(sympy.diff(a, q)) for a in arms)
    load_dq, load_dqdot = step(sympy.diff(load, q)), step(sympy.diff(load, qdot))
    state = [*lengths, *arms, inertia, load]
    partials = [*curvatures, load_dq, load_dqdot]
    symbols = {s.name: s for e in state + partials for s in e.free_symbols if s not in (q, qdot)}
    names = tuple(sorted(symbols))
    arguments = [q, qdot, *(symbols[n] for n in names)]
    made = {}
    for key, expressions in (("state", state), ("partials", partials)):
        made[key] = {module: sympy.lambdify(arguments, expressions, modules=module, cse=True)
                     for module in ("math", "numpy")}
    return Traced(q, qdot, lengths, arms, curvatures, inertia, load, load_dq, load_dqdot, names,
                  tuple(symbols[n] for n in names), made["state"], made["partials"])


def _evaluate(mechanism: Mechanism, which: str, q, qdot, p) -> list:
    """The trace's "state" (L..., dL/dq..., M, Q) or "partials" (d2L/dq2..., dQ/dq, dQ/dqdot) at q,
    qdot and p: floats, numpy arrays, or on symbols the expressions themselves (generated code)."""
    traced = mechanism.traced
    values = [getattr(p, n) for n in traced.names]
    if any(actuator.is_symbolic(x) for x in (q, qdot, *values)):
        import sympy
        if which == "state":
            expressions = [*traced.lengths, *traced.arms, traced.inertia, traced.load]
        else:
            expressions = [*traced.curvatures, traced.load_dq, traced.load_dqdot]
        values = {traced.q: q, traced.qdot: qdot, **dict(zip(traced.symbols, values))}
        return [sympy.sympify(e).xreplace(values) for e in expressions]
    scalar = type(q) is float and type(qdot) is float
    function = getattr(traced, which)["math" if scalar else "numpy"]
    try:
        values = function(q, qdot, *values)
    except (OverflowError, ZeroDivisionError, ValueError) as error:
        # Python's math raises where numpy gives inf or NaN: q**2 beyond any float (an integrator's
        # step from an inertia of 1e-320), a square root of a negative
        raise DomainError(f"mechanism '{mechanism.name}' at {mechanism.coordinate} = {q:.6g} "
                          f"{mechanism.unit}: its {which} is not a finite number ({error})"
                          ) from None
    if scalar:
        return [float(v) for v in values]
    shape = np.broadcast(q, qdot).shape
    return [np.broadcast_to(np.asarray(v, dtype=float), shape) for v in values]


# --- Kinematics and forces ------------------------------------------------------------------------

class MechanismForce(NamedTuple):
    """The generalized force of the muscles and the load at one state, with what it is made of."""

    F: object  #: sum_i (-dL_i/dq) f_i + Q [N or N m], end stops excluded
    M: object  #: inertia [kg or kg m^2]
    L: tuple  #: each muscle's length [m]
    arms: tuple  #: each dL_i/dq [m/m or m/rad]
    Ldot: tuple  #: each muscle's lengthening rate [m/s]
    f: tuple  #: each muscle's tension [N]
    Q: object  #: the load [N or N m]


def _pressures(mechanism: Mechanism, pressures) -> tuple:
    if isinstance(pressures, np.ndarray) and pressures.ndim == 1 and len(mechanism.muscles) > 1:
        pressures = tuple(pressures)  # one row of a record's commands
    pressures = tuple(pressures) if isinstance(pressures, (tuple, list)) else (pressures,)
    if len(pressures) != len(mechanism.muscles):
        raise ParameterError(f"mechanism {mechanism.name} has {len(mechanism.muscles)} muscle(s) "
                             f"({', '.join(mechanism.muscles)}); got {len(pressures)} pressure(s)")
    return tuple(actuator.as_values(P) for P in pressures)


class Kinematics(NamedTuple):
    """A mechanism's geometry and mass at one state: the lambdified trace."""

    L: tuple  #: each muscle's length [m]
    arms: tuple  #: each dL_i/dq [m/m or m/rad]
    M: object  #: inertia [kg or kg m^2]
    Q: object  #: load [N or N m]


def kinematics(mechanism: Mechanism, q, p, qdot=0.0) -> Kinematics:
    """Each muscle's length and moment arm dL_i/dq, the inertia and the load at (q, qdot).

    From the lambdified trace (:attr:`Mechanism.traced`); the moment arms are ``sympy.diff`` of
    the traced lengths, never written by hand.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    q : float, array_like or sympy expression
        The coordinate [m or rad].
    p : MechanismParams
        :meth:`Mechanism.bind`'s parameters.
    qdot : float, array_like or sympy expression
        The coordinate's rate [m/s or rad/s]; broadcasts with q.

    Returns
    -------
    Kinematics
        L (each muscle's length [m]), arms (each dL_i/dq [m/m or m/rad]), M [kg or kg m^2] and
        Q [N or N m].

    References
    ----------
    .. [1] model-spec section 3b.
    """
    k = len(mechanism.muscles)
    q, qdot = actuator.as_values(q), actuator.as_values(qdot)
    values = _evaluate(mechanism, "state", q, qdot, p)
    return Kinematics(tuple(values[:k]), tuple(values[k:2 * k]), values[2 * k], values[2 * k + 1])


def mechanism_force(mechanism: Mechanism, q, qdot, pressures, p) -> MechanismForce:
    """The generalized force of the muscles and the load at one state, by virtual work.

    ``F = sum_i (-dL_i/dq) f_i(L_i, Ldot_i, P_i) + Q(q, qdot)``, ``Ldot_i = (dL_i/dq) qdot``

    at coordinate q, rate qdot and muscle pressures (one per muscle; floats or arrays, broadcast;
    on sympy symbols the expression). End stops are not included.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    q, qdot : float, array_like or sympy expression
        The coordinate [m or rad] and its rate [m/s or rad/s].
    pressures : sequence
        Each muscle's gauge pressure [Pa], in the order of ``mechanism.muscles`` (one value for a
        single muscle).
    p : MechanismParams
        :meth:`Mechanism.bind`; the tension reads the muscle's Params.

    Returns
    -------
    MechanismForce
        F and Q [N or N m], M [kg or kg m^2], each muscle's L [m], arm dL_i/dq, Ldot [m/s] and
        tension f [N].

    Raises
    ------
    ParameterError
        For another number of pressures than muscles.
    DomainError
        Where a length leaves 0 < L < b or a pressure is not finite.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 14-17 (the knee: q = X).
    .. [2] model-spec section 3b.
    """
    q, qdot = actuator.as_values(q), actuator.as_values(qdot)
    pressures = _pressures(mechanism, pressures)
    k = len(mechanism.muscles)
    L, arms, M, Q = kinematics(mechanism, q, p, qdot)
    muscle = muscle_params(p)
    Ldot = tuple(a * qdot for a in arms)
    f = tuple(actuator.compose_tension(L[i], pressures[i], Ldot[i], muscle) for i in range(k))
    return MechanismForce(_virtual_work(arms, f, Q), M, L, arms, Ldot, f, Q)


def _virtual_work(arms, tensions, Q):
    """``sum_i (-dL_i/dq) f_i + Q``: the generalized force of the tensions and the load."""
    F = Q
    for arm, f in zip(arms, tensions):
        F = F - arm * f
    return F


def _acceleration(q, qdot, F, M, stops):
    """``qdd = (F + F_stop) / M``, F_stop the knee's contact law with inertia M (None: no stops)."""
    if stops is not None:
        F = F + knee.end_stop_force(q, qdot, _Inertia(M), stops)
    return F / M


class ForcePartials(NamedTuple):
    """Exact partial derivatives of :func:`mechanism_force`'s F."""

    F: object  #: [N or N m]
    dF_dq: object  #: [N/m or N m/rad]
    dF_dqdot: object  #: [N s/m or N m s/rad]
    dF_dP: tuple  #: each muscle's [N/Pa or N m/Pa]
    M: object  #: inertia


def force_partials(mechanism: Mechanism, q, qdot, pressures, p) -> ForcePartials:
    """Exact partials of F (:func:`mechanism_force`) by q, qdot and each muscle's pressure.

    The lengths' and the load's derivatives are ``sympy.diff`` of the trace, the tension's
    :func:`mkctl.physics.actuator.tension_partials` (sympy.diff of the traced effect terms, with
    slack's factor), joined by the chain rule with ``Ldot_i = L_i'(q) qdot``:

    ``dF/dq = sum_i -(L_i'' f_i + L_i' s_i (f_L L_i' + f_Ldot L_i'' qdot)) + dQ/dq``

    ``dF/dqdot = sum_i -L_i' s_i f_Ldot L_i' + dQ/dqdot``

    ``dF/dP_i = -L_i' s_i f_P``

    with s_i the final limits' slope (slack: 0 where the muscle carries nothing).

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    q, qdot : float, array_like or sympy expression
        The coordinate [m or rad] and its rate [m/s or rad/s].
    pressures : sequence
        Each muscle's gauge pressure [Pa].
    p : MechanismParams
        :meth:`Mechanism.bind`'s parameters.

    Returns
    -------
    ForcePartials
        F [N or N m], dF_dq [N/m or N m/rad], dF_dqdot [N s/m or N m s/rad], dF_dP (each
        muscle's, [N/Pa or N m/Pa]) and the inertia M.

    Raises
    ------
    ParameterError, DomainError
        As :func:`mechanism_force`.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 18 (the partials a1, a2 are made of).
    .. [2] model-spec section 3b (moment arms and the linearization differentiated exactly).
    """
    q, qdot = actuator.as_values(q), actuator.as_values(qdot)
    force = mechanism_force(mechanism, q, qdot, pressures, p)
    pressures = _pressures(mechanism, pressures)
    k = len(mechanism.muscles)
    extra = _evaluate(mechanism, "partials", q, qdot, p)
    curv, Q_q, Q_qdot = extra[:k], extra[k], extra[k + 1]
    muscle = muscle_params(p)
    dF_dq, dF_dqdot, dF_dP = Q_q, Q_qdot, []
    for i in range(k):
        _, f_L, f_Ldot, f_P, taut = actuator.tension_partials(force.L[i], pressures[i],
                                                              force.Ldot[i], muscle)
        arm = force.arms[i]
        df_dq = taut * (f_L * arm + f_Ldot * curv[i] * qdot)
        dF_dq = dF_dq - (curv[i] * force.f[i] + arm * df_dq)
        dF_dqdot = dF_dqdot - arm * taut * f_Ldot * arm
        dF_dP.append(-arm * taut * f_P)
    return ForcePartials(force.F, dF_dq, dF_dqdot, tuple(dF_dP), force.M)


def state_names(mechanism: Mechanism, params=DEFAULT) -> tuple:
    """The state names: the coordinate, its rate, then each pressure and each air temperature.

    The pressures with pressure dynamics (a lag, the air); the air's temperatures when they are
    states (air_heat, model-spec 4d).

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    params : Params or MechanismParams
        The muscle's effects decide whether the pressures are states (a lag).

    Returns
    -------
    tuple of str
        ``<coordinate>``, ``<coordinate>_dot`` and, with pressure dynamics, ``P_<muscle>`` for
        each muscle, then with the temperatures ``T_<muscle>`` for each muscle.

    References
    ----------
    .. [1] model-spec sections 3b, 4 (the pressure lag) and 4d (air_heat).
    """
    names = (mechanism.coordinate, mechanism.coordinate + "_dot")
    if actuator.has_pressure_states(muscle_params(params)):
        names += tuple(f"P_{m}" for m in mechanism.muscles)
    if actuator.has_temperature_states(muscle_params(params)):
        names += tuple(f"T_{m}" for m in mechanism.muscles)
    return names


def mechanism_derivatives(state, commands, mechanism: Mechanism, p, stops=None,
                          opening: bool = False) -> np.ndarray:
    """Right-hand side of the mechanism's equation of motion (model-spec section 3b).

    ``qdd = (F + F_stop) / M``

    with F of :func:`mechanism_force` and F_stop :func:`mkctl.physics.knee.end_stop_force` (the
    knee's contact law, with the mechanism's inertia in place of the hip mass).

    Parameters
    ----------
    state : sequence of float or sympy expression
        (q [m or rad], qdot [m/s or rad/s]) or, with pressure dynamics, (q, qdot, P_1[, P_2])
        with the pressures [Pa], and with the air's temperatures (..., T_1[, T_2]) [K]
        (:func:`state_names`).
    commands : sequence of float or sympy expression
        Each muscle's pressure command [Pa] (as the muscles see it: after a dead time).
    mechanism : Mechanism
        The mechanism.
    p : MechanismParams
        :meth:`Mechanism.bind`'s parameters.
    stops : tuple of float, optional
        (q_min, q_max) of the end stops [m or rad]; None: no stops.
    opening : bool
        With the air on: the commands are each muscle's valve opening u [-] (a switching valve,
        model-spec 4d; clipped to [-1, 1] by :func:`mkctl.physics.knee.valve_input`).

    Returns
    -------
    numpy.ndarray or list of sympy expression
        The state's rates [SI per second]: (qdot, qdd[, dP_1/dt, dP_2/dt][, dT_1/dt, dT_2/dt]);
        on sympy symbols (generated code) a list of expressions.

    Raises
    ------
    DomainError
        Where a length leaves 0 < L < b or a pressure is not finite.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 17 (the knee's equation of motion, q = X).
    .. [2] model-spec sections 3b and 4 (the pressure effects).
    """
    muscle = muscle_params(p)
    k = len(mechanism.muscles)
    lag = actuator.has_pressure_states(muscle)
    q, qdot = _scalar(state[0]), _scalar(state[1])
    commands = tuple(_scalar(c) for c in commands)
    pressures = tuple(_scalar(state[2 + i]) for i in range(k)) if lag else commands
    force = mechanism_force(mechanism, q, qdot, pressures, p)
    rates = [qdot, _acceleration(q, qdot, force.F, force.M, stops)]
    inputs = tuple(knee.valve_input(c) for c in commands) if opening else commands
    if lag and actuator.has_temperature_states(muscle):
        rates += _heat_rates(state, inputs, force, muscle, k, opening)
    elif lag and actuator.air_is_on(muscle):
        # the air (model-spec 4d): each pressure from its mass balance at its length and rate
        rates += [actuator.air_pressure_derivative(pressures[i], inputs[i], force.L[i],
                                                   force.Ldot[i], muscle, opening)
                  for i in range(k)]
    elif lag:
        rates += [actuator.pressure_derivative(pressures[i], commands[i], muscle)
                  for i in range(k)]
    return rates if actuator.is_symbolic(rates[1]) else np.array(rates, dtype=float)


def _heat_rates(state, commands, force, muscle, k, opening: bool = False) -> list:
    """Each muscle's dP/dt, then each one's dT/dt, with the air's temperatures as states
    (air_heat, model-spec 4d): :func:`mkctl.physics.actuator.air_rates` at its length and rate
    (``opening``: the commands are the valves' openings)."""
    rates = [actuator.air_rates(_scalar(state[2 + i]), _scalar(state[2 + k + i]), commands[i],
                                force.L[i], force.Ldot[i], muscle, opening) for i in range(k)]
    return [r[0] for r in rates] + [r[1] for r in rates]


def motion_under_tensions(state, tensions, mechanism: Mechanism, p, stops=None) -> list:
    """Right-hand side of the mechanism alone, its muscles' tensions given (model-spec 7d).

    A co-simulation where each muscle is its own FMU drives the mechanism this way.

    ``qdd = (sum_i (-dL_i/dq) f_i + Q(q, qdot) + F_stop) / M``

    the equation of motion of :func:`mechanism_derivatives` with f_i from outside.

    Parameters
    ----------
    state : sequence of float or sympy expression
        (q [m or rad], qdot [m/s or rad/s]).
    tensions : sequence of float or sympy expression
        Each muscle's tension [N], in the order of ``mechanism.muscles``.
    mechanism : Mechanism
        The mechanism.
    p : MechanismParams
        :meth:`Mechanism.bind`'s parameters.
    stops : tuple of float, optional
        (q_min, q_max) of the end stops [m or rad]; None: no stops.

    Returns
    -------
    list
        (qdot, qdd) [SI per second]: floats, or sympy expressions (generated code).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 17.
    .. [2] model-spec sections 3b and 7d.
    """
    q, qdot = _scalar(state[0]), _scalar(state[1])
    _, arms, M, Q = kinematics(mechanism, q, p, qdot)
    return [qdot, _acceleration(q, qdot, _virtual_work(arms, tensions, Q), M, stops)]


def _scalar(x):
    """A float, or a symbol as it is (generated code)."""
    return x if actuator.is_symbolic(x) else float(x)


# --- Equilibrium and stability --------------------------------------------------------------------

def equilibrium(mechanism: Mechanism, pressures, params=DEFAULT, q_range=None,
                samples: int = 400) -> float:
    """The coordinate of a stable equilibrium at rest, within the stops.

    ``F(q, 0, P) = 0`` with ``dF/dq < 0``

    bracketed on a grid of q (where F falls through zero as q grows) and refined by Brent's method.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    pressures : sequence of float
        Each muscle's gauge pressure [Pa].
    params : Params or MechanismParams
        The muscle's parameters (and the mechanism's own values).
    q_range : tuple of float, optional
        (low, high) coordinates to search [m or rad]; default: the mechanism's stops.
    samples : int
        Points of the bracketing grid.

    Returns
    -------
    q : float
        The coordinate [m or rad] of the stable root nearest the upper stop (the knee's rule,
        :func:`mkctl.physics.stability.equilibrium_hip_height`).

    Raises
    ------
    DomainError
        When there is no stable equilibrium in range (the mechanism would rest on a stop).
    ParameterError
        For another number of pressures than muscles, or invalid own parameters.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 17 and 20.
    .. [2] model-spec sections 3b and 5d (a run starts at rest in this equilibrium).
    """
    from scipy.optimize import brentq

    p = mechanism.bind(params)
    pressures = tuple(float(P) for P in _pressures(mechanism, pressures))
    low, high = q_range if q_range is not None else mechanism.stop_positions(p)
    grid = np.linspace(low, high, samples)
    F = np.asarray(mechanism_force(mechanism, grid, 0.0 * grid, pressures, p).F, dtype=float)
    crossings = np.nonzero((F[:-1] > 0) & (F[1:] <= 0))[0]
    if crossings.size == 0:
        shown = ", ".join(f"{P:g}" for P in pressures)
        raise DomainError(f"no stable equilibrium of {mechanism.name} at pressures ({shown}) Pa "
                          f"between {mechanism.coordinate} = {low:.6g} and {high:.6g} "
                          f"{mechanism.unit} (it would rest on an end stop)")
    i = crossings[-1]
    return brentq(lambda x: float(mechanism_force(mechanism, float(x), 0.0, pressures, p).F),
                  grid[i], grid[i + 1], xtol=1e-13)


def stability_coefficients(mechanism: Mechanism, q, pressures, params=DEFAULT, qdot=0.0):
    """(a1, a2) of the linearized equation of motion, Eq. 18 for one coordinate.

    ``a1 = (dF/dqdot) / M``, ``a2 = (dF/dq) / M``

    stops excluded; Eq. 19-20 ask both < 0. For the knee these are
    :func:`mkctl.physics.stability.routh_hurwitz_coefficients`.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    q : float or array_like
        The coordinate [m or rad].
    pressures : sequence
        Each muscle's gauge pressure [Pa].
    params : Params or MechanismParams
        The muscle's parameters (and the mechanism's own values).
    qdot : float or array_like
        The coordinate's rate [m/s or rad/s] (0 at rest).

    Returns
    -------
    a1 : float or array
        Velocity coefficient [1/s].
    a2 : float or array
        Position coefficient [1/s^2].

    Raises
    ------
    ParameterError, DomainError
        As :func:`mechanism_force`.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18-20.
    .. [2] model-spec section 3b (the stability analysis holds for any mechanism).
    """
    return coefficients_at(mechanism, q, qdot, pressures, mechanism.bind(params))


def coefficients_at(mechanism: Mechanism, q, qdot, pressures, p):
    """(a1, a2) of :func:`stability_coefficients` at bound parameters p, unchecked.

    ``a1 = (dF/dqdot) / M``, ``a2 = (dF/dq) / M``

    The same formula on floats, arrays or sympy symbols (a MechanismParams of symbols: the native
    FMUs trace it into C, where :meth:`Mechanism.bind` cannot check symbols).

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    q, qdot : float, array_like or sympy expression
        The coordinate [m or rad] and its rate [m/s or rad/s].
    pressures : sequence
        Each muscle's gauge pressure [Pa].
    p : MechanismParams
        :meth:`Mechanism.bind`'s parameters (or symbols).

    Returns
    -------
    a1 : float, array or sympy expression
        Velocity coefficient [1/s].
    a2 : float, array or sympy expression
        Position coefficient [1/s^2].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18-20.
    .. [2] model-spec sections 3b and 7d (``stable`` of a mechanism FMU).
    """
    d = force_partials(mechanism, q, qdot, pressures, p)
    return d.dF_dqdot / d.M, d.dF_dq / d.M


def sealed_coefficients(mechanism: Mechanism, q, pressures, params=DEFAULT):
    """(a1, a2) with every valve closed: sealed muscles, air springs (model-spec 4d), any mechanism.

    Each muscle's air mass is constant, so its pressure follows its length,
    ``dP_i/dL = -k_poly p (dV_b/dL) / V`` (:func:`mkctl.physics.pneumatics.sealed_stiffness`), and

    ``a2_sealed = (dF/dq + sum_i dF/dP_i dP_i/dL (dL_i/dq)) / M``, ``a1 = (dF/dqdot) / M``

    (for the knee :func:`mkctl.physics.stability.sealed_coefficients`). In the working range a
    muscle's spring adds ``-(dL_i/dq)^2 df_i/dP dP_i/dL / M < 0``: a2 more negative than with the
    pressures held.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    q : float
        The coordinate [m or rad].
    pressures : sequence of float
        Each muscle's gauge pressure as its valve closes [Pa].
    params : Params or MechanismParams
        The muscle's parameters (section 4d's k_poly, V_dead) and the mechanism's own values.

    Returns
    -------
    a1 : float
        Velocity coefficient [1/s].
    a2 : float
        Position coefficient with the air springs [1/s^2].

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18-23.
    .. [2] model-spec sections 3b and 4d (the sealed muscle).
    """
    from .air import sealed_stiffness

    p = mechanism.bind(params)
    muscle = muscle_params(p)
    pressures = tuple(float(P) for P in _pressures(mechanism, pressures))
    d = force_partials(mechanism, float(q), 0.0, pressures, p)
    L, arms, _, _ = kinematics(mechanism, float(q), p)
    dF_dq = float(d.dF_dq)
    for i, P in enumerate(pressures):
        spring = sealed_stiffness(float(L[i]), P, muscle.b, muscle.n, muscle.V_dead, muscle.k_poly)
        dF_dq += float(d.dF_dP[i]) * float(spring) * float(arms[i])
    return float(d.dF_dqdot) / float(d.M), dF_dq / float(d.M)


@dataclasses.dataclass(frozen=True, repr=False)
class MechanismStability(Result):
    """The stability analysis (Eq. 18-20) at one state of a mechanism."""

    mechanism: str
    q: float  #: the coordinate [m or rad]
    pressures: tuple  #: each muscle's pressure [Pa]
    a1: float  #: [1/s]
    a2: float  #: [1/s^2]
    poles: tuple  #: the eigenvalues of [[0, 1], [a2, a1]] [1/s]
    verdict: str  #: 'stable', 'marginal' or 'unstable'

    def summary_lines(self):
        """The repr's lines: the state and pressures, then a1, a2 and the verdict.

        Returns
        -------
        list of str
            Two lines.
        """
        shown = ", ".join(f"{P:g}" for P in self.pressures)
        return [f"{self.mechanism} at q = {self.q:.6g}, pressures {shown} Pa",
                f"a1 = {self.a1:.6g} 1/s, a2 = {self.a2:.6g} 1/s^2: {self.verdict}"]

    def table(self):
        """The result as one row.

        Returns
        -------
        list of dict
            One row: q [m or rad], a1 [1/s], a2 [1/s^2], verdict.
        """
        return [{"q": self.q, "a1": self.a1, "a2": self.a2, "verdict": self.verdict}]


def equilibrium_stability(mechanism: Mechanism, pressures, params=DEFAULT,
                          q=None) -> MechanismStability:
    """a1, a2, poles and the Routh-Hurwitz verdict of a mechanism at rest at q.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    pressures : sequence of float
        Each muscle's gauge pressure [Pa].
    params : Params or MechanismParams
        The muscle's parameters (and the mechanism's own values).
    q : float, optional
        The coordinate [m or rad]; default: the stable :func:`equilibrium` of the pressures.

    Returns
    -------
    MechanismStability
        q, the pressures [Pa], a1 [1/s], a2 [1/s^2], the poles [1/s] and the verdict ('stable',
        'marginal', 'unstable').

    Raises
    ------
    DomainError
        With q None, when there is no stable equilibrium between the stops.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18-20.
    .. [2] model-spec section 3b.
    """
    q = equilibrium(mechanism, pressures, params) if q is None else float(q)
    a1, a2 = (float(v) for v in stability_coefficients(mechanism, q, pressures, params))
    shown = tuple(float(P) for P in _pressures(mechanism, pressures))
    return MechanismStability(mechanism.name, q, shown, a1, a2,
                              tuple(complex(s) for s in _poles(a1, a2)), str(_verdict(a1, a2)))


def linearization(mechanism: Mechanism, q, pressures, commands=None, params=DEFAULT,
                  sealed: bool = False):
    """(A, B) of the equation of motion linearized at rest at q, stops excluded.

    States :func:`state_names`, inputs the pressure commands. Without pressure dynamics

    ``A = [[0, 1], [a2, a1]]``, ``B = [[0...], [dF/dP_i / M]]``

    with them the pressure columns move into A and the pressure rows hold
    :func:`mkctl.physics.actuator.pressure_derivative_partials`; a dead time adds the knee's
    first-order Pade states (:func:`mkctl.physics.knee.pade_delay`).

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    q : float
        The coordinate [m or rad].
    pressures : sequence of float
        Each muscle's gauge pressure [Pa].
    commands : sequence of float, optional
        Each muscle's pressure command [Pa]; default the pressures (a steady state).
    params : Params or MechanismParams
        The muscle's parameters (and the mechanism's own values).
    sealed : bool
        With the air on (``valve_flow``, model-spec 4d): the valves closed, the inputs the
        openings held at 0 (:func:`mkctl.physics.knee.air_state_rows`; with air_heat the
        temperature states too, at T_air).

    Returns
    -------
    A : numpy.ndarray
        State matrix, (n, n) [SI per second]. With the air the pressure rows hold the mass
        balance's partials, coupled to q and qdot through each muscle's volume.
    B : numpy.ndarray
        Input matrix, (n, muscles) [state units per s per Pa].

    Raises
    ------
    ParameterError, DomainError
        As :func:`mechanism_force`.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18.
    .. [2] model-spec sections 3b and 4 (pressure lag, dead time).
    """
    p = mechanism.bind(params)
    muscle = muscle_params(p)
    k = len(mechanism.muscles)
    pressures = tuple(float(P) for P in _pressures(mechanism, pressures))
    if commands is None:
        commands = pressures
    commands = tuple(float(c) for c in _pressures(mechanism, commands))
    d = force_partials(mechanism, float(q), 0.0, pressures, p)
    row = [float(d.dF_dq) / d.M, float(d.dF_dqdot) / d.M]
    gains = [float(g) / d.M for g in d.dF_dP]
    if actuator.air_is_on(muscle):
        L, arms, _, _ = kinematics(mechanism, float(q), p)
        rows, B = knee.air_state_rows(tuple(float(x) for x in L), tuple(float(a) for a in arms),
                                      pressures, commands, muscle, sealed)
        A = np.zeros((2 + rows.shape[0], 2 + rows.shape[0]))
        A[0, 1] = 1.0
        A[1, :2], A[1, 2:2 + k] = row, gains
        A[2:] = rows
        B = np.vstack([np.zeros((2, k)), B])
    elif not actuator.has_pressure_states(muscle):
        A = np.array([[0.0, 1.0], row])
        B = np.array([[0.0] * k, gains])
    else:
        A = np.zeros((2 + k, 2 + k))
        B = np.zeros((2 + k, k))
        A[0, 1] = 1.0
        A[1, :2], A[1, 2:] = row, gains
        for i in range(k):
            A[2 + i, 2 + i], B[2 + i, i] = actuator.pressure_derivative_partials(
                pressures[i], commands[i], muscle)
    delay = float(actuator.command_delay(muscle))
    return knee.pade_delay(A, B, delay) if delay > 0 else (A, B)


def linear_system(mechanism: Mechanism, pressures, params=DEFAULT, q=None):
    """A python-control state-space model (``control.ss``) of the mechanism linearized at rest.

    States :func:`state_names` (and with a dead time the Pade states ``<muscle>_pade``), inputs
    each muscle's pressure command (``<muscle>_cmd`` [Pa]), output the coordinate.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism.
    pressures : sequence of float
        Each muscle's gauge pressure [Pa] (and command).
    params : Params or MechanismParams
        The muscle's parameters (and the mechanism's own values).
    q : float, optional
        The coordinate [m or rad]; default: the stable :func:`equilibrium` of the pressures.

    Returns
    -------
    control.StateSpace
        The matrices of :func:`linearization`; C picks the coordinate [m or rad], D = 0.

    Raises
    ------
    DomainError
        With q None, when there is no stable equilibrium between the stops.

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Eq. 18.
    .. [2] model-spec section 3b.
    """
    import control

    q = equilibrium(mechanism, pressures, params) if q is None else float(q)
    A, B = linearization(mechanism, q, pressures, None, params)
    states = list(state_names(mechanism, params))
    states += [f"{m}_pade" for m in mechanism.muscles][: A.shape[0] - len(states)]
    C = np.zeros((1, A.shape[0]))
    C[0, 0] = 1.0
    return control.ss(A, B, C, np.zeros((1, B.shape[1])), states=states,
                      inputs=[f"{m}_cmd" for m in mechanism.muscles],
                      outputs=[mechanism.coordinate], name=mechanism.name)


# --- Simulation -----------------------------------------------------------------------------------

@dataclasses.dataclass(frozen=True, repr=False)
class MechanismRun(Result):
    """A mechanism simulated over a record: arrays on the record's time grid, SI units.

    ``time`` [s]; ``q`` the coordinate [m or rad] and ``qdot`` its rate; ``L``, ``f``, ``P``: each
    muscle's length [m], tension [N] and gauge pressure [Pa] (the lag state, or the command the
    muscle sees), shape (samples, muscles), columns in the order of ``muscles``.
    """

    mechanism: str
    coordinate: str
    muscles: tuple
    time: np.ndarray
    q: np.ndarray
    qdot: np.ndarray
    L: np.ndarray
    f: np.ndarray
    P: np.ndarray

    def summary_lines(self):
        """The repr's lines: samples and time span, then the coordinate's start, end and range.

        Returns
        -------
        list of str
            Two lines (one, "no samples", for an empty run).
        """
        if self.time.size == 0:
            return ["no samples"]
        t, q = self.time, self.q
        return [f"{self.mechanism}: {t.size} samples, t = {t[0]:g} .. {t[-1]:g} s",
                f"{self.coordinate} = {q[0]:.6g} -> {q[-1]:.6g} "
                f"(range {q.min():.6g} .. {q.max():.6g})"]

    def table(self):
        """The run as columns: time, the coordinate and its rate, each muscle's L, f and P.

        Returns
        -------
        dict of str to numpy.ndarray
            ``time`` [s], ``<coordinate>``, ``<coordinate>_dot``, and ``L_<muscle>`` [m],
            ``f_<muscle>`` [N], ``P_<muscle>`` [Pa] for each muscle.
        """
        columns = {"time": self.time, self.coordinate: self.q, self.coordinate + "_dot": self.qdot}
        for i, m in enumerate(self.muscles):
            columns.update({f"L_{m}": self.L[:, i], f"f_{m}": self.f[:, i], f"P_{m}": self.P[:, i]})
        return columns


def _commands(mechanism: Mechanism, commands, time, opening: bool = False) -> np.ndarray:
    """The pressure commands (or valve openings) as an array (samples, muscles)."""
    if len(mechanism.muscles) == 1 and np.ndim(commands) <= 1 and not (
            isinstance(commands, (tuple, list)) and len(commands) == 1):
        commands = (commands,)
    if len(commands) != len(mechanism.muscles):
        raise ParameterError(f"mechanism {mechanism.name} has {len(mechanism.muscles)} muscle(s) "
                             f"({', '.join(mechanism.muscles)}); got {len(commands)} "
                             f"{'valve opening' if opening else 'pressure command'}(s)")
    out = np.stack([np.broadcast_to(np.asarray(c, dtype=float), time.shape) for c in commands],
                   axis=1)
    if opening:
        simulate.check_openings(out)
    else:
        actuator.check_pressure(out)
    return out


def simulate_mechanism(time, commands, mechanism: Mechanism, params=DEFAULT, q0=None,
                       stops: bool = True, rtol: float = 1e-10, inputs: str = "pressure",
                       P0=None) -> MechanismRun:
    """Simulate a mechanism over a record, commands held from each sample to the next.

    As :func:`mkctl.physics.simulate.simulate_knee`: the equation of motion of
    :func:`mechanism_derivatives`, integrated over each run of held commands. With
    ``inputs="opening"`` the commands are each muscle's valve opening u [-] (model-spec 4d, 7d:
    u1, u2; clipped to [-1, 1]) and the pressures start at ``P0``; it needs the air
    (``valve_flow = 1``) and runs in Python.

    Parameters
    ----------
    time : array
        Increasing sample times [s].
    commands : sequence of arrays
        One pressure command per muscle [Pa], at those times (scalars broadcast); one array for one
        muscle.
    mechanism : Mechanism
        The mechanism.
    params : Params or MechanismParams
        The muscle's parameters and effects (one set for every muscle), and the mechanism's own
        values.
    q0 : float, optional
        The initial coordinate [m or rad]; None: at rest in the stable equilibrium of the first
        commands (model-spec 5d, :func:`equilibrium`), or with openings of ``P0``. The motion
        always starts at rest, the pressures at the first commands (or at ``P0``).
    stops : bool
        Whether the end stops act.
    rtol : float
        Relative tolerance of :func:`mkctl.physics.integrate.integrate` (absolute: 1e-9 on q and
        qdot, 1e-3 Pa).
    inputs : {"pressure", "opening"}
        What the commands are: pressure set-points [Pa] (the default) or valve openings [-]
        (:func:`mkctl.physics.simulate.check_inputs`).
    P0 : sequence of float, optional
        With openings (required then): each muscle's start pressure [Pa].

    Returns
    -------
    MechanismRun
        On the record's time grid [s]: q [m or rad], qdot, and each muscle's L [m], f [N] and
        P [Pa].

    Raises
    ------
    ParameterError
        For another number of commands than muscles, invalid own parameters, or openings without
        the air or without P0.
    DomainError
        For a command that is not finite, a q0 outside the geometry, or no stable equilibrium of
        the first commands (q0 None).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator",
       Eq. 17 (the knee's equation of motion).
    .. [2] model-spec sections 3b and 5d (mechanism records).
    """
    p = mechanism.bind(params)
    muscle = muscle_params(p)
    opening = simulate.check_inputs(inputs, muscle)
    time = np.asarray(time, dtype=float)
    commands = _commands(mechanism, commands, time, opening)
    k = commands.shape[1]
    start = None
    if opening:
        if P0 is None or np.size(P0) != k:
            raise ParameterError(f"valve openings as inputs need P0: the start pressure of each of "
                                 f"the {k} muscle(s) [Pa]")
        start = np.asarray(P0, dtype=float).reshape(k)
        actuator.check_pressure(start)
    if q0 is None:
        q0 = equilibrium(mechanism, tuple(commands[0] if start is None else start), p)
    delay = float(actuator.command_delay(muscle))
    if delay > 0 and time.size > 1:
        # the knee's cut grid: the commands as the muscles see them, a dead time late
        grid, seen_a, seen_b, at = simulate.delayed_commands(time, commands[:, 0], commands[:, -1],
                                                             delay)
        seen = np.stack([seen_a, seen_b][:k], axis=1)
        states = _run(grid, seen, mechanism, p, float(q0), stops, rtol, start)[at]
        seen = seen[at]
    else:
        seen = commands
        states = _run(time, commands, mechanism, p, float(q0), stops, rtol, start)
    q, qdot = states[:, 0].copy(), states[:, 1].copy()
    P = states[:, 2:2 + k].copy() if states.shape[1] > 2 else seen.copy()
    if time.size:
        force = mechanism_force(mechanism, q, qdot, tuple(P[:, i] for i in range(k)), p)
        L = np.stack([np.broadcast_to(v, q.shape) for v in force.L], axis=1)
        f = np.stack([np.broadcast_to(v, q.shape) for v in force.f], axis=1)
    else:
        L = f = np.empty((0, k))
    return MechanismRun(mechanism.name, mechanism.coordinate, tuple(mechanism.muscles), time, q,
                        qdot, L, f, P)


#: The record loop's absolute tolerances (q, qdot, each pressure) and first step [s] (the native
#: mechanism FMUs integrate with the same).
RUN_ATOL = (1e-9, 1e-9, 1e-3)
#: ... and of each air temperature [K] (air_heat): 1e-6 K, as 1e-3 Pa is of a 300 kPa pressure.
RUN_TEMPERATURE_ATOL = 1e-6
RUN_FIRST_STEP = 1e-3


def _run(time, commands, mechanism, p, q0, stops, rtol, start=None) -> np.ndarray:
    """The record loop: one integration per run of held commands, the samples read off the dense
    output. ``start``: each muscle's start pressure [Pa] when the commands are valve openings (the
    Python loop), None for pressure commands."""
    muscle = muscle_params(p)
    lag = actuator.has_pressure_states(muscle)
    k = commands.shape[1]
    stop_positions = mechanism.stop_positions(p) if stops else None
    opening = start is not None
    # with the air's temperatures as states (air_heat) each muscle's air starts at T_air
    heat = [float(muscle.T_air)] * k if actuator.has_temperature_states(muscle) else []
    state = np.array([q0, 0.0, *((start if opening else commands[0]) if lag else ()), *heat],
                     dtype=float)
    atol = np.array([*RUN_ATOL[:2], *([RUN_ATOL[2]] * k if lag else []),
                     *([RUN_TEMPERATURE_ATOL] * len(heat))])
    kinematics(mechanism, q0, p)  # q0 outside the geometry: the mechanism's own error, at once
    states = np.empty((time.size, state.size))
    if time.size == 0:
        return states
    states[0] = state
    hint = RUN_FIRST_STEP
    # the knee's runs of held commands (it takes two columns: one muscle's twice)
    # first in the compiled core (mkctl.native.mechanism_compiled, handed in through backend): the
    # same loop in C; after a fault (None) the loop below runs, to raise its own error in its words
    core = backend.mechanism_core(mechanism, p) if time.size > 1 and not opening else None
    compiled = None if core is None else core.run(time, commands, p, state, stop_positions,
                                                  rtol, atol, hint)
    if compiled is not None:
        return compiled
    for start, end in simulate.held_command_runs(commands[:, 0], commands[:, -1]):
        held = commands[start]

        def rhs(y, held=held):
            return mechanism_derivatives(y, held, mechanism, p, stop_positions, opening)

        wanted = np.arange(start + 1, end + 1)
        times = time[wanted] - time[start]
        if not times[-1] > 0:
            states[wanted] = state
            continue
        out = np.empty((wanted.size, state.size))
        step = time[start + 1] - time[start]
        first = min(hint, step) if step > 0 else hint
        state, hint, _ = integrate(rhs, state, times[-1], first, atol, rtol, dense_times=times,
                                   dense_out=out)
        states[wanted] = out
    return states


# --- Built-in mechanisms --------------------------------------------------------------------------

def _knee_lengths(q, p, xp):
    geo = knee.geometry_at_X(q, p, derivatives=False)  # section 3's geometry, the one definition
    return geo.Le, geo.Lf


def _mass(q, p, xp):
    return p.m


def _knee_load(q, qdot, p, xp):
    return -p.m * p.g


def _knee_stops(p):
    if actuator.is_symbolic(p.L1):  # traced (the knee alone's FMU): the angles as sympy numbers
        import sympy
        return tuple(knee.X_from_alpha(sympy.Float(a), p)
                     for a in (knee.ALPHA_STOP_LOW, knee.ALPHA_STOP_HIGH))
    return knee.stop_positions(p)


#: The paper's knee (model-spec section 3): q = X, the hip height; M = m; Q = -m g. Its parameters
#: are Table II's.
KNEE = Mechanism(
    "knee", "X", "m", ("extensor", "flexor"), (), _knee_lengths, _mass, _knee_load, _knee_stops,
    "the robot leg of Fig. 6: hip height X, an antagonistic pair around the knee "
    "(model-spec section 3)")


def _hanging_lengths(q, p, xp):
    return (q,)


def _hanging_load(q, qdot, p, xp):
    return p.m * p.g


#: Shares of the braid length b at which the hanging mass's stops sit: just above b / sqrt(3) =
#: 0.577 b, where the pressure's pull vanishes (Eq. 7), and short of the braid's full length.
HANGING_STOPS = (0.6, 0.97)


def _hanging_stops(p):
    return (HANGING_STOPS[0] * p.b, HANGING_STOPS[1] * p.b)


#: One muscle, its top fixed, a mass m hanging from it: q = L, M = m, Q = +m g (the weight pulls it
#: long).
HANGING_MASS = Mechanism(
    "hanging_mass", "L", "m", ("muscle",), (), _hanging_lengths, _mass, _hanging_load,
    _hanging_stops,
    "one muscle hanging from a fixed top with a mass m at its end (the isotonic rig, moving)")


#: The pulley joint's parameters. Defaults: a 10-mm Festo-like muscle pair (the muscle itself is
#: Table I's, 208 mm at rest) mounted pre-contracted to 190 mm (about 9 %) on a 20 mm pulley, so
#: that either can pull; the arm a uniform 0.3 m, 0.5 kg link about its end (J = m l^2 / 3 = 0.015
#: kg m^2, centre of mass at 0.15 m); stops at +-0.8 rad (lengths 174 to 206 mm: inside 0 < L < b =
#: 241 mm, within the muscle's 25 % contraction).
PULLEY_PARAMETERS = (
    Parameter("r_p", "m", 0.02, 0.0, 1.0, strict=True, default=0.02, description="pulley radius"),
    Parameter("J", "kg m^2", 0.015, 0.0, 1e3, strict=True, default=0.015,
              description="moment of inertia of the arm and pulley about the joint"),
    Parameter("L1_0", "m", 0.19, 0.0, 100.0, strict=True, default=0.19,
              description="length of muscle 1 at theta = 0"),
    Parameter("L2_0", "m", 0.19, 0.0, 100.0, strict=True, default=0.19,
              description="length of muscle 2 at theta = 0"),
    Parameter("m_arm", "kg", 0.5, 0.0, 1e4, default=0.5, description="mass of the arm"),
    Parameter("l_arm", "m", 0.15, 0.0, 100.0, default=0.15,
              description="distance from the joint to the arm's centre of mass"),
    Parameter("theta_min", "rad", -0.8, -math.pi, math.pi, default=-0.8,
              description="lower end stop"),
    Parameter("theta_max", "rad", 0.8, -math.pi, math.pi, default=0.8,
              description="upper end stop"),
)


def _pulley_lengths(q, p, xp):
    return p.L1_0 - p.r_p * q, p.L2_0 + p.r_p * q


def _pulley_inertia(q, p, xp):
    return p.J


def _pulley_load(q, qdot, p, xp):
    # theta from the hanging position: gravity pulls it back
    return -p.m_arm * p.g * p.l_arm * xp.sin(q)


def _pulley_stops(p):
    return (p.theta_min, p.theta_max)


#: Two antagonistic muscles over a pulley of radius r_p turning an arm: q = theta [rad] from hanging
#: down, L1 = L1_0 - r_p theta (muscle 1 raises theta), L2 = L2_0 + r_p theta, M = J, Q = -m_arm g
#: l_arm sin(theta).
PULLEY_JOINT = Mechanism(
    "pulley_joint", "theta", "rad", ("muscle1", "muscle2"), PULLEY_PARAMETERS, _pulley_lengths,
    _pulley_inertia, _pulley_load, _pulley_stops,
    "an antagonistic pair over a pulley turning an arm against gravity (most PAM robots' joint)")

#: The built-in mechanisms by name (model-spec section 3b); ``knee`` is the default.
BUILTIN = MappingProxyType({m.name: m for m in (KNEE, HANGING_MASS, PULLEY_JOINT)})


def builtin_mechanism(name: str) -> Mechanism:
    """A built-in mechanism by name (:data:`BUILTIN`).

    A mechanism file (model-spec 3b) is read by :func:`mkctl.analysis.mechanism_files.mechanism`.

    Parameters
    ----------
    name : str
        ``knee``, ``hanging_mass`` or ``pulley_joint``.

    Returns
    -------
    Mechanism
        The built-in mechanism of that name.

    Raises
    ------
    ParameterError
        A one-line error for another name, listing the built-ins.

    References
    ----------
    .. [1] model-spec section 3b (the built-ins' table).
    """
    try:
        return BUILTIN[name]
    except KeyError:
        known = ", ".join(BUILTIN)
        raise ParameterError(f"unknown mechanism {name!r} (built-in: {known})") from None
