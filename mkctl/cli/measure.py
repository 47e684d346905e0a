"""Subcommands for measurements: ``synth`` (the virtual test bench), ``compare`` and ``diagnose``.

- ``mkctl synth knee data.csv --hidden viscous_damping`` (``--hidden`` repeatable, or comma-separated:
  ``--hidden c=45,tau=0.05``) writes a measurement file made by the model with
  hidden effects (and ``data.truth.json`` with what was hidden); ``--shape``, ``--input-noise``,
  ``--noise-tau``, ``--offset``/``--declare-offset``, ``--output-column beta_deg`` and ``--pressures``
  make it as messy as a real rig. ``mkctl synth mechanism data.csv --mechanism pulley_joint`` (a built-in or a
  FILE.py) and ``mkctl synth actuator data.csv`` (a driven-length test) write the records of model-spec 5d.
- ``mkctl compare data.csv`` simulates the file's baseline on its inputs, prints RMSE and fit, and saves the
  overlay and the residual as PNG; a mechanism record naming a FILE.py needs ``--mechanism FILE.py`` (a record
  never loads code by itself).
- ``mkctl diagnose data.csv --json out.json`` finds the effects the baseline misses (see
  :mod:`mkctl.analysis.diagnose`), prints a summary and saves the JSON report and the pictures;
  ``--fit-offset`` fits a constant sensor offset; a record that cannot be this model's output (a unit or
  zero mistake) is "not diagnosed", exit status 3. Several
  files, a folder or a glob run as a batch (:func:`mkctl.cli.batch.run_diagnose_batch`).
"""
from __future__ import annotations

import glob
import json
import sys
from pathlib import Path

from .batch import add_engine_options, run_diagnose_batch
from .options import (UsageError, add_params_option, base_params, muscle_values, output_file, output_folder,
                      parse_assignments, split_items)


#: The subcommands this module adds, with the one line ``mkctl --help`` shows for each (the command line
#: lists them without importing what they need).
COMMANDS = {
    "synth": "write a synthetic measurement file with hidden effects (the virtual test bench)",
    "compare": "compare the baseline with a measurement file: RMSE, fit, overlay and residual PNGs",
    "diagnose": "find the effects a measurement shows that the baseline lacks, fit them, report",
}


