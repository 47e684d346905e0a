"""Command-line helpers shared by the subcommands and the scenario scripts: parameter assignments, output
paths, and reporting a user's mistake as one line."""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

from ..errors import MkctlError, ParameterError
from ..physics.params import PARAMETER_NAMES


class UsageError(MkctlError, ValueError):
    """A command-line value that cannot be used (a bad option value, an output path that cannot be written)."""


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (the usage hint stays available with --help)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


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

def _writable_folder(folder: Path) -> bool:
    """Whether a file can be created in the existing folder (tried, not guessed: root passes os.access)."""
    try:
        with tempfile.TemporaryFile(dir=folder):
            return True
    except OSError:
        return False


def folder_problem(folder: Path) -> str | None:
    """Why files cannot be written into ``folder`` (made if missing), or None if they can."""
    existing = folder
    while not existing.exists():
        if existing.is_symlink():  # a dangling link: it can be neither followed nor created
            return f"{existing} is a broken link"
        existing = existing.parent
    if not existing.is_dir():
        return f"{existing} is a file, not a folder"
    if not os.access(existing, os.W_OK | os.X_OK) or not _writable_folder(existing):
        return f"cannot write into the folder {existing}"
    return None


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


def run_reporting_errors(prog: str, run, *args) -> int:
    """``run(*args)``, with a user's mistake reported as one line on stderr instead of a traceback.

    Returns run's exit status (None counts as 0); 2 after a :class:`MkctlError` or an OSError (a path that
    cannot be read or written), 130 after an interrupt. Used by ``mkctl`` and by the scenario scripts.
    """
    try:
        return int(run(*args) or 0)
    except MkctlError as error:
        print(f"{prog}: error: {error}", file=sys.stderr)
        return 2
    except OSError as error:
        where = f" {error.filename}" if error.filename else ""
        print(f"{prog}: error: cannot use{where}: {error.strerror or error}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print(f"{prog}: interrupted", file=sys.stderr)
        return 130
    except MemoryError:  # the up-front checks (mkctl.errors.check_memory) missed a case: still one line
        print(f"{prog}: error: out of memory (the job needs more than this machine has: make it smaller)",
              file=sys.stderr)
        return 2


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
    from ..physics.params import DEFAULT
    path = getattr(args, "params", None)
    return DEFAULT if path is None else read_muscle(path)


def muscle_values(args) -> dict[str, float]:
    """The ``--params`` muscle file's values that differ from the paper's defaults (SI, by name), e.g. to write
    them as known parameters into a measurement file's metadata; empty without ``--params``."""
    from ..physics.params import DEFAULT
    params = base_params(args)
    return {name: value for name, value in params.as_dict().items()
            if name != "model" and value != getattr(DEFAULT, name)}
