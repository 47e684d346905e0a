"""Pictures and text of a comparison or a diagnosis (:mod:`mkctl.analysis.compare`, :mod:`mkctl.analysis.diagnose`).

Only drawing and wording here: the numbers come from the analysis, through the results it hands over (this
module imports nothing from :mod:`mkctl.analysis`). Every picture is saved as PNG through
:mod:`mkctl.io.plotting`; :func:`summary` turns a :class:`mkctl.analysis.diagnose.DiagnosisResult` into
readable lines.
"""
from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np

from ..errors import MkctlError
from ..physics import effects
from ..physics.xp import math_for
from ..physics.isometric import isometric_tension
from ..physics.params import INTEGER_PARAMETERS, UNITS, LiveMapping, LiveSequence
from .plotting import fixed_layout, new_figure, plain_log_ticks, save_png

#: How the signature pictures label their x axis: each effect's own regressor (the registry's
#: ``signature_axis``; see :func:`mkctl.analysis.diagnose.signatures`; the lag's is drawn here from its fitted
#: tau, :func:`_pressure_deficit`), with the experiments whose regressor differs (its ``signature_axes``).
SIGNATURE_AXIS = LiveMapping(lambda: {
    **{e.name: e.signature_axis or e.regressor for e in effects.all_effects()},
    **{(experiment, e.name): label for e in effects.all_effects() for experiment, label in e.signature_axes.items()}})

#: Effects whose signature slope is not a value of their parameter (see :func:`summary`).
NO_SLOPE_HINT = LiveSequence(lambda: [e.name for e in effects.all_effects() if not e.slope_hint])

#: At most this many measured samples are marked on an overlay (evenly spaced): more would hide the curves.
OVERLAY_MARKERS = 300

#: What each measured output is, for the y axis of the overlays (by the quantity of the output column).
OUTPUT_QUANTITY = {"x": "hip height X", "beta": "knee angle beta", "length": "muscle length L", "force": "tension f"}


def parameter_text(name: str, value: float) -> str:
    """``"c = 45.02 N s/m"``; an on/off switch (off at 0: ``slack``) as ``"slack = 1 (on)"`` / ``"slack = 0 (off)"``,
    a choice (``model``) as ``"model = 2"``."""
    if name in INTEGER_PARAMETERS:
        owner = effects.effect_of(name)
        if owner is not None and owner.switch_parameter.name == name and owner.switch_parameter.off == 0:
            return f"{name} = {int(round(value))} ({'on' if value > 0 else 'off'})"
        return f"{name} = {int(round(value))}"
    return f"{name} = {value:.4g} {UNITS[name]}"


def rmse(measured, simulated) -> float:
    """Root-mean-square error, in the units of the arguments."""
    error = np.asarray(measured, dtype=float) - np.asarray(simulated, dtype=float)
    return float(np.sqrt(np.mean(error * error)))


def fit_text(fit: float) -> str:
    """``"fit 87.3 %"``, or the reason there is none: a constant measured output has no spread to explain."""
    if not np.isfinite(fit):
        return "fit undefined (the measured output is constant: no variation to explain)"
    return f"fit {fit:.1f} %"


def first_muscle(measurement) -> str:
    """The name of the record's first muscle, whose pressure the signature pictures read: the knee's
    extensor, a mechanism's own first muscle (``muscle1`` of a pulley joint), else ``muscle``."""
    if measurement.experiment == "mechanism":
        return measurement.mechanism.muscles[0]
    return "extensor" if measurement.experiment == "knee" else "muscle"


def output_label(measurement) -> str:
    """The y label of a record's output: its quantity's name and the file's unit, e.g. ``hip height X [mm]``."""
    if measurement.experiment == "mechanism":
        mechanism = measurement.mechanism
        return f"{mechanism.name} {mechanism.coordinate} [{measurement.output_unit}]"
    quantity = measurement.output_quantity or measurement.output_column.rsplit("_", 1)[0]
    return f"{OUTPUT_QUANTITY.get(quantity, quantity)} [{measurement.output_unit}]"


def missing_force_label(measurement) -> str:
    """The y label of the signature pictures: the force the baseline lacks, in the unit of the
    record's equation of motion (a mechanism turning about a joint: a moment, N m)."""
    if measurement.experiment == "mechanism" and measurement.mechanism.unit == "rad":
        return "moment the baseline lacks [N m]"
    return "force the baseline lacks [N]"


