"""The command line's shared ground: a user's mistake on a command line as one line. Used by ``mkctl``
(:mod:`mkctl.cli`) and by the scenario scripts (:mod:`mkctl.scenarios`), which sit on top of this layer.

- :class:`UsageError`: a command-line value that cannot be used;
- :class:`OneLineParser`: argparse whose usage error is one line;
- :func:`folder_problem`: why files cannot be written into a folder, checked before the work;
- :func:`run_reporting_errors`: run a program, reporting a user's mistake as one line and an exit status.
"""
from __future__ import annotations

import argparse
import os
import sys
import tempfile
from pathlib import Path

from ..errors import MkctlError


class UsageError(MkctlError, ValueError):
    """A command-line value that cannot be used (a bad option value, an output path that cannot be written)."""


class OneLineParser(argparse.ArgumentParser):
    """argparse, but a usage error is one line (the usage hint stays available with --help)."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}\n")


# --- output folders: checked before the work, so that a typo does not cost a long run ---------------

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
