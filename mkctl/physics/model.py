"""The model as a value: the effects a parameter set is of (model-spec sections 2-4c).

A :class:`Model` is an immutable, hashable, picklable value: the paper's actuator and knee (Tables I
and II, always there) and the effects it knows (the built-ins of
:mod:`mkctl.physics.builtin_effects`, in the spec's order, then yours). It makes its own parameter
sets (:meth:`mkctl.physics.params.Params.of`), and every parameter set remembers the model it is of
(:attr:`mkctl.physics.params.Params.definition`), so that a computation reads the effects from the
set it is handed, never from a process-wide table: a set made before an effect was added is of the
model it was made with, and a Dask worker that receives a set receives its model too.

:func:`mkctl.physics.effects.register` stays as sugar: it replaces the model that ``Params()``
makes its sets of by that model with one more effect.

Example
-------
>>> from mkctl.physics.model import Model
>>> from mkctl.physics.effect import Effect, Parameter
>>> cubic = Effect("cubic_stiffness", "f += k3 (L - L0)^3",
...                parameters=(Parameter("k3", "N/m^3", off=0.0, lower=0.0, upper=1e9),),
...                tension=lambda L, Ldot, P, p, xp: p.k3 * (L - p.L0) ** 3)
>>> model = Model.builtin().with_effect(cubic)
>>> from mkctl.physics.params import Params
>>> Params.of(model, k3=1e6).effects
('elasticity', 'cubic_stiffness')
>>> "k3" in Model.builtin().parameter_names
False
"""
from __future__ import annotations

import dataclasses
import math

from ..errors import ParameterError
from .builtin_effects import BUILTIN
from .effect import QUASI_STATIC_KINDS, Effect, EffectError, Parameter
from .tables import BASE_NAMES, TABLE_I, TABLE_II, derived_turns, rubber_volume
from .xp import math_for

#: Names a parameter set answers for besides its parameters (:class:`~mkctl.physics.params.Params`):
#: no effect's parameter may take one.
RESERVED_NAMES = ("definition", "effects", "V_r", "replace", "as_dict", "of")

#: The built-in effects as the registry holds them (marked built in: never removed).
_BUILTIN = tuple(dataclasses.replace(e, builtin=True) for e in BUILTIN)
_BUILTIN_BY_NAME = {e.name: e for e in _BUILTIN}