def register(subparsers) -> None:
    """Add ``synth``, ``compare`` and ``diagnose`` to the `mkctl` parser."""
    from ..analysis.synth import (DEFAULT_EFFECT_VALUES, DEFAULT_NOISE_MM, DEFAULT_RATE, PRESSURE_HOLDS,
                                  PRESSURE_LOAD, PRESSURE_RATE, PRESSURE_SHAPES, SHAPES)

    p = subparsers.add_parser(
        "synth", help=COMMANDS["synth"],
        description="Simulate an experiment with the file's baseline plus hidden effects, add Gaussian noise to "
                    "the measured output, and write a measurement file (model-spec section 5). The hidden values "
                    "go to <stem>.truth.json beside it, never into the file.")
    p.add_argument("experiment", choices=["knee", "isotonic", "isometric", "mechanism", "actuator", "pressure"],
                   help="what to simulate: knee (the robot leg driven by pressure steps), isotonic (one actuator "
                        "under hanging loads, pressure swept), isometric (a blocked-force bench: the muscle "
                        "clamped at 4 lengths, pressure stepped up and down), mechanism (--mechanism's, muscle 1's "
                        "command stepped) or actuator (a driven-length test: the length imposed as sines under two "
                        "pressures, the force measured) or pressure (one muscle's pressure: a regulator's steps, "
                        "a switching valve, a leak-down; --shape, --motion)")
    p.add_argument("output", metavar="OUT.csv", help="the measurement file to write (<stem>.truth.json goes beside it)")
    p.add_argument("--hidden", action="append", default=[], metavar="EFFECT|NAME=VALUE",
                   help="an effect hidden in the data (repeatable, or comma-separated): an effect name (" + ", ".join(
                       f"{k}" + (f" = {', '.join(f'{n} {v:g}' for n, v in d.items())}" if d else " = Table I")
                       for k, d in DEFAULT_EFFECT_VALUES.items()) + ") or a parameter NAME=VALUE in SI, "
                       "e.g. --hidden c=45 --hidden tau=0.05 or --hidden c=45,tau=0.05")
    p.add_argument("--param", action="append", default=[], metavar="NAME=VALUE",
                   help="a known parameter (SI), written into the file's metadata (repeatable, or comma-separated), "
                        "e.g. --param m=2.5")
    p.add_argument("--baseline", choices=["model1", "model2"], default="model2",
                   help="the baseline the file declares (default model2); hide elasticity with model1")
    p.add_argument("--noise", type=float, default=None,
                   help=f"standard deviation of the output noise [the output column's unit: mm, deg for beta_deg, "
                        f"N for isometric] (default {DEFAULT_NOISE_MM:g} mm; isometric 0.5 N)")
    p.add_argument("--seed", type=int, default=0, help="seed of the noise (default 0)")
    p.add_argument("--samples", type=int, default=None, help="samples (default 3000 knee, 2000 isotonic, 400 isometric)")
    p.add_argument("--rate", type=float, default=None,
                   help=f"sample rate [Hz] (default {DEFAULT_RATE:g}; pressure {PRESSURE_RATE:g})")
    p.add_argument("--shape", default=None, choices=sorted({*SHAPES["knee"], *SHAPES["isotonic"], *PRESSURE_SHAPES}),
                   help="command shape: knee steps (default), ramps or chirp (changes at every sample); isotonic "
                        "sweeps (default) or steps; pressure steps (default: large set-point steps), small (small "
                        "steps), valve (a switching valve opened, closed, exhausted) or leakdown (a fast fill, then "
                        "closed: the heat's sag and the leak-down)")
    p.add_argument("--motion", choices=PRESSURE_HOLDS, default="held",
                   help="pressure: the muscle held at --length (default L0), moving (a length column) or free "
                        "under --load")
    p.add_argument("--length", type=float, default=None, metavar="MM", help="pressure: the held length [mm]")
    p.add_argument("--load", type=float, default=PRESSURE_LOAD, metavar="N",
                   help=f"pressure: the load of a free muscle [N] (default {PRESSURE_LOAD:g})")
    p.add_argument("--jitter", type=float, default=0.0,
                   help="pressure: irregular sampling, each interval within +-JITTER of 1/rate (0.2 at 80 Hz: "
                        "10-15 ms, as real loggers give); default 0")
    p.add_argument("--output-column", dest="output_column", default=None, metavar="COLUMN",
                   help="the measured output: x_mm (default) or beta_deg (a knee joint encoder); length_mm (isotonic)")
    p.add_argument("--input-noise", type=float, default=0.0, metavar="KPA",
                   help="sensor noise of the measured pressures [kPa] (isotonic pressure; knee pe, pf with "
                        "--pressures); default 0")
    p.add_argument("--noise-tau", type=float, default=0.0, metavar="S",
                   help="correlation time of the output noise [s] (coloured, first-order); default 0: white")
    p.add_argument("--offset", type=float, default=0.0,
                   help="sensor offset added to the written output [the output column's unit]; default 0")
    p.add_argument("--declare-offset", action="store_true",
                   help="declare the offset in the file's metadata (x_offset_mm = ...), as a user who knows it would")
    p.add_argument("--pressures", action="store_true",
                   help="knee: also write the measured bladder pressures pe_kPa, pf_kPa")
    p.add_argument("--resolution", type=float, default=0.0,
                   help="the output sensor's resolution [the output column's unit]: the output is rounded to it "
                        "(a 12-bit joint encoder: --output-column beta_deg --resolution 0.087890625); default 0")
    p.add_argument("--no-truth", action="store_true", help="do not write <stem>.truth.json")
    _add_mechanism_option(p)
    p.add_argument("--hold", action="append", default=[], metavar="KPA",
                   help="mechanism: each muscle's holding pressure [kPa] (one per muscle, comma-separated or "
                        "repeated; default 300 each)")
    add_params_option(p)
    p.set_defaults(func=run_synth)

    p = subparsers.add_parser(
        "compare", help=COMMANDS["compare"],
        description="Simulate the file's baseline on its inputs; print RMSE and fit = 100 (1 - |y - yhat| / "
                    "|y - mean(y)|) and save <stem>_compare_overlay.png and <stem>_compare_residual.png.")
    p.add_argument("file", metavar="FILE.csv")
    p.add_argument("--out", metavar="DIR", default=None, help="folder for the PNGs (default: beside the file)")
    _add_mechanism_option(p)
    add_params_option(p)
    p.set_defaults(func=run_compare)

    p = subparsers.add_parser(
        "diagnose", help=COMMANDS["diagnose"],
        description="Rank the candidate effects (model-spec section 4) the baseline lacks, add the best while BIC "
                    "and the held-out error support it, fit their parameters on simulation error, and report "
                    "(JSON as model-spec section 6, plus PNGs: the error step by step, before/after overlay, "
                    "residuals, signatures).")
    p.add_argument("file", metavar="FILE.csv", nargs="+",
                   help="a measurement file; several files, folders or globs run as a batch (mkctl.cli.batch)")
    p.add_argument("--json", metavar="OUT.json", default=None, help="write the report here")
    p.add_argument("--out", metavar="DIR", default=None,
                   help="folder for the PNGs (default: beside the JSON, or beside the file); for a batch, the "
                        "folder for the reports, the summary table and figure (default ./diagnosis)")
    p.add_argument("--quiet", action="store_true", help="no progress lines on stderr")
    p.add_argument("--fit-offset", action="store_true",
                   help="fit a constant sensor offset of the measured output (a sensor zeroed at rest, an encoder "
                        "mounted off by a few degrees); without it, an output the model cannot reach is not "
                        "diagnosed (exit status 3)")
    p.add_argument("--suggest", metavar="FILE.py", default=None,
                   help="when the verdict is incomplete, write the terms the discovery found as an effect file "
                        "(model-spec section 4c) to add with --effects FILE.py")
    _add_mechanism_option(p)
    add_params_option(p)
    add_engine_options(p)
    p.set_defaults(func=run_diagnose)


