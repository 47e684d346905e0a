"""What the scenario scripts share: arguments, the FMUs, running them with fmpy, CSV files and figures.

Every scenario is ``python -m mkctl.scenarios.NAME [--out DIR] [--fmu-dir DIR] [--duration S]`` (in a checkout
also ``python scenarios/NAME.py``, a thin wrapper): it drives the FMUs of ``--fmu-dir`` (default ``dist`` in the
working folder, built by :func:`build_fmus` when missing) with fmpy, writes ``NAME.csv`` and ``NAME.png`` under
``--out`` (default ``out/NAME`` in the working folder) and prints a short summary. Each scenario module has
``run(argv)`` (raises on a problem) and ``main(argv) -> exit status`` (one line on stderr instead).

Errors. Every option is checked before the first simulation (``parse_args`` and the scenario's ``check``):
a bad value, a folder that cannot be used or a parameter the model cannot represent ends the script with one
line on stderr naming the option and the value, exit status 2, no traceback. A run that fails anyway (the FMU
refuses a step, the FMUs cannot be built) ends the same way, with the FMU's own logged message.

The FMUs run in this Python. The scenarios import mkctl (for the plots, the checks of the options and the
reference numbers they print), so the FMUs use that copy of mkctl, not the one packed in the FMU
(DEVELOPERS.md, "Known pitfalls"): the same code when the FMUs were built from this checkout. The packed FMUs
are tested on their own in tests/test_fmu*.py.
"""
from __future__ import annotations

import argparse
import csv
import math
import os
import subprocess
import sys
import zipfile
from pathlib import Path

import numpy as np

from ..errors import MkctlError
from ..io.command_line import OneLineParser, UsageError, folder_problem, run_reporting_errors  # as mkctl's
from ..physics.params import Params

FMU_FILES = {"knee": "McKibbenKnee.fmu", "actuator": "McKibbenActuator.fmu"}
STEP = 1e-3  #: communication step of the fmpy runs [s]

_prog = "scenario"  # the script's name in error messages, set by parse_args


class ScenarioError(MkctlError):
    """A scenario could not run to its end."""


# --- figures: matplotlib is imported only when a figure is drawn, so that a bad option fails fast ---------

def new_figure(*args, **kwargs):
    """:func:`mkctl.io.plotting.new_figure`."""
    from mkctl.io.plotting import new_figure as new
    return new(*args, **kwargs)


def save_png(fig, path, dpi: int = 120) -> Path:
    """:func:`mkctl.io.plotting.save_png`."""
    from mkctl.io.plotting import save_png as save
    return save(fig, path, dpi)


# --- the command line ------------------------------------------------------------------------------------

def require(condition, message: str) -> None:
    """Raise :class:`UsageError` with message unless condition holds."""
    if not condition:
        raise UsageError(message)


def positive(value: float, option: str, unit: str = "") -> float:
    """value if it is a finite number > 0, else a :class:`UsageError` naming the option."""
    require(math.isfinite(value) and value > 0, f"{option} {value:g}: must be a positive number{unit and ' of ' + unit}")
    return value


def number_list(text: str, option: str) -> list[float]:
    """``"0,20,40"`` -> ``[0.0, 20.0, 40.0]``; empty items, non-numbers and repeated values are usage errors."""
    values = []
    for item in str(text).split(","):
        try:
            value = float(item)
        except ValueError:
            raise UsageError(f"{option} {text!r}: {item.strip()!r} is not a number") from None
        require(f"{value:g}" not in {f"{v:g}" for v in values},
                f"{option} {text!r}: {value:g} is given twice")
        values.append(value)
    return values


def checked_params(option: str, params: Params | None = None, **values) -> Params:
    """``params.replace(**values)`` (default: the FMUs' defaults); a value the model cannot represent is a
    :class:`UsageError` naming the option, e.g. ``--Fc -3: parameter Fc must not be negative, got -3.0``."""
    try:
        return (params or Params()).replace(**values)
    except MkctlError as error:
        raise UsageError(f"{option}: {error}") from None