class Model:
    """The paper's model with a set of effects: immutable, hashable, picklable.

    Parameters
    ----------
    effects : tuple of Effect
        Every effect the model knows, in order (the built-ins first); switched on or off by a
        parameter set's values. Checked as :meth:`with_effect` checks a new one.

    Raises
    ------
    EffectError
        One line naming the effect: see :meth:`with_effect`.

    References
    ----------
    .. [1] model-spec sections 4 (the effects), 4b (a real rig's), 4c (yours), 4d (the air).
    """

    __slots__ = ("effects", "_by_name", "_parameters", "_names", "_switches", "_hash")

    def __init__(self, effects: tuple[Effect, ...]):
        effects = tuple(effects)
        by_name: dict[str, Effect] = {}
        for effect in effects:
            _check_effect(effect, by_name)
            by_name[effect.name] = effect
        object.__setattr__(self, "effects", effects)
        object.__setattr__(self, "_by_name", by_name)
        parameters = tuple(q for e in effects for q in e.parameters)
        object.__setattr__(self, "_parameters", parameters)
        # read at every parameter set made: derived once, as the model never changes
        object.__setattr__(self, "_names", (*BASE_NAMES, *(q.name for q in parameters)))
        object.__setattr__(self, "_switches", frozenset(q.name for q in parameters if q.switch))
        object.__setattr__(self, "_hash", hash(tuple((e.name, id(e)) for e in effects)))

    @classmethod
    def builtin(cls) -> "Model":
        """The model of the spec's effects (sections 4, 4b, 4d), nothing of yours.

        Returns
        -------
        Model
            The same value at every call.
        """
        return _BUILTIN_MODEL

    # --- a value: immutable, compared by the effects it holds, pickled by what they are ------
    def __setattr__(self, name, value):
        raise AttributeError("a Model is immutable: use with_effect() or without()")

    def __eq__(self, other) -> bool:
        if not isinstance(other, Model):
            return NotImplemented
        return len(self.effects) == len(other.effects) and all(
            a is b for a, b in zip(self.effects, other.effects))

    def __hash__(self) -> int:
        return self._hash

    def __reduce__(self):
        # the built-ins travel by name (their terms are this package's functions); yours travel
        # as they are (Dask's cloudpickle carries a file's functions by value)
        return (_model_from, (tuple(e.name if e.builtin else e for e in self.effects),))

    def __repr__(self) -> str:
        return f"Model({', '.join(self.names)})"

    # --- what it holds ------------------------------------------------------------------------
    @property
    def names(self) -> tuple[str, ...]:
        """The effects' names, in order."""
        return tuple(self._by_name)

    @property
    def parameters(self) -> tuple[Parameter, ...]:
        """Every parameter the effects bring, in the effects' order."""
        return self._parameters

    @property
    def parameter_names(self) -> tuple[str, ...]:
        """Every name of a parameter set of this model: the tables', then the effects'."""
        return self._names

    @property
    def switch_names(self) -> frozenset[str]:
        """The parameters that are whole-number switches (``model``, ``slack``, ...)."""
        return self._switches

    def get(self, name: str) -> Effect:
        """The effect of this name.

        Parameters
        ----------
        name : str
            The effect's name.

        Returns
        -------
        Effect

        Raises
        ------
        ParameterError
            For an effect the model does not know (the known ones listed).
        """
        try:
            return self._by_name[name]
        except KeyError:
            raise ParameterError(
                f"unknown effect {name!r} (known: {', '.join(self._by_name)})") from None

    def __contains__(self, name: str) -> bool:
        return name in self._by_name

    def extends(self, other: "Model") -> bool:
        """Whether this model holds every effect of another (the same definitions, maybe more).

        Parameters
        ----------
        other : Model

        Returns
        -------
        bool
            True when a set of ``other`` means the same physics as a set of this model with the
            further effects off.
        """
        mine = {id(e) for e in self.effects}
        return all(id(e) in mine for e in other.effects)

    # --- new values ---------------------------------------------------------------------------
    def with_effect(self, effect: Effect) -> "Model":
        """This model with one more effect (model-spec section 4c).

        Parameters
        ----------
        effect : Effect
            The effect: its name, parameters and terms.

        Returns
        -------
        Model
            A new model; this one is unchanged.

        Raises
        ------
        EffectError
            One line naming the effect: a name already taken, a parameter named twice or
            already a parameter of mkctl, bounds that exclude the off value, or terms that
            cannot be evaluated on floats and on symbols.
        """
        if not isinstance(effect, Effect):
            raise EffectError(f"register() takes an Effect, got {type(effect).__name__}")
        model = Model((*self.effects, effect))
        if not effect.builtin:
            _check_term(effect, model)
        return model

    def without(self, name: str) -> "Model":
        """This model without an effect that is not built in.

        Parameters
        ----------
        name : str
            The effect's name; an unknown one gives this model.

        Returns
        -------
        Model

        Raises
        ------
        EffectError
            For a built-in effect.
        """
        effect = self._by_name.get(name)
        if effect is None:
            return self
        if effect.builtin:
            raise EffectError(f"effect {name!r} is built in and cannot be removed")
        return Model(tuple(e for e in self.effects if e is not effect))


def model_of(params) -> Model:
    """The model a parameter set is of (:attr:`mkctl.physics.params.Params.definition`).

    Parameters
    ----------
    params : Params, SymbolicParams or a stand-in with the parameters as attributes
        The set; a stand-in without a model (a user file's probe) is of the current one.

    Returns
    -------
    Model
    """
    model = getattr(params, "definition", None)
    return current() if model is None else model


def _model_from(effects: tuple) -> Model:
    """A model again from a pickle: built-ins by name, the others as they came."""
    return Model(tuple(_BUILTIN_BY_NAME[e] if isinstance(e, str) else e for e in effects))


