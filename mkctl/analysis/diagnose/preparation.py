"""Preparing the record: measured inputs smoothed, commands held over blocks, gaps, the sanity checks of
the output, the saturation note, and the record the search runs on (:class:`Record`).
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field

import numpy as np

from ...physics.air import P_ATM
from ...errors import MkctlError
from ...io import diagnosis_report
from ...io.measurements import Measurement
from ...physics import actuator, effects, isotonic, knee
from ...physics.params import Params
from ..compare import rmse, simulate_output
from ..diagnosis_rule import Rule
from ..statistics import lag_one_correlation
from .candidates import path_effect
from .noise import (NoiseModel, QUASI_STATIC, QUASI_STATIC_NULL_REALISATIONS, _output_noise_model,
                    input_noise)
from .problem import Problem

#: The knee's fits hold the commands over blocks so that they change at most about this often.
MAX_COMMAND_CHANGES = 300

#: Savitzky-Golay window [samples] (quadratic) that smooths a noisy measured input.
INPUT_SMOOTHING_SAMPLES = 9

#: An input is smoothed when its estimated noise exceeds this fraction of its range (file rounding lies below).
INPUT_NOISE_FLOOR = 1e-4

#: An interval between samples longer than this many times the median interval is a gap in the record.
GAP_FACTOR = 5.0


def time_gaps(time) -> list[tuple[float, float]]:
    """The gaps of a record: (last time before, first time after) of every interval between samples longer than
    :data:`GAP_FACTOR` times the median interval (a logger that dropped samples)."""
    t = np.asarray(time, dtype=float)
    if t.size < 3:
        return []
    steps = np.diff(t)
    long = np.flatnonzero(steps > GAP_FACTOR * float(np.median(steps)))
    return [(float(t[k]), float(t[k + 1])) for k in long]


def gap_note(measurement) -> str | None:
    """A note on the record's gaps, or None: the commands are held across a gap (model-spec section 5), so
    if they changed there the model cannot follow what comes after it."""
    gaps = time_gaps(measurement.time)
    if not gaps:
        return None
    first = gaps[0]
    where = f"t = {first[0]:g}-{first[1]:g} s" + (f" and {len(gaps) - 1} more" if len(gaps) > 1 else "")
    return (f"the record has {len(gaps)} gap{'s' if len(gaps) > 1 else ''} without samples ({where}): the "
            f"commands are held across {'them' if len(gaps) > 1 else 'it'}, so if they changed there no model "
            f"follows what comes after; cut the record there if they did")


#: A piece of a measured input between steps that stays within this many times its noise of a level (or a
#: straight line) is taken as that level (a pressure held): the filter alone would leave a third of the noise.
PLATEAU_NOISE_FACTOR = 1.2


def _held_level(piece, sigma: float):
    """The piece as its mean (a level held), else as its least-squares line (a slow drift), when it stays within
    :data:`PLATEAU_NOISE_FACTOR` sigma of it; else None."""
    index = np.arange(piece.size, dtype=float)
    for degree in (0, 1):
        fit = np.polyval(np.polyfit(index, piece, degree), index)
        if np.sqrt(np.mean((piece - fit) ** 2)) <= PLATEAU_NOISE_FACTOR * sigma:
            return fit
    return None


def smooth_input(signal, sigma: float, window: int = INPUT_SMOOTHING_SAMPLES) -> np.ndarray:
    """A noisy measured input smoothed by a quadratic Savitzky-Golay filter, steps kept sharp.

    Steps (a load hung on, a pressure step) are found where a first difference departs from its
    neighbours' median by more than 8 sigma sqrt(2), and each piece between steps is smoothed apart: as a
    level or a straight line where it stays within :data:`PLATEAU_NOISE_FACTOR` sigma of one (:func:`_held_level`),
    else by the filter. The noise the filter leaves on a held level was enough for a small friction to win
    (its dead band ignores the wiggles the model passed on), and biased a real one by 0.034 N per kPa.
    """
    from scipy.ndimage import median_filter
    from ..filters import savgol_filter

    x = np.asarray(signal, dtype=float)
    d = np.diff(x)
    jumps = np.flatnonzero(np.abs(d - median_filter(d, 5, mode="nearest")) > 8.0 * sigma * math.sqrt(2.0)) + 1
    out = x.copy()
    for a, b in zip(np.r_[0, jumps], np.r_[jumps, x.size]):
        length = b - a
        level = _held_level(x[a:b], sigma) if length >= 5 else None
        if level is not None:
            out[a:b] = level
            continue
        w = min(window, length if length % 2 else length - 1)
        if w >= 5:
            out[a:b] = savgol_filter(x[a:b], w, 2)
    return out


def measured_inputs(measurement: Measurement) -> list[str]:
    """The inputs of the record that a sensor read (not commands): these may be noisy."""
    if measurement.experiment == "isotonic":
        return [name for name in ("pressure", "force") if name in measurement.inputs]
    if measurement.experiment == "actuator":  # the imposed length is the machine's, not noisy
        return [name for name in ("pressure",) if name in measurement.inputs]
    if measurement.experiment == "mechanism":
        names = [f"p{i + 1}" for i in range(len(measurement.mechanism.muscles))]
        return [name for name in names if name in measurement.inputs]
    return [name for name in ("pe", "pf") if name in measurement.inputs]


def block_commands(measurement: Measurement, block: int) -> Measurement:
    """The knee record with its commands averaged over blocks of ``block`` samples, held over each block."""
    if block <= 1:
        return measurement
    inputs = dict(measurement.inputs)
    n = measurement.samples
    starts = np.arange(0, n, block)
    for name in _drive_names(measurement):
        values = np.asarray(inputs[name], dtype=float)
        means = np.add.reduceat(values, starts) / np.diff(np.r_[starts, n])
        inputs[name] = np.repeat(means, np.diff(np.r_[starts, n]))
    return dataclasses.replace(measurement, inputs=inputs)


def command_changes(measurement: Measurement) -> int:
    """How many samples change a knee command (each is a stop of the integrator)."""
    if measurement.experiment != "knee":
        return 0
    pe, pf = (measurement.inputs[name] for name in _drive_names(measurement))
    return int(np.count_nonzero((np.diff(pe) != 0) | (np.diff(pf) != 0)))


def _drive_names(measurement: Measurement) -> tuple[str, str]:
    """The inputs that drive the knee model (:func:`mkctl.analysis.compare.knee_drive`)."""
    return ("pe", "pf") if "pe" in measurement.inputs and "pf" in measurement.inputs else ("pe_cmd", "pf_cmd")


#: Unit mistakes a sanity check recognises: factor (file value / expected value) -> the likely cause.
_UNIT_MISTAKES = {1e-3: "metres written under a millimetre header", 1e-1: "centimetres written under a "
                  "millimetre header", 1 / 25.4: "inches written under a millimetre header",
                  1e3: "micrometres written under a millimetre header (or millimetres under a metre header)",
                  10.0: "millimetres written under a centimetre header", 25.4: "millimetres written under an "
                  "inch header", math.pi / 180: "radians written under a degree header",
                  180 / math.pi: "degrees written under a radian header"}


def output_range(measurement: Measurement, params: Params) -> tuple[float, float]:
    """The range [SI] the model's output can physically take: the actuator between its shortest length and
    the braid limit (isotonic), the hip height or knee angle between the end stops (knee), a little wider."""
    # a pressure lies between absolute zero and the supply or the highest command
    if measurement.experiment == "pressure":
        command = measurement.inputs.get("p_cmd", np.zeros(1))
        return -P_ATM, 1.2 * max(params.P_supply, float(np.max(command))) + 1e4
    if measurement.experiment == "isotonic":
        low, high = isotonic.length_limits(params)
        return 0.0, high
    if measurement.experiment in ("isometric", "actuator"):
        # the tension between no pressure and twice the highest one (a driven length: half as wide
        # again, for the forces of its motion)
        inputs = measurement.inputs
        L, P = inputs["length"], inputs["pressure"] if "pressure" in inputs else inputs["p_cmd"]
        ends = [actuator.static_tension(L, p, params) for p in (0.0 * P, 2.0 * np.max(np.abs(P)) + 0.0 * P)]
        low, high = float(min(np.min(ends[0]), 0.0)), float(np.max(ends[1]))
        margin = 0.1 if measurement.experiment == "isometric" else 0.5
        return low - margin * (high - low), high + margin * (high - low)
    if measurement.experiment == "mechanism":  # the coordinate between the mechanism's end stops
        q_low, q_high = measurement.mechanism.stop_positions(measurement.mechanism.bind(
            params, **measurement.mechanism_values))
        return q_low - 0.1 * (q_high - q_low), q_high + 0.1 * (q_high - q_low)
    x_low, x_high = knee.stop_positions(params)
    span = x_high - x_low
    low, high = x_low - 0.1 * span, x_high + 0.1 * span
    if output_quantity(measurement) == "beta":
        return float(knee.beta_from_X(max(low, abs(params.Lo - params.Lu) * 1.0001), params)), \
            float(knee.beta_from_X(min(high, (params.Lo + params.Lu) * 0.9999), params))
    return low, high


def output_quantity(measurement: Measurement) -> str:
    """The measured quantity: ``length`` (isotonic), ``x`` or ``beta`` (knee)."""
    return measurement.output_quantity


def sanity_problems(measurement: Measurement, simulated, params: Params, fit_offset: bool = False) -> list[str]:
    """Reasons the measured output cannot be this model's output (a unit or zero mistake), or [].

    The level must lie in the range the model can reach (:func:`output_range`) unless an offset is
    fitted; the measured range of motion must not be a unit factor away from the simulated one.
    """
    m = measurement
    y = np.asarray(m.output, dtype=float)
    sim = np.asarray(simulated, dtype=float)
    column, unit = m.output_column, m.output_unit
    problems = []
    low, high = output_range(m, params)
    level, sim_level = float(np.median(y)), float(np.median(sim))
    to_file = 1.0 / m.output_factor
    # a mechanism whose coordinate runs through 0 (a joint angle about its middle) has no level a
    # unit scales: its level is judged by the range alone, its unit by the range of motion
    level_scales = not (m.experiment == "mechanism" and low < 0.0 < high)
    if not fit_offset:
        cause = None
        ratio = level / sim_level if sim_level else math.inf
        if not level_scales:
            ratio = 1.0
        if ratio and math.isfinite(ratio) and ratio > 0 and abs(math.log(ratio)) > 1.0:
            for factor, text in _UNIT_MISTAKES.items():
                if abs(math.log(ratio / factor)) < 0.3:
                    cause = f"likely {text}"
                    break
        if cause is None and level_scales and abs(level) < 0.05 * abs(sim_level):
            cause = (f"the sensor looks zeroed at rest (the record sits near 0 {unit}): declare its offset in "
                     f"the metadata ({output_quantity(m)}_offset_{unit} = ...) or fit it with --fit-offset")
        if cause is None and not (low <= level <= high):
            cause = "a unit or zero mistake, or a sensor offset (declare it in the metadata or use --fit-offset)"
        if cause is not None:
            problems.append(f"the measured {column} sits at {level * to_file:.4g} {unit} where the model can "
                            f"reach {low * to_file:.4g} to {high * to_file:.4g} {unit} and the baseline sits at "
                            f"{sim_level * to_file:.4g} {unit}: {cause}")
    if problems:
        return problems
    # A unit mistake scales the level with the motion. When the level was judged above (no offset fitted) and
    # matched, a range of motion some factor off is the dynamics the baseline lacks (a chirp through an undamped
    # resonance swings ten times wider than the damped record), not a unit: judge the range only where a fitted
    # offset hides the level.
    level_judged = not fit_offset and level_scales
    spread, sim_spread = float(np.ptp(y)), float(np.ptp(sim))
    if spread > 0 and sim_spread > 0 and not level_judged:
        ratio = spread / sim_spread
        for factor, text in _UNIT_MISTAKES.items():
            angle = output_quantity(m) == "beta" or m.output_unit in ("deg", "rad")
            if factor in (math.pi / 180, 180 / math.pi) and not angle:
                continue
            if abs(factor - 1) > 0.5 and abs(math.log(ratio / factor)) < 0.25 and abs(math.log(ratio)) > 1.5:
                problems.append(f"the measured {column} moves over {spread * to_file:.4g} {unit}, "
                                f"{ratio:.3g} times the model's {sim_spread * to_file:.4g} {unit}: likely {text}")
                break
    return problems


def saturation_note(measurement: Measurement, params: Params, simulated) -> dict | None:
    """Where the baseline could not follow the record (it went to a physical limit), or None."""
    m = measurement
    if m.experiment in ("isometric", "actuator", "pressure"):  # a clamped or driven muscle, the air: no limit
        return None
    if m.experiment == "isotonic":
        where = isotonic.saturation(m.inputs["pressure"], m.inputs["force"], params)
        at_limit = where != 0
        what = ("no length of the baseline carries the load there: it is pulled to its braid limit (L = b)"
                if (where > 0).any() else "the baseline stays at its shortest length")
    elif m.experiment == "mechanism":
        q_low, q_high = m.mechanism.stop_positions(m.mechanism.bind(params, **m.mechanism_values))
        at_limit = (simulated < q_low) | (simulated > q_high)
        what = f"the baseline's {m.mechanism.name} rests on an end stop there"
    else:
        X = simulated if output_quantity(m) != "beta" else knee.hip_height(simulated, params)
        x_low, x_high = knee.stop_positions(params)
        at_limit = (X < x_low) | (X > x_high)
        what = "the baseline's leg rests on an end stop there"
    count = int(np.count_nonzero(at_limit))
    if count == 0:
        return None
    t = m.time[at_limit]
    return {"samples": count, "fraction": count / m.samples, "from_s": float(t[0]), "to_s": float(t[-1]),
            "text": f"the baseline could not follow {count} samples ({count / m.samples:.0%}, "
                    f"t = {t[0]:.3g}-{t[-1]:.3g} s): {what}; the large error there points at what it lacks"}


def prepare_inputs(measurement: Measurement) -> tuple[Measurement, dict, list]:
    """The record with its noisy measured inputs smoothed: (record, {input: noise info}, notes)."""
    inputs = dict(measurement.inputs)
    info, notes = {}, []
    for name in measured_inputs(measurement):
        values = np.asarray(inputs[name], dtype=float)
        sigma = input_noise(values)
        spread = float(np.ptp(values))
        smoothed = bool(sigma > INPUT_NOISE_FLOOR * spread and spread > 0)
        kind = "force" if name == "force" else "pressure"
        unit, factor = ("N", 1.0) if kind == "force" else ("kPa", 1e3)
        info[name] = {"sigma": sigma / factor, "unit": unit, "smoothed": smoothed}
        if smoothed:
            inputs[name] = smooth_input(values, sigma)
            notes.append(f"the measured {name} is noisy (about {sigma / factor:.3g} {unit} standard deviation, "
                         f"from its high-frequency part): the model is driven by it smoothed "
                         f"({INPUT_SMOOTHING_SAMPLES}-sample quadratic Savitzky-Golay, steps kept), so that "
                         f"no effect can win by filtering sensor noise")
    if notes:
        measurement = dataclasses.replace(measurement, inputs=inputs)
    return measurement, info, notes


def renoised_inputs(raw: Measurement, prepared: Measurement, info: dict, seed: int = 1) -> Measurement | None:
    """The prepared record driven by its smoothed measured inputs with a fresh realisation of their noise added
    before the smoothing, or None when no input was smoothed.

    The model driven by it departs from the model driven by the prepared inputs as much as the smoothed
    measured inputs depart from the true ones (the smoothing is close to linear, so the fresh noise through it
    is distributed like the real noise through it): that part of a residual is the inputs' noise passed
    through the model, not a missing effect.
    """
    smoothed = [name for name, item in info.items()
                if item.get("smoothed") and name in raw.inputs and name in prepared.inputs]
    if not smoothed:
        return None
    rng = np.random.default_rng(seed)
    inputs = dict(prepared.inputs)
    for name in smoothed:
        values = np.asarray(raw.inputs[name], dtype=float)
        sigma = input_noise(values)
        inputs[name] = smooth_input(values + sigma * rng.standard_normal(values.size), sigma)
    return dataclasses.replace(prepared, inputs=inputs)


def _blocked_problem(problem: Problem, baseline: Params, full_before, out_sigma: float, notes: list, say) -> Problem:
    """The problem with the knee's commands held over blocks when they change at many samples."""
    m = problem.measurement
    changes = command_changes(m)
    if changes <= MAX_COMMAND_CHANGES:
        return problem
    tolerance = 0.5 * max(out_sigma, 1e-6 * float(np.ptp(m.output)))
    block = int(math.ceil(m.samples / MAX_COMMAND_CHANGES))
    while block > 1:
        blocked = block_commands(m, block)
        try:
            moved = rmse(simulate_output(blocked, baseline, problem.grid), full_before[problem.grid])
        except MkctlError:
            moved = math.inf
        if moved <= tolerance:
            to_file = 1.0 / m.output_factor
            notes.append(f"the commands change at {changes} samples: the fits hold them over blocks of {block} "
                         f"samples (their mean), which moves the baseline by {moved * to_file:.2g} "
                         f"{m.output_unit} RMS, below the output noise; reported errors use every sample")
            say(notes[-1])
            return dataclasses.replace(problem, measurement=blocked)
        block //= 2
    return problem