def _check_folders(args, fmus) -> None:
    problem = folder_problem(Path(args.out))
    require(problem is None, f"--out {args.out}: {problem}")
    for suffix in ("csv", "png"):
        target = Path(args.out) / f"{args.name}.{suffix}"
        require(not target.is_dir(), f"--out {args.out}: {target} is a folder, cannot write the {suffix.upper()} there")
    fmu_dir = Path(args.fmu_dir)
    require(not fmu_dir.exists() or fmu_dir.is_dir(), f"--fmu-dir {fmu_dir}: is a file, not a folder")
    paths = [fmu_file(args, which) for which in fmus]
    for path in paths:
        require(not path.exists() or zipfile.is_zipfile(path), f"--fmu-dir {fmu_dir}: {path.name} is not an FMU "
                "(not a zip file)")
    if not all(path.exists() for path in paths):  # build_fmu.py will write there
        problem = folder_problem(fmu_dir)
        require(problem is None, f"--fmu-dir {fmu_dir}: the FMUs are missing and cannot be built there: {problem}")


def parse_args(name: str, description: str, duration: float, argv=None, extra=None, check=None,
               fmus=("knee",)) -> argparse.Namespace:
    """The common command line, checked before any work.

    ``extra(parser)`` may add the scenario's own options; ``check(args)`` checks them (and the duration
    against what the scenario needs), raising :class:`UsageError` (or an mkctl error) with a message naming the
    option, and may store what it derived on args. ``fmus`` are the FMUs the scenario drives ("knee",
    "actuator"). Any problem ends the script: one line on stderr, exit status 2.
    """
    global _prog
    parser = OneLineParser(prog=f"scenarios/{name}.py", description=description)
    _prog = parser.prog
    parser.add_argument("--out", type=Path, default=Path("out") / name,
                        help="folder for the CSV and PNG (default: out/NAME)")
    parser.add_argument("--fmu-dir", type=Path, default=Path("dist"),
                        help="folder holding the FMUs (default: dist; built when missing)")
    parser.add_argument("--duration", type=float, default=duration, help=f"simulated time [s] (default {duration:g})")
    parser.add_argument("--native", action="store_true",
                        help="drive the native FMUs of FMU_DIR/native (compiled C, built when missing) instead of "
                             "the pythonfmu ones")
    if extra is not None:
        extra(parser)
    args = parser.parse_args(argv)
    args.name = name
    try:
        positive(args.duration, "--duration", "seconds")
        require(args.duration >= 10 * STEP, f"--duration {args.duration:g}: must be at least {10 * STEP:g} s "
                f"(ten communication steps)")
        _check_folders(args, fmus)
        if check is not None:
            check(args)
    except (UsageError, MkctlError) as error:
        parser.error(str(error))
    return args


# --- the FMUs ---------------------------------------------------------------------------------------------

def build_fmus(out, run: bool = False, native: bool = False) -> tuple[dict[str, Path], str]:
    """Build (and, with ``run``, check by running) the knee and actuator FMUs into the folder out (with
    ``native``, also the compiled ones into out/native, returned as "native_knee", "native_actuator").

    Runs :mod:`mkctl.fmu.build` of this mkctl (``python -m mkctl.fmu.build``) in a fresh Python: no file of a
    checkout is needed, and the build does not depend on what this process has imported or changed (in a
    long-lived process, such as a test session, an in-process build once packed an FMU fmpy could not run).
    Returns ({"knee": path, "actuator": path}, what the build printed); raises :class:`ScenarioError` with the
    build's last message.
    """
    out = Path(out).resolve()
    package_parent = str(Path(__file__).resolve().parents[2])  # the folder this mkctl is imported from
    env = dict(os.environ)
    env["PYTHONPATH"] = os.pathsep.join([package_parent] + ([env["PYTHONPATH"]] if env.get("PYTHONPATH") else []))
    argv = ["--out", str(out)] + ([] if run else ["--no-run"]) + ([] if native else ["--no-native"])
    done = subprocess.run([sys.executable, "-m", "mkctl.fmu.build", *argv], capture_output=True, text=True, env=env)
    paths = {which: out / name for which, name in FMU_FILES.items()}
    if done.returncode != 0 or not all(path.is_file() for path in paths.values()):
        lines = (done.stderr or done.stdout).strip().splitlines()
        raise ScenarioError(f"building the FMUs into {out} failed: "
                            + (lines[-1] if lines else f"exit status {done.returncode}"))
    if native:  # none on a machine without a C compiler: the build said so in a note
        paths.update({f"native_{which}": out / "native" / name for which, name in FMU_FILES.items()
                      if (out / "native" / name).is_file()})
    return paths, done.stdout + done.stderr


