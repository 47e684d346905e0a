"""``mkctl paper``: reproduce the paper's figures (Fig. 5, Fig. 7) and check the claims of Section VI.

Writes into ``--out`` (default ``out/paper``): ``fig5_contraction.png``, ``fig7_surfaces.png`` (3-D),
``fig7_sections.png`` (2-D), ``claims.md`` and ``claims.json``. Parameters default to Table I and II;
``--mass`` and ``--set NAME=VALUE`` (repeatable, any name of :data:`mkctl.physics.params.PARAMETER_NAMES`) change them.
"""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from ..physics.params import PARAMETER_NAMES
from .options import add_params_option, base_params, output_folder, parse_assignments


#: The subcommands this module adds, with the one line ``mkctl --help`` shows for each (the command line
#: lists them without importing what they need).
COMMANDS = {
    "paper": "reproduce the paper's Fig. 5 and Fig. 7 and check its stability claims",
}


def register(subparsers) -> None:
    """Add the ``paper`` subcommand to the ``mkctl`` parser."""
    parser = subparsers.add_parser(
        "paper", help=COMMANDS["paper"],
        description="Reproduce the paper's Fig. 5 (contraction against pressure, model 1 against model 2) and "
                    "Fig. 7 (the h = 0 sheet and the equilibrium set), and write a table of the claims of "
                    "Section VI with the model's numbers (claims.md, claims.json).")
    parser.add_argument("--out", type=Path, default=Path("out/paper"), metavar="DIR",
                        help="folder for the figures and the claims (default: out/paper)")
    parser.add_argument("--mass", type=float, metavar="KG", help="hip mass m [kg] (Table II: 10)")
    parser.add_argument("--set", dest="overrides", action="append", default=[], metavar="NAME=VALUE",
                        help="override a parameter in SI units, e.g. --set c=45 (repeatable; names: "
                             + ", ".join(PARAMETER_NAMES) + ")")
    add_params_option(parser)
    parser.add_argument("--quiet", action="store_true", help="do not report progress on stderr")
    parser.set_defaults(func=run_paper)


def run_paper(args: argparse.Namespace) -> int:
    overrides = parse_assignments(args.overrides)
    if args.mass is not None:
        overrides["m"] = args.mass
    params = base_params(args).replace(**overrides)
    progress = None if args.quiet else (lambda message: print(f"mkctl paper: {message}", file=sys.stderr))
    output_folder(args.out, "--out")
    from ..analysis import paper  # here, not at the top: it imports matplotlib, which other commands need not wait for

    written = paper.reproduce_paper(args.out, params, progress=progress)
    for name, path in written.items():
        print(f"{name}: {path}")
    return 0
