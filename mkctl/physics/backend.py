"""The compiled core as a backend the physics layer is handed, never one it imports.

The physics layer sits at the bottom of mkctl: it imports nothing above it. A layer above
(``mkctl/__init__.py`` installs :mod:`mkctl.native.compiled` when mkctl is imported) hands in a
provider with :func:`install`; the simulations then ask :func:`compiled_core` for the core of a
parameter set's structure and fall back to their Python loops when there is none (no provider, no
compiler, ``MKCTL_NATIVE=0``).
"""
from __future__ import annotations

from typing import Callable

_provider: list = [None]


def install(provider: Callable | None) -> Callable | None:
    """Install the provider of the compiled core, replacing the previous one.

    Parameters
    ----------
    provider : callable or None
        ``provider(params) -> core or None``: the compiled core for a parameter set's
        structure; None removes the provider (the simulations then run their Python loops).

    Returns
    -------
    callable or None
        The provider installed before (None if there was none), to put back later.
    """
    previous, _provider[0] = _provider[0], provider
    return previous


def compiled_core(params):
    """The compiled core for a parameter set's structure, or None.

    Parameters
    ----------
    params : Params
        The model whose structure (elasticity model, effects switched on) the core is compiled for.

    Returns
    -------
    core or None
        The core the installed provider gives; None when no provider is installed or the
        provider has none (no compiler, ``MKCTL_NATIVE=0``).
    """
    provider = _provider[0]
    return None if provider is None else provider(params)


_mechanism_provider: list = [None]


def install_mechanism(provider: Callable | None) -> Callable | None:
    """Install the provider of mechanisms' compiled cores, replacing the previous one.

    Parameters
    ----------
    provider : callable or None
        ``provider(mechanism, params) -> core or None``: the compiled core of a mechanism
        (:class:`mkctl.physics.mechanism.Mechanism`) for a parameter set; the core's
        ``run(time, commands, p, state, stops, rtol, atol, hint)`` gives a record's states, or
        None after a fault. None removes the provider (the Python loop then runs).

    Returns
    -------
    callable or None
        The provider installed before (None if there was none), to put back later.
    """
    previous, _mechanism_provider[0] = _mechanism_provider[0], provider
    return previous


def mechanism_core(mechanism, params):
    """The compiled core of a mechanism for a parameter set, or None.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism (a built-in or a user's file) whose traced functions the core is made from.
    params : MechanismParams
        Its parameters (the muscle's effects decide whether the core carries them).

    Returns
    -------
    core or None
        The core the installed provider gives; None when no provider is installed or the
        provider has none (no compiler, ``MKCTL_NATIVE=0``, the air's temperature as a state).
    """
    provider = _mechanism_provider[0]
    return None if provider is None else provider(mechanism, params)
