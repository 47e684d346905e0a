"""Parameter sets: Table I (actuator), Table II (knee) and the effects of model-spec section 4.

All values are SI (m, s, N, Pa, kg). :class:`Params` is one immutable, flat set holding every name
of model-spec sections 2-4, so that the same names work everywhere: in Python (``Params(m=2.5)``),
in a measurement file's metadata (``# m = 2.5``) and as FMU parameters.

Derived values (model-spec section 2):

- ``n = sqrt(b^2 - L0^2) / (pi D0)``, the turns of a thread, missing from Table I. It makes the
  braid geometry of Eq. 5 pass through the rest state (L0, D0).
- ``V_r = pi t0 (D0 - t0) L0``, the rubber volume of Eq. 8-9 (an annulus times L0).

References: "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator" (the seed
paper), Table I, Table II, Eq. 5 and 8-9; model-spec sections 2 (n, V_r), 3 (Table II's r) and 4
(the effects' parameters).

Example
-------
>>> from mkctl.physics.params import Params
>>> p = Params(m=2.5, c=40.0)
>>> p.effects
('elasticity', 'viscous_damping')
"""
from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from types import MappingProxyType
from typing import NamedTuple

from . import effects
from .model import Model
from .effects import outside_domain_message  # noqa: F401  (re-exported: native FMUs write it in C)
from ..errors import ParameterError
from .tables import (BASE_NAMES, RATED_PRESSURE, TABLE_I, TABLE_II,  # noqa: F401 (re-exported)
                     Quantity, derived_turns, rubber_volume)


#: Table parameters that must be positive, and those that must not be negative (the effects' own
#: bounds are in their definitions, :mod:`mkctl.physics.effects`).
_POSITIVE = ("b", "L0", "D0", "t0", "m", "L1", "L2", "L5", "L6", "Lo", "Lu", "r", "g")
_NOT_NEGATIVE = ("C1", "C2", "Lec", "Lfc")


class LiveSequence(Sequence):
    """A tuple-like view of the current model's names (effects registered at run time included).

    The current model (:func:`mkctl.physics.effects.current`) is the one ``Params()`` makes its
    sets of.

    Parameters
    ----------
    compute : callable
        ``compute() -> iterable``, the items; called again whenever the current model is another
        value, its result kept until then.
    """

    def __init__(self, compute):
        self._compute = compute
        self._cache = (None, ())

    def _items(self) -> tuple:
        key = effects.current()
        if self._cache[0] is not key:
            self._cache = (key, tuple(self._compute()))
        return self._cache[1]

    def __getitem__(self, index):
        return self._items()[index]

    def __len__(self) -> int:
        return len(self._items())

    def __contains__(self, item) -> bool:
        return item in self._items()

    def __iter__(self):
        return iter(self._items())

    def __eq__(self, other) -> bool:
        return (tuple(self) == tuple(other) if isinstance(other, (tuple, list, LiveSequence))
                else NotImplemented)

    def __hash__(self):
        return hash(tuple(self))

    def __repr__(self) -> str:
        return repr(self._items())

    def __add__(self, other):
        return tuple(self) + tuple(other)

    def __radd__(self, other):
        return tuple(other) + tuple(self)


class LiveMapping(Mapping):
    """A read-only mapping of the current model (as :class:`LiveSequence`).

    Parameters
    ----------
    compute : callable
        ``compute() -> mapping`` (or (key, value) pairs); called again whenever the current model
        is another value, its result kept until then.
    """

    def __init__(self, compute):
        self._compute = compute
        self._cache = (None, {})

    def _items(self) -> dict:
        key = effects.current()
        if self._cache[0] is not key:
            self._cache = (key, dict(self._compute()))
        return self._cache[1]

    def __getitem__(self, key):
        return self._items()[key]

    def __iter__(self):
        return iter(self._items())

    def __len__(self) -> int:
        return len(self._items())

    def __repr__(self) -> str:
        return repr(self._items())


#: Effects beyond the paper (spec section 4): every effect parameter with its off value (the
#: default; model's default is 2), unit and meaning, read from the registry
#: (:mod:`mkctl.physics.effects`).
EFFECTS_TABLE = LiveMapping(lambda: {q.name: Quantity(q.start if q.switch else float(q.start),
                                                       q.unit, q.description)
                                      for q in effects.parameters() if q.name != "model"})

