"""Pictures and text of a comparison or a diagnosis (:mod:`mkctl.analysis.compare`, :mod:`mkctl.analysis.diagnose`).

Only drawing and wording here: the numbers come from the analysis. Every picture is saved as PNG through
:mod:`mkctl.io.plotting`; :func:`summary` turns a :class:`mkctl.analysis.diagnose.DiagnosisResult` into
readable lines.
"""
from __future__ import annotations

from pathlib import Path

import numpy as np

from ..physics.params import INTEGER_PARAMETERS, UNITS
from .plotting import new_figure, save_png

#: How the signature pictures label their x axis.
SIGNATURE_AXIS = {"viscous_damping": "velocity [mm/s]", "coulomb_friction": "velocity [mm/s]",
                  "pressure_lag": "extensor pressure rate (smoothed) [kPa/s]",
                  "elasticity": "rubber tension of the model's C1, C2 [N]",
                  "slack": "tension the slack muscle would not carry [N]",
                  ("isometric", "coulomb_friction"): "friction's sign at a clamped length: -1 rising, +1 falling "
                                                     "pressure"}


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
        from ..analysis.compare import plot_isometric
        from ..analysis.diagnose import CANDIDATES
        after = measurement.params
        for effect in result.missing:
            after = CANDIDATES[effect].apply(after, result.params[CANDIDATES[effect].parameter])
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
    lines += discovery_lines(getattr(result, "discovery", None))
    lines.append(f"verdict: {result.verdict}")
    return lines


def discovery_lines(found: dict | None) -> list[str]:
    """The discovery of an incomplete diagnosis (spec 6b, :mod:`mkctl.analysis.discovery`) as lines; [] without."""
    if not found:
        return []
    if not found["terms"]:
        return [f"discovery: nothing proposed: {found.get('reason') or 'no term explains the missing force'}"]
    lines = [f"discovery: the force the baseline lacks (RMS {found['missing_force_rms']:.3g} N) follows "
             f"{' + '.join(t['term'] for t in found['terms'])}: {found['explained']:.0%} of it explained "
             f"({found['explained_holdout']:.0%} on held-out blocks)"]
    for t in found["terms"]:
        match = (f"the form of the effect {t['matches']}" if t["matches"] else "registered nowhere: a new effect")
        lines.append(f"  {t['term']:<26} coefficient {t['coefficient']:.4g} +- {t['stderr']:.2g} {t['unit']} "
                     f"per actuator ({match})")
        if t.get("alternatives"):
            lines.append(f"    the record hardly tells it from: {', '.join(t['alternatives'])}")
    if found.get("effect_file"):
        lines.append(f"  suggested effect file: {found['effect_file']} (add it with --effects {found['effect_file']})")
    return lines
