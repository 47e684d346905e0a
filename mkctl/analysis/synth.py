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
- Noise: Gaussian, added to the measured output only, with the given standard deviation in the output
  column's unit (mm), from ``numpy.random.default_rng(seed)``.
"""
from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ..errors import ParameterError
from ..physics.isotonic import simulate_isotonic
from ..io.measurements import BASELINES, EXPERIMENTS, UNIT_FACTORS, round_to_file, write_measurement
from ..physics.params import EFFECT_PARAMETERS, PARAMETER_NAMES, Params
from ..physics.simulate import default_commands, simulate_knee

#: Default samples per experiment.
DEFAULT_SAMPLES = {"knee": 3000, "isotonic": 2000}
#: Default sample rate of the knee [Hz].
DEFAULT_RATE = 1000.0
#: Default noise standard deviation of the measured output [mm].
DEFAULT_NOISE_MM = 0.01
#: Values an effect takes when it is hidden by name alone (SI); elasticity takes Table I's C1, C2.
DEFAULT_EFFECT_VALUES = {"elasticity": {}, "viscous_damping": {"c": 45.0}, "coulomb_friction": {"Fc": 2.0},
                         "pressure_lag": {"tau": 0.05}}
#: Knee extensor command steps: (fraction of the record, factor on the holding pressure).
KNEE_STEPS = ((0.05, 1.04), (0.275, 0.97), (0.50, 1.03), (0.725, 0.98))
#: Isotonic sweeps: loads [N], pressure range [Pa], slow and fast cycle durations [s].
ISOTONIC_LOADS = (20.0, 50.0, 80.0)
ISOTONIC_PRESSURES = (150e3, 600e3)
ISOTONIC_CYCLES = (20.0, 5.0)


def knee_inputs(samples: int = DEFAULT_SAMPLES["knee"], rate: float = DEFAULT_RATE, params: Params = Params()):
    """(time [s], pe_cmd [Pa], pf_cmd [Pa]) of the default knee experiment (see the module docstring)."""
    _check_samples(samples)
    if not rate > 0:
        raise ParameterError(f"sample rate must be positive, got {rate!r} Hz")
    time = np.arange(samples) / rate
    pe0, pf0 = default_commands(params)
    pe = np.full(samples, pe0)
    for fraction, factor in KNEE_STEPS:
        pe[time >= fraction * time[-1]] = pe0 * factor
    return time, pe, np.full(samples, pf0)


def isotonic_inputs(samples: int = DEFAULT_SAMPLES["isotonic"], loads=ISOTONIC_LOADS,
                    pressures=ISOTONIC_PRESSURES, cycles=ISOTONIC_CYCLES):
    """(time [s], pressure [Pa], load [N]) of the default isotonic experiment: triangular sweeps."""
    _check_samples(samples)
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
    return time, pressure, load


def _check_samples(samples):
    if int(samples) != samples or samples < 10:
        raise ParameterError(f"a synthetic record needs at least 10 samples, got {samples!r}")


def hidden_values(hidden) -> dict:
    """Turn a list of ``name`` or ``name=value`` items (effect or parameter names) into parameter values.

    ``viscous_damping`` alone means c = 45 N s/m (see :data:`DEFAULT_EFFECT_VALUES`); ``elasticity``
    means model 2 with the parameter set's C1, C2. Returns {parameter: value} with ``model`` = 2 when
    elasticity is hidden.
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
        if name in DEFAULT_EFFECT_VALUES:
            if value is not None:
                raise ParameterError(f"give the effect {name!r} without a value, or its parameter "
                                     f"({', '.join(EFFECT_PARAMETERS[name])}) with one")
            values.update(DEFAULT_EFFECT_VALUES[name])
            if name == "elasticity":
                values["model"] = 2
        elif name == "model":
            raise ParameterError("hide the rubber's elasticity with 'elasticity' and a model1 baseline")
        elif name in PARAMETER_NAMES:
            if value is None:
                raise ParameterError(f"hidden parameter {name!r} needs a value ({name}=VALUE)")
            values[name] = value
            if name in EFFECT_PARAMETERS["elasticity"]:
                values["model"] = 2
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
    output_clean: np.ndarray  #: the truth's output [m]
    output: np.ndarray  #: with noise [m]
    noise: float  #: standard deviation in the output column's unit (mm; N for isometric)
    seed: int
    offsets: dict = field(default_factory=dict)  #: hidden sensor offsets (SI, by quantity): readings = true + offset

    @property
    def hidden_effects(self) -> list[str]:
        # hidden static parameters (a calibration's b, n) belong to the muscle, not to an effect
        effect_parameters = {p for e, ps in EFFECT_PARAMETERS.items() if e != "elasticity" for p in ps}
        muscle = {k: v for k, v in self.hidden.items() if k not in effect_parameters and k != "model"}
        baseline = Params().replace(model=BASELINES[self.baseline], **self.known, **muscle)
        return [e for e in self.truth.effects if e not in baseline.effects]