#: Names of the effects of spec section 4, and the parameters each one brings.
EFFECT_PARAMETERS = LiveMapping(lambda: effects.effect_parameters())

#: Units of every parameter name (derived ones included), for files, FMUs and plots.
UNITS = LiveMapping(lambda: {**{k: q.unit for k, q in {**TABLE_I, **TABLE_II}.items()}, "n": "1",
                              **{q.name: q.unit for q in effects.parameters()}})

#: Parameters that are whole numbers (switches), not real values.
INTEGER_PARAMETERS = LiveSequence(lambda: [q.name for q in effects.parameters() if q.switch])

#: Every parameter name accepted by :meth:`Params.replace`, a measurement file and the FMUs: the
#: tables', then each registered effect's, in the registry's order.
PARAMETER_NAMES = LiveSequence(lambda: [*BASE_NAMES, *(q.name for q in effects.parameters())])


class Params:
    """Every parameter of the actuator, the knee and the effects, in SI units; immutable, hashable.

    Defaults are Table I, Table II and "effects off" (every effect parameter at its off value,
    model 2: elasticity on). Switches (``model`` 1 or 2, ``slack`` 0 or 1) are whole numbers;
    everything else is a float. ``n`` is derived from b, L0 and D0 unless given:
    ``n = sqrt(b^2 - L0^2) / (pi D0)``. A set is of a model (:attr:`definition`, a
    :class:`~mkctl.physics.model.Model`): the effects whose parameters it has. ``Params(...)``
    makes a set of the current model (the built-ins and the effects registered so far);
    ``model.params(...)`` or :meth:`of` a set of any model. A set made before an effect was
    registered stays of the model it was made of. Invalid values raise :class:`ParameterError`.

    Attributes
    ----------
    definition : Model
        The model the set is of; it travels with the set (a pickle, a Dask worker).

    Parameters
    ----------
    **values : float or int
        Any names of :data:`PARAMETER_NAMES`, in SI units (their units: :data:`UNITS`): Table I's
        b, L0, D0, t0 [m], C1, C2 [Pa]; Table II's m [kg], g [m/s^2], L1, L2, L5, L6, Lo, Lu,
        Lec, Lfc, r [m]; n [-]; the effects' parameters (c [N s/m], Fc [N], vs [m/s], tau [s],
        ..., the switches model and slack).

    Raises
    ------
    ParameterError
        For an unknown name; a value that is not a finite number (a bool included); a switch that
        is not whole; a table length, m or g not positive, C1, C2, Lec or Lfc negative; a value
        outside its effect's bounds or :data:`DOMAIN`; an effect switched on without the effect
        it requires; L0 >= b; t0 >= D0/2; n not positive; r >= L1 (see :func:`check_domain`).

    References
    ----------
    .. [1] "Stability Analysis of Robot Motions driven by McKibben Pneumatic Actuator", Table I,
       Table II and Eq. 5 (n at rest).
    .. [2] model-spec sections 2 (n, V_r), 3 (r) and 4 (the effects' parameters).

    Examples
    --------
    >>> from mkctl.physics.params import Params
    >>> round(Params().n, 6)
    2.980485
    >>> Params(m=2.5).replace(m=3.0).m
    3.0
    """

    def __init__(self, **values):
        self._fill(effects.current(), values)

    @classmethod
    def of(cls, definition: Model, /, **values) -> "Params":
        """A parameter set of a given model (:meth:`mkctl.physics.model.Model.params`).

        Parameters
        ----------
        definition : Model
            The model: the effects the set's names and values are of (positional: ``model`` is
            the elasticity's parameter).
        **values : float or int
            Any names of the model's :attr:`~mkctl.physics.model.Model.parameter_names`, SI.

        Returns
        -------
        Params

        Raises
        ------
        ParameterError
            As :class:`Params`.
        """
        params = cls.__new__(cls)
        params._fill(definition, values)
        return params

    def _fill(self, model: Model, values: dict) -> None:
        names = model.parameter_names
        unknown = [k for k in values if k not in names]
        if unknown:
            raise ParameterError(f"unknown parameter {unknown[0]!r} (known: {', '.join(names)})")
        own = self.__dict__
        own["definition"] = model
        for name in BASE_NAMES:
            own[name] = values.get(name, None if name == "n" else _BASE_DEFAULTS[name])
        for q in model.parameters:
            own[q.name] = values.get(q.name, q.start)
        self._validate(own, model)

    @staticmethod
    def _validate(own: dict, model: Model) -> None:
        switches = model.switch_names
        for name in model.parameter_names:
            value = own[name]
            if value is None:
                continue
            if (isinstance(value, bool) or not isinstance(value, (int, float))
                    or not math.isfinite(value)):
                raise ParameterError(f"parameter {name} must be a finite number, got {value!r}")
            if name in switches and value != int(value):
                raise ParameterError(f"parameter {name} must be a whole number, got {value!r}")
            own[name] = int(value) if name in switches else float(value)
        for name in _POSITIVE:
            if own[name] <= 0:
                raise ParameterError(f"parameter {name} must be positive, got {own[name]!r}")
        for name in _NOT_NEGATIVE:
            if own[name] < 0:
                raise ParameterError(f"parameter {name} must not be negative, got {own[name]!r}")
        for q in model.parameters:
            q.check(own[q.name])
        for effect in model.effects:
            q = effect.switch_parameter
            if own[q.name] == q.off:
                continue
            for name in effect.requires:
                needed = model.get(name).switch_parameter
                if own[needed.name] == needed.off:
                    raise ParameterError(f"parameter {q.name} ({effect.name}) needs the effect "
                                         f"{name} ({needed.name} switched on)")
        if own["L0"] >= own["b"]:
            raise ParameterError(f"rest length L0 = {own['L0']} m must be shorter than the braid "
                                 f"b = {own['b']} m")
        if own["t0"] >= own["D0"] / 2:
            raise ParameterError(f"wall thickness t0 = {own['t0']} m must be less than the radius "
                                 "D0/2")
        if own["n"] is None:
            own["n"] = derived_turns(own["b"], own["L0"], own["D0"])
        elif own["n"] <= 0:
            raise ParameterError(f"parameter n must be positive, got {own['n']!r}")
        check_domain(own)

    def __setattr__(self, name, value):
        raise AttributeError(f"Params are immutable: use replace({name}=...) for a copy with "
                             "another value")

    def __delattr__(self, name):
        raise AttributeError("Params are immutable")

    def _key(self) -> tuple:
        """The model, then every value in its names' order (remembered: a set never changes)."""
        cached = self.__dict__.get("_cached_key")
        if cached is None:
            model = self.definition
            cached = (model, *(getattr(self, name) for name in model.parameter_names))
            self.__dict__["_cached_key"] = cached
        return cached

    def __eq__(self, other) -> bool:
        if not isinstance(other, Params):
            return NotImplemented
        return self._key() == other._key()

    def __hash__(self) -> int:
        return hash(self._key())

    def __repr__(self) -> str:
        return ("Params(" + ", ".join(f"{name}={getattr(self, name)!r}"
                                      for name in self.definition.parameter_names) + ")")

    def __reduce__(self):
        # the model travels with the values (a Dask worker needs no effect file); caches do not
        return (_params_from, (self.definition, self.as_dict()))

    @property
    def V_r(self) -> float:
        """Rubber volume ``V_r = pi t0 (D0 - t0) L0`` [m^3], spec section 2 (Eq. 8-9)."""
        return rubber_volume(self.t0, self.D0, self.L0)

    @property
    def effects(self) -> tuple[str, ...]:
        """The effects of spec section 4 that are switched on, in the registry's order."""
        return tuple(e.name for e in self.definition.effects if e.is_on(self))

    def replace(self, **overrides) -> "Params":
        """A copy with some values changed; unknown names raise :class:`ParameterError`.

        ``n`` is derived again from b, L0, D0 when one of them changes value, unless it is given
        explicitly. The copy is of the same model, or of the current one when a name belongs to an
        effect registered since (the current model then holds every effect of this set's: the set
        means the same with the new effect off).

        Parameters
        ----------
        **overrides : float or int
            The names to change (any of the model's names) with their new values, in SI units.

        Returns
        -------
        Params
            A new set; this one is unchanged.

        Raises
        ------
        ParameterError
            For an unknown name, or a new value that is invalid (see :class:`Params`).
        """
        model = self.definition
        if not set(overrides) <= set(model.parameter_names):
            model = _wider_model(model)  # a name of an effect registered since this set was made
        names = model.parameter_names
        unknown = sorted(set(overrides) - set(names))
        if unknown:
            raise ParameterError(f"unknown parameter {unknown[0]!r} (known: {', '.join(names)})")
        values = self.as_dict()
        # a geometry that does not change (a file repeating a muscle file's L0) keeps that muscle's
        # fitted n
        if "n" not in overrides and any(overrides[k] != values[k]
                                        for k in {"b", "L0", "D0"} & set(overrides)):
            values["n"] = None
        values.update(overrides)
        return Params.of(model, **values)

    def as_dict(self) -> dict[str, float]:
        """All values by name (n included), e.g. for a JSON report or an FMU's start values.

        Returns
        -------
        dict
            ``{name: value}`` in :data:`PARAMETER_NAMES`' order, SI units (floats; the switches
            ints).
        """
        return {name: getattr(self, name) for name in self.definition.parameter_names}