def fmu_file(args, which: str) -> Path:
    """Where the knee or actuator FMU is: FMU_DIR, or FMU_DIR/native with --native."""
    folder = Path(args.fmu_dir) / "native" if getattr(args, "native", False) else Path(args.fmu_dir)
    return folder / FMU_FILES[which]


def fmu_path(args, which: str) -> Path:
    """Path of the knee or actuator FMU, building both (:func:`build_fmus`, or the native ones with --native) if
    it is missing."""
    path = fmu_file(args, which)
    if not path.exists():
        print(f"{path} missing: building the FMUs ...")
        if getattr(args, "native", False):
            from ..native.fmu import build_native
            try:
                build_native(Path(args.fmu_dir))
            except MkctlError as error:
                raise ScenarioError(f"building the native FMUs into {args.fmu_dir} failed: {error}") from error
        else:
            build_fmus(args.fmu_dir, run=False)
    return path


class FMULog:
    """An fmpy logger callback that keeps the FMU's messages of status discard, error and fatal."""

    def __init__(self):
        self.messages: list[str] = []

    def __call__(self, component, instance, status, category, message):
        if status >= 2:  # fmi2Discard, fmi2Error, fmi2Fatal
            text = message.decode(errors="replace") if isinstance(message, bytes) else str(message)
            self.messages.append(" ".join(text.split()))  # one line

    def reason(self) -> str:
        """The last message (pythonfmu's own note on a Python exception aside), or "no message"."""
        own = [m for m in self.messages if not m.startswith("Fatal py exception encountered")]
        return own[-1] if own else (self.messages[-1] if self.messages else "the FMU logged no message")

    def fmi2_callbacks(self):
        """fmi2CallbackFunctions calling this logger, for ``FMU2Slave.instantiate(callbacks=...)``; keep a
        reference as long as the instance lives."""
        from ctypes import byref

        from fmpy import calloc, free
        from fmpy.fmi2 import (fmi2CallbackAllocateMemoryTYPE, fmi2CallbackFreeMemoryTYPE, fmi2CallbackFunctions,
                               fmi2CallbackLoggerTYPE)
        from fmpy.logging import addLoggerProxy  # formats the variadic message, as fmpy.simulate_fmu does

        callbacks = fmi2CallbackFunctions()
        callbacks.logger = fmi2CallbackLoggerTYPE(self)
        callbacks.allocateMemory = fmi2CallbackAllocateMemoryTYPE(calloc)
        callbacks.freeMemory = fmi2CallbackFreeMemoryTYPE(free)
        addLoggerProxy(byref(callbacks))
        return callbacks


def input_signal(rows) -> np.ndarray:
    """An fmpy input from rows ``(time, {name: value})``, interpolated linearly in between; a repeated time
    makes a step."""
    names = list(rows[0][1])
    return np.array([(t, *(values[n] for n in names)) for t, values in rows],
                    dtype=[("time", float)] + [(n, float) for n in names])


