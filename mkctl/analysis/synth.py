"""The virtual test bench: measurement files made by the model, with hidden effects and noise.

A synthetic record is simulated with the *truth*: the file's baseline (its known parameters and model)
plus the hidden effects. The file says only what the user would know (experiment, baseline, known
parameters); the hidden values go to a sidecar ``<name>.truth.json``, never into the file's metadata
(where they would become part of the baseline).

Default inputs (chosen to excite what each experiment can show):

- ``knee``: 3000 samples at 1 kHz (3 s). The leg starts at rest in the equilibrium of the first commands
  (the extensor command that holds alpha = 60 deg, :func:`mkctl.physics.simulate.default_commands`, with
  pf = 100 kPa); then the extensor command steps through +4 %, -3 %, +3 %, -2 % of that pressure at
  5, 27.5, 50 and 72.5 % of the record. Steps excite the leg's oscillation (about 1.7 Hz with Table II),
  whose decay shows damping and friction, and whose start shows the pressure lag.
- ``isotonic``: 2000 samples; for each load of (20, 50, 80) N the bladder pressure is swept from 150 to
  600 kPa and back twice: slowly (20 s) and fast (5 s). Friction leaves the same loop at both rates,
  damping a loop that grows with the rate. 150 kPa is low enough to show the rubber's elasticity and
  high enough that model 1 still carries 80 N.
- Command shapes (``shape``): the knee's extensor command as ``steps`` (above), ``ramps`` (the same levels
  reached by linear ramps over :data:`RAMP_FRACTION` of the record each) or a ``chirp`` (a sine of
  :data:`CHIRP_AMPLITUDE` of the holding pressure whose frequency rises linearly from 0.2 to 3 Hz after the
  first 5 % of the record: the command changes at every sample). The isotonic pressure as ``sweeps``
  (above) or ``steps`` (the same sweeps held on :data:`ISOTONIC_LEVELS` levels).
- Output noise: Gaussian with the given standard deviation in the output column's unit (mm, or deg for
  ``beta_deg``), white, or coloured (first-order autoregressive with correlation time ``noise_tau`` [s],
  the same standard deviation), from ``numpy.random.default_rng(seed)``.
- Measured inputs: the isotonic bladder pressure, and the knee's bladder pressures when ``pressures`` is
  set (written as ``pe_kPa``, ``pf_kPa``: the truth's pressures after any lag), get Gaussian sensor noise
  of ``input_noise`` kPa; the truth is simulated with the clean pressures.
- A sensor's resolution: ``resolution`` (output column's unit; an encoder's count, 360 / 2^bits deg for
  ``beta_deg``) rounds the measured output to multiples of it, after the noise, as a digital sensor does.
- ``mechanism`` (model-spec 5d, :func:`synthesize_mechanism`): 3000 samples at 1 kHz; every muscle
  held at :data:`MECHANISM_PRESSURE` (or the pressures given), muscle 1's command stepped through
  +10 %, -8 %, +6 %, -4 % at 5, 27.5, 50 and 72.5 % of the record; the mechanism starts at rest in
  the equilibrium of the first commands. Noise in the output column's unit (mm or deg).
- ``actuator`` (a driven-length test, :func:`synthesize_actuator`): 4000 samples at 1 kHz; the
  length imposed as a sine about 0.89 L0 of amplitude 0.06 L0, at 1 Hz then 3 Hz, under two
  pressure commands (:data:`ACTUATOR_PRESSURES`); the force measured (noise in N). The file holds
  the command ``p_cmd_kPa``, or with ``pressures`` the measured pressure ``pressure_kPa`` (the
  truth's, after any lag and dead time).
- A sensor offset: ``offset`` (output column's unit) is added to the written output; with
  ``declare_offset`` the file declares it (``x_offset_mm = ...``) and a reader removes it, without it the
  file holds the offset like a sensor zeroed elsewhere.
"""
from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ParameterError, check_memory
from ..physics.isotonic import simulate_isotonic
from ..io.text import write_text_atomic
from ..io.measurements import (BASELINES, EXPERIMENTS, LARGEST, UNIT_FACTORS, experiment_columns, round_to_file,
                               write_measurement)
from ..physics import effects
from ..physics.params import EFFECT_PARAMETERS, PARAMETER_NAMES, LiveMapping, Params
from ..physics.simulate import default_commands, simulate_knee

#: Default samples per experiment.
DEFAULT_SAMPLES = {"knee": 3000, "isotonic": 2000}
#: Default sample rate of the knee [Hz].
DEFAULT_RATE = 1000.0
#: Default noise standard deviation of the measured output [mm].
DEFAULT_NOISE_MM = 0.01
#: Values an effect takes when it is hidden by name alone (SI; each parameter's typical value in the registry);
#: elasticity takes Table I's C1, C2. Switches (slack) are hidden by value (slack=1).
DEFAULT_EFFECT_VALUES = LiveMapping(lambda: {e.name: e.typical_values for e in effects.all_effects()
                                             if not e.is_switch})
#: Knee extensor command steps: (fraction of the record, factor on the holding pressure).
KNEE_STEPS = ((0.05, 1.04), (0.275, 0.97), (0.50, 1.03), (0.725, 0.98))
#: Isotonic sweeps: loads [N], pressure range [Pa], slow and fast cycle durations [s].
ISOTONIC_LOADS = (20.0, 50.0, 80.0)
ISOTONIC_PRESSURES = (150e3, 600e3)
ISOTONIC_CYCLES = (20.0, 5.0)
#: Isotonic ``steps`` shape: the sweep held on this many pressure levels.
ISOTONIC_LEVELS = 8
#: Share of the record each knee ramp takes (``ramps`` shape).
RAMP_FRACTION = 0.1
#: Knee chirp: amplitude (fraction of the holding pressure) and frequency range [Hz].
CHIRP_AMPLITUDE = 0.03
CHIRP_FREQUENCIES = (0.2, 3.0)
#: Command shapes of each experiment (the first is the default).
SHAPES = {"knee": ("steps", "ramps", "chirp"), "isotonic": ("sweeps", "steps")}


