"""``mkctl calibrate FILE... --out MUSCLE.json``: calibrate a user's own muscle (model-spec section 5b).

Reads one or more isometric, isotonic and/or actuator (driven-length) files of the same muscle, fits
``b, n, C1, C2`` (and more with ``--fit``), adds the effects the data support (see
:mod:`mkctl.analysis.calibrate`), prints the error fall step by step, and writes the muscle file and
two pictures beside it: ``<stem>_fit.png`` (data and fits per length) and ``<stem>_error.png`` (the
error fall).
"""
from __future__ import annotations

import sys

from .batch import add_tls_options, tls_settings
from .options import UsageError, add_params_option, base_params, output_file, output_folder, split_items


#: The subcommands this module adds, with the one line ``mkctl --help`` shows for each (the command line
#: lists them without importing what they need).
COMMANDS = {
    "calibrate": "fit your own muscle's b, n, C1, C2 (and the effects its data show) from blocked-force "
                 "and isotonic files; write MUSCLE.json",
}


def register(subparsers) -> None:
    """Add ``calibrate`` to the `mkctl` parser."""
    from ..analysis.calibrate import CANDIDATES, MAX_EVALUATIONS, OPTIONAL

    p = subparsers.add_parser(
        "calibrate", help=COMMANDS["calibrate"],
        description="Fit the static parameters a user cannot measure (b, n, C1, C2; more with --fit) from one or "
                    "more isometric, isotonic and/or actuator (driven-length) files of the same "
                    "muscle, from several starting points within physical bounds; then add the "
                    "effects "
                    "the data support (the registry's calibration candidates: forward "
                    "stepwise, BIC and a held-out quarter of the points), refitting the static parameters with "
                    "each. Prints the error fall, standard errors and what the data cannot separate; writes the "
                    "muscle file (model-spec section 5b) and <stem>_fit.png, <stem>_error.png beside it.")
    p.add_argument("files", nargs="+", metavar="FILE.csv",
                   help="isometric, isotonic and/or actuator measurement files (with --each: "
                        "files, folders or quoted globs)")
    p.add_argument("--out", metavar="MUSCLE.json", required=True,
                   help="the muscle file to write (with --each: the folder for one muscle file per record)")
    p.add_argument("--each", action="store_true",
                   help="each file is its own muscle: calibrate them in parallel (local processes, or a Dask "
                        "cluster with --scheduler) into OUT/<stem>.muscle.json, with a summary table "
                        "(calibration_summary.csv) and calibration_parameters.png")
    p.add_argument("--jobs", type=int, default=None, metavar="N", help="with --each: worker processes "
                   "(default: the cores; 0: one after the other in this process)")
    p.add_argument("--scheduler", default=None, metavar="ADDRESS",
                   help="with --each: a running Dask scheduler (tcp://HOST:PORT, or tls://HOST:PORT with --tls-ca, "
                        "--tls-cert, --tls-key) instead of local processes")
    add_tls_options(p)
    p.add_argument("--fit", action="append", default=[], metavar="NAMES",
                   help=f"also fit these (comma-separated): {', '.join(OPTIONAL)} (offset: a force sensor's zero "
                        "offset, one per isometric file) - else L0, D0, t0 come from the files' metadata")
    p.add_argument("--link-n", action="store_true",
                   help="tie n to b, L0, D0 (n = sqrt(b^2 - L0^2) / (pi D0), model-spec section 2) instead of "
                        "fitting it")
    p.add_argument("--effects", action="append", default=[], metavar="NAMES|FILE.py",
                   help=f"candidate effects (comma-separated, default {','.join(CANDIDATES)} and those of the effect "
                        "files given; 'none' for the static fit only), and/or a file of your own effects (model-spec "
                        "section 4c, docs/effects.md): an item ending in .py is registered first and its effects "
                        "join the candidates (repeatable)")
    p.add_argument("--png-dir", metavar="DIR", default=None, help="folder for the PNGs (default: beside --out)")
    p.add_argument("--max-evaluations", type=int, default=MAX_EVALUATIONS, metavar="N",
                   help=f"cap on model evaluations per least-squares run, per parameter (default {MAX_EVALUATIONS})")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    add_params_option(p, effects=False)  # --effects above takes effect files too
    p.set_defaults(func=run_calibrate)


