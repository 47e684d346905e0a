"""The registry of every effect beyond the paper (model-spec sections 4, 4b, 4c): the built-ins and
yours.

An :class:`~mkctl.physics.effect.Effect` says everything mkctl needs to know about one effect, in
one place (the built-ins are defined in :mod:`mkctl.physics.builtin_effects`):

- its parameters (:class:`Parameter`: unit, off value, allowed bounds, the value synth hides it at,
  a typical magnitude, whether it is a 0/1 switch or a setting that is never fitted), which become
  fields of :class:`mkctl.physics.params.Params`, FMU parameters and metadata names;
- what it changes in the model, written ONCE on the math namespace ``xp`` mkctl hands in (Python
  floats, numpy arrays or sympy symbols), so that the same function runs in Python, is traced into
  the compiled core and the native FMUs, and is differentiated exactly (``sympy.diff``) for the
  knee-force partials and the linearization:

  * ``tension(L, Ldot, P, p, xp)``: a term added to each actuator's tension before the final
    limits [N];
  * ``pressure_rate(P, P_cmd, p, xp)``: a term added to each actuator's pressure rate [Pa/s] (the
    pressures then become states of the knee);
  * ``final(f, p, xp)``: a limit applied last to the whole tension (slack: ``max(f, 0)``);

- its quasi-static limit, for the isotonic and isometric tests where nothing moves fast: the
  tension term at Ldot = 0 always stays (elasticity's whole term, nothing of damping's or
  friction's), and on top of it ``"play"`` (a band of half-width ``play(P, p, xp)`` [N] around the
  static tension: a play operator, or two branches at a clamped length, as Coulomb friction),
  ``"viscous"`` (a coefficient ``viscous(p)`` [N s/m]: backward Euler in the isotonic test, as
  damping) or ``"static"``/None (nothing more);
- how the diagnosis sees it: the experiments it can show in, with the search bounds of its fitted
  parameter, its signature regressor and the experiment that separates it from each other effect.

The registry keeps the effects in a stable order (the spec's, then the order of registration).
:func:`register` adds an effect at run time (``mkctl.effects.register``, model-spec section 4c); its
parameters join :class:`~mkctl.physics.params.Params` at once.

Example
-------
>>> from mkctl.physics import effects
>>> [e.name for e in effects.all_effects()][:3]
['elasticity', 'viscous_damping', 'coulomb_friction']
>>> effects.get("coulomb_friction").parameter_names
('Fc', 'vs')
"""

from __future__ import annotations

import dataclasses
import math
from types import MappingProxyType
from typing import Mapping

from ..errors import ParameterError
from .builtin_effects import (
    BUILTIN,
    DISCOVERY_DELAYS,
    DISCOVERY_LAGS,  # noqa: F401 (re-exported)
    DISCOVERY_THRESHOLDS,
)
from .effect import (
    QUASI_STATIC_KINDS,
    DiscoveryColumn,
    Effect,
    EffectError,  # noqa: F401 (re-exported)
    Parameter,
    outside_domain_message,
)
from .tables import BASE_NAMES, TABLE_I, TABLE_II, derived_turns, rubber_volume
from .xp import math_for

_REGISTRY: dict[str, Effect] = {}
#: Bumped at every registration: caches keyed by the registry's contents compare it.
_generation = [0]


def generation() -> int:
    """A number that changes whenever an effect is registered or removed.

    Returns
    -------
    int
        The registry's generation: caches keyed by the registry's contents compare it.
    """
    return _generation[0]