# --- The model's domain: the values a real muscle and knee can take ------------------------------

#: The range [low, high] of each parameter (SI) that the model accepts: every real muscle and knee
#: lies well inside it (lengths from a micrometre to 100 m, masses from a gram to 10 t, ...), and
#: every value inside it keeps the equations' intermediate numbers far from overflow and underflow.
#: The effects' parameters are checked by their own bounds in the registry
#: (:class:`mkctl.physics.effects.Parameter`). A value outside gives a one-line ParameterError.
DOMAIN = MappingProxyType({
    **{name: (1e-6, 100.0)
       for name in ("b", "L0", "D0", "t0", "L1", "L2", "L5", "L6", "Lo", "Lu", "r")},
    "Lec": (0.0, 100.0), "Lfc": (0.0, 100.0),
    "n": (1e-4, 1e4),
    "C1": (0.0, 1e9), "C2": (0.0, 1e9),
    "m": (1e-3, 1e4),
    "g": (1e-3, 100.0),
})


def domain_of(name: str) -> tuple[float, float] | None:
    """The range [low, high] a parameter must lie in, or None when it has no finite range.

    The paper's parameters from :data:`DOMAIN`, an effect's from its registry bounds.

    Parameters
    ----------
    name : str
        A parameter name (:data:`PARAMETER_NAMES`).

    Returns
    -------
    tuple of float or None
        (low, high) in the parameter's SI unit (:data:`UNITS`); None for a switch, an effect
        parameter without a finite upper bound, or an unknown name.
    """
    if name in DOMAIN:
        return DOMAIN[name]
    q = next((q for q in effects.parameters() if q.name == name and not q.switch), None)
    return (q.lower, q.upper) if q is not None and math.isfinite(q.upper) else None


