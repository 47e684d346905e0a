"""The pictures and the table of a calibration (:func:`mkctl.analysis.calibrate.calibrate`'s result).

One PNG per record (data and fits), the error-fall bars, and the result as lines of text; drawn from the
:class:`~mkctl.analysis.calibrate.CalibrationResult` handed over.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import MkctlError
from ..physics import actuator
from ..physics.params import UNITS
from .force_records import ForceRecord

#: A change of the pressure between two samples beyond this [Pa] is a step of the command: a driven
#: record's model curve is drawn in pieces between steps.
PRESSURE_STEP_PA = 5e3


def plot_fits(result, folder, stem: str) -> list[Path]:
    """Data and fits per length: one PNG per record (``<stem>_fit.png``, or ``<stem>_fit_<i>.png`` for
    several). Isometric: tension against pressure at each clamped length, both branches, with the static
    fit and the final model (:func:`mkctl.analysis.compare.plot_isometric`). Isotonic: the measured
    length against pressure per load, with the final model's quasi-static simulation."""
    from .compare import plot_isometric

    folder = Path(folder)
    paths = []
    curves = {"static fit (no effects)": result.curves["static fit"]}
    if result.effects:
        curves["calibrated: + " + ", ".join(result.effects)] = result.curves["final"]
    else:
        curves = {"calibrated (no effects added)": result.curves["final"]}
    for number, record in enumerate(result.records):
        name = f"{stem}_fit.png" if len(result.records) == 1 else f"{stem}_fit_{number + 1}.png"
        own = {label: (params, offsets[number]) for label, (params, offsets) in curves.items()}  # its offset
        title = f"{Path(record.source).name}: blocked force, data and fits (NRMS {result.nrms_before:.2%} -> " \
                f"{result.nrms_after:.2%})"
        if record.experiment == "isometric":
            paths.append(plot_isometric(record.length, record.pressure, record.force, record.sign, own,
                                        folder / name, title, L0=result.params.L0))
        elif record.velocity is not None:
            paths.append(_plot_driven(record, own, folder / name))
        else:
            paths.append(_plot_isotonic(record, result, folder / name))
    return paths


def _plot_driven(record: ForceRecord, curves: dict, path) -> Path:
    """A driven-length record: the measured tension against the imposed length (the loops a moving
    muscle draws) and each model's (``curves``: label -> (Params, offset [N]))."""
    from ..io.plotting import new_figure, save_png

    fig, ax = new_figure(figsize=(6.5, 4.2))
    ax.plot(record.length * 1e3, record.force, ".", ms=2, color="0.5", alpha=0.5, label="measured")
    # a line stops where the pressure steps: the model's loops at one pressure are not joined to the
    # next pressure's by a stroke across the picture
    steps = np.flatnonzero(np.abs(np.diff(record.pressure)) > PRESSURE_STEP_PA) + 1
    colours = ("tab:blue", "tab:red", "tab:green")
    for colour, (label, (params, offset)) in zip(colours, curves.items()):
        try:
            model = actuator.compose_tension(record.length, record.pressure, record.velocity,
                                             params) + offset
        except MkctlError:  # this model cannot reach these lengths: no curve
            continue
        length_mm = np.insert(record.length * 1e3, steps, np.nan)
        ax.plot(length_mm, np.insert(np.asarray(model, float), steps, np.nan), "-", color=colour,
                lw=0.8, label=label)
    ax.set_xlabel("imposed length [mm]")
    ax.set_ylabel("tension [N]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7)
    ax.set_title(f"{Path(record.source).name}: driven length, data and fits", fontsize=9)
    return save_png(fig, path, dpi=150)


def _plot_isotonic(record: ForceRecord, result, path) -> Path:
    from ..io.plotting import new_figure, save_png
    from ..physics.isotonic import simulate_isotonic

    fig, ax = new_figure(figsize=(6.5, 4.2))
    loads = np.unique(np.round(record.force, 9))
    colors = ["tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange", "tab:brown"]
    for color, load in zip(colors * 10, loads):
        pick = np.isclose(record.force, load)
        ax.plot(record.pressure[pick] / 1e3, record.length[pick] * 1e3, ".", ms=2, color=color, alpha=0.4,
                label=f"measured, {load:g} N")
        if record.time is not None:
            try:
                simulated = simulate_isotonic(record.time[pick], record.pressure[pick], record.force[pick],
                                              result.params)
                ax.plot(record.pressure[pick] / 1e3, simulated * 1e3, "-", color=color, lw=1.0,
                        label=f"calibrated model, {load:g} N")
            except MkctlError:
                pass
    ax.set_xlabel("pressure [kPa]")
    ax.set_ylabel("length [mm]")
    ax.grid(alpha=0.3)
    ax.legend(fontsize=7, ncol=2)
    ax.set_title(f"{Path(record.source).name}: isotonic, data and calibrated model", fontsize=9)
    return save_png(fig, path, dpi=150)


def plot_error_fall(result, path) -> Path:
    """The error fall: NRMS of each step (start, static fit, each added effect) as bars, log scale."""
    from matplotlib.ticker import FuncFormatter

    from ..io.plotting import new_figure, save_png

    steps = [s for s in result.steps if s["nrms"] is not None]
    labels = [s["label"] for s in steps]
    values = [100 * s["nrms"] for s in steps]
    fig, ax = new_figure(figsize=(max(4.5, 1.5 * len(labels) + 1.5), 3.8))
    colors = ["0.75" if s["label"] == "start" else "0.45" if s["label"] == "static fit" else "tab:blue" for s in steps]
    bars = ax.bar(range(len(values)), values, color=colors)
    for bar, value in zip(bars, values):
        ax.annotate(f"{value:.3g} %", (bar.get_x() + bar.get_width() / 2, value), ha="center", va="bottom",
                    fontsize=8)
    ax.set_xticks(range(len(values)), labels, fontsize=8)
    ax.set_yscale("log")
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))
    ax.yaxis.set_minor_formatter(FuncFormatter(lambda v, _: ""))
    ax.set_ylabel("NRMS force error [% of the force range]")
    ax.set_title("calibration: the error falls step by step", fontsize=10)
    return save_png(fig, path, dpi=150)