def _check_effect(effect: Effect) -> None:
    if not effect.name.isidentifier():
        raise EffectError(f"effect {effect.name!r}: the name must be an identifier")
    if effect.name in _REGISTRY:
        what = "a built-in effect" if _REGISTRY[effect.name].builtin else "already registered"
        raise EffectError(f"effect {effect.name!r}: the name is {what}")
    if not effect.parameters:
        raise EffectError(
            f"effect {effect.name!r}: it needs at least one parameter (the one that switches it on)"
        )
    taken = set(BASE_NAMES) | {n for e in _REGISTRY.values() for n in e.parameter_names}
    seen = set()
    for q in effect.parameters:
        if not q.name.isidentifier():
            raise EffectError(
                f"effect {effect.name!r}: parameter name {q.name!r} is not an identifier"
            )
        if q.name in seen:
            raise EffectError(f"effect {effect.name!r}: parameter {q.name!r} is named twice")
        if q.name in taken:
            raise EffectError(
                f"effect {effect.name!r}: parameter {q.name!r} is already a parameter of mkctl"
            )
        seen.add(q.name)
        values = (q.off, q.lower, q.upper, q.scale) + (
            (q.typical,) if q.typical is not None else ()
        )
        if any(
            not isinstance(v, (int, float)) or isinstance(v, bool) or math.isnan(v) for v in values
        ):
            raise EffectError(
                f"effect {effect.name!r}: parameter {q.name!r} has a bound or value that is not a"
                " number"
            )
        if not q.lower <= q.upper:
            raise EffectError(
                f"effect {effect.name!r}: parameter {q.name!r} has lower bound {q.lower:g} above"
                f" its upper bound {q.upper:g}"
            )
        try:
            q.check(q.off)
            q.check(q.start)
            if q.typical is not None:
                q.check(q.typical)
        except ParameterError as error:
            raise EffectError(
                f"effect {effect.name!r}: the bounds exclude a value it declares ({error})"
            ) from None
        if not q.scale > 0:
            raise EffectError(
                f"effect {effect.name!r}: parameter {q.name!r} needs a positive scale"
            )
    if effect.switched_by is not None and effect.switched_by not in seen:
        raise EffectError(
            f"effect {effect.name!r}: switched_by {effect.switched_by!r} is not one of its"
            " parameters"
        )
    if effect.quasi_static not in QUASI_STATIC_KINDS:
        raise EffectError(
            f"effect {effect.name!r}: quasi_static must be one of {QUASI_STATIC_KINDS}"
        )
    if (
        effect.quasi_static == "play"
        and effect.play is None
        or effect.quasi_static == "viscous"
        and effect.viscous is None
    ):
        raise EffectError(
            f"effect {effect.name!r}: a {effect.quasi_static!r} limit needs its function"
        )
    if (
        effect.tension is None
        and effect.pressure_rate is None
        and effect.final is None
        and effect.command_delay is None
        and not effect.moves_air
    ):
        raise EffectError(
            f"effect {effect.name!r}: it changes nothing (give tension, pressure_rate, final, "
            "command_delay, air_flow, valve_opening or air_temperature)"
        )
    unknown = [name for name in effect.requires if name not in _REGISTRY]
    if unknown:
        raise EffectError(
            f"effect {effect.name!r}: it requires {unknown[0]!r}, which is not registered"
        )
    if effect.fitted is not None and effect.fitted not in seen and effect.fitted not in effect.uses:
        raise EffectError(
            f"effect {effect.name!r}: fitted parameter {effect.fitted!r} is not one of its"
            " parameters"
        )
    for experiment, (low, high) in effect.experiments.items():
        if not 0 < low <= high:
            raise EffectError(
                f"effect {effect.name!r}: search bounds for {experiment} must be positive and"
                " ordered"
            )


def _probe_values(effect: Effect) -> dict:
    """Numbers to evaluate an effect's terms at: Table I and II, every registered parameter at its
    start value, and the effect's own at a value where it is on (its typical value, else a
    bound)."""
    values = {name: q.value for name, q in {**TABLE_I, **TABLE_II}.items()}
    values["n"] = derived_turns(values["b"], values["L0"], values["D0"])
    values.update({q.name: q.start for q in parameters()})
    values.update(
        {
            q.name: (
                q.typical
                if q.typical is not None
                else (q.upper if math.isfinite(q.upper) else q.lower + 1.0)
            )
            for q in effect.parameters
        }
    )
    return values


