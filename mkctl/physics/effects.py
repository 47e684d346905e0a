"""The effects beyond the paper (model-spec sections 4, 4b, 4c): the built-ins and yours, and the
current model they form.

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

The effects a parameter set is of form a model, a value (:class:`~mkctl.physics.model.Model`):
every set carries its own (``params.definition``). This module is the sugar over it: the current
model (:func:`current`, the one ``Params()`` makes its sets of: the spec's effects, then yours in
the order of registration), :func:`register` (model-spec section 4c: the current model becomes one
with the effect; sets made afterwards have its parameters, sets made before keep their model) and
the look-ups below, each on the current model.

Example
-------
>>> from mkctl.physics import effects
>>> [e.name for e in effects.all_effects()][:3]
['elasticity', 'viscous_damping', 'coulomb_friction']
>>> effects.get("coulomb_friction").parameter_names
('Fc', 'vs')
"""

from __future__ import annotations

import contextlib
import dataclasses
from types import MappingProxyType
from typing import Mapping

from .effect import (  # noqa: F401 (re-exported: the public face of an effect)
    DiscoveryColumn,
    Effect,
    EffectError,
    Parameter,
    outside_domain_message,
)
from .model import Model, SymbolicParams, _current, current  # noqa: F401 (re-exported)

def register(effect: Effect, _builtin: bool = False) -> Effect:
    """Add an effect to the model ``Params()`` makes its sets of (model-spec section 4c).

    Sugar for ``Model.with_effect``: the new model replaces the current one, so that parameter
    sets made afterwards have the effect's parameters (sets made before keep their model).

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
    if _builtin and isinstance(effect, Effect):
        effect = dataclasses.replace(effect, builtin=True)
    _current[0] = _current[0].with_effect(effect)
    return effect


@contextlib.contextmanager
def using(model: Model):
    """Make ``Params()`` make its sets of another model for a while (a Dask worker, a test).

    Parameters
    ----------
    model : Model
        The model; the current one comes back when the block ends, whatever happens in it.

    Returns
    -------
    context manager
        Current inside the ``with`` block: the model.
    """
    if not isinstance(model, Model):
        raise EffectError(f"using() takes a Model, got {type(model).__name__}")
    previous, _current[0] = _current[0], model
    try:
        yield model
    finally:
        _current[0] = previous


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
    _current[0] = _current[0].without(name)


def get(name: str) -> Effect:
    """The effect of this name in the current model (:meth:`Model.get`).

    An unknown name raises :class:`ParameterError` naming the known ones.

    Parameters
    ----------
    name : str

    Returns
    -------
    Effect
    """
    return current().get(name)


def all_effects() -> tuple[Effect, ...]:
    """Every registered effect, in the registry's order.

    Returns
    -------
    tuple of Effect
        The spec's built-ins first, then the others in the order of registration.
    """
    return current().effects


def names() -> tuple[str, ...]:
    """The names of every registered effect.

    Returns
    -------
    tuple of str
        In the registry's order.
    """
    return current().names


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
    return current().parameters


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
        if a in current() and b in current()
        else ""
    )


def parameter_names() -> tuple[str, ...]:
    """Every parameter name of a parameter set.

    Returns
    -------
    tuple of str
        The tables' names, then each registered effect's, in the registry's order.
    """
    return current().parameter_names


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

