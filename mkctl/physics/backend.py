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