def knee_inputs(samples: int = DEFAULT_SAMPLES["knee"], rate: float = DEFAULT_RATE, params: Params = Params(),
                shape: str = "steps"):
    """(time [s], pe_cmd [Pa], pf_cmd [Pa]) of the knee experiment: steps, ramps or a chirp (module docstring)."""
    _check_samples(samples)
    _check_shape("knee", shape)
    if not rate > 0:
        raise ParameterError(f"sample rate must be positive, got {rate!r} Hz")
    time = np.arange(samples) / rate
    pe0, pf0 = default_commands(params)
    end = time[-1]
    pe = np.full(samples, pe0)
    if shape == "steps":
        for fraction, factor in KNEE_STEPS:
            pe[time >= fraction * end] = pe0 * factor
    elif shape == "ramps":
        level = 1.0
        for fraction, factor in KNEE_STEPS:
            start, stop = fraction * end, (fraction + RAMP_FRACTION) * end
            u = np.clip((time - start) / (stop - start), 0.0, 1.0)
            pe = np.where(time >= start, pe0 * (level + (factor - level) * u), pe)
            level = factor
    else:  # chirp: frequency rising linearly from f0 to f1 after the first 5 %
        f0, f1 = CHIRP_FREQUENCIES
        start = 0.05 * end
        tau = np.clip(time - start, 0.0, None)
        duration = end - start
        phase = 2 * np.pi * (f0 * tau + 0.5 * (f1 - f0) / duration * tau * tau)
        pe = pe0 * (1.0 + CHIRP_AMPLITUDE * np.sin(phase))
    return time, pe, np.full(samples, pf0)


def _check_shape(experiment: str, shape: str):
    if shape not in SHAPES[experiment]:
        raise ParameterError(f"unknown command shape {shape!r} for {experiment} (known: {', '.join(SHAPES[experiment])})")


