"""The ``mkctl`` command: a small command line over the plain Python API.

Each subcommand lives in its own module of this package, which adds its parser in ``register`` and
sets ``func`` to a function taking the parsed arguments. A user's mistake (bad arguments, a bad file, a
parameter the model cannot represent) ends with one line on stderr and exit status 2, never a traceback.
"""
from __future__ import annotations

import argparse
import gc
import sys

from ..io.command_line import OneLineParser, run_reporting_errors
from . import batch, calibrate, control, measure, paper, run
from .options import run_command

#: Subcommand modules, in the order ``mkctl --help`` lists them. Each is light to import: what a command needs
#: (scipy, matplotlib, python-control, fmpy, Dask) is imported when the command runs, and its options (whose
#: defaults may come from those modules) are added only when that command is asked for.
COMMANDS = [run, paper, control, measure, batch, calibrate]


def build_parser(command: str | None = None) -> argparse.ArgumentParser:
    """The ``mkctl`` parser: every subcommand with all its options, or (given ``command``) that subcommand's module
    in full and the others by name and one-line help only, which is all ``mkctl --help`` and a usage error need."""
    parser = OneLineParser(
        prog="mkctl",
        description="McKibben muscles and the knee they drive: the paper's figures, FMUs, control analysis "
                    "and diagnosis of measurements.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    for module in COMMANDS:
        if command is None or command in module.COMMANDS:
            module.register(sub)
        else:
            for name, text in module.COMMANDS.items():
                sub.add_parser(name, help=text)
    return parser


def requested_command(argv: list[str]) -> str:
    """The subcommand named on a command line (its first word that is not an option), or "" when there is none.
    ``mkctl`` itself takes no option with a value, so the first such word is the subcommand."""
    return next((word for word in argv if not word.startswith("-")), "")


def main(argv: list[str] | None = None) -> int:
    """Run the command line ``argv`` (default: this process's own, as the ``mkctl`` program); returns the exit status."""
    program = argv is None
    argv = sys.argv[1:] if argv is None else list(argv)
    try:
        parser = build_parser(requested_command(argv))
        args = parser.parse_args(argv)
    except KeyboardInterrupt:  # Ctrl-C while the subcommands load: one line, as during a run
        print("mkctl: interrupted", file=sys.stderr)
        return 130
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    status = run_reporting_errors(f"mkctl {args.command}", run_command, args)
    if program:  # the process ends now: spare its objects the last collection (a quarter of a second of exit once
        gc.freeze()  # scipy and matplotlib are loaded); files are closed and atexit runs as ever
    return status


if __name__ == "__main__":
    sys.exit(main())