class _ProbeParams:
    """Plain numbers by attribute, as a parameter set reads (V_r derived): what a new term is tried
    on."""

    def __init__(self, values: dict):
        self.__dict__.update(values)

    @property
    def V_r(self) -> float:
        return rubber_volume(self.t0, self.D0, self.L0)


def _check_term(effect: Effect) -> None:
    """Evaluate the effect's terms once on floats and once on sympy symbols: a term that fails
    either way (a name mkctl's math namespace lacks, a Python branch on a symbol) is refused here,
    in one line.
    """
    for label in ("on floats", "on symbols"):
        try:
            if label == "on symbols":
                import sympy

                L, Ldot, P, f = sympy.symbols("L Ldot P f", real=True)
                p = SymbolicParams()
            else:
                L, Ldot, P, f, p = 0.19, 0.01, 2e5, 10.0, _ProbeParams(_probe_values(effect))
            xp = math_for(L)
            if effect.tension is not None:
                effect.tension(L, Ldot, P, p, xp)
            if effect.pressure_rate is not None:
                effect.pressure_rate(P, P * 1.1, p, xp)
            if effect.final is not None:
                effect.final(f, p, xp)
            if effect.command_delay is not None:
                effect.command_delay(p)
            if effect.air_flow is not None:
                effect.air_flow(P, 293.15 + L, 0.5, p, xp)
            if effect.valve_opening is not None:
                effect.valve_opening(P, P * 1.1, p, xp)
            if effect.air_temperature is not None:
                effect.air_temperature(P, 293.15 + L, 3e-5, Ldot * 1e-4, 1e-4, p, xp)
        except (
            Exception
        ) as error:  # any failure of user code: say which effect and why, in one line
            raise EffectError(
                f"effect {effect.name!r}: its terms cannot be evaluated {label} "
                f"({type(error).__name__}: {error})"
            ) from None


def register(effect: Effect, _builtin: bool = False) -> Effect:
    """Add an effect to the registry (model-spec section 4c); its parameters join Params at once.

    Parameters
    ----------
    effect : Effect
        The effect (its name, parameters and terms).
    _builtin : bool, optional
        For the built-ins only: their terms are not traced again.

    Returns
    -------
    Effect
        The effect as registered.

    Raises
    ------
    EffectError
        One line naming the effect: a name already taken, a parameter named twice or already a
        parameter of mkctl, bounds that exclude the off value, or terms that cannot be evaluated on
        floats and on symbols.
    """
    if not isinstance(effect, Effect):
        raise EffectError(f"register() takes an Effect, got {type(effect).__name__}")
    if _builtin:
        effect = dataclasses.replace(effect, builtin=True)
    _check_effect(effect)
    _REGISTRY[effect.name] = effect
    _generation[0] += 1
    if not _builtin:
        try:
            _check_term(effect)
        except EffectError:
            del _REGISTRY[effect.name]
            _generation[0] += 1
            raise
    return effect


def unregister(name: str) -> None:
    """Remove a registered effect that is not built in (tests register throwaway effects).

    Parameters
    ----------
    name : str
        The effect's name; an unknown one is ignored.

    Raises
    ------
    EffectError
        For a built-in effect.
    """
    effect = _REGISTRY.get(name)
    if effect is None:
        return
    if effect.builtin:
        raise EffectError(f"effect {name!r} is built in and cannot be removed")
    del _REGISTRY[name]
    _generation[0] += 1


def get(name: str) -> Effect:
    """The registered effect of this name.

    Parameters
    ----------
    name : str
        The effect's name.

    Returns
    -------
    Effect
        Its definition.

    Raises
    ------
    ParameterError
        For an unknown effect (the known ones listed).
    """
    try:
        return _REGISTRY[name]
    except KeyError:
        raise ParameterError(f"unknown effect {name!r} (known: {', '.join(_REGISTRY)})") from None


def all_effects() -> tuple[Effect, ...]:
    """Every registered effect, in the registry's order.

    Returns
    -------
    tuple of Effect
        The spec's built-ins first, then the others in the order of registration.
    """
    return tuple(_REGISTRY.values())