def isotonic_inputs(samples: int = DEFAULT_SAMPLES["isotonic"], loads=ISOTONIC_LOADS,
                    pressures=ISOTONIC_PRESSURES, cycles=ISOTONIC_CYCLES, shape: str = "sweeps"):
    """(time [s], pressure [Pa], load [N]) of the isotonic experiment: triangular sweeps, or held on levels."""
    _check_samples(samples)
    _check_shape("isotonic", shape)
    low, high = pressures
    period = sum(cycles)
    time = np.linspace(0.0, period * len(loads), samples)
    phase = np.mod(time, period)
    load = np.asarray(loads, dtype=float)[np.minimum((time // period).astype(int), len(loads) - 1)]
    pressure = np.empty(samples)
    start = 0.0
    for duration in cycles:
        inside = (phase >= start) & (phase < start + duration) if start + duration < period else phase >= start
        u = (phase[inside] - start) / duration  # 0 -> 1 over the cycle
        pressure[inside] = low + (high - low) * (1.0 - np.abs(2.0 * u - 1.0))
        start += duration
    if shape == "steps":
        step = (high - low) / (ISOTONIC_LEVELS - 1)
        pressure = low + step * np.round((pressure - low) / step)
    return time, pressure, load


def _check_samples(samples):
    if isinstance(samples, bool) or not isinstance(samples, (int, np.integer)) or samples < 10:
        raise ParameterError(f"a synthetic record needs a whole number of at least 10 samples, got {samples!r}")
    # the simulation keeps about 40 float arrays of the record's length (states, outputs, inputs, noise, text)
    check_memory(f"a synthetic record of {samples} samples", samples, 40 * 8)


#: Largest sample rate of a synthetic knee record [Hz] (a real rig logs at most a few kHz).
LARGEST_RATE = 1e6
#: Largest correlation time of the output noise [s].
LARGEST_NOISE_TAU = 1e4


def _check_ranges(experiment, seed, samples, rate, noise, noise_factor, output_kind, input_noise, noise_tau, offset,
                  resolution, pressures):
    """The domain of synthesize's arguments: one line naming the argument, its value and the allowed range."""
    if isinstance(seed, bool) or not isinstance(seed, (int, np.integer)) or not 0 <= seed < 2**63:
        raise ParameterError(f"seed must be a whole number in [0, 2^63), got {seed!r}")
    if samples is not None:
        _check_samples(samples)
    if not (np.isfinite(rate) and 0 < rate <= LARGEST_RATE):
        raise ParameterError(f"sample rate = {rate!r} Hz is outside (0, {LARGEST_RATE:g}] Hz")
    n = DEFAULT_SAMPLES.get(experiment, 0) if samples is None else samples
    if experiment == "knee" and not n / rate <= LARGEST["time"]:
        raise ParameterError(f"{n} samples at {rate:g} Hz last {n / rate:g} s, longer than a record may "
                             f"({LARGEST['time']:g} s)")
    largest = LARGEST[output_kind] / noise_factor  # in the output column's unit
    for name, value in (("noise", noise), ("offset", abs(offset)), ("resolution", resolution)):
        if not (np.isfinite(value) and 0 <= value <= largest):
            raise ParameterError(f"{name} = {value!r} is outside [0, {largest:g}] (the output column's unit; beyond "
                                 "it no real sensor reads)")
    if 0 < resolution < largest * 1e-12:  # the output / resolution overflows; no sensor resolves that finely
        raise ParameterError(f"resolution = {resolution!r} is below {largest * 1e-12:g} (the output column's unit; "
                             "finer than any sensor resolves); 0 means no rounding")
    if not (np.isfinite(input_noise) and 0 <= input_noise <= LARGEST["pressure"] / 1e3):
        raise ParameterError(f"input noise = {input_noise!r} kPa is outside [0, {LARGEST['pressure'] / 1e3:g}] kPa")
    if input_noise and experiment == "knee" and not pressures:
        raise ParameterError("input noise is the noise of the measured bladder pressures: a knee record has them "
                             "only with pressures (--pressures)")
    if not (np.isfinite(noise_tau) and 0 <= noise_tau <= LARGEST_NOISE_TAU):
        raise ParameterError(f"noise correlation time = {noise_tau!r} s is outside [0, {LARGEST_NOISE_TAU:g}] s")


def hidden_values(hidden) -> dict:
    """Turn a list of ``name`` or ``name=value`` items (effect or parameter names) into parameter values.

    An effect named alone takes its on values (:attr:`~mkctl.physics.effects.Effect.on_values`):
    ``viscous_damping`` means c = 45 N s/m (see :data:`DEFAULT_EFFECT_VALUES`), ``elasticity`` model 2 with the
    parameter set's C1, C2, ``slack`` slack = 1. A table value that only an effect reads (C1, C2) switches that
    effect on too. Returns {parameter: value}.
    """
    values: dict = {}
    for item in hidden or ():
        if isinstance(item, tuple):
            name, value = item
        elif "=" in item:
            name, text = (part.strip() for part in item.split("=", 1))
            try:
                value = float(text)
            except ValueError:
                raise ParameterError(f"hidden value of {name!r} is not a number: {text!r}") from None
        else:
            name, value = item.strip(), None
        if name in effects.names() and (value is None or name not in PARAMETER_NAMES):
            if value is not None:
                raise ParameterError(f"give the effect {name!r} without a value, or its parameter "
                                     f"({', '.join(EFFECT_PARAMETERS[name])}) with one")
            values.update(effects.get(name).on_values)
        elif name == "model":
            raise ParameterError("hide the rubber's elasticity with 'elasticity' and a model1 baseline")
        elif name in PARAMETER_NAMES:
            if value is None:
                raise ParameterError(f"hidden parameter {name!r} needs a value ({name}=VALUE)")
            values[name] = value
            owner = effects.effect_of(name)
            if owner is not None and name in owner.uses:  # a table value only that effect reads (C1, C2)
                values.update({k: v for k, v in owner.on_values.items() if k not in values})
        else:
            raise ParameterError(f"unknown effect or parameter {name!r} to hide (effects: "
                                 f"{', '.join(DEFAULT_EFFECT_VALUES)}; or any parameter NAME=VALUE)")
    return values


@dataclass(frozen=True)
class SyntheticRecord:
    """A synthetic measurement: SI arrays, the baseline the file declares and the hidden truth."""

    experiment: str
    baseline: str
    known: dict  #: parameter values written into the file's metadata
    hidden: dict  #: parameter values of the truth that the file does not tell
    truth: Params
    time: np.ndarray
    inputs: dict
    output_clean: np.ndarray  #: the truth's output [SI: m, or rad for beta_deg]
    output: np.ndarray  #: with noise [SI], without the sensor offset
    noise: float  #: standard deviation in the output column's unit (mm or deg)
    seed: int
    output_column: str = ""  #: ``length_mm``, ``x_mm`` or ``beta_deg``
    shape: str = ""
    input_noise: float = 0.0  #: standard deviation of the measured pressures' noise [kPa]
    noise_tau: float = 0.0  #: correlation time of the output noise [s] (0: white)
    offset: float = 0.0  #: sensor offset in the output column's unit, added to what the file holds
    declare_offset: bool = False  #: whether the file's metadata declares the offset
    inputs_clean: dict | None = None  #: the inputs before sensor noise (SI)
    resolution: float = 0.0  #: the output sensor's resolution in the output column's unit (0: none)
    mechanism: object = None  #: a mechanism record's mechanism
    #: a pressure record's metadata settings, in the file's units (``supply_kPa``, ``length_mm``,
    #: ``load_N``)
    settings: dict = field(default_factory=dict)

    @property
    def spec(self):
        """The record's columns (:func:`mkctl.io.measurements.experiment_columns`)."""
        return experiment_columns(self.experiment, self.mechanism)

    @property
    def hidden_effects(self) -> list[str]:
        # hidden static parameters (a calibration's b, n) belong to the muscle, not to an effect
        effect_parameters = {q.name for e in effects.all_effects() for q in e.parameters}
        muscle = {k: v for k, v in self.hidden.items() if k not in effect_parameters}
        known = {k: v for k, v in self.known.items() if k in PARAMETER_NAMES}  # not a mechanism's own
        baseline = Params().replace(model=BASELINES[self.baseline], **known, **muscle)
        return [e for e in self.truth.effects if e not in baseline.effects]


def synthesize(experiment: str, hidden=None, known: dict | None = None, baseline: str = "model2",
               noise: float | None = DEFAULT_NOISE_MM, seed: int = 0, samples: int | None = None,
               rate: float = DEFAULT_RATE, *, shape: str | None = None, output: str | None = None,
               input_noise: float = 0.0, noise_tau: float = 0.0, offset: float = 0.0,
               declare_offset: bool = False, pressures: bool = False, resolution: float = 0.0) -> SyntheticRecord:
    """Simulate a record of ``experiment`` with the truth = baseline + hidden, and add noise.

    Parameters
    ----------
    experiment : ``knee``, ``isotonic`` or ``isometric`` (:func:`synthesize_isometric`)
    hidden : list for :func:`hidden_values`, or dict {parameter: value} (SI)
    known : dict
        Parameter overrides (SI) that the file declares.
    baseline : ``model1`` or ``model2``
    noise : float
        Output noise standard deviation [output column's unit: mm, deg for ``beta_deg``, N for isometric];
        None: the experiment's default.
    seed : int
        Seed of every noise.
    samples : int
        Default 3000 (knee), 2000 (isotonic).
    rate : float
        The knee's sample rate [Hz].
    shape : str
        Command shape (:data:`SHAPES`; default steps for the knee, sweeps for the isotonic test).
    output : str
        Output column: ``x_mm`` (default) or ``beta_deg`` for the knee; ``length_mm`` for the isotonic test.
    input_noise : float
        Sensor noise of the measured pressures [kPa] (isotonic pressure; knee ``pe``, ``pf`` if written).
    noise_tau : float
        Correlation time of the output noise [s]; 0 for white noise.
    offset : float
        Sensor offset added to the written output [output column's unit].
    declare_offset : bool
        Declare the offset in the file's metadata (the reader then removes it).
    pressures : bool
        Knee: also write the measured bladder pressures ``pe_kPa``, ``pf_kPa``.
    resolution : float
        The output sensor's resolution [output column's unit]: the measured output is rounded to multiples of
        it (a 12-bit joint encoder: ``output="beta_deg", resolution=360 / 2**12``); 0: none.
    """
    if experiment in EXPERIMENTS:
        spec = EXPERIMENTS[experiment]
        kind, factor = spec.output.kind, UNIT_FACTORS[spec.output.kind][spec.output.unit]
        if output:
            name, _, unit = output.rpartition("_")
            q = next((q for q in spec.outputs if q.name == name), spec.output)
            kind, factor = q.kind, UNIT_FACTORS[q.kind].get(unit, factor)
        default = DEFAULT_NOISE_N if experiment == "isometric" else DEFAULT_NOISE_MM
        _check_ranges(experiment, seed, samples, rate, default if noise is None else noise, factor, kind,
                      input_noise, noise_tau, offset, resolution, pressures)
    if experiment == "isometric":  # the blocked-force bench (noise in N)
        if resolution:
            raise ParameterError("resolution rounds a knee or isotonic output; the isometric bench has none")
        return synthesize_isometric(hidden, known, DEFAULT_NOISE_N if noise is None else noise, offset=offset,
                                    seed=seed, samples=ISOMETRIC_SAMPLES if samples is None else samples,
                                    baseline=baseline, declare_offset=declare_offset)
    noise = DEFAULT_NOISE_MM if noise is None else noise
    _check_choices(experiment, baseline, noise, input_noise, noise_tau, resolution, offset, pressures)
    spec = EXPERIMENTS[experiment]
    output_column = output or f"{spec.output.name}_{spec.output.unit}"
    out_quantity = _output_quantity(spec, output_column)
    known, hidden, truth = _truth(known, hidden, baseline)
    samples = DEFAULT_SAMPLES[experiment] if samples is None else samples
    shape = shape or SHAPES[experiment][0]
    rng = np.random.default_rng(seed)
    time, inputs, clean, clean_inputs = _simulate_truth(experiment, truth, samples, rate, shape, out_quantity.name,
                                                        pressures, input_noise, rng)
    factor = UNIT_FACTORS[out_quantity.kind][out_quantity.unit]
    measured = clean + colored_noise(rng, noise * factor, time, noise_tau)
    if resolution > 0:
        measured = np.round(measured / (resolution * factor)) * (resolution * factor)
    return SyntheticRecord(experiment, baseline, known, hidden, truth, time, inputs, clean, measured, noise, seed,
                           output_column, shape, input_noise, noise_tau, offset, declare_offset, clean_inputs,
                           resolution)


def _check_choices(experiment: str, baseline: str, noise: float, input_noise: float, noise_tau: float,
                   resolution: float, offset: float, pressures: bool) -> None:
    """One-line errors for choices :func:`synthesize` cannot make (the experiment, the baseline, signs; the
    ranges are :func:`_check_ranges`')."""
    if experiment not in ("knee", "isotonic"):
        raise ParameterError(f"unknown experiment {experiment!r} for synth (known: knee, isotonic)")
    if baseline not in BASELINES:
        raise ParameterError(f"unknown baseline {baseline!r} (known: {', '.join(BASELINES)})")
    for name, value in (("noise", noise), ("input noise", input_noise), ("noise correlation time", noise_tau),
                        ("resolution", resolution)):
        if not (value >= 0 and np.isfinite(value)):
            raise ParameterError(f"{name} must be a finite number >= 0, got {value!r}")
    if not np.isfinite(offset):
        raise ParameterError(f"offset must be a finite number, got {offset!r}")
    if pressures and experiment != "knee":
        raise ParameterError("measured pressures (pe, pf) belong to a knee record; the isotonic pressure is measured "
                             "anyway")


def _truth(known: dict | None, hidden, baseline: str) -> tuple[dict, dict, Params]:
    """(known, hidden, truth): the file's declared parameters, the hidden ones, and the Params that simulate."""
    known = dict(known or {})
    if "model" in known:
        raise ParameterError("choose the model with the baseline (model1 or model2), not 'model'")
    hidden = dict(hidden) if isinstance(hidden, dict) else hidden_values(hidden)
    if hidden.get("model") == 2 and baseline == "model2":
        raise ParameterError("elasticity is already in the model2 baseline: hide it with --baseline model1")
    return known, hidden, Params().replace(**{"model": BASELINES[baseline], **known, **hidden})


def _simulate_truth(experiment: str, truth: Params, samples: int, rate: float, shape: str, quantity: str,
                    pressures: bool, input_noise: float, rng):
    """The inputs as the file will hold them (measured ones with sensor noise), the truth's clean output [SI] and
    the clean inputs: (time, inputs, clean output, clean inputs)."""
    if experiment == "knee":
        time, pe, pf = knee_inputs(samples, rate, truth, shape)
        inputs = {"pe_cmd": pe, "pf_cmd": pf}
    else:
        time, pressure, load = isotonic_inputs(samples, shape=shape)
        inputs = {"pressure": pressure, "force": load}
    # simulate the inputs exactly as the file will hold them (rounded to its digits)
    time, inputs = as_written(experiment, time, inputs)
    clean_inputs = dict(inputs)
    if experiment == "knee":
        run = simulate_knee(time, inputs["pe_cmd"], inputs["pf_cmd"], truth)
        clean = run["beta"] if quantity == "beta" else run["X"]
        if pressures:
            clean_inputs.update({"pe": run["Pe"], "pf": run["Pf"]})
            inputs.update({name: clean_inputs[name] + _sensor_noise(rng, input_noise * 1e3, time.size)
                           for name in ("pe", "pf")})
    else:
        clean = simulate_isotonic(time, inputs["pressure"], inputs["force"], truth)
        if input_noise > 0:
            inputs["pressure"] = inputs["pressure"] + _sensor_noise(rng, input_noise * 1e3, time.size)
    return time, inputs, clean, clean_inputs


def _output_quantity(spec, column: str):
    name, _, unit = column.rpartition("_")
    for q in spec.outputs:
        if q.name == name and unit in UNIT_FACTORS[q.kind]:
            return type(q)(name, q.kind, unit)
    names = ", ".join(f"{q.name}_{q.unit}" for q in spec.outputs)
    raise ParameterError(f"output {column!r} is not an output of a {spec.name} record (use {names})")


def _sensor_noise(rng, std: float, size: int) -> np.ndarray:
    return rng.normal(0.0, std, size) if std > 0 else np.zeros(size)


def colored_noise(rng, std: float, time, tau: float = 0.0) -> np.ndarray:
    """Gaussian noise of standard deviation ``std``: white (tau = 0) or first-order autoregressive with
    correlation time tau [s] (``e_k = a e_{k-1} + sqrt(1 - a^2) w_k``, ``a = exp(-dt / tau)``)."""
    time = np.asarray(time, dtype=float)
    if std <= 0:
        return np.zeros(time.size)
    white = rng.normal(0.0, 1.0, time.size)
    if tau <= 0:
        return std * white
    from .filters import ar1_filter

    dt = float(np.mean(np.diff(time)))
    a = math.exp(-dt / tau)
    # lfilter([sqrt(1 - a^2)], [1, -a], white, zi=[a white_0]): the first innovation carries the state a white_0
    innovations = math.sqrt(1 - a * a) * white
    innovations[0] += a * white[0]
    e = ar1_filter(innovations, a)
    e[0] = white[0]
    return std * e


def as_written(experiment: str, time, inputs: dict, mechanism=None):
    """Time and inputs rounded as :func:`mkctl.io.measurements.write_measurement` writes them."""
    spec = experiment_columns(experiment, mechanism)
    rounded = {q.name: round_to_file(inputs[q.name], q) for q in (*spec.inputs[1:], *spec.optional)
               if q.name in inputs}
    return round_to_file(time, spec.inputs[0]), rounded


def write_synthetic(path, record: SyntheticRecord, truth_file: bool = True) -> tuple[Path, Path | None]:
    """Write the record as a measurement file and (optionally) its truth as ``<stem>.truth.json``."""
    spec = record.spec
    column = record.output_column or f"{spec.output.name}_{spec.output.unit}"
    quantity = _output_quantity(spec, column)
    offset_si = record.offset * UNIT_FACTORS[quantity.kind][quantity.unit]
    metadata = dict(record.known)
    if record.declare_offset and record.offset:
        metadata[f"{quantity.name}_offset_{quantity.unit}"] = record.offset
    path = write_measurement(path, record.experiment, record.time, record.inputs, record.output + offset_si,
                             metadata=metadata, baseline=record.baseline, output_column=column,
                             comments=("synthetic record from mkctl synth (the virtual test bench)",),
                             branch=record.inputs.get("branch"), mechanism=record.mechanism,
                             settings=record.settings)
    truth_path = None
    if truth_file:
        truth_path = truth_path_for(path)
        write_text_atomic(truth_path, json.dumps({
            "file": path.name,
            "experiment": record.experiment,
            **({"mechanism": record.mechanism.name} if record.mechanism is not None else {}),
            "baseline": record.baseline,
            "hidden_effects": record.hidden_effects,
            "hidden": {k: v for k, v in record.hidden.items() if k != "model"},
            "known": record.known,
            **({"settings": record.settings} if record.settings else {}),
            "noise": record.noise,
            "noise_unit": quantity.unit,
            "noise_tau": record.noise_tau,
            "shape": record.shape,
            "input_noise_kPa": record.input_noise,
            "offset": record.offset,
            "offset_declared": bool(record.declare_offset and record.offset),
            "resolution": record.resolution,
            "seed": record.seed,
            "samples": int(record.time.size),
        }, indent=2, allow_nan=False) + "\n")
    return path, truth_path


def truth_path_for(path) -> Path:
    """Where :func:`write_synthetic` puts the hidden truth of a file: ``<stem>.truth.json`` beside it."""
    path = Path(path)
    return path.with_name(path.stem + ".truth.json")


# --- The isometric (blocked-force) bench -------------------------------------------------------------

#: Isometric bench: clamped lengths as fractions of L0, the pressure range [Pa] stepped up then down at
#: each length, and the force noise's default standard deviation [N].
ISOMETRIC_LENGTHS = (0.75, 0.83, 0.91, 0.98)
ISOMETRIC_PRESSURES = (0.0, 600e3)
ISOMETRIC_SAMPLES = 400
DEFAULT_NOISE_N = 0.5
#: Seconds between two points of the isometric bench (each a settled, quasi-static reading).
ISOMETRIC_PERIOD = 1.0


def isometric_inputs(samples: int = ISOMETRIC_SAMPLES, lengths=None, pressures=ISOMETRIC_PRESSURES,
                     params: Params = Params()):
    """(time [s], length [m], pressure [Pa], branch) of the default blocked-force test.

    The muscle is clamped at each length in turn (default ``ISOMETRIC_LENGTHS`` times L0, shortest first);
    at each the pressure is stepped evenly from the low to the high end of ``pressures`` (branch +1, up)
    and back (branch -1, down), ``samples / len(lengths)`` points per length, one point a second.
    """
    _check_samples(samples)
    lengths = np.asarray([f * params.L0 for f in ISOMETRIC_LENGTHS] if lengths is None else lengths, dtype=float)
    per_length = int(samples) // lengths.size
    if per_length < 4:
        raise ParameterError(f"{samples} samples over {lengths.size} lengths leave fewer than 4 per length")
    up = per_length - per_length // 2
    low, high = pressures
    ramp_up = np.linspace(low, high, up)
    ramp_down = np.linspace(high, low, per_length - up + 1)[1:]
    pressure = np.tile(np.concatenate([ramp_up, ramp_down]), lengths.size)
    branch = np.tile(np.concatenate([np.ones(up), -np.ones(per_length - up)]), lengths.size)
    length = np.repeat(lengths, per_length)
    time = np.arange(length.size) * ISOMETRIC_PERIOD
    return time, length, pressure, branch


def synthesize_isometric(hidden=None, known: dict | None = None, noise: float = DEFAULT_NOISE_N, offset: float = 0.0,
                         seed: int = 0, samples: int = ISOMETRIC_SAMPLES, lengths=None, baseline: str = "model2",
                         declare_offset: bool = False) -> SyntheticRecord:
    """A blocked-force record made by the truth (baseline + hidden), with force noise and a sensor offset.

    Parameters: hidden, a list for :func:`hidden_values` (``slack`` means slack = 1, ``coulomb_friction``
    Fc = 2 N) or a dict {parameter: value}; known, parameters the file declares (SI); noise, the force
    noise's standard deviation [N]; offset, the load cell's zero offset [N], added to what the file holds
    (declared in its metadata with ``declare_offset``); seed, the noise's seed; samples and lengths [m] as for
    :func:`isometric_inputs`.
    Returns a SyntheticRecord with ``inputs = {"length", "pressure", "branch"}`` and the force [N] as output
    (without the offset, as for the other experiments).
    """
    from ..physics.isometric import isometric_tension

    if not (noise >= 0 and np.isfinite(noise)):
        raise ParameterError(f"noise must be a finite number >= 0 N, got {noise!r}")
    if not np.isfinite(offset):
        raise ParameterError(f"offset must be a finite number of N, got {offset!r}")
    if baseline not in BASELINES:
        raise ParameterError(f"unknown baseline {baseline!r} (known: {', '.join(BASELINES)})")
    known = dict(known or {})
    if isinstance(hidden, dict):
        hidden = dict(hidden)
    else:
        items = list(hidden or ())
        hidden = hidden_values(items)
    truth = Params().replace(**{"model": BASELINES[baseline], **known, **hidden})
    time, length, pressure, branch = isometric_inputs(samples, lengths, params=truth)
    time, rounded = as_written("isometric", time, {"length": length, "pressure": pressure})
    inputs = {"length": rounded["length"], "pressure": rounded["pressure"], "branch": branch}
    clean = isometric_tension(inputs["length"], inputs["pressure"], branch, truth)
    measured = clean + colored_noise(np.random.default_rng(seed), noise, time)
    return SyntheticRecord("isometric", baseline, known, hidden, truth, time, inputs, clean, measured, noise, seed,
                           "force_N", "steps", 0.0, 0.0, float(offset), declare_offset, dict(inputs))


# --- Mechanism and driven-length (actuator) records (model-spec 5d) ------------------------------

#: A mechanism record's default: every muscle's holding pressure [Pa].
MECHANISM_PRESSURE = 300e3
#: Muscle 1's command steps of a mechanism record: (fraction of the record, factor on its holding
#: pressure).
MECHANISM_STEPS = ((0.05, 1.10), (0.275, 0.92), (0.50, 1.06), (0.725, 0.96))
#: Default samples of a mechanism and of an actuator record.
MECHANISM_SAMPLES = 3000
ACTUATOR_SAMPLES = 4000
#: The driven-length test: the length's centre and amplitude as shares of L0, its frequencies [Hz]
#: (each for a quarter of the record), and the pressure command of each half [Pa].
ACTUATOR_LENGTH = (0.89, 0.06)
ACTUATOR_FREQUENCIES = (1.0, 3.0)
ACTUATOR_PRESSURES = (200e3, 450e3)


def _noise_settings(seed, samples, rate, noise, input_noise, noise_tau, offset, resolution, kind,
                    factor):
    """The checks of the new kinds: :func:`_check_ranges`' ranges, for an output of ``kind``."""
    _check_ranges("mechanism", seed, samples, rate, noise, factor, kind, input_noise, noise_tau,
                  offset, resolution, True)
    if not samples / rate <= LARGEST["time"]:
        raise ParameterError(f"{samples} samples at {rate:g} Hz last {samples / rate:g} s, longer "
                             f"than a record may ({LARGEST['time']:g} s)")


def _split_known(known: dict | None, mechanism=None) -> tuple[dict, dict]:
    """(the muscle's known values, the mechanism's own) of ``known``."""
    known = dict(known or {})
    own_names = mechanism.parameter_names if mechanism is not None else ()
    own = {k: v for k, v in known.items() if k in own_names}
    return {k: v for k, v in known.items() if k not in own}, own


def mechanism_inputs(mechanism, samples: int = MECHANISM_SAMPLES, rate: float = DEFAULT_RATE,
                     pressures=None):
    """(time [s], commands [Pa], one array per muscle) of a mechanism record.

    Each muscle held at its pressure (default :data:`MECHANISM_PRESSURE`), muscle 1's command
    stepped by :data:`MECHANISM_STEPS`.
    """
    _check_samples(samples)
    count = len(mechanism.muscles)
    held = [MECHANISM_PRESSURE] * count if pressures is None else [float(p) for p in pressures]
    if len(held) != count:
        raise ParameterError(f"mechanism {mechanism.name} has {count} muscle(s) "
                             f"({', '.join(mechanism.muscles)}); got {len(held)} pressure(s)")
    largest = LARGEST["pressure"]
    for value in held:
        if not (np.isfinite(value) and 0 <= value <= largest):
            raise ParameterError(f"pressure {value / 1e3:g} kPa is outside "
                                 f"[0, {largest / 1e3:g}] kPa")
    time = np.arange(samples) / rate
    first = np.full(samples, held[0])
    for fraction, factor in MECHANISM_STEPS:
        first[time >= fraction * time[-1]] = held[0] * factor
    return time, [first] + [np.full(samples, value) for value in held[1:]]


def synthesize_mechanism(mechanism, hidden=None, known: dict | None = None,
                         baseline: str = "model2", noise: float | None = None, seed: int = 0,
                         samples: int | None = None, rate: float = DEFAULT_RATE, *, pressures=None,
                         output: str | None = None, input_noise: float = 0.0,
                         noise_tau: float = 0.0, offset: float = 0.0,
                         declare_offset: bool = False, measured_pressures: bool = False,
                         resolution: float = 0.0) -> SyntheticRecord:
    """A mechanism record (model-spec 5d) made by the truth (baseline + hidden) on
    :func:`mechanism_inputs`.

    Parameters
    ----------
    mechanism : Mechanism
        The mechanism (:func:`mkctl.analysis.mechanism_files.mechanism`).
    hidden : list or dict
        As :func:`synthesize` (the muscle's effects and parameters).
    known : dict
        Values written into the metadata: the muscle's (SI) and the mechanism's own (their units).
    noise : float
        Output noise [the output column's unit: mm or deg]; default :data:`DEFAULT_NOISE_MM`.
    pressures : sequence of float, optional
        Each muscle's holding pressure [Pa].
    output : str
        The output column, ``q_mm`` or ``q_deg`` (default: by the coordinate's unit).
    measured_pressures : bool
        Also write each muscle's measured pressure (``p1_kPa``, ...: the truth's, with
        ``input_noise`` kPa of sensor noise).
    baseline, seed, samples, rate, input_noise, noise_tau, offset, declare_offset, resolution
        As :func:`synthesize`.

    Returns
    -------
    SyntheticRecord
        ``inputs`` ``p1_cmd``, ... (and ``p1``, ...), the coordinate [m or rad] as output.
    """
    from .compare import mechanism_output
    from ..io.measurements import measurement_from_arrays

    spec = experiment_columns("mechanism", mechanism)
    column = output or f"{spec.output.name}_{spec.output.unit}"
    quantity = _output_quantity(spec, column)
    factor = UNIT_FACTORS[quantity.kind][quantity.unit]
    noise = DEFAULT_NOISE_MM if noise is None else noise
    samples = MECHANISM_SAMPLES if samples is None else samples
    _noise_settings(seed, samples, rate, noise, input_noise, noise_tau, offset, resolution,
                    quantity.kind, factor)
    if input_noise and not measured_pressures:
        raise ParameterError("input noise is the noise of the measured pressures: a mechanism "
                             "record has them only with --pressures")
    muscle_known, own = _split_known(known, mechanism)
    muscle_known, hidden, truth = _truth(muscle_known, hidden, baseline)
    bound = mechanism.bind(truth, **own)  # the own values checked at once (a one-line error)
    time, commands = mechanism_inputs(mechanism, samples, rate, pressures)
    inputs = {f"p{i + 1}_cmd": c for i, c in enumerate(commands)}
    time, inputs = as_written("mechanism", time, inputs, mechanism)
    record = measurement_from_arrays("mechanism", time, inputs, np.zeros(time.size), params=own,
                                     mechanism=mechanism, source="<synth>")
    clean, _ = mechanism_output(record, truth)
    rng = np.random.default_rng(seed)
    clean_inputs = dict(inputs)
    if measured_pressures:
        from ..physics.mechanism import simulate_mechanism

        held = tuple(inputs[f"p{i + 1}_cmd"] for i in range(len(commands)))
        run = simulate_mechanism(time, held, mechanism, bound)
        for i in range(len(commands)):
            clean_inputs[f"p{i + 1}"] = run.P[:, i]
            inputs[f"p{i + 1}"] = run.P[:, i] + _sensor_noise(rng, input_noise * 1e3, time.size)
    measured = clean + colored_noise(rng, noise * factor, time, noise_tau)
    if resolution > 0:
        measured = np.round(measured / (resolution * factor)) * (resolution * factor)
    return SyntheticRecord("mechanism", baseline, {**muscle_known, **own}, hidden, truth, time,
                           inputs, clean, measured, noise, seed, column, "steps", input_noise,
                           noise_tau, offset, declare_offset, clean_inputs, resolution, mechanism)


def actuator_inputs(samples: int = ACTUATOR_SAMPLES, rate: float = DEFAULT_RATE,
                    params: Params = Params()):
    """(time [s], length [m], pressure command [Pa]) of a driven-length test.

    A sine of :data:`ACTUATOR_LENGTH` at each frequency of :data:`ACTUATOR_FREQUENCIES` under each
    pressure of :data:`ACTUATOR_PRESSURES` (a quarter of the record each), the phase continuous.
    """
    _check_samples(samples)
    time = np.arange(samples) / rate
    quarter = np.minimum((4 * np.arange(samples)) // samples, 3)
    frequency = np.asarray(ACTUATOR_FREQUENCIES)[quarter % 2]
    phase = np.concatenate([[0.0], np.cumsum(2 * np.pi * frequency[:-1] * np.diff(time))])
    centre, amplitude = ACTUATOR_LENGTH
    length = params.L0 * (centre + amplitude * np.sin(phase))
    command = np.asarray(ACTUATOR_PRESSURES)[quarter // 2]
    return time, length, command


def synthesize_actuator(hidden=None, known: dict | None = None, baseline: str = "model2",
                        noise: float | None = None, seed: int = 0, samples: int | None = None,
                        rate: float = DEFAULT_RATE, *, input_noise: float = 0.0,
                        noise_tau: float = 0.0, offset: float = 0.0, declare_offset: bool = False,
                        measured_pressures: bool = False,
                        resolution: float = 0.0) -> SyntheticRecord:
    """A driven-length record (``experiment = actuator``, model-spec 5d) made by the truth on
    :func:`actuator_inputs`: the tension with every effect
    (:func:`mkctl.analysis.compare.actuator_output`).

    ``noise``: the force noise [N] (default :data:`DEFAULT_NOISE_N`); ``measured_pressures``: write
    the measured pressure ``pressure_kPa`` (the truth's, after any lag and dead time, with
    ``input_noise`` kPa) in place of the command ``p_cmd_kPa``; others as :func:`synthesize`.
    """
    from .compare import actuator_output, commanded_pressure
    from ..io.measurements import measurement_from_arrays

    noise = DEFAULT_NOISE_N if noise is None else noise
    samples = ACTUATOR_SAMPLES if samples is None else samples
    _noise_settings(seed, samples, rate, noise, input_noise, noise_tau, offset, resolution,
                    "force", 1.0)
    if input_noise and not measured_pressures:
        raise ParameterError("input noise is the noise of the measured pressure: an actuator "
                             "record has it only with --pressures")
    known, hidden, truth = _truth(known, hidden, baseline)
    time, length, command = actuator_inputs(samples, rate, truth)
    time, inputs = as_written("actuator", time, {"length": length, "p_cmd": command})
    rng = np.random.default_rng(seed)
    record = measurement_from_arrays("actuator", time, inputs, np.zeros(time.size),
                                     source="<synth>")
    clean, _ = actuator_output(record, truth)
    clean_inputs = dict(inputs)
    if measured_pressures:
        pressure = commanded_pressure(time, inputs.pop("p_cmd"), truth)
        clean_inputs["pressure"] = pressure
        inputs["pressure"] = pressure + _sensor_noise(rng, input_noise * 1e3, time.size)
    measured = clean + colored_noise(rng, noise, time, noise_tau)
    if resolution > 0:
        measured = np.round(measured / resolution) * resolution
    return SyntheticRecord("actuator", baseline, known, hidden, truth, time, inputs, clean,
                           measured, noise, seed, "force_N", "sines", input_noise, noise_tau,
                           offset, declare_offset, clean_inputs, resolution)


# --- Pressure records (model-spec 5c) -----------------------------------------------------------

#: A pressure record's defaults: samples, sample rate [Hz] (a logger of the rigs of issue 28: 80
#: Hz), and the output noise [kPa].
PRESSURE_SAMPLES = 1200
PRESSURE_RATE = 80.0
DEFAULT_NOISE_KPA = 0.3
#: The supply's gauge pressure a pressure record declares unless told [Pa] (the rigs of issue 28:
#: 620 kPa).
PRESSURE_SUPPLY = 620e3
#: The shapes of a pressure record: ``steps`` (a regulator's large fill and exhaust steps, as shares
#: of the supply), ``small`` (small steps around a middle pressure: where the valve is a lag),
#: ``valve`` (a switching valve opened to the supply, closed, opened to the exhaust) and
#: ``leakdown`` (a fast fill, then the valve closed for the rest: the heat's sag and the leak-down).
PRESSURE_SHAPES = ("steps", "small", "valve", "leakdown")
#: ``steps``: (fraction of the record, set-point as a share of the supply's gauge pressure).
PRESSURE_STEPS = ((0.05, 0.6), (0.3, 0.1), (0.55, 0.45), (0.8, 0.0))
#: ``small``: the middle set-point (share of the supply) and the steps around it (shares of the
#: supply).
PRESSURE_SMALL = (0.3, ((0.05, 0.01), (0.3, -0.01), (0.55, 0.015), (0.8, -0.005)))
#: ``valve``: (fraction of the record, opening).
PRESSURE_OPENINGS = ((0.05, 1.0), (0.25, 0.0), (0.5, -1.0), (0.6, 0.0), (0.7, 0.5), (0.8, 0.0))
#: ``leakdown``: the fill's end (fraction of the record); the valve is open to the supply before it.
LEAK_FILL = 0.03
#: How a pressure record's muscle is held: at a length, moving (a length column) or free under a
#: load.
PRESSURE_HOLDS = ("held", "moving", "load")
#: ``moving``: the length's centre and amplitude as shares of L0, and its frequency [Hz].
PRESSURE_MOTION = (0.9, 0.05, 0.5)
#: ``load``: the constant load [N].
PRESSURE_LOAD = 50.0


def pressure_inputs(
    shape: str, samples: int, rate: float, supply: float, jitter: float = 0.0, rng=None
):
    """(time [s], {"p_cmd" [Pa] or "valve" [-]}) of a pressure record of ``shape``
    (:data:`PRESSURE_SHAPES`).

    ``jitter``: each sampling interval drawn uniformly within +-jitter of ``1 / rate`` (a logger's
    irregular steps: 10-15 ms at 80 Hz is jitter 0.2); ``supply``: the supply's gauge pressure [Pa].
    """
    _check_samples(samples)
    if shape not in PRESSURE_SHAPES:
        raise ParameterError(
            f"unknown pressure record shape {shape!r} (known: {', '.join(PRESSURE_SHAPES)})"
        )
    if not (np.isfinite(jitter) and 0 <= jitter < 1):
        raise ParameterError(
            f"jitter = {jitter!r} is outside [0, 1) (a share of the sampling interval)"
        )
    steps = np.full(samples - 1, 1.0 / rate)
    if jitter:
        steps *= 1.0 + jitter * (2.0 * rng.random(samples - 1) - 1.0)
    time = np.concatenate([[0.0], np.cumsum(steps)])
    share = time / time[-1]
    if shape in ("steps", "small"):
        level, changes = (0.0, PRESSURE_STEPS) if shape == "steps" else PRESSURE_SMALL
        command = np.full(samples, level * supply)
        for fraction, value in changes:
            command[share >= fraction] = (value if shape == "steps" else level + value) * supply
        return time, {"p_cmd": command}
    if shape == "valve":
        opening = np.zeros(samples)
        for fraction, value in PRESSURE_OPENINGS:
            opening[share >= fraction] = value
        return time, {"valve": opening}
    return time, {"valve": np.where(share < LEAK_FILL, 1.0, 0.0)}


def synthesize_pressure(
    hidden=None,
    known: dict | None = None,
    baseline: str = "model2",
    noise: float | None = None,
    seed: int = 0,
    samples: int | None = None,
    rate: float = PRESSURE_RATE,
    *,
    shape: str = "steps",
    hold: str = "held",
    length: float | None = None,
    load: float = PRESSURE_LOAD,
    jitter: float = 0.0,
    noise_tau: float = 0.0,
    offset: float = 0.0,
    declare_offset: bool = False,
    resolution: float = 0.0,
) -> SyntheticRecord:
    """A pressure record (``experiment = pressure``, model-spec 5c) made by the truth (baseline +
    hidden) on :func:`pressure_inputs` (:func:`mkctl.analysis.compare.pressure_output`).

    Parameters
    ----------
    hidden : list or dict
        As :func:`synthesize`: ``valve_flow`` (the valve), ``leak``, ``air_heat`` (both need the
        valve), ``pressure_lag``, ``asymmetric_lag``, ``dead_time``, or values (``C_fill=3e-9``).
    known : dict
        Values written into the metadata (SI), e.g. ``{"P_supply": 520e3}`` (written as
        ``supply_kPa``).
    noise : float
        Output noise [kPa] (default :data:`DEFAULT_NOISE_KPA`).
    shape : str
        :data:`PRESSURE_SHAPES`: the ``valve`` and ``leakdown`` shapes are driven by openings (the
        valve is then in the record's baseline: hide its values, ``C_fill=...``, or leave its
        typical ones).
    hold : str
        :data:`PRESSURE_HOLDS`: ``held`` at ``length`` [m] (default L0), ``moving`` (a sine of
        :data:`PRESSURE_MOTION`, written as a length column) or ``load`` (free under ``load`` [N]).
    jitter : float
        Irregular sampling: each interval within +-jitter of 1 / rate.
    baseline, seed, samples, rate, noise_tau, offset, declare_offset, resolution
        As :func:`synthesize` (rate default :data:`PRESSURE_RATE`; the output's unit is kPa).

    Returns
    -------
    SyntheticRecord
        ``inputs`` ``p_cmd`` or ``valve`` (and ``length``), the gauge pressure [Pa] as output.
    """
    from .compare import pressure_output
    from ..io.measurements import measurement_from_arrays

    noise = DEFAULT_NOISE_KPA if noise is None else noise
    samples = PRESSURE_SAMPLES if samples is None else samples
    _noise_settings(seed, samples, rate, noise, 0.0, noise_tau, offset, resolution, "pressure", 1e3)
    if hold not in PRESSURE_HOLDS:
        raise ParameterError(f"unknown hold {hold!r} (known: {', '.join(PRESSURE_HOLDS)})")
    known = dict(known or {})
    known.setdefault("P_supply", PRESSURE_SUPPLY)
    if shape in (
        "valve",
        "leakdown",
    ):  # driven by openings: the valve is in the record's baseline (5c)
        valve = next(
            e for e in effects.all_effects() if e.valve_opening is not None
        ).switch_parameter
        known.setdefault(valve.name, valve.on_value)
    hidden = dict(hidden) if isinstance(hidden, dict) else hidden_values(hidden)
    # the rig's own numbers (the supply, V_dead, T_air, k_poly) an effect named alone brings at
    # their defaults are not hidden: the record states the rig's (known) values
    rig = {q.name: q for q in effects.parameters() if q.rig}
    hidden = {
        k: v for k, v in hidden.items() if not (k in rig and (k in known or v == rig[k].start))
    }
    known, hidden, truth = _truth(known, hidden, baseline)
    rng = np.random.default_rng(seed)
    time, inputs = pressure_inputs(shape, samples, rate, truth.P_supply, jitter, rng)
    settings = {"supply_kPa": truth.P_supply / 1e3}
    metadata = {k: v for k, v in known.items() if k != "P_supply"}
    if hold == "moving":
        centre, amplitude, frequency = PRESSURE_MOTION
        inputs["length"] = truth.L0 * (centre + amplitude * np.sin(2 * np.pi * frequency * time))
    elif hold == "load":
        if not (np.isfinite(load) and 0 <= load <= LARGEST["force"]):
            raise ParameterError(f"load = {load!r} N is outside [0, {LARGEST['force']:g}] N")
        settings["load_N"] = float(load)
    elif length is not None:
        settings["length_mm"] = float(length) * 1e3
    time, inputs = as_written("pressure", time, inputs)
    # a record driven by openings starts at its first measured pressure: the truth's, 0 gauge here
    record = measurement_from_arrays(
        "pressure",
        time,
        inputs,
        np.zeros(time.size),
        params=metadata,
        baseline=baseline,
        source="<synth>",
        settings=settings,
    )
    clean, _ = pressure_output(record, truth)
    measured = clean + colored_noise(rng, noise * 1e3, time, noise_tau)
    if resolution > 0:
        measured = np.round(measured / (resolution * 1e3)) * (resolution * 1e3)
    return SyntheticRecord(
        "pressure",
        baseline,
        metadata,
        hidden,
        truth,
        time,
        inputs,
        clean,
        measured,
        noise,
        seed,
        "p_kPa",
        shape,
        0.0,
        noise_tau,
        offset,
        declare_offset,
        dict(inputs),
        resolution,
        settings=settings,
    )