def _check_effect(effect: Effect, known: dict) -> None:
    """Refuse, in one line, an effect that cannot join a model that knows ``known``."""
    if not isinstance(effect, Effect):
        raise EffectError(f"a model holds Effects, got {type(effect).__name__}")
    if not effect.name.isidentifier():
        raise EffectError(f"effect {effect.name!r}: the name must be an identifier")
    if effect.name in known:
        what = "a built-in effect" if known[effect.name].builtin else "already registered"
        raise EffectError(f"effect {effect.name!r}: the name is {what}")
    if not effect.parameters:
        raise EffectError(
            f"effect {effect.name!r}: it needs at least one parameter (the one that switches it on)"
        )
    taken = set(BASE_NAMES) | set(RESERVED_NAMES)
    taken |= {n for e in known.values() for n in e.parameter_names}
    seen: set[str] = set()
    for q in effect.parameters:
        _check_parameter(effect, q, taken, seen)
        seen.add(q.name)
    if effect.switched_by is not None and effect.switched_by not in seen:
        raise EffectError(f"effect {effect.name!r}: switched_by {effect.switched_by!r} is not one"
                          " of its parameters")
    if effect.quasi_static not in QUASI_STATIC_KINDS:
        raise EffectError(
            f"effect {effect.name!r}: quasi_static must be one of {QUASI_STATIC_KINDS}")
    if (effect.quasi_static == "play" and effect.play is None
            or effect.quasi_static == "viscous" and effect.viscous is None):
        raise EffectError(
            f"effect {effect.name!r}: a {effect.quasi_static!r} limit needs its function")
    if (effect.tension is None and effect.pressure_rate is None and effect.final is None
            and effect.command_delay is None and not effect.moves_air):
        raise EffectError(
            f"effect {effect.name!r}: it changes nothing (give tension, pressure_rate, final, "
            "command_delay, air_flow, valve_opening or air_temperature)")
    unknown = [name for name in effect.requires if name not in known]
    if unknown:
        raise EffectError(
            f"effect {effect.name!r}: it requires {unknown[0]!r}, which is not registered")
    if effect.fitted is not None and effect.fitted not in seen and effect.fitted not in effect.uses:
        raise EffectError(f"effect {effect.name!r}: fitted parameter {effect.fitted!r} is not one"
                          " of its parameters")
    for experiment, (low, high) in effect.experiments.items():
        if not 0 < low <= high:
            raise EffectError(f"effect {effect.name!r}: search bounds for {experiment} must be"
                              " positive and ordered")


def _check_parameter(effect: Effect, q: Parameter, taken: set, seen: set) -> None:
    """Refuse, in one line, a parameter of a new effect: its name, its bounds and values."""
    where = f"effect {effect.name!r}: parameter {q.name!r}"
    if not q.name.isidentifier():
        raise EffectError(f"{where} is not an identifier")
    if q.name in seen:
        raise EffectError(f"{where} is named twice")
    if q.name in taken:
        raise EffectError(f"{where} is already a parameter of mkctl")
    values = (q.off, q.lower, q.upper, q.scale) + ((q.typical,) if q.typical is not None else ())
    if any(not isinstance(v, (int, float)) or isinstance(v, bool) or math.isnan(v)
           for v in values):
        raise EffectError(f"{where} has a bound or value that is not a number")
    if not q.lower < q.upper:
        raise EffectError(f"{where}: lower bound {q.lower:g} is not below the upper {q.upper:g}")
    try:
        q.check(q.off)
        q.check(q.start)
        if q.typical is not None:
            q.check(q.typical)
    except ParameterError as error:
        raise EffectError(f"effect {effect.name!r}: the bounds exclude a value it declares"
                          f" ({error})") from None
    if not q.scale > 0:
        raise EffectError(f"{where} needs a positive scale")


class _ProbeParams:
    """Plain numbers by attribute, as a parameter set reads (V_r derived): what a new term is tried
    on."""

    def __init__(self, values: dict):
        self.__dict__.update(values)

    @property
    def V_r(self) -> float:
        return rubber_volume(self.t0, self.D0, self.L0)


def _probe_values(effect: Effect, model: Model) -> dict:
    """Numbers to evaluate an effect's terms at: Table I and II, every parameter of the model at
    its start value, and the effect's own at a value where it is on (its typical value, else a
    bound)."""
    values = {name: q.value for name, q in {**TABLE_I, **TABLE_II}.items()}
    values["n"] = derived_turns(values["b"], values["L0"], values["D0"])
    values.update({q.name: q.start for q in model.parameters})
    values.update({q.name: (q.typical if q.typical is not None
                            else (q.upper if math.isfinite(q.upper) else q.lower + 1.0))
                   for q in effect.parameters})
    return values