def _motion_record(m: Measurement, path, baseline: Params, notes: list, say):
    """The record and baseline the motion is fitted with, after the pressure path judged on the
    measured pressures (``path``: :func:`~.pressure_path.path_from_pressures`, or None).

    With measured pressures that the path found follows to within a few times their noise, the
    motion is driven by the commands through that path, noise-free; pressures that depart from it
    (a supply that sags), or a path the knee cannot simulate, drive the motion themselves, smoothed.
    """
    if path is None:
        return None, m, baseline, False
    report = path.report
    noise = max(report["noise_kPa"] or 0.0, 1e-6)
    values = report["path"]["values"]
    found = (", ".join(diagnosis_report.parameter_text(k, v) for k, v in values.items())
             if report["path"]["effects"] else "nothing found: " + str(report["reason"]))
    if report["path"]["effects"]:
        found = " + ".join(report["path"]["effects"]) + " found, " + found
    if path.motion:
        found += (f"; they show {' + '.join(path.motion)}, placed by them only to within a sample: "
                  "it is fitted on the motion")
    inputs = {k: v for k, v in m.inputs.items() if k not in ("pe", "pf")}
    commanded = dataclasses.replace(m, inputs=inputs)
    # how far the measured pressures depart from the path found, over the record's own samples: the
    # one sample that joins the two muscles in the pressure record is ours, not the rig's (a step of
    # the whole pressure range there, which a path without a state cannot place, would otherwise
    # dominate the RMS of a record whose pressures follow their commands within a sample)
    departure = _departure_kPa(m, path, report["rmse_kPa"])
    # (a delay left to the motion: the motion must be driven by the commands to show it)
    follows = bool(path.motion) or departure <= 5.0 * noise
    if follows:
        try:
            simulate_output(commanded, path.params)
        except MkctlError:
            follows = False
    if not follows:
        notes.append(f"the file holds measured bladder pressures: the pressure path is judged on "
                     f"them directly ({found}); they depart from the commands through it by "
                     f"{departure:.3g} kPa RMS (noise {noise:.2g} kPa), so they drive the "
                     "motion themselves")
        say(notes[-1])
        return path, m, baseline, True
    notes.append(f"the file holds measured bladder pressures: the pressure path is judged on them "
                 f"directly ({found}); they follow the commands through it to within their noise "
                 f"({departure:.3g} kPa RMS), so the motion is driven by the commands "
                 "through that path, free of the pressure sensors' noise")
    say(notes[-1])
    return path, commanded, path.params, True


