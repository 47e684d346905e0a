"""Many runs at once: ``mkctl sweep``, and ``mkctl diagnose`` over many files (its batch half).

- ``mkctl sweep --grid c=0:200:21 m=2:10:5 --out sweep/`` computes the equilibrium, a1/a2, the verdict,
  the poles, the damping ratio, settling time and overshoot over every combination (or ``--random N
  --range c=0:200 --range m=2:10``), writes ``sweep.csv`` (and ``sweep.parquet`` with pyarrow) and maps;
  ``--mechanism NAME|FILE.py`` sweeps any mechanism instead (:mod:`mkctl.analysis.mechanism_sweep`).
- ``mkctl diagnose a.csv b.csv data/ 'runs/*.csv' --out results/`` diagnoses every record in parallel
  (:func:`mkctl.analysis.batch.diagnose_batch`); ``mkctl diagnose FILE`` alone stays the one-record command
  of :mod:`mkctl.cli.measure`, which calls :func:`run_diagnose_batch` when it gets more than one file.

Both run on a LocalCluster of ``--jobs`` processes (default: the cores) or on the Dask cluster whose
scheduler is ``--scheduler tcp://HOST:PORT``, or ``--scheduler tls://HOST:PORT`` with ``--tls-ca``, ``--tls-cert``
and ``--tls-key`` (or Dask's own ``distributed.comm.tls`` configuration; docs/batch.md).
"""
from __future__ import annotations

import contextlib
import sys
from pathlib import Path

from .options import UsageError, add_effects_option, base_params, output_folder


def add_engine_options(parser) -> None:
    """``--jobs`` and ``--scheduler``, shared by the commands that run on the batch engine."""
    parser.add_argument("--jobs", type=int, default=None, metavar="N",
                        help="worker processes on this machine (default: the cores; 0: no workers, in this process)")
    parser.add_argument("--scheduler", metavar="ADDRESS", default=None,
                        help="run on the Dask cluster of this scheduler instead, e.g. tcp://10.0.0.5:8786 "
                             "(workers need mkctl installed and the files under the same paths)")
    add_tls_options(parser)
    parser.add_argument("--dashboard", metavar="[HOST:]PORT", default=None,
                        help="serve Dask's dashboard of the local cluster here and print its link (PORT alone: on "
                             "127.0.0.1; 0: any free port; HOST:PORT to offer it to the network). Default: a free "
                             "port on 127.0.0.1; the local scheduler and workers listen on 127.0.0.1 only")


def add_tls_options(parser) -> None:
    """``--tls-ca``, ``--tls-cert``, ``--tls-key``: the PEM files of a ``tls://`` scheduler's connection."""
    for what, text in (("ca", "the certificate authority that signed the scheduler's certificate"),
                       ("cert", "this client's certificate (signed by that authority)"),
                       ("key", "this client's private key (if not in the --tls-cert file)")):
        parser.add_argument(f"--tls-{what}", metavar="FILE.pem", default=None,
                            help=f"with --scheduler tls://HOST:PORT: {text}; or set Dask's "
                                 f"distributed.comm.tls configuration instead (docs/batch.md)")


def tls_settings(args):
    """A context in which Dask's configuration holds the ``--tls-*`` files (nothing changes without them)."""
    import dask

    from ..analysis.batch import tls_config
    values = tls_config(*(getattr(args, f"tls_{what}", None) for what in ("ca", "cert", "key")))
    return dask.config.set(values) if values else contextlib.nullcontext()


def _check_jobs(args) -> None:
    if args.jobs is not None and args.jobs < 0:
        raise UsageError(f"--jobs must be 0 or more, got {args.jobs}")


#: The subcommands this module adds, with the one line ``mkctl --help`` shows for each (the command line
#: lists them without importing what they need).
COMMANDS = {
    "sweep": "the model over a grid or a random sample of parameters: stability, poles, step metrics",
}


