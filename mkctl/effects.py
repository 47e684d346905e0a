"""Your own effects (model-spec section 4c): ``mkctl.effects.register(Effect(...))`` adds one without editing mkctl.

Everything here lives in :mod:`mkctl.physics.effects` (the registry of every effect, built-in ones included);
this module is its public face. Example::

    from mkctl.effects import Effect, Parameter, register

    register(Effect(
        "cubic_stiffness", "f += k3 (L - L0)^3",
        parameters=(Parameter("k3", "N/m^3", off=0.0, lower=0.0, upper=1e9, typical=1e6),),
        tension=lambda L, Ldot, P, p, xp: p.k3 * (L - p.L0) ** 3))

The new parameter (``k3``) is then a parameter of the sets :class:`mkctl.Params` makes, of measurement files'
metadata, of the compiled core and of the FMUs built afterwards. ``register`` is sugar: the model is a value
(:class:`Model`), and ``Params.of(Model.builtin().with_effect(effect), k3=1e6)`` makes a set of a model with the
effect without registering anything; a set carries its model wherever it goes (a Dask worker included).
"""
from .physics.effects import (Effect, EffectError, Parameter, all_effects, current, effect_of, get, names,
                              register, separating_experiment, unregister, using)
from .physics.model import Model

__all__ = ["Effect", "EffectError", "Model", "Parameter", "all_effects", "current", "effect_of", "get", "names",
           "register", "separating_experiment", "unregister", "using"]
