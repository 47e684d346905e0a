"""The ``mkctl`` command: a small command line over the plain Python API.

Each subcommand lives in its own module of this package, which adds its parser in ``register`` and
sets ``func`` to a function taking the parsed arguments. A user's mistake (bad arguments, a bad file, a
parameter the model cannot represent) ends with one line on stderr and exit status 2, never a traceback.
"""
from __future__ import annotations

import argparse
import sys

from .options import OneLineParser, run_reporting_errors
from . import batch, calibrate, control, measure, paper, run

#: Subcommand modules, in the order ``mkctl --help`` lists them.
COMMANDS = [run, paper, control, measure, batch, calibrate]


def build_parser() -> argparse.ArgumentParser:
    parser = OneLineParser(
        prog="mkctl",
        description="McKibben muscles and the knee they drive: the paper's figures, FMUs, control analysis "
                    "and diagnosis of measurements.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=OneLineParser)
    for module in COMMANDS:
        module.register(sub)
    return parser


def main(argv: list[str] | None = None) -> int:
    try:
        parser = build_parser()
        args = parser.parse_args(argv)
    except KeyboardInterrupt:  # Ctrl-C while the subcommands load: one line, as during a run
        print("mkctl: interrupted", file=sys.stderr)
        return 130
    if not getattr(args, "func", None):
        parser.print_help()
        return 2
    return run_reporting_errors(f"mkctl {args.command}", args.func, args)

if __name__ == "__main__":
    sys.exit(main())
