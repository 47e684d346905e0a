"""The compiled core as a backend the physics layer finds, never one it imports or is handed.

The physics layer sits at the bottom of mkctl: it imports nothing above it, and nothing above
fills its state when imported. The compiled cores are plug-ins, declared in the package's metadata
as entry points of the group :data:`ENTRY_POINT_GROUP` (``pyproject.toml``: ``knee`` is
:func:`mkctl.native.compiled.core_for`, ``mechanism`` is
:func:`mkctl.native.mechanism_compiled.core_for`), the way Python packages offer plug-ins. The
simulations ask :func:`compiled_core` (or :func:`mechanism_core`) for the core of a parameter set
and fall back to their Python loops when there is none: no such entry point (mkctl used from a
folder it was not installed from, or the modules a pythonfmu FMU packs), no compiler,
``MKCTL_NATIVE=0``.

:func:`install` and :func:`install_mechanism` set a provider in place of the entry point's for a
while (a test that wants the Python path hands in None and puts the previous one back).
"""
from __future__ import annotations

import functools
from typing import Callable

#: The entry-point group the compiled cores are declared in (the package's metadata).
ENTRY_POINT_GROUP = "mkctl.compiled_cores"

#: Providers set by :func:`install` / :func:`install_mechanism` in place of the entry points';
#: empty: the entry points' (nothing is set when mkctl is imported).
_chosen: dict[str, Callable | None] = {}


@functools.lru_cache(maxsize=None)
def _declared(name: str) -> Callable | None:
    """The provider the package's metadata declares under ``name``, loaded once; None when there is
    none or it cannot be imported here (a pythonfmu FMU packs only the modules it imports)."""
    from importlib.metadata import entry_points

    for point in entry_points(group=ENTRY_POINT_GROUP):
        if point.name == name:
            try:
                return point.load()
            except ImportError:
                return None
    return None


def _provider(name: str) -> Callable | None:
    return _chosen[name] if name in _chosen else _declared(name)


def _set(name: str, provider: Callable | None) -> Callable | None:
    previous = _provider(name)
    _chosen[name] = provider
    return previous


def install(provider: Callable | None) -> Callable | None:
    """Set the provider of the compiled core in place of the declared one (a test's Python path).

    Parameters
    ----------
    provider : callable or None
        ``provider(params) -> core or None``: the compiled core for a parameter set's
        structure; None: no core (the simulations then run their Python loops).

    Returns
    -------
    callable or None
        The provider in use before (the declared one if none was set), to put back later.
    """
    return _set("knee", provider)


def compiled_core(params):
    """The compiled core for a parameter set's structure, or None.

    Parameters
    ----------
    params : Params
        The model whose structure (elasticity model, effects switched on) the core is compiled for.

    Returns
    -------
    core or None
        The core the provider gives; None when there is no provider or the provider has none (no
        compiler, ``MKCTL_NATIVE=0``).
    """
    provider = _provider("knee")
    return None if provider is None else provider(params)


def install_mechanism(provider: Callable | None) -> Callable | None:
    """Set the provider of mechanisms' compiled cores in place of the declared one.

    Parameters
    ----------
    provider : callable or None
        ``provider(mechanism, params) -> core or None``: the compiled core of a mechanism
        (:class:`mkctl.physics.mechanism.Mechanism`) for a parameter set; the core's
        ``run(time, commands, p, state, stops, rtol, atol, hint)`` gives a record's states, or
        None after a fault. None: no core (the Python loop then runs).

    Returns
    -------
    callable or None
        The provider in use before (the declared one if none was set), to put back later.
    """
    return _set("mechanism", provider)


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
        The core the provider gives; None when there is no provider or the provider has none (no
        compiler, ``MKCTL_NATIVE=0``, the air's temperature as a state).
    """
    provider = _provider("mechanism")
    return None if provider is None else provider(mechanism, params)