def simulate(fmu: Path, stop: float, step: float = STEP, inputs=None, start_values=None) -> np.ndarray:
    """Run an FMU with fmpy at a fixed communication step; raise ScenarioError (with the FMU's last logged
    error) unless it reaches the stop time."""
    from fmpy import extract, simulate_fmu

    from fmpy.fmi1 import FMICallException

    from ..analysis.fmu_probe import prefer_installed_pythonfmu, remove_extraction

    log = FMULog()
    unzipdir = extract(str(fmu))  # ours to remove, with what a pythonfmu FMU adds to sys.path inside it
    prefer_installed_pythonfmu()
    try:
        result = simulate_fmu(unzipdir, stop_time=stop, output_interval=step, input=inputs,
                              start_values=start_values or {}, debug_logging=True, logger=log)
    except FMICallException:  # the FMUs answer invalid parameters with fmi2Fatal at initialization
        raise ScenarioError(f"{Path(fmu).name} refused to start: {log.reason()}") from None
    finally:
        remove_extraction(unzipdir)
    if abs(result["time"][-1] - stop) > 1e-9 * max(1.0, stop):
        raise ScenarioError(f"{Path(fmu).name} stopped at t = {result['time'][-1]:g} s instead of {stop:g} s: "
                            f"{log.reason()}")
    return result


# --- reference numbers and metrics ------------------------------------------------------------------------

def first_peak_time(params: Params | None = None) -> float:
    """pi / omega [s]: when the undamped leg, linearized at the FMUs' default posture (alpha = 60 deg), reaches
    its first peak after a step. A step response needs at least this long to show its overshoot."""
    from mkctl.physics.simulate import DEFAULT_ALPHA, DEFAULT_PF
    from mkctl.physics.stability import posture_stability

    rest = posture_stability(DEFAULT_ALPHA, Pf=DEFAULT_PF, params=(params or Params()).replace(c=0.0, Fc=0.0))
    omega = max(abs(pole.imag) for pole in rest.poles)
    if omega == 0:
        raise UsageError("the default posture does not oscillate: no first peak to wait for")
    return math.pi / omega


def step_overshoot(t, X, X0: float, target: float, t_step: float, settled: float = 0.02):
    """Overshoot of a step response X(t) from X0 towards target (step at t_step), in % of the step.

    Returns ``(value, None)``, or ``(None, why)`` when the run cannot tell: the step does not move the
    equilibrium by more than the run resolves, X is still moving away at the end of the run, or X has neither
    crossed the target nor come within ``settled`` (a fraction of the step) of it by the end.
    """
    step = target - X0
    resolution = 1e-8 * max(abs(X0), abs(target))  # 100 x the relative tolerance (1e-10) of the FMU's integrator
    if not abs(step) > resolution:
        return None, f"the step moves the equilibrium by only {abs(step):.2g} m, below what the run resolves"
    after = np.asarray(X)[np.asarray(t) >= t_step]
    beyond = (after - target) / step  # > 0 past the target in the direction of the step, -1 at the start
    peak = int(np.argmax(beyond))
    if beyond[peak] > 0:
        if peak == after.size - 1:
            return None, f"X still moving away from the new equilibrium at t = {t[-1]:g} s"
        return float(beyond[peak] * 100), None
    if beyond[-1] >= -settled:
        return 0.0, None  # within `settled` of the target without crossing it
    return None, f"X covered only {(1 + beyond[-1]) * 100:.0f} % of the step by t = {t[-1]:g} s"


def undefined(why: str) -> str:
    """How a metric that cannot be computed is printed."""
    return f"undefined ({why})"


# --- output ----------------------------------------------------------------------------------------------

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
    """Run a scenario; a failure (ScenarioError, an mkctl error, a file that cannot be written) ends it with one
    line on stderr and exit status 2, an interrupt with exit status 130."""
    # the scenarios show the FMUs' messages themselves (one line, see FMULog): the FMUs need not echo them on
    # stderr (set when a scenario runs, not when this module is imported)
    os.environ.setdefault("MKCTL_FMU_STDERR", "0")
    return run_reporting_errors(_prog, run, argv)


__all__ = ["STEP", "build_fmus", "ScenarioError", "UsageError", "parse_args", "require", "positive", "number_list",
           "checked_params", "fmu_path", "FMULog", "input_signal", "simulate", "first_peak_time", "step_overshoot",
           "undefined", "write_csv", "finish", "main_guard", "new_figure", "save_png"]