def names() -> tuple[str, ...]:
    """The names of every registered effect.

    Returns
    -------
    tuple of str
        In the registry's order.
    """
    return tuple(_REGISTRY)


def effect_parameters() -> Mapping[str, tuple[str, ...]]:
    """The parameters that describe each effect (``params.EFFECT_PARAMETERS``).

    Returns
    -------
    Mapping of str to tuple of str
        Each effect's name to its parameters' names (the table values it uses first).
    """
    return MappingProxyType({e.name: e.names for e in all_effects()})


def parameters() -> tuple[Parameter, ...]:
    """Every parameter the effects bring.

    Returns
    -------
    tuple of Parameter
        In the registry's order.
    """
    return tuple(q for e in all_effects() for q in e.parameters)


def effect_of(parameter: str) -> Effect | None:
    """The effect a parameter belongs to: its own or one it uses (elasticity: C1, C2).

    Parameters
    ----------
    parameter : str
        A parameter's name.

    Returns
    -------
    Effect or None
        The first effect in the registry's order that names it, or None.
    """
    for e in all_effects():
        if parameter in e.parameter_names or parameter in e.uses:
            return e
    return None


def separating_experiment(a: str, b: str) -> str:
    """The experiment that tells two effects apart, as either one's definition gives it.

    Parameters
    ----------
    a, b : str
        The two effects' names.

    Returns
    -------
    str
        The experiment in words, or "" when neither definition gives one (or one is unknown).
    """
    return (
        get(a).separation.get(b) or get(b).separation.get(a, "")
        if a in _REGISTRY and b in _REGISTRY
        else ""
    )


def parameter_names() -> tuple[str, ...]:
    """Every parameter name of a parameter set.

    Returns
    -------
    tuple of str
        The tables' names, then each registered effect's, in the registry's order.
    """
    return (*BASE_NAMES, *(q.name for q in parameters()))


class SymbolicParams:
    """A parameter set of sympy symbols: what the equations are traced on (C, exact derivatives).

    A stand-in for :class:`~mkctl.physics.params.Params` whose values are sympy symbols named after
    the parameters.

    An effect traced off has its switch parameter at its off value; one traced on has it as a
    symbol (positive when its off value is the lower bound 0), except a whole-number switch (model,
    slack), which holds its "on" value.

    Parameters
    ----------
    on : collection of str, optional
        The names of the effects to trace as switched on (default: every effect).
    fixed : dict, optional
        Further names held at the given numbers.
    """

    def __init__(self, on=None, fixed: dict | None = None):
        import sympy

        for name in parameter_names():
            self.__dict__[name] = sympy.Symbol(name, real=True)
        for effect in all_effects():
            q = effect.switch_parameter
            if on is not None and effect.name not in on:
                self.__dict__[q.name] = q.off
            elif q.switch:
                self.__dict__[q.name] = q.on_value
            elif q.off == 0 and q.lower == 0:
                self.__dict__[q.name] = sympy.Symbol(q.name, positive=True)
        self.__dict__.update(fixed or {})

    @classmethod
    def like(cls, params) -> "SymbolicParams":
        """Symbols for every value, with the effects switched on that are on in a parameter set.

        Parameters
        ----------
        params : Params
            The parameter set whose effects are traced as on.

        Returns
        -------
        SymbolicParams
            The symbolic stand-in.
        """
        return cls(on={e.name for e in all_effects() if e.is_on(params)})

    @property
    def V_r(self):
        return rubber_volume(self.t0, self.D0, self.L0)


def why(name: str) -> str:
    """What an effect changes, in a few words: its short text, else its description.

    Parameters
    ----------
    name : str
        A registered effect's name.

    Returns
    -------
    str
        The text of the diagnosis report's "why" column.

    Raises
    ------
    ParameterError
        For an unknown effect.
    """
    effect = get(name)
    return effect.why or effect.description


for _effect in BUILTIN:  # the registry starts with the built-ins, in the spec's order
    register(_effect, _builtin=True)