def _add_mechanism_option(parser) -> None:
    parser.add_argument("--mechanism", metavar="NAME|FILE.py", default=None,
                        help="the mechanism (model-spec 3b): hanging_mass, pulley_joint, knee or a mechanism file; "
                             "a record's 'mechanism = FILE.py' is loaded only when given here too")


def load_mechanism(args):
    """The mechanism ``--mechanism`` names (loaded: the user asked), or None."""
    if getattr(args, "mechanism", None) is None:
        return None
    from ..analysis.mechanism_files import mechanism

    return mechanism(args.mechanism)


def _own_values(args, items) -> dict:
    """The --param items that set the mechanism's own parameters (synth mechanism), by name."""
    if args.experiment != "mechanism" or args.mechanism is None:
        return {}
    names = load_mechanism(args).parameter_names
    own = {}
    for item in items:
        name, _, text = item.partition("=")
        if name.strip() in names:
            try:
                own[name.strip()] = float(text)
            except ValueError:
                raise UsageError(f"--param {name.strip()}: {text.strip()!r} is not a number") from None
    return own


def _synthesize(args, known: dict):
    """The record ``mkctl synth`` asks for."""
    from ..analysis.synth import (DEFAULT_RATE, PRESSURE_RATE, synthesize, synthesize_actuator, synthesize_mechanism,
                                  synthesize_pressure)

    mech = load_mechanism(args)
    hold = split_items(args.hold)
    if args.experiment != "mechanism":
        if mech is not None or hold:
            raise UsageError(f"--mechanism and --hold belong to 'synth mechanism', not '{args.experiment}'")
    elif mech is None:
        raise UsageError("synth mechanism needs --mechanism NAME|FILE.py (hanging_mass, pulley_joint, knee or a "
                         "mechanism file)")
    if args.experiment != "pressure" and (args.motion != "held" or args.length is not None or args.jitter):
        raise UsageError(f"--motion, --length and --jitter belong to 'synth pressure', not '{args.experiment}'")
    if args.experiment == "pressure":
        if args.shape not in (None, "steps", "small", "valve", "leakdown"):
            raise UsageError(f"--shape {args.shape}: a pressure record's shapes are steps, small, valve and leakdown")
        if args.pressures or args.input_noise:
            raise UsageError("a pressure record's inputs are commands (set-points or openings): no --pressures "
                             "or --input-noise")
        if args.output_column not in (None, "p_kPa"):
            raise UsageError(f"--output-column {args.output_column}: a pressure record's output is p_kPa")
        return synthesize_pressure(split_items(args.hidden), known, args.baseline, noise=args.noise,
                                   seed=args.seed, samples=args.samples,
                                   rate=PRESSURE_RATE if args.rate is None else args.rate,
                                   shape=args.shape or "steps", hold=args.motion,
                                   length=None if args.length is None else args.length * 1e-3, load=args.load,
                                   jitter=args.jitter, noise_tau=args.noise_tau, offset=args.offset,
                                   declare_offset=args.declare_offset, resolution=args.resolution)
    args.rate = DEFAULT_RATE if args.rate is None else args.rate
    common = dict(noise=args.noise, seed=args.seed, samples=args.samples, rate=args.rate,
                  input_noise=args.input_noise, noise_tau=args.noise_tau, offset=args.offset,
                  declare_offset=args.declare_offset, measured_pressures=args.pressures, resolution=args.resolution)
    if args.experiment in ("mechanism", "actuator") and args.shape is not None:
        raise UsageError(f"--shape belongs to the knee and isotonic records; a {args.experiment} record has one")
    if args.experiment == "mechanism":
        try:
            pressures = [float(v) * 1e3 for v in hold] or None
        except ValueError:
            raise UsageError(f"--hold {','.join(hold)}: each holding pressure must be a number of kPa") from None
        return synthesize_mechanism(mech, split_items(args.hidden), known, args.baseline, pressures=pressures,
                                    output=args.output_column, **common)
    if args.experiment == "actuator":
        if args.output_column not in (None, "force_N"):
            raise UsageError(f"--output-column {args.output_column}: an actuator record's output is force_N")
        return synthesize_actuator(split_items(args.hidden), known, args.baseline, **common)
    return synthesize(args.experiment, split_items(args.hidden), known,
                      args.baseline, args.noise, args.seed, args.samples, args.rate, shape=args.shape,
                      output=args.output_column, input_noise=args.input_noise, noise_tau=args.noise_tau,
                      offset=args.offset, declare_offset=args.declare_offset, pressures=args.pressures,
                      resolution=args.resolution)


