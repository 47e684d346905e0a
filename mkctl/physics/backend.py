"""The compiled core as a backend the physics layer is handed, never one it imports.

The physics layer sits at the bottom of mkctl: it imports nothing above it. A layer above (``mkctl/__init__.py``
installs :mod:`mkctl.native.compiled` when mkctl is imported) hands in a provider with :func:`install`; the
simulations then ask :func:`compiled_core` for the core of a parameter set's structure and fall back to their
Python loops when there is none (no provider, no compiler, ``MKCTL_NATIVE=0``).
"""
from __future__ import annotations

from typing import Callable

_provider: list = [None]


def install(provider: Callable | None) -> Callable | None:
    """Use provider(params) -> core or None as the compiled core; None removes it. Returns the previous one."""
    previous, _provider[0] = _provider[0], provider
    return previous


def compiled_core(params):
    """The compiled core for params' structure, or None (none installed, or the provider has none)."""
    provider = _provider[0]
    return None if provider is None else provider(params)
