"""Command-line options shared by several subcommands."""
from __future__ import annotations

from ..errors import ParameterError
from ..params import PARAMETER_NAMES


def parse_assignments(items, option: str = "--set") -> dict[str, float]:
    """``["m=2.5", "c=45"]`` -> ``{"m": 2.5, "c": 45.0}``, names checked against the parameter names.

    A malformed item, an unknown name or a value that is not a number raises :class:`ParameterError`
    naming the option and the item.
    """
    values = {}
    for item in items:
        name, sep, text = item.partition("=")
        name = name.strip()
        if not sep or not name:
            raise ParameterError(f"{option} expects NAME=VALUE, got {item!r}")
        if name not in PARAMETER_NAMES:
            raise ParameterError(f"{option}: unknown parameter {name!r} (known: {', '.join(PARAMETER_NAMES)})")
        try:
            values[name] = float(text)
        except ValueError:
            raise ParameterError(f"{option} {name}: {text.strip()!r} is not a number") from None
    return values
