"""Muscle files (model-spec section 5b): one user's calibrated muscle as JSON, read back as :class:`Params`.

A muscle file holds at least::

    {"params": {"b": 0.241, "n": 2.98, "L0": 0.208, "D0": 0.013, "t0": 0.0015, "C1": 1.9e5, "C2": 1.3e3,
                "model": 2, "slack": 1, "Fc": 0.0},
     "effects": ["slack"], "nrms_before": 0.09, "nrms_after": 0.02,
     "stderr": {"b": 0.0004}, "not_identifiable": [["C1", "C2"]], "steps": []}

``params`` are SI values of any name of :data:`mkctl.physics.params.PARAMETER_NAMES`; names not given keep
their defaults (Table I, Table II, effects off). ``mkctl calibrate`` writes such files; every command that takes
parameters reads one with ``--params MUSCLE.json`` (values given after it on the command line win), and so does
``build_fmu.py`` (the FMUs' defaults become that muscle's).
"""
from __future__ import annotations

import json
import math
from pathlib import Path

from ..errors import MkctlError, ParameterError
from ..physics.params import DEFAULT, INTEGER_PARAMETERS, PARAMETER_NAMES, Params
from .text import read_user_text, write_text_atomic


class MuscleFileError(MkctlError, ValueError):
    """A muscle file that cannot be read or does not follow model-spec section 5b."""


def read_muscle_file(path) -> dict:
    """The whole muscle file as a dict, its ``params`` checked (names, numbers, a valid :class:`Params`).

    Raises :class:`MuscleFileError` with one line naming the file and the problem.
    """
    path = Path(path)
    text = read_user_text(path, MuscleFileError, "a muscle file")
    try:
        data = json.loads(text)
    except json.JSONDecodeError as error:
        raise MuscleFileError(f"{path}: not a JSON muscle file (line {error.lineno}: {error.msg})") from None
    except RecursionError:
        raise MuscleFileError(f"{path}: not a muscle file (JSON nested too deeply)") from None
    except ValueError as error:  # a number too long to read (Python's limit on integer digits)
        raise MuscleFileError(f"{path}: not a muscle file ({error})") from None
    if not isinstance(data, dict) or not isinstance(data.get("params"), dict):
        raise MuscleFileError(f'{path}: a muscle file is a JSON object with a "params" object (model-spec 5b)')
    data["params"] = dict(data["params"])
    params_from_values(data["params"], str(path))
    return data


def params_from_values(values: dict, source: str = "muscle file", base: Params = DEFAULT) -> Params:
    """:class:`Params` from ``base`` with ``values`` (SI, by name); one-line :class:`MuscleFileError` if invalid."""
    for name, value in values.items():
        if name not in PARAMETER_NAMES:
            raise MuscleFileError(f"{source}: unknown parameter {name!r} (known: {', '.join(PARAMETER_NAMES)})")
        if isinstance(value, bool) or not isinstance(value, (int, float)) or not _finite(value):
            raise MuscleFileError(f"{source}: parameter {name} must be a finite number, got {value!r}")
    try:
        return base.replace(**values)
    except ParameterError as error:
        raise MuscleFileError(f"{source}: {error}") from None


def _finite(value) -> bool:
    """Whether a JSON number is a finite float (an integer of 400 digits is not: it has no float)."""
    try:
        return math.isfinite(float(value))
    except OverflowError:
        return False


def read_muscle(path, base: Params = DEFAULT) -> Params:
    """The :class:`Params` of a muscle file: ``base`` (default: the paper's) with the file's values."""
    return params_from_values(read_muscle_file(path)["params"], str(path), base)


def write_muscle(path, params: Params, **report) -> Path:
    """Write a muscle file: every parameter of ``params`` (SI) plus the report's entries (``effects``,
    ``nrms_before``, ``nrms_after``, ``stderr``, ``not_identifiable``, ``steps``, ...). Returns the path."""
    values = {name: (int(v) if name in INTEGER_PARAMETERS else float(v)) for name, v in params.as_dict().items()}
    data = {"params": values, "effects": list(params.effects), **report}
    return write_text_atomic(path, json.dumps(data, indent=2, allow_nan=False) + "\n")