def run_synth(args) -> int:
    from ..physics.params import UNITS
    from ..analysis.synth import write_synthetic

    from ..analysis.synth import truth_path_for

    output_file(args.output, "output file")
    if not args.no_truth:
        output_file(truth_path_for(args.output), "truth file")
    known = muscle_values(args)
    items = split_items(args.param)
    own = _own_values(args, items)
    known.update(parse_assignments([i for i in items if i.partition("=")[0].strip() not in own], "--param"))
    record = _synthesize(args, {**known, **own})
    path, truth = write_synthetic(args.output, record, truth_file=not args.no_truth)
    hidden = ", ".join(f"{k} = {v:g} {UNITS[k]}" for k, v in record.hidden.items() if k != "model")
    effects = ", ".join(record.hidden_effects) or "none"
    what = record.experiment + (f" ({record.mechanism.name})" if record.mechanism is not None else "")
    print(f"wrote {path}: {what}, {record.time.size} samples over {record.time[-1]:g} s, "
          f"baseline {record.baseline}")
    print(f"hidden effects: {effects}" + (f" ({hidden})" if hidden else ""))
    unit = record.output_column.rsplit("_", 1)[1]
    extras = [f"shape {record.shape}"]
    if record.noise_tau:
        extras.append(f"coloured (correlation time {record.noise_tau:g} s)")
    if record.input_noise:
        extras.append(f"pressure sensor noise {record.input_noise:g} kPa")
    if record.resolution:
        extras.append(f"resolution {record.resolution:g} {unit}")
    if record.offset:
        extras.append(f"sensor offset {record.offset:g} {unit}" + (" (declared)" if record.declare_offset else ""))
    print(f"noise {record.noise:g} {unit}, seed {record.seed}; " + ", ".join(extras)
          + (f"; the truth is in {truth}" if truth else ""))
    return 0


