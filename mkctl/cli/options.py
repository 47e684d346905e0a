"""Command-line helpers shared by the subcommands: parameter assignments, output paths, a muscle file and effect
files as options. :class:`UsageError` (the subcommands import it from here), the one-line parser and the one-line
report of a user's mistake live in :mod:`mkctl.io.command_line`: the scenario scripts use them too."""
from __future__ import annotations

import os
from pathlib import Path

from ..errors import ParameterError
from ..io.command_line import UsageError, folder_problem
from ..physics.params import PARAMETER_NAMES


def split_items(items) -> list[str]:
    """Repeated option values, each possibly a comma-separated list: ``["c=45,tau=0.05", "m=2"]`` -> 3 items."""
    return [part.strip() for item in items or () for part in str(item).split(",") if part.strip()]


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


# --- output paths: checked before the work, so that a typo does not cost a long run ---------------

def output_folder(path, option: str) -> Path:
    """Check that ``path`` is (or can become) a folder we can write into; return it as a Path.

    Nothing is created. Raises :class:`UsageError` naming ``option`` (``--out``, ...), the path and the
    problem: the path or one of its parents is a file, or the nearest existing folder cannot be written.
    """
    path = Path(path)
    if path.exists() and not path.is_dir():
        raise UsageError(f"{option} {path}: is a file, not a folder")
    problem = folder_problem(path)
    if problem:
        raise UsageError(f"{option} {path}: {problem}")
    return path


def output_file(path, option: str) -> Path:
    """Check that the file ``path`` can be written (its folder made if missing); return it as a Path.

    Nothing is created. Raises :class:`UsageError` naming ``option``, the path and the problem: the path is
    a folder, a parent is a file, the folder cannot be written, or an existing file cannot be overwritten.
    """
    path = Path(path)
    if path.is_dir() or str(path).endswith(("/", os.sep)):
        raise UsageError(f"{option} {path}: is a folder, not a file")
    problem = folder_problem(path.parent)
    if problem:
        raise UsageError(f"{option} {path}: {problem}")
    if path.exists() and not path.is_file():
        raise UsageError(f"{option} {path}: is not a regular file (a device, a pipe or a socket): give a file name")
    if path.exists() and not os.access(path, os.W_OK):
        raise UsageError(f"{option} {path}: the file exists and cannot be overwritten")
    return path


# --- parameters: a muscle file first, then NAME=VALUE items on top -----------------------------------

def add_params_option(parser, effects: bool = True) -> None:
    """Add ``--params MUSCLE.json`` (model-spec section 5b) to a subcommand's parser, and (``effects``) ``--effects
    FILE.py`` (:func:`add_effects_option`)."""
    parser.add_argument("--params", type=Path, default=None, metavar="MUSCLE.json",
                        help="a muscle file (from mkctl calibrate): its parameters replace the paper's defaults; "
                             "values given with --set/--param win over it")
    if effects:
        add_effects_option(parser)


#: The help of ``--effects FILE.py``.
EFFECTS_HELP = ("a file of your own effects (model-spec section 4c, docs/effects.md), registered before anything "
                "else: their parameters become parameters like the others, and they are candidates of the "
                "diagnosis (repeatable)")


def add_effects_option(parser) -> None:
    """Add ``--effects FILE.py`` (repeatable; model-spec section 4c) to a subcommand's parser. The files are
    registered by :func:`register_effects` before the command runs (``mkctl``'s main), so before any Params."""
    parser.add_argument("--effects", action="append", default=[], dest="effect_files", metavar="FILE.py",
                        help=EFFECTS_HELP)


def register_effects(args) -> list:
    """Register the effect files of ``--effects`` (:func:`mkctl.analysis.effect_files.register_effect_file`);
    nothing without the option. A bad file raises a one-line error naming it and the effect."""
    files = getattr(args, "effect_files", None)
    if not files:
        return []
    from ..analysis.effect_files import register_effect_files
    return register_effect_files(files)


def run_command(args) -> int:
    """A subcommand's ``func(args)``, after its ``--effects`` files are registered."""
    register_effects(args)
    return args.func(args)


def base_params(args):
    """The parameter set a command starts from: the ``--params`` muscle file, or the paper's defaults."""
    from ..io.muscle import read_muscle
    from ..physics.params import Params
    path = getattr(args, "params", None)
    return Params() if path is None else read_muscle(path)


def muscle_values(args) -> dict[str, float]:
    """The ``--params`` muscle file's values that differ from the paper's defaults (SI, by name), e.g. to write
    them as known parameters into a measurement file's metadata; empty without ``--params``."""
    from ..physics.params import Params
    params, defaults = base_params(args), Params()
    return {name: value for name, value in params.as_dict().items()
            if name != "model" and value != getattr(defaults, name, None)}