def summary(result) -> list[str]:
    """The result as lines of text: the steps' table, the parameters with standard errors, and the notes."""
    lines = [f"{result.points} points from {len(result.sources)} file(s): {', '.join(result.sources)}",
             f"{'step':<24} {'NRMS':>8} {'RMS [N]':>9} {'dBIC':>9} {'held-out RMS [N]':>17}"]
    previous_bic = None
    for step in result.steps:
        nrms = "n/a" if step["nrms"] is None else f"{step['nrms']:.2%}"
        rms = "" if step["rms"] is None else f"{step['rms']:.4g}"
        bic = step.get("bic")
        delta = "" if bic is None or previous_bic is None else f"{bic - previous_bic:+.1f}"
        previous_bic = bic if bic is not None else previous_bic
        hold = "" if step.get("rms_holdout") is None else f"{step['rms_holdout']:.4g}"
        lines.append(f"{step['label']:<24} {nrms:>8} {rms:>9} {delta:>9} {hold:>17}")
        stop = step.get("stop")
        if stop:
            for row in stop["candidates"]:
                lines.append(f"  (not added) {row['effect']:<18} dBIC {row['delta_bic']:+.1f}, held-out RMS "
                             f"{row['rms_holdout']:.4g} N")
            lines.append(f"  stop: {stop['reason']}")
    lines.append("effects added: " + (", ".join(result.effects) or "none"))
    for name, value in result.fitted.items():
        unit = {"1": ""}.get(UNITS.get(name, "N"), UNITS.get(name, "N"))
        if name in result.stderr:
            text = f"{value:.6g} +- {result.stderr[name]:.2g} {unit}"
        elif name in result.ambiguous:
            others = ", ".join(f"{v:.4g}" for v in result.ambiguous[name])
            text = f"{value:.6g} {unit} (ambiguous: fits as good put it at {others})"
        elif name in result.held:
            text = f"{value:.6g} {unit} (held: not identifiable)"
        else:
            text = f"{value:.6g} {unit} (not identifiable on its own)"
        flag = "  <- on its bound" if name in result.at_bound else ""
        lines.append(f"  {name:<7} = {text}{flag}")
    if result.not_identifiable:
        lines.append("not identifiable from these data: " + "; ".join(" with ".join(g) for g in result.not_identifiable))
    lines.append(f"braid diameter at rest sqrt(b^2 - L0^2) / (pi n) = {result.braid_diameter * 1e3:.3f} mm "
                 f"(bladder D0 = {result.params.D0 * 1e3:.3f} mm)")
    for note in result.notes:
        lines.append("note: " + note)
    return lines