def run_compare(args) -> int:
    from ..analysis.compare import (RECORD_OUTPUTS, compare, fit_text, plot_overlay, plot_record_overlay,
                                    plot_residuals)
    from ..io.measurements import read_measurement

    folder = output_folder(args.out, "--out") if args.out else Path(args.file).resolve().parent
    measurement = read_measurement(args.file, base=base_params(args), mechanism=load_mechanism(args))
    if not args.out:
        output_folder(folder, "PNG folder (beside the file; choose another with --out)")
    result = compare(measurement)
    stem = Path(args.file).stem
    effects = ", ".join(measurement.params.effects) or "no effects"
    what = measurement.experiment + (f" ({measurement.mechanism.name})" if measurement.mechanism else "")
    print(f"{args.file}: {what}, {measurement.samples} samples, baseline {measurement.baseline} "
          f"({effects})")
    print(f"RMSE {result.rmse:.4g} {measurement.output_unit}   {fit_text(result.fit_percent)}")
    if measurement.experiment in RECORD_OUTPUTS:
        overlay = plot_record_overlay(measurement, {f"baseline {measurement.baseline}": result.simulated},
                                      folder / f"{stem}_compare_overlay.png", f"{stem}: baseline vs measurement")
    else:
        overlay = plot_overlay(measurement, {f"baseline {measurement.baseline}": result.simulated},
                               folder / f"{stem}_compare_overlay.png", f"{stem}: baseline vs measurement")
    residual = plot_residuals(measurement, {"measured - baseline": result.residual},
                              folder / f"{stem}_compare_residual.png")
    print(f"saved {overlay} and {residual}")
    if measurement.experiment == "isometric":
        from ..analysis.compare import plot_isometric
        figure = plot_isometric(measurement.inputs["length"], measurement.inputs["pressure"], measurement.output,
                                measurement.branch, {f"baseline {measurement.baseline}": measurement.params},
                                folder / f"{stem}_compare_isometric.png", f"{stem}: tension against pressure",
                                L0=measurement.params.L0)
        print(f"saved {figure}")
    return 0


def run_diagnose(args) -> int:
    from ..analysis.diagnose import diagnose, public, save_pictures, summary
    from ..io.text import write_text_atomic
    from ..io.measurements import read_measurement

    batch = len(args.file) > 1 or Path(args.file[0]).is_dir() or glob.has_magic(args.file[0])
    if batch and getattr(args, "suggest", None):
        raise UsageError("--suggest takes one record, not a batch")
    if batch:
        return run_diagnose_batch(args)
    args.file = args.file[0]
    suggest = output_file(args.suggest, "--suggest") if getattr(args, "suggest", None) else None

    # every output path is checked before the fit, which takes seconds to minutes
    json_path = output_file(args.json, "--json") if args.json else None
    if args.out:
        folder = output_folder(args.out, "--out")
    elif args.json:
        folder = Path(args.json).resolve().parent
    else:
        folder = Path(args.file).resolve().parent
    measurement = read_measurement(args.file, base=base_params(args),
                                   mechanism=load_mechanism(args))
    if not args.out and not args.json:
        output_folder(folder, "PNG folder (beside the file; choose another with --out)")
    progress = None if args.quiet else (lambda text: print(text, file=sys.stderr, flush=True))
    result = diagnose(measurement, progress, fit_offset=args.fit_offset)
    if suggest:
        _write_suggestion(result, suggest, args.file)
    save_pictures(measurement, result, folder, Path(args.file).stem)
    for line in summary(result):
        print(line)
    if json_path:
        path = json_path
        write_text_atomic(path, json.dumps(public(result), indent=2, allow_nan=False, default=float) + "\n")
        print(f"report: {path}")
    print("pictures: " + ", ".join(result.pictures.values()))
    if result.verdict == "not diagnosed":
        print(f"mkctl diagnose: {args.file}: not diagnosed: " + "; ".join(result.problems), file=sys.stderr)
        return 3
    return 0


def _write_suggestion(result, path: Path, source: str) -> None:
    """--suggest: the discovery's terms as an effect file (spec 4c); the report's ``effect_file`` names it."""
    from ..analysis.discovery import registered_effects
    from ..analysis.effect_files import write_suggestion

    found = result.discovery
    if not found or not found["terms"]:
        why = (f"the verdict is {result.verdict}, not incomplete" if not found
               else "the discovery proposed nothing")
        print(f"--suggest: nothing written: {why}", file=sys.stderr)
        return
    written = write_suggestion(path, found, source=source, registered=registered_effects())
    if written is None:
        print("--suggest: nothing written: the terms found have the form of registered effects, or change the "
              "pressure (see the discovery lines)", file=sys.stderr)
        return
    found["effect_file"] = str(written)