def synthesize(experiment: str, hidden=None, known: dict | None = None, baseline: str = "model2",
               noise: float | None = DEFAULT_NOISE_MM, seed: int = 0, samples: int | None = None,
               rate: float = DEFAULT_RATE) -> SyntheticRecord:
    """Simulate a record of ``experiment`` with the truth = baseline + hidden, and add noise.

    Parameters: hidden, a list for :func:`hidden_values` or a dict {parameter: value}; known, parameter
    overrides (SI) that the file declares; baseline ``model1`` or ``model2``; noise, the output noise's
    standard deviation [mm]; seed for the noise; samples (default 3000 knee, 2000 isotonic); rate, the
    knee's sample rate [Hz].
    """
    if experiment not in EXPERIMENTS:
        raise ParameterError(f"unknown experiment {experiment!r} (known: {', '.join(EXPERIMENTS)})")
    if baseline not in BASELINES:
        raise ParameterError(f"unknown baseline {baseline!r} (known: {', '.join(BASELINES)})")
    if noise is not None and not (noise >= 0 and np.isfinite(noise)):
        raise ParameterError(f"noise must be a finite number >= 0 mm, got {noise!r}")
    known = dict(known or {})
    if "model" in known:
        raise ParameterError("choose the model with the baseline (model1 or model2), not 'model'")
    if experiment == "isometric":
        return synthesize_isometric(hidden, known, DEFAULT_NOISE_N if noise is None else noise, seed=seed,
                                    samples=ISOMETRIC_SAMPLES if samples is None else samples, baseline=baseline)
    noise = DEFAULT_NOISE_MM if noise is None else noise
    hidden = dict(hidden) if isinstance(hidden, dict) else hidden_values(hidden)
    if hidden.get("model") == 2 and baseline == "model2":
        raise ParameterError("elasticity is already in the model2 baseline: hide it with --baseline model1")
    truth = Params().replace(**{"model": BASELINES[baseline], **known, **hidden})
    samples = DEFAULT_SAMPLES[experiment] if samples is None else samples
    if experiment == "knee":
        time, pe, pf = knee_inputs(samples, rate, truth)
        inputs = {"pe_cmd": pe, "pf_cmd": pf}
    else:
        time, pressure, load = isotonic_inputs(samples)
        inputs = {"pressure": pressure, "force": load}
    # simulate the inputs exactly as the file will hold them (rounded to its digits)
    time, inputs = as_written(experiment, time, inputs)
    if experiment == "knee":
        clean = simulate_knee(time, inputs["pe_cmd"], inputs["pf_cmd"], truth)["X"]
    else:
        clean = simulate_isotonic(time, inputs["pressure"], inputs["force"], truth)
    std = noise * UNIT_FACTORS["length"]["mm"]
    measured = clean + np.random.default_rng(seed).normal(0.0, std, clean.size) if std > 0 else clean.copy()
    return SyntheticRecord(experiment, baseline, known, hidden, truth, time, inputs, clean, measured, noise, seed)