def _departure_kPa(m: Measurement, path, whole: float) -> float:
    """The RMS [kPa] of the measured pressures about the path found (:attr:`PressurePath.simulated`),
    over the knee record's own samples of both muscles; ``whole`` (the pressure record's) when the
    path gives no curve."""
    simulated = path.simulated
    if simulated is None:
        return whole
    measured = np.vstack([m.inputs["pe"], m.inputs["pf"]])
    if measured.shape != simulated.shape:
        return whole
    return float(np.sqrt(np.mean((measured - simulated) ** 2)) / 1e3)


@dataclass(frozen=True)
class Record:
    """The record as prepared for the search: the inputs the model is driven by, the baseline's simulation,
    the output noise, and what the report says about them."""

    measurement: Measurement  #: as read
    prepared: Measurement  #: inputs smoothed (and the lag's pressures replaced by the commands through it)
    start: Params  #: the baseline, with a lag found on measured pressures
    #: the pressure path judged on measured pressures (:attr:`PressurePath.report`)
    lag: dict | None
    exclude: set  #: candidates judged elsewhere (the pressure path, on measured pressures)
    noise: NoiseModel  #: the measured output's noise [SI]
    full_before: np.ndarray  #: the baseline over every sample [SI]
    notes: list
    common: dict  #: the fields every DiagnosisResult of this record shares
    problems: list  #: why the output cannot be this model's (sanity checks)
    fit_offset: bool = False
    renoised: Measurement | None = None  #: the prepared record with re-noised inputs (:func:`renoised_inputs`)
    #: more such records, other realisations (quasi-static records: see
    #: :data:`QUASI_STATIC_NULL_REALISATIONS`)
    renoised_more: list = field(default_factory=list)

    def input_floor(self, params: Params, simulated) -> float:
        """RMS [SI] of the measured inputs' noise passed through the model at params (0 when none was smoothed):
        the model driven by re-noised inputs against ``simulated``, the model driven by the prepared ones."""
        if self.renoised is None:
            return 0.0
        try:
            return rmse(simulate_output(self.renoised, params), simulated)
        except MkctlError:
            return 0.0

    @property
    def to_file(self) -> float:
        return 1.0 / self.measurement.output_factor

    @property
    def output(self) -> np.ndarray:
        """The measured output in file units."""
        return self.measurement.output * self.to_file