def register(subparsers) -> None:
    """Add ``sweep`` to the `mkctl` parser."""
    from ..analysis.sweep import DYNAMICS, QUANTITIES

    p = subparsers.add_parser(
        "sweep", help=COMMANDS["sweep"],
        description="For every point (parameters of model-spec sections 2-4 in SI, the posture alpha_deg [deg] "
                    "and the flexor pressure pf_kPa [kPa]) compute the extensor pressure that holds the posture, "
                    "a1 and a2 of Eq. 18 and the Routh-Hurwitz verdict, the poles, the damping ratio, and the "
                    "settling time and overshoot of the hip height after a pe_cmd step (linear model). Writes "
                    "sweep.csv (sweep.parquet with pyarrow) and PNG maps of chosen quantities. With --mechanism, "
                    "any mechanism instead: its own parameters, the muscle's and each muscle's pressure p1_kPa, "
                    "p2_kPa [kPa] (default 300) give the stable rest of its coordinate between its stops, and the "
                    "same dynamics.")
    p.add_argument("--grid", nargs="+", action="extend", default=[], metavar="NAME=START:STOP:COUNT",
                   help="an axis of the grid (every combination is computed): NAME=START:STOP:COUNT (evenly "
                        "spaced, ends included) or NAME=V1,V2,...; e.g. --grid c=0:200:21 m=2:10:5")
    p.add_argument("--random", type=int, default=None, metavar="N",
                   help="instead of a grid, N points drawn uniformly in the --range ranges")
    p.add_argument("--range", nargs="+", action="extend", default=[], metavar="NAME=LOW:HIGH", dest="ranges",
                   help="a range of the random sample, e.g. --range c=0:200 tau=0:0.1")
    p.add_argument("--seed", type=int, default=0, help="seed of the random sample (default 0)")
    p.add_argument("--set", nargs="+", action="extend", default=[], metavar="NAME=VALUE", dest="fixed",
                   help="a value held for every point (SI; alpha_deg in deg, pf_kPa in kPa), e.g. --set tau=0.05")
    p.add_argument("--map", action="append", default=None, metavar="QUANTITY",
                   help="a quantity to map (repeatable; default: verdict, damping_ratio, settling_time_s); "
                        "one of " + ", ".join(QUANTITIES) + " (with --mechanism: the coordinate at rest, "
                        "e.g. theta_rad, and " + ", ".join(DYNAMICS) + ")")
    p.add_argument("--mechanism", metavar="NAME|FILE.py", default=None,
                   help="sweep this mechanism instead of the knee (model-spec 3b): hanging_mass, pulley_joint or "
                        "a mechanism file")
    p.add_argument("--axes", nargs=2, default=None, metavar=("X", "Y"),
                   help="the two swept names the maps are drawn over (default: the first two)")
    p.add_argument("--out", metavar="DIR", default="sweep", help="folder for the table and maps (default: sweep)")
    p.add_argument("--chunk", type=int, default=None, metavar="POINTS", help="points per task (default: automatic)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    add_effects_option(p)
    add_engine_options(p)
    p.set_defaults(func=run_sweep)


def _number(text: str, option: str, name: str) -> float:
    try:
        return float(text)
    except ValueError:
        raise UsageError(f"{option} {name}: {text.strip()!r} is not a number") from None


def _subject(args):
    """What ``mkctl sweep`` sweeps: the knee, or the mechanism ``--mechanism`` names (loaded: the user asked)."""
    from ..analysis.sweep import KneeSweep

    if args.mechanism is None:
        return KneeSweep()
    from ..analysis.mechanism_files import mechanism
    from ..analysis.mechanism_sweep import MechanismSweep
    return MechanismSweep(mechanism(args.mechanism))


def run_sweep(args) -> int:
    from ..analysis.sweep import SweepError, parse_axis, sweep

    _check_jobs(args)
    folder = output_folder(args.out, "--out")
    subject = _subject(args)
    for quantity in args.map or ():
        if quantity not in subject.quantities:
            raise UsageError(f"--map {quantity}: not a quantity of this sweep (known: "
                             f"{', '.join(subject.quantities)})")
    fixed = {}
    for item in args.fixed:
        name, sep, text = item.partition("=")
        if not sep:
            raise UsageError(f"--set expects NAME=VALUE, got {item!r}")
        fixed[name.strip()] = _number(text, "--set", name.strip())
    if args.random is not None:
        if args.grid:
            raise UsageError("give either --grid or --random with --range, not both")
        ranges = dict(parse_axis(item, random=True, names=subject.names) for item in args.ranges)
        if not ranges:
            raise UsageError("--random needs at least one --range NAME=LOW:HIGH")
        grid = None
    else:
        if args.ranges:
            raise UsageError("--range goes with --random N; a grid takes --grid NAME=START:STOP:COUNT")
        if not args.grid:
            raise UsageError("nothing to sweep: give --grid NAME=START:STOP:COUNT ... or --random N --range ...")
        grid = dict(parse_axis(item, names=subject.names) for item in args.grid)
        ranges = None
    with tls_settings(args):
        result = sweep(grid, random=args.random, ranges=ranges, fixed=fixed, seed=args.seed, jobs=args.jobs,
                       scheduler=args.scheduler, progress=not args.quiet, chunk=args.chunk,
                       dashboard=args.dashboard, subject=subject)
    print(repr(result))
    paths = result.save(folder)
    names = list(result.axes)
    x, y = args.axes if args.axes else (names[0], names[1] if len(names) > 1 else None)
    for name in (x, y):
        if name is not None and name not in names:
            raise SweepError(f"--axes {name}: not swept (swept: {', '.join(names)})")
    for quantity in args.map or ["verdict", "damping_ratio", "settling_time_s"]:
        path = folder / f"sweep_{quantity}.png"
        result.plot_map(quantity, x, y, path)
        paths.append(path)
    print("wrote " + ", ".join(str(p) for p in paths))
    return 0


def run_diagnose_batch(args) -> int:
    """``mkctl diagnose`` with several files, a folder or a glob: the batch engine, a table, a figure."""
    from ..analysis.batch import SUMMARY_CSV, SUMMARY_PNG, diagnose_batch, expand_files

    _check_jobs(args)
    if getattr(args, "json", None):
        raise UsageError("--json names one report: with several files, give --out DIR (one JSON per record there)")
    files = expand_files(args.file)
    folder = output_folder(args.out, "--out") if args.out else Path("diagnosis")
    if not args.out:
        output_folder(folder, "output folder (./diagnosis; choose another with --out)")
    quiet = getattr(args, "quiet", False)

    def said(file, report, error):
        if not quiet:  # above the progress bar
            from tqdm import tqdm

            what = f"error: {error}" if error else "missing: " + (", ".join(report["missing"]) or "nothing")
            tqdm.write(f"{Path(file).name}: {what}", file=sys.stderr)

    with tls_settings(args):
        result = diagnose_batch(files, folder, jobs=args.jobs, scheduler=args.scheduler, progress=not quiet,
                                on_record=said, base=base_params(args),
                                fit_offset=getattr(args, "fit_offset", False),
                                dashboard=getattr(args, "dashboard", None),
                                mechanism=getattr(args, "mechanism", None))
    print(repr(result))
    print(f"reports: {folder}/<record>.diagnosis.json; table: {folder / SUMMARY_CSV}; figure: {folder / SUMMARY_PNG}")
    refused = [f for f, r in result.reports.items() if r.get("verdict") == "not diagnosed"]
    return 1 if result.errors or refused else 0