def candidate_effects(args) -> list[str]:
    """The candidates of ``--effects``: effect files (items ending in .py) are registered, their effects that
    calibrate can add join the names given (default: every candidate); ``none`` alone: the static fit only."""
    from ..analysis.calibrate import CANDIDATES
    from ..analysis.effect_files import register_effect_file

    items = split_items(args.effects)
    files = [item for item in items if item.endswith(".py")]
    names = [item for item in items if not item.endswith(".py")]
    added = [e.name for path in files for e in register_effect_file(path) if e.name in CANDIDATES]
    if [n.lower() for n in names] == ["none"]:
        return []
    chosen = names or [n for n in CANDIDATES if n not in added]
    return list(dict.fromkeys([*chosen, *added]))


def run_calibrate(args) -> int:
    from ..analysis.calibrate import calibrate, plot_error_fall, plot_fits, read_records, summary
    from ..io.muscle import write_muscle

    if args.each:
        return run_calibrate_each(args)

    out = output_file(args.out, "--out")
    folder = output_folder(args.png_dir, "--png-dir") if args.png_dir else out.resolve().parent
    if args.max_evaluations < 1:
        raise UsageError(f"--max-evaluations must be at least 1, got {args.max_evaluations}")
    effects = candidate_effects(args)
    start = base_params(args) if args.params is not None else None
    measurements = read_records(args.files, start)
    progress = None if args.quiet else (lambda text: print(text, file=sys.stderr, flush=True))
    result = calibrate(measurements, fit=split_items(args.fit), params=start, link_n=args.link_n, effects=effects,
                       max_evaluations=args.max_evaluations, progress=progress)
    for assumption in result.assumed:  # a default taken for the user's muscle: said, and kept in the muscle file
        print(f"mkctl calibrate: warning: {assumption}", file=sys.stderr)
    for line in summary(result):
        print(line)
    stem = out.stem
    fits = plot_fits(result, folder, stem)
    error = plot_error_fall(result, folder / f"{stem}_error.png")
    report = result.to_dict()
    report.pop("params")
    path = write_muscle(out, result.params, **report)
    print(f"muscle file: {path}")
    print("pictures: " + ", ".join(str(p) for p in [*fits, error]))
    return 0


def run_calibrate_each(args) -> int:
    """``--each``: one calibration per file on the batch engine; a table on screen, exit 1 if any file failed."""
    from ..analysis.batch import calibrate_batch

    out = output_folder(args.out, "--out")
    if args.jobs is not None and args.jobs < 0:
        raise UsageError(f"--jobs must be 0 or more, got {args.jobs}")
    effects = candidate_effects(args)
    with tls_settings(args):
        rows = calibrate_batch(args.files, out, jobs=args.jobs, scheduler=args.scheduler,
                               progress=not args.quiet, base=base_params(args) if args.params is not None else None,
                               fit=split_items(args.fit), link_n=args.link_n, effects=effects)
    print(f"{'file':<28} {'effects':<26} {'b [m]':>16} {'n':>14} {'NRMS':>15} error")
    for row in rows:
        b = "-" if row["b"] is None else f"{row['b']:.4g}" + (f" +-{row['b_se']:.1g}" if row["b_se"] else "")
        n = "-" if row["n"] is None else f"{row['n']:.4g}" + (f" +-{row['n_se']:.1g}" if row["n_se"] else "")
        nrms = "-" if row["nrms_after"] is None else f"{row['nrms_before']:.2%} -> {row['nrms_after']:.2%}"
        name = row["file"].rsplit("/", 1)[-1]
        print(f"{name:<28} {row['effects'] or '-':<26} {b:>16} {n:>14} {nrms:>15} {row['error'] or ''}")
    print(f"muscle files, calibration_summary.csv and calibration_parameters.png in {out}")
    return 1 if any(row["status"] != "ok" for row in rows) else 0