def _prepare(m: Measurement, rule: Rule, fit_offset: bool, say, path=None) -> Record:
    """Step 0 of the module docstring: the pressure path judged on measured pressures (``path``,
    :func:`~.pressure_path.path_from_pressures`), the noisy inputs smoothed, the output noise, the
    baseline simulated, the saturation and the sanity checks."""
    notes: list = []
    path, motion, start, lag_judged = _motion_record(m, path, m.params, notes, say)
    lag = path.report if path is not None else None
    prepared, noise_info, input_notes = prepare_inputs(motion)
    if lag_judged:
        for name in ("pe", "pf"):
            noise_info.setdefault(name, {"sigma": input_noise(m.inputs[name]) / 1e3, "unit": "kPa", "smoothed": False})
    notes += input_notes
    gaps = gap_note(m)
    if gaps:
        notes.append(gaps)
        say(gaps)
    for note in input_notes:
        say(note)
    try:
        full_before = simulate_output(prepared, m.params)
    except MkctlError as error:
        raise MkctlError(f"{m.source}: the model cannot simulate this record: {error}") from None
    noise = _output_noise_model(m, full_before)
    saturation = saturation_note(prepared, m.params, full_before)
    if saturation:
        notes.append(saturation["text"])
        say(saturation["text"])
    to_file = 1.0 / m.output_factor
    common = dict(file=str(m.source), experiment=m.experiment, baseline=m.baseline,
                  baseline_effects=list(m.params.effects), output=m.output_column, output_unit=m.output_unit,
                  samples=m.samples, input_noise=noise_info, output_noise=noise.sigma * to_file,
                  output_noise_correlation=noise.correlation, saturation=saturation,
                  rule={**rule.as_dict(), "fit_offset": fit_offset}, pressure_lag=lag,
                  pressure_path_simulated=path.simulated if path is not None else None)
    problems = sanity_problems(m, full_before, m.params, fit_offset)
    # the effects on the pressure path were judged on the measured pressures (what only delays the
    # command is left to the motion)
    judged = ({e.name for e in effects.all_effects() if path_effect(e)} - set(path.motion)
              if lag_judged else set())
    # a quasi-static record passes its inputs' noise straight to the output, sample by sample: one
    # realisation of it is a poor measure of what it gives a candidate, so the null test takes the
    # worst of several
    seeds = range(2, QUASI_STATIC_NULL_REALISATIONS + 1) if m.experiment in QUASI_STATIC else ()
    more = [renoised_inputs(motion, prepared, noise_info, seed) for seed in seeds]
    return Record(m, prepared, start, lag, judged, noise, full_before, notes,
                   common, problems, fit_offset, renoised_inputs(motion, prepared, noise_info),
                   [r for r in more if r is not None])