def _check_term(effect: Effect, model: Model) -> None:
    """Evaluate the effect's terms once on floats and once on sympy symbols: a term that fails
    either way (a name mkctl's math namespace lacks, a Python branch on a symbol) is refused here,
    in one line.
    """
    for label in ("on floats", "on symbols"):
        try:
            if label == "on symbols":
                import sympy

                L, Ldot, P, f = sympy.symbols("L Ldot P f", real=True)
                p = SymbolicParams(model=model)
            else:
                L, Ldot, P, f = 0.19, 0.01, 2e5, 10.0
                p = _ProbeParams(_probe_values(effect, model))
            _evaluate_terms(effect, L, Ldot, P, f, p, math_for(L))
        except Exception as error:  # any failure of user code: which effect and why, in one line
            raise EffectError(f"effect {effect.name!r}: its terms cannot be evaluated {label} "
                              f"({type(error).__name__}: {error})") from None
    if effect.tension is not None:
        _check_tension_off_and_finite(effect, model)


def _check_tension_off_and_finite(effect: Effect, model: Model) -> None:
    """A tension term is finite on a grid of lengths, rates and pressures at its typical values and
    at its off values, and 0 at the off values: an effect switched off changes nothing (model-spec
    4c). One rule for an effect from Python and from a file."""
    import numpy as np

    on = _ProbeParams(_probe_values(effect, model))
    off_values = {q.name: q.off for q in effect.parameters}
    off = _ProbeParams({**_probe_values(effect, model), **off_values})
    L = np.linspace(0.6, 0.99, 7) * on.b
    Ldot, P = np.linspace(-0.2, 0.2, 7), np.linspace(0.0, 6e5, 7)
    try:
        # an overflow or a division by zero is a term not finite: refused below in one line, not a
        # RuntimeWarning printed before it
        with np.errstate(all="ignore"):
            at_off = np.asarray(effect.tension(L, Ldot, P, off, math_for(L)), dtype=float)
            typical = np.asarray(effect.tension(L, Ldot, P, on, math_for(L)), dtype=float)
    except Exception as error:
        raise EffectError(f"effect {effect.name!r}: term fails with numpy arrays "
                          f"({type(error).__name__}: {error})") from None
    if not np.all(np.isfinite(at_off)):
        raise EffectError(f"effect {effect.name!r}: term is not finite with every parameter at its "
                          "off value")
    if not np.all(np.isfinite(typical)):
        raise EffectError(f"effect {effect.name!r}: term is not finite at the typical values")
    if np.any(np.abs(at_off) > 1e-12 * (1.0 + np.max(np.abs(typical)))):
        raise EffectError(f"effect {effect.name!r}: term is not 0 with every parameter at its off "
                          "value (an effect switched off must change nothing)")


def _evaluate_terms(effect: Effect, L, Ldot, P, f, p, xp) -> None:
    """Call each term an effect gives once, on the values given (their results are not kept)."""
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


_BUILTIN_MODEL = Model(_BUILTIN)

#: The model ``Params()`` makes its sets of: the built-ins, then the effects registered since.
#: :func:`register` replaces it by a new value; a set already made keeps the model it was made of.
_current: list[Model] = [_BUILTIN_MODEL]


def current() -> Model:
    """The model that ``Params()`` makes its sets of: the built-ins and the effects registered.

    Returns
    -------
    Model
        An immutable value (:class:`mkctl.physics.model.Model`); registering an effect replaces
        it by another, and caches keyed on it see the change.
    """
    return _current[0]



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
    model : Model, optional
        The model whose names and effects are traced (default: :func:`current`).
    """

    def __init__(self, on=None, fixed: dict | None = None, model: Model | None = None):
        import sympy

        model = current() if model is None else model
        self.__dict__["definition"] = model
        for name in model.parameter_names:
            self.__dict__[name] = sympy.Symbol(name, real=True)
        for effect in model.effects:
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
        model = params.definition
        return cls(on={e.name for e in model.effects if e.is_on(params)}, model=model)

    @property
    def V_r(self):
        return rubber_volume(self.t0, self.D0, self.L0)
