"""What the scenario scripts share: arguments, the FMUs, running them with fmpy, CSV files and figures.

Every scenario is ``python scenarios/NAME.py [--out DIR] [--fmu-dir DIR] [--duration S]``: it drives the FMUs
of ``--fmu-dir`` (default ``dist``, built by build_fmu.py when missing) with fmpy, writes ``NAME.csv`` and
``NAME.png`` under ``--out`` (default ``out/NAME``) and prints a short summary.
"""
from __future__ import annotations

import argparse
import csv
import subprocess
import sys
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
if str(ROOT) not in sys.path:  # run as a script from anywhere: find mkctl and build_fmu.py
    sys.path.insert(0, str(ROOT))

from mkctl.plotting import new_figure, save_png  # noqa: E402

FMU_FILES = {"knee": "McKibbenKnee.fmu", "actuator": "McKibbenActuator.fmu"}


class ScenarioError(Exception):
    """A scenario could not run to its end."""


def parse_args(name: str, description: str, duration: float, argv=None, extra=None) -> argparse.Namespace:
    """The common command line; ``extra(parser)`` may add the scenario's own options."""
    parser = argparse.ArgumentParser(prog=f"scenarios/{name}.py", description=description)
    parser.add_argument("--out", type=Path, default=ROOT / "out" / name,
                        help="folder for the CSV and PNG (default: out/NAME)")
    parser.add_argument("--fmu-dir", type=Path, default=ROOT / "dist",
                        help="folder holding the FMUs (default: dist; built when missing)")
    parser.add_argument("--duration", type=float, default=duration, help=f"simulated time [s] (default {duration:g})")
    if extra is not None:
        extra(parser)
    args = parser.parse_args(argv)
    args.name = name
    return args


def fmu_path(args, which: str) -> Path:
    """Path of the knee or actuator FMU, building both with build_fmu.py if it is missing."""
    path = Path(args.fmu_dir) / FMU_FILES[which]
    if not path.exists():
        print(f"{path} missing: building the FMUs ...")
        subprocess.run([sys.executable, str(ROOT / "build_fmu.py"), "--out", str(args.fmu_dir), "--no-run"],
                       check=True)
    return path


def input_signal(rows) -> np.ndarray:
    """An fmpy input from rows ``(time, {name: value})``, interpolated linearly in between; a repeated time
    makes a step."""
    names = list(rows[0][1])
    return np.array([(t, *(values[n] for n in names)) for t, values in rows],
                    dtype=[("time", float)] + [(n, float) for n in names])


def simulate(fmu: Path, stop: float, step: float = 1e-3, inputs=None, start_values=None) -> np.ndarray:
    """Run an FMU with fmpy at a fixed communication step; raise ScenarioError (with the FMU's own messages)
    unless it reaches the stop time."""
    from fmpy import simulate_fmu

    messages = []

    def logger(component, instance, status, category, message):
        if status >= 2:  # discard, error, fatal
            messages.append(message.decode(errors="replace") if isinstance(message, bytes) else str(message))

    result = simulate_fmu(str(fmu), stop_time=stop, output_interval=step, input=inputs,
                          start_values=start_values or {}, debug_logging=True, logger=logger)
    if abs(result["time"][-1] - stop) > 1e-9 * max(1.0, stop):
        raise ScenarioError(f"{Path(fmu).name} stopped at t = {result['time'][-1]:g} s instead of {stop:g} s: "
                            + ("; ".join(messages) or "no message"))
    return result


def write_csv(path: Path, columns: dict[str, np.ndarray]) -> Path:
    """One column per entry (name with its unit as suffix, e.g. ``X_m``), one row per sample."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    names = list(columns)
    data = np.column_stack([np.asarray(columns[n], dtype=float) for n in names])
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(names)
        writer.writerows(data.tolist())
    return path


def finish(args, columns: dict[str, np.ndarray], fig, summary: list[str]) -> None:
    """Write NAME.csv and NAME.png under --out and print the summary."""
    csv_path = write_csv(Path(args.out) / f"{args.name}.csv", columns)
    png_path = save_png(fig, Path(args.out) / f"{args.name}.png")
    print(f"{args.name}:")
    for line in summary:
        print(f"  {line}")
    print(f"  wrote {csv_path} and {png_path}")


def main_guard(run, argv=None) -> int:
    """Run a scenario; a ScenarioError (or an FMU that could not be built) ends it with one line, exit 1."""
    try:
        run(argv)
    except (ScenarioError, subprocess.CalledProcessError) as error:
        print(f"error: {error}", file=sys.stderr)
        return 1
    return 0


__all__ = ["ROOT", "ScenarioError", "parse_args", "fmu_path", "input_signal", "simulate", "write_csv", "finish",
           "main_guard", "new_figure", "save_png"]