def input_noise_through_model(record: "Record", params: Params) -> tuple[float, float]:
    """The measured inputs' noise as the model passes it to the output: (standard deviation [SI],
    lag-one correlation between samples) of the model driven by re-noised inputs against the model
    driven by the prepared ones (:func:`renoised_inputs`); (0, 0) when no input was smoothed."""
    if record.renoised is None:
        return 0.0, 0.0
    try:
        renoised = simulate_output(record.renoised, params)
        difference = renoised - simulate_output(record.prepared, params)
    except MkctlError:
        return 0.0, 0.0
    return float(np.sqrt(np.mean(difference ** 2))), lag_one_correlation(difference)


def _with_input_noise(problem: "Problem", record: "Record", say) -> "Problem":
    """A quasi-static record's problem with its inputs' noise in the correlation BIC counts with.

    Its model follows the measured inputs sample by sample, so what their noise leaves after the
    smoothing reaches the residual as it is: a wiggle as long as the smoothing window, correlated
    between neighbouring samples. BIC counted those samples as independent (with the output noise's
    correlation alone), so that any effect that bends the model along one wiggle gained tens in BIC
    (damping c = 63 N s/m added on a clean record under 16 kPa of pressure noise). The correlation
    of the sum of both noises, ``(s_o^2 phi_o + s_i^2 phi_i) / (s_o^2 + s_i^2)``, takes its place
    (the knee's inputs are commands, or pressures that its dynamics filter: unchanged)."""
    if problem.measurement.experiment not in QUASI_STATIC or record.renoised is None:
        return problem
    sigma_in, phi_in = input_noise_through_model(record, record.start)
    sigma_out, phi_out = record.noise.sigma, record.noise.correlation
    total = sigma_in ** 2 + sigma_out ** 2
    if not sigma_in > 0 or not total > 0:
        return problem
    phi = (sigma_out ** 2 * phi_out + sigma_in ** 2 * max(phi_in, 0.0)) / total
    if phi <= problem.noise_correlation:
        return problem
    to_file = record.to_file
    unit = record.measurement.output_unit
    record.notes.append(f"the measured inputs' noise reaches the output through the model "
                        f"({sigma_in * to_file:.2g} {unit} RMS, correlated {phi_in:.2f} between "
                        f"samples, beside {sigma_out * to_file:.2g} {unit} of output noise): BIC "
                        f"counts the samples as correlated {phi:.2f}, so that no effect wins by "
                        f"following it")
    say(record.notes[-1])
    return dataclasses.replace(problem, noise_correlation=phi)