def input_panels(measurement) -> list:
    """The record's inputs to draw under an overlay: ``[(y label, [(values, curve label), ...]), ...]``, pressures
    in kPa, loads in N, lengths in mm. A knee record gets a panel for each muscle, its command and, when the file
    has it, its measured pressure."""
    inputs = measurement.inputs
    if measurement.experiment == "isotonic":
        return [("pressure [kPa]", [(inputs["pressure"] / 1e3, "pressure")]),
                ("load [N]", [(inputs["force"], "hanging load")])]
    if measurement.experiment == "isometric":
        return [("pressure [kPa]", [(inputs["pressure"] / 1e3, "pressure")]),
                ("clamped length [mm]", [(inputs["length"] * 1e3, "length")])]
    if measurement.experiment == "actuator":  # a driven length: the imposed length, the pressure
        name = "pressure" if "pressure" in inputs else "p_cmd"
        what = "measured" if name == "pressure" else "command"
        return [("length [mm]", [(inputs["length"] * 1e3, "imposed length")]),
                ("pressure [kPa]", [(inputs[name] / 1e3, what)])]
    if measurement.experiment == "mechanism":  # each muscle's command, and its measured pressure
        panels = []
        for i, muscle in enumerate(measurement.mechanism.muscles):
            curves = [(inputs[f"p{i + 1}_cmd"] / 1e3, "command")]
            if f"p{i + 1}" in inputs:
                curves.append((inputs[f"p{i + 1}"] / 1e3, "measured"))
            panels.append((f"{muscle} [kPa]", curves))
        return panels
    if measurement.experiment == "pressure":  # its drive (set-point or opening), and a moving length
        panels = [("set-point [kPa]", [(inputs["p_cmd"] / 1e3, "set-point p_cmd")])] if "p_cmd" in inputs \
            else [("valve opening", [(inputs["valve"], "opening u")])]
        if "length" in inputs:
            panels.append(("length [mm]", [(inputs["length"] * 1e3, "moving length")]))
        return panels
    panels = []
    for short, muscle in (("pe", "extensor"), ("pf", "flexor")):
        curves = [(inputs[f"{short}_cmd"] / 1e3, f"command {short}_cmd")]
        if short in inputs:
            curves.append((inputs[short] / 1e3, f"measured {short}"))
        panels.append((f"{muscle} {short} [kPa]", curves))
    return panels


