"""Pictures and text of a comparison or a diagnosis (:mod:`mkctl.analysis.compare`, :mod:`mkctl.analysis.diagnose`).

Only drawing and wording here: the numbers come from the analysis, through the results it hands over (this
module imports nothing from :mod:`mkctl.analysis`). Every picture is saved as PNG through
:mod:`mkctl.io.plotting`; :func:`summary` turns a :class:`mkctl.analysis.diagnose.DiagnosisResult` into
readable lines.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..errors import MkctlError
from ..physics import effects
from ..physics.isometric import isometric_tension
from ..physics.params import INTEGER_PARAMETERS, UNITS, LiveMapping
from .plotting import new_figure, save_png

#: How the signature pictures label their x axis.
SIGNATURE_AXIS = LiveMapping(lambda: {
    **{e.name: e.signature_axis or e.regressor for e in effects.all_effects()},
    ("isometric", "coulomb_friction"): "friction's sign at a clamped length: -1 rising, +1 falling pressure"})


def rmse(measured, simulated) -> float:
    """Root-mean-square error, in the units of the arguments."""
    error = np.asarray(measured, dtype=float) - np.asarray(simulated, dtype=float)
    return float(np.sqrt(np.mean(error * error)))


def fit_text(fit: float) -> str:
    """``"fit 87.3 %"``, or the reason there is none: a constant measured output has no spread to explain."""
    if not np.isfinite(fit):
        return "fit undefined (the measured output is constant: no variation to explain)"
    return f"fit {fit:.1f} %"


def input_axis(measurement):
    """The record's main input (pressure or extensor command, in kPa) and its label, for plots."""
    if measurement.experiment in ("isotonic", "isometric"):
        return measurement.inputs["pressure"] / 1e3, "pressure [kPa]"
    return measurement.inputs["pe_cmd"] / 1e3, "extensor command pe_cmd [kPa]"


def plot_overlay(measurement, curves: dict, path, title: str = "") -> Path:
    """Measured output and simulated curves (label -> SI array) over time, with the main input below."""
    fig, (top, bottom) = new_figure(2, 1, figsize=(9, 6), sharex=True, height_ratios=(3, 1))
    unit = measurement.output_unit
    top.plot(measurement.time, measurement.to_file_units(measurement.output), ".", ms=2, color="0.5",
             label=f"measured ({Path(measurement.source).name})")
    for label, values in curves.items():
        top.plot(measurement.time, measurement.to_file_units(values), lw=1.2, label=label)
    top.set_ylabel(f"{measurement.output_column} [{unit}]")
    top.legend(loc="best", fontsize=8)
    top.set_title(title or f"{measurement.experiment}: model vs measurement")
    values, label = input_axis(measurement)
    bottom.plot(measurement.time, values, color="k", lw=1)
    bottom.set_ylabel(label, fontsize=8)
    bottom.set_xlabel("time [s]")
    return save_png(fig, path)


def plot_residuals(measurement, residuals: dict, path, title: str = "") -> Path:
    """Residuals (label -> array in file units) over time, one panel each, with their RMSE."""
    fig, axes = new_figure(len(residuals), 1, figsize=(9, 2.2 * len(residuals) + 0.6), sharex=True,
                           squeeze=False)
    for ax, (label, residual) in zip(axes[:, 0], residuals.items()):
        ax.plot(measurement.time, residual, lw=0.8)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylabel(f"residual [{measurement.output_unit}]", fontsize=8)
        ax.set_title(f"{label}: RMSE {rmse(residual, 0.0):.4g} {measurement.output_unit}",
                     fontsize=9)
    axes[-1, 0].set_xlabel("time [s]")
    if title:
        fig.suptitle(title)
    return save_png(fig, path)