def check_domain(values) -> None:
    """Raise :class:`ParameterError` unless the values lie in :data:`DOMAIN` and the knee exists.

    Every value of ``values`` must lie in :data:`DOMAIN`, and the knee's geometry must exist: the
    kneecap lever ``r`` shorter than the extensor's thigh anchor distance ``L1``, so that

    ``beta = pi/2 + alpha + asin(r sin(alpha) / L1)`` (spec section 3)

    is defined for every kneecap angle alpha in (0, pi/2).

    Parameters
    ----------
    values : Mapping
        Names to values, SI units; r and L1 [m] must be among them (a name of :data:`DOMAIN`
        missing or None is not checked).

    Raises
    ------
    ParameterError
        One line: the name, the value and the allowed range; or r >= L1.

    References
    ----------
    .. [1] model-spec section 3 (the knee geometry and its kneecap angle alpha).
    """
    for name, (low, high) in DOMAIN.items():
        value = values.get(name)
        if value is not None and not low <= value <= high:
            raise ParameterError(outside_domain_message(name, f"{value:.6g}", low, high,
                                                        UNITS.get(name, "1")))
    if values["r"] >= values["L1"]:
        raise ParameterError(f"parameter r = {values['r']:.6g} m must be shorter than "
                             f"L1 = {values['L1']:.6g} m: the kneecap lever cannot reach past the "
                             "extensor's thigh anchor (no knee geometry)")


def _wider_model(model: Model) -> Model:
    """The current model when it holds every effect of ``model`` (an effect registered since a set
    of ``model`` was made: the set means the same with that effect off), else ``model``."""
    current = effects.current()
    return current if current.extends(model) else model


def _params_from(model: Model, values: dict) -> Params:
    """A parameter set again from a pickle: its model and its values, checked as they were."""
    params = Params.__new__(Params)
    params.__dict__.update(values, definition=model)
    return params


_BASE_DEFAULTS = {name: q.value for name, q in {**TABLE_I, **TABLE_II}.items()}

#: The parameter set of the paper: Table I, Table II, model 2, no further effects.
DEFAULT = Params()