def plot_overlay(measurement, curves: dict, path, title: str = "") -> Path:
    """Measured output and simulated curves (label -> SI array) over time, with the inputs in panels below.

    The measured samples are drawn over the curves as open circles (at most :data:`OVERLAY_MARKERS` of them, evenly
    spaced), so that a curve running through them stays visible and so do they."""
    panels = input_panels(measurement)
    fig, axes = new_figure(1 + len(panels), 1, figsize=(9, 5.2 + 1.3 * len(panels)), sharex=True,
                           height_ratios=(3.2,) + (1,) * len(panels), squeeze=False, layout="none")
    top = axes[0, 0]
    # a tie draws each explanation: as many curves as it has alternatives (cycled past ten)
    colours = itertools.cycle(["tab:blue", "tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink",
                               "tab:olive", "tab:cyan", "tab:red", "tab:gray"])
    for label, values in curves.items():
        top.plot(measurement.time, measurement.to_file_units(values), lw=1.4, color=next(colours), label=label,
                 zorder=2)
    every = max(1, -(-measurement.samples // OVERLAY_MARKERS))
    shown = f"every {every}th of {measurement.samples} samples" if every > 1 else f"{measurement.samples} samples"
    top.plot(measurement.time[::every], measurement.to_file_units(measurement.output)[::every], "o", ms=3.2,
             mfc="none", mew=0.7, color="k", alpha=0.6, zorder=3,
             label=f"measured ({Path(measurement.source).name}, {shown})")
    top.set_ylabel(output_label(measurement))
    top.legend(loc="best", fontsize=8, markerscale=3)
    top.set_title(title or f"{measurement.experiment}: model vs measurement")
    for ax, (label, lines) in zip(axes[1:, 0], panels):
        for (values, name), colour in zip(lines, ("k", "tab:red")):
            ax.plot(measurement.time, values, color=colour, lw=1, label=name)
        ax.set_ylabel(label, fontsize=8)
        if len(lines) > 1:
            ax.legend(loc="best", fontsize=7)
    axes[-1, 0].set_xlabel("time [s]")
    fixed_layout(fig, left=0.85, bottom=0.55, hgap=0.15)
    return save_png(fig, path)


def plot_pressure_path(measurement, simulated, path, title: str = "") -> Path:
    """A knee record's measured bladder pressures against their commands and the pressure path the
    diagnosis found on them (``simulated``: the extensor's and the flexor's model pressures [Pa]),
    one panel per muscle, with the residual below each."""
    muscles = (("extensor", "pe_cmd", "pe"), ("flexor", "pf_cmd", "pf"))
    fig, axes = new_figure(4, 1, figsize=(9, 8.2), sharex=True, height_ratios=(3, 1, 3, 1),
                           squeeze=False, layout="none")
    t = measurement.time
    every = max(1, -(-measurement.samples // OVERLAY_MARKERS))
    for k, (muscle, command, measured) in enumerate(muscles):
        top, low = axes[2 * k, 0], axes[2 * k + 1, 0]
        top.step(t, measurement.inputs[command] / 1e3, where="post", color="0.55", lw=1,
                 label="command (held)")
        top.plot(t, np.asarray(simulated[k]) / 1e3, color="tab:blue", lw=1.4,
                 label="the path found")
        top.plot(t[::every], measurement.inputs[measured][::every] / 1e3, "o", ms=3, mfc="none",
                 mew=0.7, color="k", alpha=0.6, label="measured")
        top.set_ylabel(f"{muscle} {measured} [kPa]", fontsize=8)
        top.legend(loc="best", fontsize=7)
        residual = (measurement.inputs[measured] - np.asarray(simulated[k])) / 1e3
        low.plot(t, residual, lw=0.7, color="tab:blue")
        low.axhline(0, color="k", lw=0.5)
        low.set_ylabel("residual [kPa]", fontsize=7)
        low.set_title(f"RMSE {rmse(residual, 0.0):.3g} kPa", fontsize=8)
    axes[0, 0].set_title(title or "the pressure path on the measured pressures")
    axes[-1, 0].set_xlabel("time [s]")
    fixed_layout(fig, left=0.85, bottom=0.55, hgap=0.35)
    return save_png(fig, path)


def plot_residuals(measurement, residuals: dict, path, title: str = "") -> Path:
    """Residuals (label -> array in file units) over time, one panel each, with their RMSE."""
    fig, axes = new_figure(len(residuals), 1, figsize=(9, 2.2 * len(residuals) + 0.6), sharex=True,
                           squeeze=False, layout="none")
    for ax, (label, residual) in zip(axes[:, 0], residuals.items()):
        ax.plot(measurement.time, residual, lw=0.8)
        ax.axhline(0, color="k", lw=0.5)
        ax.set_ylabel(f"residual [{measurement.output_unit}]", fontsize=8)
        ax.set_title(f"{label}: RMSE {rmse(residual, 0.0):.4g} {measurement.output_unit}",
                     fontsize=9)
    axes[-1, 0].set_xlabel("time [s]")
    if title:
        fig.suptitle(title)
    fixed_layout(fig, left=0.85, bottom=0.55, top=0.75 if title else 0.35, hgap=0.4)
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
            if np.any(down != up):  # a play effect (Coulomb or pressure friction) parts the branches
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


def _binned(x, y, bins: int = 12, by_value: bool = False):
    """Mean of y in bins of x (for the signature pictures): of equal counts, or (``by_value``) of equal width,
    which suits a regressor that piles up at a few values (friction's direction at -1 and +1)."""
    x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
    if by_value:
        edges = np.linspace(x.min(), x.max(), bins + 1)
        which = np.clip(np.searchsorted(edges, x, side="right") - 1, 0, bins - 1)
        groups = [np.flatnonzero(which == k) for k in range(bins)]
    else:
        groups = np.array_split(np.argsort(x), bins)
    return ([float(np.mean(x[g])) for g in groups if g.size], [float(np.mean(y[g])) for g in groups if g.size])


#: The lag the signature picture shows the pressure deficit of when the first round fitted none [s].
LAG_PICTURE_TAU = 0.05


def _pressure_deficit(measurement, result, effect):
    """An effect's own regressor for its signature panel (its definition's ``pressure_deficit_axis``: a lag): how
    far the extensor's pressure stays behind its command through the effect's exact pressure step,
    ``pe_cmd - pe`` [kPa], at the first round's fitted value of its parameter (or :data:`LAG_PICTURE_TAU` when that
    fit found none); None for a record without a pressure command. Returns (values, axis label)."""
    if "pe_cmd" not in measurement.inputs:
        return None
    first = (result.steps[0] if result.steps else result.stopped) or {}
    found = [row["params"].get(effect.fitted) for row in first.get("candidates", [])
             if row.get("effect") == effect.name]
    fitted = bool(found and found[0])
    value = float(found[0]) if fitted else LAG_PICTURE_TAU
    p = measurement.params.replace(**{effect.fitted: value})
    time, command = measurement.time, measurement.inputs["pe_cmd"]
    behind = np.empty(time.size)
    behind[0] = command[0]
    for k in range(1, time.size):  # the command held from each sample to the next, as the simulation holds it
        behind[k] = effect.pressure_step(behind[k - 1], float(command[k - 1]), float(time[k] - time[k - 1]), p,
                                         math_for(1.0))
    which = "the fitted" if fitted else "a trial (none fitted):"
    return ((command - behind) / 1e3, f"{first_muscle(measurement)} pressure behind its command, lag at {which} "
                                      f"{effect.fitted} = {value:.3g} s [kPa]")


def _step_label(step: dict) -> str:
    return "+ " + " & ".join([step["added"], *step.get("added_with", [])])


def alternative_label(alternative: dict) -> str:
    """How the pictures name one explanation of a tie: ``"with pressure_lag"`` (the tied effects it
    holds)."""
    return "with " + " & ".join(alternative.get("with") or alternative["effects"])


def error_bars(result) -> tuple[list, list, list]:
    """The bars of ``*_error_steps.png``: labels, RMSE (file units) and colours. The baseline, the
    RMSE after each round's step (as the report's "-> added" lines print it), and last the final fit
    on the whole record (the report's "after: RMSE"), when anything was added; on a tie, instead of
    that, each explanation refitted on the whole record as a whole model (orange)."""
    labels = ["baseline"] + [_step_label(s) for s in result.steps]
    values = list(result.error_steps)
    colours = ["0.6"] + ["tab:blue"] * (len(values) - 1)
    alternatives = getattr(result, "alternatives", None) or []
    if alternatives:
        for alternative in alternatives:
            label = alternative_label(alternative).replace(" & ", "\n& ")
            labels.append(label + "\n(whole record)")
            values.append(alternative["rmse"])
            colours.append("tab:orange")
    elif result.steps or result.missing:
        labels.append("final fit\n(whole record)")
        values.append(result.rmse_after)
        colours.append("tab:green")
    return labels, values, colours


def save_pictures(measurement, result, folder, stem: str | None = None) -> dict:
    """Save the diagnosis pictures as PNG; returns {what: path}.

    ``error_steps`` (RMSE after each step, log scale), ``overlay`` (measured, baseline and final model),
    ``residuals`` (before and after) and, when the first round had any, ``signatures``.
    """
    folder = Path(folder)
    stem = stem or Path(measurement.source).stem
    unit = measurement.output_unit
    paths = {}

    labels, values, colours = error_bars(result)
    fig, ax = new_figure(figsize=(max(4.5, 1.6 * len(labels) + 2), 3.8), layout="none")
    bars = ax.bar(range(len(values)), values, color=colours)
    ax.plot(range(len(values)), values, "k.-", lw=0.8)
    for bar, value in zip(bars, values):
        ax.annotate(f"{value:.4g}", (bar.get_x() + bar.get_width() / 2, value), ha="center", va="bottom", fontsize=8)
    ax.set_xticks(range(len(values)), labels, fontsize=8)
    ax.set_yscale("log")
    plain_log_ticks(ax.yaxis)
    ax.set_ylabel(f"RMSE [{unit}] (log)")
    tied = bool(getattr(result, "alternatives", None))
    title = "the error falls as effects are added" if len(values) > 1 else f"{result.verdict}"
    ax.set_title(title + ("; the tie's explanations (orange), each refitted" if tied else ""))
    fixed_layout(fig, left=0.8, bottom=0.55)
    paths["error_steps"] = save_png(fig, folder / f"{stem}_error_steps.png")

    after_label = "baseline + " + ", ".join(result.missing) if result.missing else "baseline (nothing added)"
    alternatives = getattr(result, "alternatives", None) or []
    curves = getattr(result, "alternative_simulated", None) or []
    if alternatives and len(curves) == len(alternatives):  # a tie: each explanation, a whole model
        after = {"baseline + " + ", ".join(a["effects"]): simulated
                 for a, simulated in zip(alternatives, curves)}
    else:
        after = {after_label: result.simulated_after}
    paths["overlay"] = plot_overlay(measurement, {"baseline": result.simulated_before, **after},
                                    folder / f"{stem}_overlay.png", f"before and after the diagnosis ({result.verdict})")
    paths["residuals"] = plot_residuals(measurement, {
        "before (baseline)": measurement.to_file_units(measurement.output - result.simulated_before),
        **{f"after ({label})": measurement.to_file_units(measurement.output - simulated)
           for label, simulated in after.items()},
    }, folder / f"{stem}_residuals.png")

    path_curves = getattr(result, "pressure_path_simulated", None)
    if path_curves is not None and result.pressure_lag:  # a knee's measured pressures
        found = ", ".join(result.pressure_lag["path"]["effects"]) or "nothing found"
        paths["pressure_path"] = plot_pressure_path(
            measurement, path_curves, folder / f"{stem}_pressure_path.png",
            f"the pressure path judged on the measured pressures: {found}")

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
        fig, axes = new_figure(1, len(names), figsize=(3.7 * len(names), 3.6), squeeze=False, layout="none")
        for ax, name in zip(axes[0], names):
            sig = sigs[name]
            x, label = sig["x"], SIGNATURE_AXIS.get((measurement.experiment, name), SIGNATURE_AXIS[name])
            view = effects.get(name)
            deficit = _pressure_deficit(measurement, result, view) if view.pressure_deficit_axis else None
            if deficit is not None and np.size(deficit[0]) == np.size(sig["missing"]):
                x, label = deficit
            label = label.replace("{muscle}", first_muscle(measurement))
            if measurement.experiment == "mechanism" and measurement.mechanism.unit == "rad":
                # the speed is the joint's (SignatureAxes)
                label = label.replace("[mm/s]", "[mrad/s]")
            two_sided = view.two_sided
            ax.plot(x, sig["missing"], "o", ms=2, mew=0, color="0.45", alpha=0.35)
            ax.plot(*_binned(x, sig["missing"], by_value=two_sided), "o-", color="tab:red", ms=4,
                    label="mean in bins of x")
            ax.axhline(0, color="k", lw=0.5)
            if view.acts_below_zero:  # where the model's tension turns negative, a slack muscle carries nothing
                ax.axvspan(min(np.min(x), -0.15 * np.ptp(x), -1.0) * 1.05, 0.0, color="tab:orange", alpha=0.15, lw=0,
                           label=f"{name} region (tension < 0)")
                ax.axvline(0, color="tab:orange", lw=1)
                if np.min(x) >= 0:
                    ax.text(0.98, 0.04, f"no sample goes {name}\n(least tension {np.min(x):.3g} N)",
                            transform=ax.transAxes, ha="right", va="bottom", fontsize=7)
            ax.set_xlabel(label, fontsize=7)
            ax.set_title(f"{name}: r = {sig['correlation']:+.2f}", fontsize=9)
            ax.legend(fontsize=6, loc="upper right")
        axes[0, 0].set_ylabel(missing_force_label(measurement))
        fig.suptitle("signatures: the force the baseline lacks (at the smoothed measured states) against what "
                     "each effect acts through" if len(names) > 2 else
                     "signatures: the force the baseline lacks\nagainst what each effect acts through", fontsize=9)
        fixed_layout(fig, left=0.9, bottom=0.5, top=0.55 if len(names) > 2 else 0.7, wgap=0.55)
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
                         f"{', '.join(step['replaced']) or 'the baseline'}: "
                         f"RMSE {step['rmse']:.4g} {unit} (whole record)")
            continue
        interleaved = result.experiment in result.rule.get("interleaved_holdout", ())
        held_out = (f"one sample in {result.rule['holdout_every']}"
                    if interleaved else f"the last {result.rule['holdout_fraction']:.0%}")
        lines.append(f"round {number}: candidates (best BIC first; RMSE over the compared samples, held-out "
                     f"over {held_out})")
        for row in step["candidates"]:
            if row["bic"] is None:
                lines.append(f"  {row['effect']:<17} could not be simulated")
                continue
            (name, value), = row["params"].items()
            sig = row.get("signature") or {}
            # the slope's value is a hint only where the effect's force is linear in its parameter: the lag's
            # first-order term (tau times the smoothed command rate) is not, for step commands (it disagreed with
            # the fitted tau by tenfold); a switch has no value to suggest
            estimate = sig.get("estimate") if row["effect"] not in NO_SLOPE_HINT else None
            flag = " (on its bound: rejected)" if row.get("at_bound") else ""
            shown = f"{int(value)} ({'on' if value else 'off'})" if name in INTEGER_PARAMETERS else f"{value:.4g}"
            lines.append(f"  {row['effect']:<17} {name} = {shown:<10} dBIC {row['delta_bic']:+9.1f}  "
                         f"RMSE {row['rmse']:.4g}  held-out {row['rmse_holdout']:.4g} {unit}  "
                         f"signature r = {sig.get('correlation', 0.0):+.2f}"
                         + (f" (slope says {name} ~ {estimate:.3g})" if estimate is not None else "") + flag)
        for tie in step["ties"]:
            lines.append(f"  tie: {' ~ '.join(tie['effects'])}; to tell them apart: {tie['experiment']}")
        for tried in step.get("with_requirements", []):  # a prerequisite with what requires it (issue 32)
            values = ", ".join(f"{k} = {v:.4g}" for k, v in tried["params"].items())
            lines.append(f"  with what requires it: {' + '.join(tried['effects'])} ({values}) dBIC "
                         f"{tried['delta_bic']:+.1f}, held-out {tried['rmse_holdout']:.4g} {unit}"
                         + (" (on a bound)" if tried.get("at_bound") else "")
                         + (": added" if tried.get("accepted") else ""))
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
        neither = item.get("explains") is False  # the best of them still leaves more than the noise
        lines.append(f"{'tie' if neither else 'undecided'}: this record cannot tell {' from '.join(item['effects'])}"
                     f"{', and neither explains it' if neither else ''}; "
                     f"to separate them: {item['experiment']}")
    alternatives = getattr(result, "alternatives", None) or []
    for number, alternative in enumerate(alternatives, 1):
        values = ", ".join(_value_text(name, value, alternative["uncertainty"].get(name))
                           for name, value in alternative["params"].items())
        lines.append(f"alternative {number} ({alternative_label(alternative)}): "
                     f"{', '.join(alternative['effects'])}: {values}; "
                     f"RMSE {alternative['rmse']:.4g} {unit} (whole record), {alternative['text']}")
    if result.missing and alternatives:
        lines.append("missing (what every alternative shares): " + ", ".join(result.missing))
        for name, value in result.params.items():
            value_text = _value_text(name, value, result.uncertainty.get(name))
            lines.append(f"  {value_text} (every alternative agrees)")
        for effect in result.missing:
            disputed = [p for p in effects.get(effect).parameter_names
                        if p not in result.params and all(p in a["params"] for a in alternatives)]
            lines += [f"  {p}: depends on the explanation (see the alternatives above)"
                      for p in disputed]
    elif result.missing:
        lines.append("missing: " + ", ".join(result.missing))
        for name, value in result.params.items():
            if name in INTEGER_PARAMETERS:  # a switch (slack = 1): on, no standard error to give
                lines.append(f"  {name} = {int(value)} (on)")
                continue
            error = result.uncertainty.get(name)
            plus = f" +- {error:.2g}" if error is not None else ""
            lines.append(f"  {name} = {value:.4g}{plus} {UNITS[name]}")
    elif result.undecided and result.verdict == "undecided":
        lines.append("missing: undecided (see above)")
    elif result.undecided:
        lines.append("missing: none of the candidates (the tied ones leave more than the noise: see the note)")
    else:
        lines.append("missing: nothing (no candidate effect is supported by the data)")
    for key, (value, error) in (getattr(result, "identified", None) or {}).items():
        plus = f" +- {error:.2g}" if error is not None else ""
        conductance = key.split("/")[0]
        lines.append(f"identified: {key} = {value:.4g}{plus} 1/(s Pa) (the {conductance} above "
                     "holds only for the assumed dead volume)")
    if result.offset is not None:
        lines.append(f"sensor offset (fitted): {result.offset:.4g} {unit}")
    lines.append(f"after: RMSE {result.rmse_after:.4g} {unit} (whole record), {fit_text(result.fit_percent_after)}"
                 + (f"; output noise about {result.output_noise:.2g} {unit}" if result.output_noise else ""))
    lines += discovery_lines(getattr(result, "discovery", None))
    lines.append(f"verdict: {result.verdict}")
    return lines


def _value_text(name: str, value: float, error: float | None) -> str:
    """``"c = 45.02 +- 0.3 N s/m"`` (a switch as on/off, no error)."""
    if name in INTEGER_PARAMETERS:
        return f"{name} = {int(value)} ({'on' if value else 'off'})"
    plus = f" +- {error:.2g}" if error is not None else ""
    return f"{name} = {value:.4g}{plus} {UNITS[name]}"


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