def plot_isometric(length, pressure, force, branch, curves: dict, path, title: str = "", L0: float | None = None,
                   columns: int = 2) -> Path:
    """Blocked-force data and models: tension against pressure, one panel per clamped length, both branches.

    Parameters: length [m], pressure [Pa], force [N], branch (+1 up, -1 down) of the measured points;
    curves {label: Params or (Params, force offset [N])}, each drawn over the measured pressure range at
    every length, rising branch solid and falling branch dashed
    (:func:`mkctl.physics.isometric.isometric_tension`); L0 [m] to label each panel's length as a share of
    it. Measured points: up-pointing markers on the rising branch, down-pointing on the falling one.
    """
    length, pressure, force, branch = (np.asarray(a, dtype=float) for a in (length, pressure, force, branch))
    lengths = np.unique(length)
    columns = max(1, min(columns, lengths.size))
    rows = -(-lengths.size // columns)
    fig, axes = new_figure(rows, columns, figsize=(3.6 * columns + 0.6, 2.9 * rows + 0.5), squeeze=False,
                           sharex=True)
    colors = ["tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange"]
    grid = np.linspace(pressure.min(), pressure.max(), 200)
    for number, (ax, value) in enumerate(zip(axes.flat, lengths)):
        here = length == value
        for sign, marker, name in ((1, "^", "measured, pressure rising"), (-1, "v", "measured, pressure falling")):
            pick = here & (branch == sign)
            ax.plot(pressure[pick] / 1e3, force[pick], marker, ms=3.5, mfc="none", color="0.35" if sign > 0 else "0.6",
                    lw=0, label=name if number == 0 else None)
        for color, (label, model) in zip(colors, curves.items()):
            params, offset = model if isinstance(model, tuple) else (model, 0.0)
            try:
                up = isometric_tension(value, grid, 1, params) + offset
                down = isometric_tension(value, grid, -1, params) + offset
            except MkctlError:  # this model cannot reach this length: no curve
                continue
            ax.plot(grid / 1e3, up, "-", color=color, lw=1.3, label=label if number == 0 else None)
            if params.Fc:
                ax.plot(grid / 1e3, down, "--", color=color, lw=1.1)
        ax.axhline(0, color="k", lw=0.5)
        share = f" ({value / L0:.0%} of L0)" if L0 else ""
        ax.set_title(f"L = {value * 1e3:.1f} mm{share}", fontsize=9)
        ax.grid(alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("pressure [kPa]")
    for ax in axes[:, 0]:
        ax.set_ylabel("tension [N]")
    for ax in list(axes.flat)[lengths.size:]:
        ax.set_visible(False)
    fig.legend(loc="outside lower center", ncol=2, fontsize=8, frameon=False)
    fig.suptitle(title or "blocked force: tension against pressure at each clamped length", fontsize=10)
    return save_png(fig, path, dpi=150)


def _binned(x, y, bins: int = 12):
    """Mean of y in bins of equal counts of x (for the signature pictures)."""
    order = np.argsort(x)
    groups = np.array_split(order, bins)
    return ([float(np.mean(x[g])) for g in groups if g.size], [float(np.mean(y[g])) for g in groups if g.size])


def _step_label(step: dict) -> str:
    return "+ " + " & ".join([step["added"], *step.get("added_with", [])])


def save_pictures(measurement, result, folder, stem: str | None = None) -> dict:
    """Save the diagnosis pictures as PNG; returns {what: path}.

    ``error_steps`` (RMSE after each step, log scale), ``overlay`` (measured, baseline and final model),
    ``residuals`` (before and after) and, when the first round had any, ``signatures``.
    """
    folder = Path(folder)
    stem = stem or Path(measurement.source).stem
    unit = measurement.output_unit
    paths = {}

    labels = ["baseline"] + [_step_label(s) for s in result.steps]
    fig, ax = new_figure(figsize=(max(4.5, 1.6 * len(labels) + 2), 3.8))
    values = result.error_steps
    bars = ax.bar(range(len(values)), values, color=["0.6"] + ["tab:blue"] * (len(values) - 1))
    ax.plot(range(len(values)), values, "k.-", lw=0.8)
    for bar, value in zip(bars, values):
        ax.annotate(f"{value:.3g}", (bar.get_x() + bar.get_width() / 2, value), ha="center", va="bottom", fontsize=8)
    ax.set_xticks(range(len(values)), labels, fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel(f"RMSE [{unit}] (log)")
    ax.set_title("the error falls as effects are added" if len(values) > 1 else f"{result.verdict}")
    paths["error_steps"] = save_png(fig, folder / f"{stem}_error_steps.png")

    after_label = "baseline + " + ", ".join(result.missing) if result.missing else "baseline (nothing added)"
    paths["overlay"] = plot_overlay(measurement, {"baseline": result.simulated_before,
                                                  after_label: result.simulated_after},
                                    folder / f"{stem}_overlay.png", f"before and after the diagnosis ({result.verdict})")
    paths["residuals"] = plot_residuals(measurement, {
        "before (baseline)": measurement.to_file_units(measurement.output - result.simulated_before),
        f"after ({after_label})": measurement.to_file_units(measurement.output - result.simulated_after),
    }, folder / f"{stem}_residuals.png")

    if measurement.experiment == "isometric":  # the blocked-force picture: tension against pressure per length
        after = result.params_after  # the final model's parameters, from the result
        paths["isometric"] = plot_isometric(measurement.inputs["length"], measurement.inputs["pressure"],
                                            measurement.output, measurement.branch,
                                            {"baseline": measurement.params, after_label: after},
                                            folder / f"{stem}_isometric.png", "before and after the diagnosis",
                                            L0=measurement.params.L0)

    sigs = result.signatures
    names = [name for name in result.signature_order if name in sigs]
    if names:
        fig, axes = new_figure(1, len(names), figsize=(3.6 * len(names), 3.4), squeeze=False)
        for ax, name in zip(axes[0], names):
            sig = sigs[name]
            ax.plot(sig["x"], sig["missing"], ".", ms=2, color="0.6", alpha=0.4)
            ax.plot(*_binned(sig["x"], sig["missing"]), "o-", color="tab:red", ms=4)
            ax.axhline(0, color="k", lw=0.5)
            ax.set_xlabel(SIGNATURE_AXIS.get((measurement.experiment, name), SIGNATURE_AXIS[name]), fontsize=7)
            ax.set_title(f"{name}: r = {sig['correlation']:+.2f}", fontsize=9)
        axes[0, 0].set_ylabel("force the baseline lacks [N]")
        fig.suptitle("signatures: the force the baseline lacks (equation error at the smoothed measured states)",
                     fontsize=9)
        paths["signatures"] = save_png(fig, folder / f"{stem}_signatures.png")
    result.pictures = {k: str(v) for k, v in paths.items()}
    return result.pictures


def summary(result) -> list[str]:
    """A readable summary of a diagnosis, line by line."""
    unit = result.output_unit
    lines = [f"{result.file}: {result.experiment}, {result.samples} samples, baseline "
             f"{result.baseline} ({', '.join(result.baseline_effects) or 'no effects'})"]
    lines += [f"note: {note}" for note in result.notes]
    lines.append(f"baseline: RMSE {result.rmse_before:.4g} {unit} (whole record), "
                 f"{fit_text(result.fit_percent_before)}")
    if result.problems:
        lines += [f"problem: {text}" for text in result.problems]
        lines.append("verdict: not diagnosed (fix the record, or declare its offset / use --fit-offset)")
        return lines
    rounds = result.steps + ([result.stopped] if result.stopped and result.stopped["candidates"] else [])
    for number, step in enumerate(rounds, 1):
        if step.get("wider_search"):
            lines.append(f"wider search (what forward selection added left many times the noise): "
                         f"{' + '.join([step['added'], *step['added_with']])} fitted together replace "
                         f"{', '.join(step['replaced'])}: RMSE {step['rmse']:.4g} {unit} (whole record)")
            continue
        lines.append(f"round {number}: candidates (best BIC first; RMSE over the compared samples, held-out "
                     f"over the last {result.rule['holdout_fraction']:.0%})")
        for row in step["candidates"]:
            if row["bic"] is None:
                lines.append(f"  {row['effect']:<17} could not be simulated")
                continue
            (name, value), = row["params"].items()
            sig = row.get("signature") or {}
            estimate = sig.get("estimate")
            flag = " (on its bound: rejected)" if row.get("at_bound") else ""
            lines.append(f"  {row['effect']:<17} {name} = {value:<10.4g} dBIC {row['delta_bic']:+9.1f}  "
                         f"RMSE {row['rmse']:.4g}  held-out {row['rmse_holdout']:.4g} {unit}  "
                         f"signature r = {sig.get('correlation', 0.0):+.2f}"
                         + (f" (slope says {name} ~ {estimate:.3g})" if estimate is not None else "") + flag)
        for tie in step["ties"]:
            lines.append(f"  tie: {' ~ '.join(tie['effects'])}; to tell them apart: {tie['experiment']}")
        if step.get("added"):
            dropped = f" (dropped {', '.join(step['dropped'])}: no longer needed)" if step.get("dropped") else ""
            together = " together with " + ", ".join(step["added_with"]) if step.get("added_with") else ""
            lines.append(f"  -> added {step['added']}{together}{dropped}: RMSE {step['rmse']:.4g} {unit} "
                         f"(whole record, {result.samples} samples)")
        else:
            lines.append(f"  -> stop: {step['reason']}")
    if result.stopped and not result.stopped["candidates"]:
        lines.append(f"stop: {result.stopped['reason']}")
    for item in result.undecided:
        lines.append(f"undecided: this record cannot tell {' from '.join(item['effects'])}; "
                     f"to separate them: {item['experiment']}")
    if result.missing:
        lines.append("missing: " + ", ".join(result.missing))
        for name, value in result.params.items():
            if name in INTEGER_PARAMETERS:  # a switch (slack = 1): on, no standard error to give
                lines.append(f"  {name} = {int(value)} (on)")
                continue
            error = result.uncertainty.get(name)
            plus = f" +- {error:.2g}" if error is not None else ""
            lines.append(f"  {name} = {value:.4g}{plus} {UNITS[name]}")
    elif result.undecided:
        lines.append("missing: undecided (see above)")
    else:
        lines.append("missing: nothing (no candidate effect is supported by the data)")
    if result.offset is not None:
        lines.append(f"sensor offset (fitted): {result.offset:.4g} {unit}")
    lines.append(f"after: RMSE {result.rmse_after:.4g} {unit} (whole record), {fit_text(result.fit_percent_after)}"
                 + (f"; output noise about {result.output_noise:.2g} {unit}" if result.output_noise else ""))
    lines.append(f"verdict: {result.verdict}")
    return lines