def as_written(experiment: str, time, inputs: dict):
    """Time and inputs rounded as :func:`mkctl.io.measurements.write_measurement` writes them."""
    spec = EXPERIMENTS[experiment]
    rounded = {q.name: round_to_file(inputs[q.name], q) for q in spec.inputs[1:]}
    return round_to_file(time, spec.inputs[0]), rounded


def write_synthetic(path, record: SyntheticRecord, truth_file: bool = True) -> tuple[Path, Path | None]:
    """Write the record as a measurement file and (optionally) its truth as ``<stem>.truth.json``."""
    path = write_measurement(path, record.experiment, record.time, record.inputs, record.output,
                             metadata=record.known, baseline=record.baseline,
                             comments=("synthetic record from mkctl synth (the virtual test bench)",),
                             branch=record.inputs.get("branch"))
    truth_path = None
    if truth_file:
        truth_path = truth_path_for(path)
        truth_path.write_text(json.dumps({
            "file": path.name,
            "experiment": record.experiment,
            "baseline": record.baseline,
            "hidden_effects": record.hidden_effects,
            "hidden": {k: v for k, v in record.hidden.items() if k != "model"},
            "known": record.known,
            "noise": record.noise,
            "noise_unit": "N" if record.experiment == "isometric" else "mm",
            "sensor_offsets": record.offsets,
            "seed": record.seed,
            "samples": int(record.time.size),
        }, indent=2) + "\n", encoding="utf-8")
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
                         seed: int = 0, samples: int = ISOMETRIC_SAMPLES, lengths=None, baseline: str = "model2"):
    """A blocked-force record made by the truth (baseline + hidden), with force noise and a sensor offset.

    Parameters: hidden, a list for :func:`hidden_values` (``slack`` means slack = 1, ``coulomb_friction``
    Fc = 2 N, ``force_offset=VALUE`` a force sensor offset [N]) or a dict {parameter: value}; known, parameters the file declares (SI); noise, the force
    noise's standard deviation [N]; offset, the force sensor's zero offset [N] added to every reading;
    seed, the noise's seed; samples and lengths [m] as for :func:`isometric_inputs`.
    Returns a SyntheticRecord with ``inputs = {"length", "pressure", "branch"}`` and the force [N] as output
    (``offsets = {"force": offset}`` when there is one).
    """
    from ..physics.isometric import isometric_tension

    if not (noise >= 0 and np.isfinite(noise)):
        raise ParameterError(f"noise must be a finite number >= 0 N, got {noise!r}")
    known = dict(known or {})
    if isinstance(hidden, dict):
        hidden = dict(hidden)
    else:
        items = list(hidden or ())
        sensor = [i for i in items if isinstance(i, str) and i.replace(" ", "").startswith("force_offset=")]
        for item in sensor:
            text = item.split("=", 1)[1].strip()
            try:
                offset = float(text)
            except ValueError:
                raise ParameterError(f"hidden force_offset is not a number of N: {text!r}") from None
        hidden = hidden_values([i for i in items if i != "slack" and i not in sensor])
        if "slack" in items:
            hidden["slack"] = 1
    if not np.isfinite(offset):
        raise ParameterError(f"force_offset must be a finite number of N, got {offset!r}")
    truth = Params().replace(**{"model": BASELINES[baseline], **known, **hidden})
    time, length, pressure, branch = isometric_inputs(samples, lengths, params=truth)
    time, rounded = as_written("isometric", time, {"length": length, "pressure": pressure})
    length, pressure = rounded["length"], rounded["pressure"]
    clean = isometric_tension(length, pressure, branch, truth)
    measured = clean + offset
    if noise > 0:
        measured = measured + np.random.default_rng(seed).normal(0.0, noise, clean.size)
    inputs = {"length": length, "pressure": pressure, "branch": branch}
    return SyntheticRecord("isometric", baseline, known, hidden, truth, time, inputs, clean, measured, noise, seed,
                           {"force": float(offset)} if offset else {})
