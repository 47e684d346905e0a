"""Diagnosis: which effect of model-spec section 4 is the model missing, and with what parameter?

Given a measurement (:mod:`mkctl.io.measurements`), :func:`diagnose` checks the record, then starts from
the file's baseline and adds effects one at a time, forward stepwise, while the evidence supports it:

0. **Prepare and check.** Measured inputs are measurements: the noise of each (the isotonic test's
   bladder pressure and load, the knee's measured pressures) is estimated from its high-frequency part
   (:func:`input_noise`), and an input noisier than its file's rounding is smoothed (:func:`smooth_input`)
   before anything is simulated, so that an effect cannot win by filtering sensor noise. A knee record
   whose commands change at many samples (a chirp) is fitted with the commands averaged over short
   blocks, checked against the full commands to stay well below the output noise. Then the baseline is
   simulated; where it leaves its domain it saturates physically (the braid limit, the end stops) and
   the report says where it could not follow. An output whose level or range the model cannot reach
   (a zeroed sensor, metres under a millimetre header) stops the diagnosis with the likely cause
   (verdict ``"not diagnosed"``), unless a constant sensor offset is fitted on request (``fit_offset``).
1. **Split** the record in time: the first 70 % trains, the last 30 % is held out. (Simulations always
   start at the beginning of the record; a held-out error is a prediction from the trained parameters.)
2. **Candidates** are the effects the experiment can show that the model does not have yet
   (:data:`CANDIDATES`): the isotonic test shows elasticity, Coulomb friction and viscous damping (its
   pressure is measured in the bladder, so a lag cannot show); the knee shows all four.
3. **Fit** each candidate's one parameter on simulation error over the training part
   (:func:`mkctl.analysis.diagnosis_rule.best_value`: log-space grid, bounded Brent, "off" as an
   option). From the second round on, each is refitted jointly with the effects already added.
4. **Judge** with the rule of :mod:`mkctl.analysis.diagnosis_rule` and its forward selection: physical
   (not switched off, not on a bound), BIC lower by more than 10 (BIC counting the effective samples when
   the output noise is correlated, :func:`noise_model`), held-out RMSE lower by 2 %, held-out RMSE better
   than every other physical candidate's by 2 %, more gained than the noise alone gives it (the null test:
   refitted on the current model's simulation plus the estimated noise) and a signature that does not go
   against the force the model lacks. When the best does not beat a rival, the two are fitted together:
   if each is needed beside the other both are added, otherwise the diagnosis stops with the verdict
   ``"undecided"``, saying plainly which effects this record cannot tell apart and which experiment
   would (:data:`DISCRIMINATING_EXPERIMENTS`). An effect that requires another (the registry's
   ``requires``) is tried together with its prerequisite when that is tied or a round stops, and in
   the wider search on top of every combination that holds it. After an acceptance, earlier effects
   that no longer earn their place are dropped.
5. **Report** a final joint fit of all added parameters on the whole record, with standard errors from
   the Jacobian of the residuals, ``cov = s^2 (J^T J)^-1``, ``s^2 = RSS / (n - k)``, widened for
   correlated residuals by ``(1 + rho) / (1 - rho)`` (rho: the residual's lag-one autocorrelation).
6. **Verdict** (:func:`verdict_of`): "diagnosed" only when the final model leaves what the noise explains,
   over the whole record and in each tenth of it (:func:`mkctl.analysis.diagnosis_rule.adequacy`: the
   output noise and the measured inputs' noise passed through the model); else "incomplete", and the
   discovery of model-spec section 6b runs. A tie is judged on the best of the tied effects (the final model
   refitted with each, :func:`_tied_rivals`): "undecided" when it reaches the noise, else neither explains the
   record and the verdict is "incomplete" (the tie still reported). Each explanation of a tie is
   reported as a whole model (``alternatives``), and the top level keeps only what they share
   (:func:`_shared_values`).

The result is a :class:`DiagnosisResult`; ``result.to_dict()`` is the JSON of model-spec section 6.
For the knee, fits are evaluated on every ``stride``-th sample (about :data:`FIT_POINTS` points, at most
:data:`MAX_FIT_SPACING` apart), so n in BIC is the number of those samples. RMSE in the steps and before/after
is over every sample. All RMSE are in the units of the file's output column; parameters are SI.
"""
from __future__ import annotations

import dataclasses
import itertools
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable

import numpy as np
from scipy.optimize import least_squares

from ..errors import MkctlError
from ..io import diagnosis_report
from ..io.measurements import Measurement
from ..physics import actuator, effects, isotonic, knee
from ..physics.isometric import isometric_tension
from ..physics.params import UNITS, LiveMapping, Params
from ..results import Result, plain
from .compare import fit_percent, rmse, simulate_output
from .discovery import discover
from .equation_error import (ISOTONIC_SMOOTHING_SAMPLES, KNEE_SMOOTHING_S, knee_force_at,  # noqa: F401 (re-exported)
                             lagged, missing_force, model_pressures)
from .effect_files import discovery_effects
from .diagnosis_rule import (RULE, Adequacy, Candidate as Outcome, Rule, Score, adequacy, at_bound, best_value, decide,
                             extension_needed, forward_selection, judge, pair_needed, to_drop)

# The rule's thresholds (the held-out share, the BIC and held-out gains, the margin) are the fields of
# :class:`mkctl.analysis.diagnosis_rule.Rule`, passed down from :func:`diagnose`: no copies here.
#: About how many samples the knee's fits are evaluated on ...
FIT_POINTS = 200
#: ... but never further apart than this [s]: the knee's transients last a few tenths of a second (its
#: natural period is 0.58 s at the default posture), and a long record thinned to 200 samples would skip them.
MAX_FIT_SPACING = 0.02
#: Tolerance of the one-parameter search, in decades (0.01: 2.3 %; the joint fits refine it).
FIT_XATOL = 0.01
#: The knee's fits hold the commands over blocks so that they change at most about this often.
MAX_COMMAND_CHANGES = 300
#: Savitzky-Golay window [samples] (quadratic) that smooths a noisy measured input.
INPUT_SMOOTHING_SAMPLES = 9
#: An input is smoothed when its estimated noise exceeds this fraction of its range (file rounding lies below).
INPUT_NOISE_FLOOR = 1e-4


@dataclass(frozen=True)
class Candidate:
    """An effect of spec section 4 as a diagnosis candidate: the one parameter it fits and its bounds."""

    effect: str
    parameter: str
    bounds: dict  #: experiment -> (lower, upper) [SI], searched in log space
    regressor: str  #: the force term its signature is checked against
    why: str

    @property
    def switch(self) -> bool:
        """An effect that is on or off (slack): its search interval is one point, never a bound it hits."""
        return self.effect == "slack"

    def apply(self, params: Params, value: float) -> Params:
        """params with this effect switched on at ``value``."""
        if self.effect == "elasticity":
            return params.replace(model=2, C1=value)
        if self.effect == "slack":  # a switch: any value searched (its bounds are [1, 1 + 1e-6]) means on
            return params.replace(slack=1 if value > 0 else 0)
        return params.replace(**{self.parameter: value})


#: The candidates, in the registry's order (:mod:`mkctl.physics.effects`: every effect with a fitted parameter and
#: the experiments it shows in). Elasticity fits C1 with C2 kept at its (Table I) value: C2 is 150 times smaller
#: and its share of the tension is not separable from C1's in these experiments. Slack is a switch (0 or 1): its
#: one-point search interval just compares on with off.
CANDIDATES = LiveMapping(lambda: {
    e.name: Candidate(e.name, e.fitted, dict(e.experiments), e.regressor, effects.why(e.name))
    for e in effects.all_effects() if e.fitted is not None and e.experiments})

#: The experiment that tells two candidates apart, for records that cannot (each effect's definition).
DISCRIMINATING_EXPERIMENTS = LiveMapping(lambda: {
    frozenset({e.name, other}): text for e in effects.all_effects() for other, text in e.separation.items()})

_LN10 = math.log(10.0)
_FAILED = object()


def experiment_to_separate(effects) -> str:
    """The experiment that would tell the given effects apart (each pair's, joined)."""
    effects = list(effects)
    texts = [DISCRIMINATING_EXPERIMENTS.get(frozenset({a, b}), "")
             for i, a in enumerate(effects) for b in effects[i + 1:]]
    return "; ".join(t for t in texts if t)


def candidates_for(measurement: Measurement, params: Params) -> list[str]:
    """The candidate effects the experiment can show that params do not have yet.

    A knee file with measured bladder pressures drives the model with them: its lag is judged on the
    pressures directly (:func:`lag_from_pressures`), not as a candidate of the motion.
    """
    measured_pressures = "pe" in measurement.inputs and "pf" in measurement.inputs
    return [name for name, c in CANDIDATES.items()
            if measurement.experiment in c.bounds and name not in params.effects
            and not (name == "pressure_lag" and measured_pressures)]


#: The effects of the pressure path (command -> bladder pressure), judged on measured pressures when a knee file
#: has them, in the order they are tried, with their parameter.
PRESSURE_PATH = {"pressure_lag": "tau", "dead_time": "delay", "asymmetric_lag": "tau_exhaust"}


def pressure_path(time, command, tau: float = 0.0, delay: float = 0.0, tau_exhaust: float = 0.0) -> np.ndarray:
    """The bladder pressure a command gives through a dead time and the lag [Pa] (model-spec sections 4, 4b).

    The command is held from its sample to the next and reaches the lag ``delay`` late (the first command held
    before that); ``tau dP/dt = P_cmd - P`` while filling, ``tau_exhaust`` instead while exhausting when it is
    given; P(0) = P_cmd(0). Exact between the instants the delayed command changes; no lag: the delayed command.
    """
    time, command = np.asarray(time, dtype=float), np.asarray(command, dtype=float)
    seen_from = time + delay  # command[j] acts from time[j] + delay on
    if tau <= 0:
        return command[np.clip(np.searchsorted(seen_from, time + 1e-12, side="right") - 1, 0, time.size - 1)]
    out = np.empty(time.size)
    P = out[0] = command[0]
    j = 0  # the command acting now
    for k in range(1, time.size):
        t, stop = time[k - 1], time[k]
        while t < stop:
            while j + 1 < time.size and seen_from[j + 1] <= t + 1e-12:
                j += 1
            until = min(stop, seen_from[j + 1]) if j + 1 < time.size else stop
            target = command[j]
            rate_tau = tau_exhaust if (tau_exhaust > 0 and target < P) else tau
            P = target + (P - target) * math.exp(-(until - t) / rate_tau)
            t = until
        out[k] = P
    return out


def lag_from_pressures(measurement: Measurement, params: Params, rule: Rule = RULE) -> dict | None:
    """The pressure path judged directly on a knee file's measured bladder pressures, or None without them.

    The measured pe, pf are compared with the commands through a lag ``tau dP/dt = P_cmd - P``, a dead time, or
    both, and a lag that exhausts at its own rate (:func:`pressure_path`, commands held between samples): forward
    selection by the same rule as the motion's candidates, on the first part of the record, against the commands
    themselves. Round 1 tries the lag and the dead time alone, round 2 adds the other (or the exhausting time
    constant) fitted jointly. Returns {"accepted" (the lag), "tau" [s], "uncertainty" [s], "candidate" (the lag's
    report row, RMSE in kPa), "reason", "path": {"effects", "values", "uncertainty", "undecided"}}; a lag the file
    already declares (tau in the metadata) is not judged.
    """
    m = measurement
    if m.experiment != "knee" or not ("pe" in m.inputs and "pf" in m.inputs) or params.tau > 0:
        return None
    measured = np.concatenate([m.inputs["pe"], m.inputs["pf"]])
    n = m.samples
    train_one = m.time <= rule.split_time(m.time[0], m.time[-1])
    train = np.concatenate([train_one, train_one])

    def residual(values):
        model = np.concatenate([pressure_path(m.time, m.inputs[c], **values) for c in ("pe_cmd", "pf_cmd")])
        return (measured - model) / 1e3  # kPa

    def score(r, k):
        return Score.from_residuals(r[train], r[~train], k)

    def bounds(name):
        return CANDIDATES[name].bounds["knee"]

    def fit(names, start):
        """The parameters of ``names`` fitted jointly (log space) from ``start``; (values, Outcome)."""
        lows = np.log10([bounds(e)[0] for e in names])
        highs = np.log10([bounds(e)[1] for e in names])
        x0 = np.clip(np.log10([max(start.get(PRESSURE_PATH[e], 0.0), 1e-300) for e in names]), lows + 1e-9,
                     highs - 1e-9)
        keys = [PRESSURE_PATH[e] for e in names]
        result = least_squares(lambda x: residual(dict(zip(keys, 10.0 ** x)))[train], x0, bounds=(lows, highs),
                               diff_step=1e-4, xtol=1e-6, max_nfev=40 * len(names))
        values = dict(zip(keys, (float(v) for v in 10.0 ** result.x)))
        pinned = any(at_bound(values[PRESSURE_PATH[e]], bounds(e)) for e in names)
        return values, Outcome(names[-1], score(residual(values), len(names)), at_bound=pinned)

    off = score(residual({}), 0)
    # round 1: the lag alone (as before: a 1-D search, "off" an option) and the dead time alone
    tau, _ = best_value(lambda v: float(np.sum(residual({"tau": v})[train] ** 2)), bounds("pressure_lag"),
                        off.rss_train)
    if tau == 0.0:
        lag_outcome = Outcome("pressure_lag", dataclasses.replace(off, k=1), switched_off=True)
    else:
        lag_outcome = Outcome("pressure_lag", score(residual({"tau": tau}), 1), at_bound=at_bound(tau, bounds("pressure_lag")))
    delay, _ = best_value(lambda v: float(np.sum(residual({"delay": v})[train] ** 2)), bounds("dead_time"),
                          off.rss_train)
    dead_outcome = (Outcome("dead_time", dataclasses.replace(off, k=1), switched_off=True) if delay == 0.0 else
                    Outcome("dead_time", score(residual({"delay": delay}), 1), at_bound=at_bound(delay, bounds("dead_time"))))
    decision = decide(off, [lag_outcome, dead_outcome], rule)
    path = {"effects": [], "values": {}, "uncertainty": {}, "undecided": []}
    first_values = {"pressure_lag": {"tau": tau}, "dead_time": {"delay": delay}}
    current_score = off
    if decision.verdict == "undecided":
        effects_ = [decision.effect, *decision.rivals]
        path["undecided"].append({"effects": effects_, "experiment": experiment_to_separate(effects_),
                                  "text": f"the measured pressures cannot tell {' from '.join(e.replace('_', ' ') for e in effects_)}: "
                                          f"{decision.reason}"})
    elif decision.verdict == "add":
        path["effects"] = [decision.effect]
        path["values"] = dict(first_values[decision.effect])
        current_score = (lag_outcome if decision.effect == "pressure_lag" else dead_outcome).score
        # round 2: the other effect of the path, or the exhausting time constant, fitted jointly with it
        trials = {}
        if decision.effect == "pressure_lag":
            trials["dead_time"] = ["pressure_lag", "dead_time"], {"tau": tau, "delay": 1e-2}
            trials["asymmetric_lag"] = ["pressure_lag", "asymmetric_lag"], {"tau": tau, "tau_exhaust": tau}
        else:
            trials["pressure_lag"] = ["dead_time", "pressure_lag"], {"delay": delay, "tau": 1e-2}
        fitted = {name: fit(names, start) for name, (names, start) in trials.items()}
        second = decide(current_score, [outcome for _, outcome in fitted.values()], rule)
        if second.verdict == "add":
            path["effects"].append(second.effect)
            path["values"] = fitted[second.effect][0]
            if "pressure_lag" not in path["effects"][:1] and second.effect == "pressure_lag":
                path["effects"] = ["pressure_lag", "dead_time"]  # the lag first: an asymmetric lag needs it
            current_score = fitted[second.effect][1].score
            if second.effect == "dead_time" or "dead_time" in path["effects"]:
                if "pressure_lag" in path["effects"]:  # round 3: with both, the exhausting time constant
                    values3, outcome3 = fit(["pressure_lag", "dead_time", "asymmetric_lag"],
                                            {**path["values"], "tau_exhaust": path["values"]["tau"]})
                    third = decide(current_score, [outcome3], rule)
                    if third.verdict == "add":
                        path["effects"].append("asymmetric_lag")
                        path["values"] = values3
        path["values"] = {k: v for k, v in path["values"].items()
                          if any(PRESSURE_PATH[e] == k for e in path["effects"])}
        # standard errors: each parameter by a central difference of the whole record's residual, the others held
        r = residual(path["values"])
        dof = max(r.size - len(path["values"]), 1)
        rho = _lag_one_correlation(r[:n])
        widen = (1 + rho) / (1 - rho) if rho > 0 else 1.0
        for key, value in path["values"].items():
            step = value * 1e-3
            jac = (residual({**path["values"], key: value + step}) - residual({**path["values"], key: value - step})) \
                / (2 * step)
            path["uncertainty"][key] = float(math.sqrt(widen * (r @ r) / dof / max(jac @ jac, 1e-300)))
    accepted = "pressure_lag" in path["effects"]
    tau_found = path["values"].get("tau", tau)
    j = decision.judgements["pressure_lag"]
    lag_row_score = score(residual(path["values"]), len(path["values"])) if path["effects"] else lag_outcome.score
    row = {"effect": "pressure_lag", "params": {"tau": tau_found}, "rmse_train_kPa": lag_row_score.rmse_train,
           "rmse_holdout_kPa": lag_row_score.rmse_holdout, "rmse_holdout_before_kPa": off.rmse_holdout,
           "delta_bic": j.delta_bic, "passes_bic": j.passes_bic, "passes_holdout": j.passes_holdout,
           "switched_off": lag_outcome.switched_off, "at_bound": lag_outcome.at_bound}
    reason = decision.reason if not accepted or decision.effect == "pressure_lag" else "found with a dead time"
    if path["effects"] == ["dead_time"]:
        # without a lag the modelled pressure is the delayed command, sample by sample: the pressures place
        # the delay only within a sample, and the motion, which follows it continuously, fits it instead
        path["motion"] = "dead_time"
        path["effects"], path["values"], path["uncertainty"] = [], {}, {}
    return {"accepted": accepted, "tau": tau_found,
            "uncertainty": path["uncertainty"].get("tau") if accepted else None, "candidate": row,
            "reason": reason, "path": path}


# --- Preparing the record: measured inputs, commands, sanity -----------------------------------------

def input_noise(signal) -> float:
    """Noise standard deviation of a sampled signal, in its units, from its second differences.

    ``sigma = 1.4826 MAD(d2) / sqrt(6)`` with ``d2_k = x_{k+1} - 2 x_k + x_{k-1}``: white noise of
    standard deviation sigma gives var(d2) = 6 sigma^2, while a smooth signal (a ramp, a slow sweep)
    leaves d2 near zero, and steps and kinks touch too few samples to move the median.
    """
    x = np.asarray(signal, dtype=float)
    if x.size < 12:
        return 0.0
    d2 = np.diff(x, 2)
    return float(1.4826 * np.median(np.abs(d2 - np.median(d2))) / math.sqrt(6.0))


def quantization_step(signal) -> float:
    """The count q of a sensor that reads in whole counts (a joint encoder, an ADC), in the signal's units, or 0.

    The signal's distinct values lie on a grid of step q when every gap between neighbouring values is a whole
    multiple of the smallest gap (within 5 % of one count, for 95 % of the gaps: a file rounds the counts to
    its digits). q is then refined by least squares over the gaps. A file's own rounding is such a grid too,
    far finer than any noise. 0 when there are fewer than 3 distinct values or no grid.
    """
    x = np.asarray(signal, dtype=float)
    levels = np.unique(x[np.isfinite(x)])
    if levels.size < 3:
        return 0.0
    gaps = np.diff(levels)
    smallest = float(gaps.min())
    if not smallest > 0:
        return 0.0
    counts = np.round(gaps / smallest)
    q = float(gaps @ counts / (counts @ counts))
    on_grid = np.abs(gaps / q - counts) <= 0.05
    return q if on_grid.mean() >= 0.95 else 0.0


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


def output_noise(signal) -> float:
    """Noise standard deviation of a measured output, in its units: :func:`input_noise`, but at least the
    rounding error q / sqrt(12) of a sensor that reads in counts of q (:func:`quantization_step`). A fine
    encoder on a slow motion repeats one count for many samples, so its second differences are mostly zero
    and alone would call it noise-free; a model that fits perfectly still misses by the rounding."""
    return max(input_noise(signal), quantization_step(signal) / math.sqrt(12.0))


#: Window [samples] of the local cubic whose residual :func:`noise_model` reads the noise's colour from.
NOISE_WINDOW = 31
#: The AR(1) estimate needs a record this many windows long (else the noise is taken as white).
NOISE_WINDOWS_NEEDED = 10
#: A correlated noise is estimated again over this many of its correlation times 1 / (1 - phi) ...
NOISE_WINDOW_PER_TIME = 8
#: ... but over no more samples than this.
MAX_NOISE_WINDOW = 201
#: The largest lag-one correlation of the output noise that is resolved ...
MAX_NOISE_CORRELATION = 0.99
#: ... and a longer window's estimate above this is taken as the signal leaking into it, not noise.
SIGNAL_LEAK_CORRELATION = 0.98
#: Below this lag-one correlation the output noise is taken as white (the estimate's own scatter on white
#: noise is a few hundredths; a signal's kinks leak a little into the local cubic's residual).
WHITE_NOISE_CORRELATION = 0.3


@dataclass(frozen=True)
class NoiseModel:
    """The measured output's noise as first-order autoregressive: standard deviation ``sigma`` [SI] and lag-one
    correlation ``correlation`` (phi) between neighbouring samples (0: white)."""

    sigma: float
    correlation: float = 0.0
    seed: int = 0  #: of the realisation the null test adds to a simulation
    #: the signal leaked into the estimate (a correlation at :data:`SIGNAL_LEAK_CORRELATION`): taken as white
    unresolved: bool = False

    def on_grid(self, stride: int) -> float:
        """The correlation between samples ``stride`` apart: phi ** stride."""
        return float(self.correlation ** max(int(stride), 1)) if self.correlation > 0 else 0.0

    def realisation(self, n: int) -> np.ndarray:
        """n samples of the noise: ``e_k = phi e_(k-1) + sigma sqrt(1 - phi^2) z_k``, e_0 = sigma z_0."""
        from .filters import ar1_filter

        z = np.random.default_rng(self.seed).standard_normal(n) * self.sigma
        phi = self.correlation
        if phi <= 0:
            return z
        z[1:] *= math.sqrt(1.0 - phi * phi)
        return ar1_filter(z, phi)

    def null_output(self, problem: "_Problem", fit: "_Fit", renoised: Measurement | None = None) -> np.ndarray:
        """The output a record would hold if the fitted model were the truth: its simulation (driven by the
        re-noised inputs when given, :func:`renoised_inputs`; else on the grid, interpolated between) plus its
        offset plus a realisation of this noise [SI]."""
        m = problem.measurement
        simulated = None
        if renoised is not None:
            try:
                simulated = simulate_output(renoised, fit.params)
            except MkctlError:
                simulated = None
        if simulated is None:
            simulated = np.interp(np.arange(m.samples), problem.grid, fit.simulated)
        return simulated + fit.offset + self.realisation(m.samples)


def _robust_variance(x) -> float:
    """(1.4826 MAD)^2: the variance of the bulk of x, blind to the few samples a kink or a step spoils."""
    x = np.asarray(x, dtype=float)
    return float((1.4826 * np.median(np.abs(x - np.median(x)))) ** 2)


def _residual_filter(window: int) -> np.ndarray:
    """Impulse response of "signal minus its local cubic" (Savitzky-Golay, centre point) over ``window``."""
    from .filters import savgol_coeffs

    h = -savgol_coeffs(window, 3)
    h[window // 2] += 1.0
    return h


def _ar1_moments(h: np.ndarray, phi: float) -> tuple[float, float]:
    """Variance (per sigma^2) and lag-one correlation of AR(1) noise of correlation phi passed through h."""
    lags = np.arange(-(h.size - 1), h.size)
    auto = np.correlate(h, h, mode="full")  # sum_i h_i h_(i+m), m = lags
    cov = lambda m: float(np.sum(auto * phi ** np.abs(lags + m)))  # noqa: E731
    return cov(0), cov(1) / cov(0)


def noise_model(signal, window: int = NOISE_WINDOW) -> NoiseModel:
    """The measured output's noise as AR(1): sigma and phi, robust to the signal and to coloured noise.

    The signal is taken out by a local cubic (Savitzky-Golay over ``window`` samples); what is left is the
    noise through a known filter h. Its robust variance v and robust lag-one correlation r (from the spreads
    of the sum and difference of neighbours) are matched to those of AR(1) noise through h,
    ``v = sigma^2 sum_ij h_i h_j phi^|i-j|`` (and the same for r): r fixes phi, then v sigma. Noise that stays
    correlated over much of the window is estimated again over a window :data:`NOISE_WINDOW_PER_TIME`
    correlation times long (at most :data:`MAX_NOISE_WINDOW`), else the cubic takes much of it for signal. For
    white noise (phi below :data:`WHITE_NOISE_CORRELATION`), a record shorter than :data:`NOISE_WINDOWS_NEEDED`
    windows, or a correlation at :data:`SIGNAL_LEAK_CORRELATION` or above (a signal too rough for the cubic, or
    a drift slower than the record resolves) sigma is :func:`output_noise`, white. The lag-one
    estimate alone reads AR(1) noise of phi = 0.9 as about a quarter of its size.
    """
    x = np.asarray(signal, dtype=float)
    white = NoiseModel(output_noise(x))
    estimate = _ar1_estimate(x, window)
    if estimate is not None and estimate[1] >= SIGNAL_LEAK_CORRELATION:  # the signal leaked in
        return dataclasses.replace(white, unresolved=True)
    if estimate is None or estimate[1] < WHITE_NOISE_CORRELATION:
        return white
    longer = min(MAX_NOISE_WINDOW, x.size // 4)
    longer = min(longer, int(NOISE_WINDOW_PER_TIME / (1.0 - estimate[1]))) | 1
    if longer > window:  # kept unless the signal leaked in (phi driven to the largest it resolves)
        refined = _ar1_estimate(x, longer)
        if refined is not None and refined[1] < SIGNAL_LEAK_CORRELATION:
            estimate = refined
    sigma, phi = estimate
    if phi < WHITE_NOISE_CORRELATION:
        return white
    return NoiseModel(max(sigma, white.sigma), phi)


def _ar1_estimate(x: np.ndarray, window: int) -> tuple[float, float] | None:
    """(sigma, phi) of :func:`noise_model` from the residual of a local cubic over ``window`` samples, or None
    (too short a record, no spread)."""
    from scipy.optimize import brentq
    from .filters import fir_valid

    if x.size < NOISE_WINDOWS_NEEDED * window:
        return None
    h = _residual_filter(window)
    e = fir_valid(h, x)
    plus, minus = _robust_variance(e[1:] + e[:-1]), _robust_variance(e[1:] - e[:-1])
    if not plus + minus > 0:
        return None
    r = (plus - minus) / (plus + minus)
    low, high = _ar1_moments(h, 0.0)[1], _ar1_moments(h, MAX_NOISE_CORRELATION)[1]
    if r <= low:
        return 0.0, 0.0
    phi = MAX_NOISE_CORRELATION if r >= high else brentq(lambda p: _ar1_moments(h, p)[1] - r, 0.0,
                                                         MAX_NOISE_CORRELATION, xtol=1e-4)
    return math.sqrt(_robust_variance(e) / _ar1_moments(h, phi)[0]), float(phi)


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
    from .filters import savgol_filter

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
    if measurement.experiment == "isotonic":
        low, high = isotonic.length_limits(params)
        return 0.0, high
    if measurement.experiment == "isometric":  # the tension between no pressure and twice the highest one
        L, P = measurement.inputs["length"], measurement.inputs["pressure"]
        ends = [actuator.static_tension(L, p, params) for p in (0.0 * P, 2.0 * np.max(np.abs(P)) + 0.0 * P)]
        low, high = float(min(np.min(ends[0]), 0.0)), float(np.max(ends[1]))
        return low - 0.1 * (high - low), high + 0.1 * (high - low)
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
    if not fit_offset:
        cause = None
        ratio = level / sim_level if sim_level else math.inf
        if ratio and math.isfinite(ratio) and ratio > 0 and abs(math.log(ratio)) > 1.0:
            for factor, text in _UNIT_MISTAKES.items():
                if abs(math.log(ratio / factor)) < 0.3:
                    cause = f"likely {text}"
                    break
        if cause is None and abs(level) < 0.05 * abs(sim_level):
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
    level_judged = not fit_offset
    spread, sim_spread = float(np.ptp(y)), float(np.ptp(sim))
    if spread > 0 and sim_spread > 0 and not level_judged:
        ratio = spread / sim_spread
        for factor, text in _UNIT_MISTAKES.items():
            if factor in (math.pi / 180, 180 / math.pi) and output_quantity(m) != "beta":
                continue
            if abs(factor - 1) > 0.5 and abs(math.log(ratio / factor)) < 0.25 and abs(math.log(ratio)) > 1.5:
                problems.append(f"the measured {column} moves over {spread * to_file:.4g} {unit}, "
                                f"{ratio:.3g} times the model's {sim_spread * to_file:.4g} {unit}: likely {text}")
                break
    return problems


def saturation_note(measurement: Measurement, params: Params, simulated) -> dict | None:
    """Where the baseline could not follow the record (it went to a physical limit), or None."""
    m = measurement
    if m.experiment == "isometric":  # a clamped muscle has no limit to run into
        return None
    if m.experiment == "isotonic":
        where = isotonic.saturation(m.inputs["pressure"], m.inputs["force"], params)
        at_limit = where != 0
        what = ("no length of the baseline carries the load there: it is pulled to its braid limit (L = b)"
                if (where > 0).any() else "the baseline stays at its shortest length")
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

# --- The fitting problem -----------------------------------------------------------------------------

@dataclass
class _Problem:
    """The record as the fits see it: (smoothed, blocked) inputs, the samples compared, the split, and
    whether a constant sensor offset is profiled out of every residual."""

    measurement: Measurement  #: with the inputs the fits use
    grid: np.ndarray  #: sample indices fits are evaluated on
    train: np.ndarray  #: bool over grid: in the training part
    n_train: int  #: samples (of the record) the training simulations run over
    fit_offset: bool = False
    noise_correlation: float = 0.0  #: the output noise's correlation between neighbouring grid samples

    @property
    def measured(self) -> np.ndarray:
        return self.measurement.output[self.grid]

    @property
    def extra_parameters(self) -> int:
        return 1 if self.fit_offset else 0

    def simulate(self, params: Params, train_only: bool = False):
        """Model output [SI] on the grid (the training grid only if train_only), or _FAILED."""
        try:
            if train_only:
                return simulate_output(self.measurement, params, self.grid[self.train], stop=self.n_train)
            return simulate_output(self.measurement, params, self.grid)
        except MkctlError:
            return _FAILED

    def offset(self, residual_train) -> float:
        """The constant sensor offset that the training residual calls for (0 unless fit_offset)."""
        return float(np.mean(residual_train)) if self.fit_offset else 0.0

    def train_residual(self, simulated_train) -> np.ndarray:
        r = self.measured[self.train] - simulated_train
        return r - self.offset(r)

    def score(self, simulated, k: int) -> tuple[Score, float]:
        """The score of a simulation over the whole grid (k effect parameters), and the offset used."""
        r = self.measured - simulated
        offset = self.offset(r[self.train])
        r = r - offset
        return (Score.from_residuals(r[self.train], r[~self.train], k + self.extra_parameters, self.noise_correlation),
                offset)


def _knee_stride(time) -> int:
    """Every how many samples the knee's fits compare: about :data:`FIT_POINTS` samples over the record, at most
    :data:`MAX_FIT_SPACING` apart (a 60 s record at 1 kHz: every 20th sample, 3000 in all)."""
    n = len(time)
    interval = float(np.median(np.diff(time))) if n > 1 else 0.0
    widest = max(1, int(MAX_FIT_SPACING / interval)) if interval > 0 else n
    return max(1, min(n // FIT_POINTS, widest))


def _problem(measurement: Measurement, fit_offset: bool, rule: Rule = RULE, noise: NoiseModel | None = None) -> _Problem:
    """The fitting problem: the grid compared, the time split of the rule, the noise's correlation on the grid."""
    n = measurement.samples
    stride = 1 if measurement.experiment in ("isotonic", "isometric") else _knee_stride(measurement.time)
    grid = np.arange(0, n, stride)
    if grid[-1] != n - 1:
        grid = np.append(grid, n - 1)
    t = measurement.time
    split = rule.split_time(t[0], t[-1])
    n_train = int(np.searchsorted(t, split, side="right"))
    train = grid < n_train
    if train.sum() < 5 or (~train).sum() < 3:
        raise MkctlError(f"{measurement.source}: too few samples to diagnose ({n}); need at least 20")
    correlation = noise.on_grid(stride) if noise is not None else 0.0
    return _Problem(measurement, grid, train, n_train, fit_offset, correlation)


@dataclass
class _Fit:
    """A model on the problem: its parameters, score and simulation (SI, on the grid)."""

    params: Params
    values: dict  #: fitted parameter values by name
    score: Score
    offset: float  #: the fitted sensor offset [SI] (0 unless fit_offset)
    simulated: np.ndarray  #: grid output [SI]

    @property
    def rss_train(self) -> float:
        return self.score.rss_train


def _evaluate(problem: _Problem, params: Params, values: dict):
    """Simulate params over the whole record on the grid and score it, or None if it fails."""
    simulated = problem.simulate(params)
    if simulated is _FAILED:
        return None
    score, offset = problem.score(simulated, len(values))
    return _Fit(params, dict(values), score, offset, simulated)


def _fit_one(problem: _Problem, base: Params, candidate: Candidate, rss_off: float, progress,
             hint: float | None = None) -> tuple[float, int]:
    """Best value of the candidate's parameter on the training part, 0 when off does as well.

    ``hint``: the value its signature's slope suggests (:func:`signatures`). The grid of one point per decade
    assumes a cost unimodal in log space; a threshold pressure's is not on the knee (a small P0 weakens the
    flexor at 100 kPa most, a large one the extensor: the hip first rises, then falls through the truth, in a
    valley narrower than a decade). When the hint does better than the grid's best, the search is repeated
    within a quarter decade of it.
    """
    evaluations = [0]

    def cost(value):
        evaluations[0] += 1
        simulated = problem.simulate(candidate.apply(base, value), train_only=True)
        if simulated is _FAILED:
            return math.inf
        r = problem.train_residual(simulated)
        return float(r @ r)

    bounds = candidate.bounds[problem.measurement.experiment]
    value, best = best_value(cost, bounds, rss_off, xatol=FIT_XATOL)
    if hint is not None and math.isfinite(hint) and bounds[0] < hint < bounds[1] and not candidate.switch \
            and abs(math.log10(hint) - math.log10(value if value > 0 else bounds[0])) > 0.25:
        near = (max(bounds[0], hint / 10 ** 0.25), min(bounds[1], hint * 10 ** 0.25))
        if cost(hint) < best:
            around, cost_around = best_value(cost, near, rss_off, points_per_decade=4.0, xatol=FIT_XATOL,
                                             early_stop=False)
            if around > 0 and cost_around < best:
                value = around
    if progress:
        progress(f"    {candidate.effect}: {diagnosis_report.parameter_text(candidate.parameter, value)} "
                 f"({evaluations[0]} simulations)")
    return value, evaluations[0]


def _joint_fit(problem: _Problem, base: Params, effects: list[str], start: dict, train_only: bool,
               rough: bool = False):
    """Refit the parameters of ``effects`` jointly by least squares in log space.

    ``rough``: looser tolerances and fewer evaluations, for ranking candidates.
    Returns (values, standard errors (dict), the least_squares result, the fitted Params)."""
    experiment = problem.measurement.experiment
    cands = [CANDIDATES[e] for e in effects]
    lows = np.log10([c.bounds[experiment][0] for c in cands])
    highs = np.log10([c.bounds[experiment][1] for c in cands])
    x0 = np.clip(np.log10([max(start[c.parameter], 1e-300) for c in cands]), lows + 1e-9, highs - 1e-9)
    size = int(problem.train.sum()) if train_only else problem.grid.size

    def params_at(x):
        params = base
        for c, value in zip(cands, x):
            params = c.apply(params, 10.0 ** value)
        return params

    def residual(x):
        simulated = problem.simulate(params_at(x), train_only=train_only)
        if simulated is _FAILED:
            return np.full(size, 1.0)  # 1 m everywhere: far worse than any fit
        if train_only:
            return problem.train_residual(simulated)
        r = problem.measured - simulated
        return r - problem.offset(r)

    tolerance = 1e-4 if rough else 1e-6
    result = least_squares(residual, x0, bounds=(lows, highs), x_scale=1.0, diff_step=1e-4, xtol=tolerance,
                           ftol=tolerance * 1e-2, max_nfev=(6 if rough else 25) * (len(cands) + 1))
    values = {c.parameter: float(10.0 ** v) for c, v in zip(cands, result.x)}
    n, k = size, len(cands) + problem.extra_parameters
    rss = float(result.fun @ result.fun)
    errors = {}
    if n > k:
        rho = _lag_one_correlation(result.fun)
        widen = (1 + rho) / (1 - rho) if rho > 0 else 1.0
        cov = widen * rss / (n - k) * np.linalg.pinv(result.jac.T @ result.jac)
        for i, c in enumerate(cands):
            errors[c.parameter] = float(values[c.parameter] * _LN10 * math.sqrt(max(cov[i, i], 0.0)))
    return values, errors, result, params_at(result.x)


def _lag_one_correlation(residual) -> float:
    r = np.asarray(residual, dtype=float) - np.mean(residual)
    denominator = float(r @ r)
    if r.size < 3 or denominator == 0:
        return 0.0
    return float(min(0.95, (r[1:] @ r[:-1]) / denominator))


# --- Signatures: the force the model lacks, against what each effect acts through ------------------

# The equation error (the force the model lacks at the measured states) lives in
# :mod:`mkctl.analysis.equation_error`, shared with the discovery; its names stay importable from here.
_knee_force, _model_pressures, _lagged = knee_force_at, model_pressures, lagged


#: Reference value of each candidate's parameter for its unit force term (elasticity: the model's C1), from the
#: effects' definitions.
_REFERENCE = LiveMapping(lambda: {e.fitted: e.reference for e in effects.all_effects()
                                  if e.fitted is not None and e.reference is not None})


def signatures(measurement: Measurement, params: Params, names: list[str]) -> dict:
    """Each candidate's signature in the force the model lacks (see :func:`missing_force`).

    For each candidate: its own force term at the measured states per reference value of its parameter
    (damping: per N s/m, friction: per N, lag: per s (first order, P = P_cmd - tau dP_cmd/dt, with the
    commands smoothed like the acceleration),
    elasticity: model 2 minus model 1 at the model's C1), the correlation of the missing force with that
    term, and the parameter the slope suggests (``estimate``: an equation-error value, for comparison
    only). ``x`` and ``missing`` are arrays for the pictures.
    """
    m = measurement
    missing, states = missing_force(m, params)
    isotonic = m.experiment == "isotonic"
    out = {}
    if m.experiment == "isometric":  # the candidate's change of the tension at the clamped points
        for name in names:
            cand = CANDIDATES[name]
            ref = params.C1 if name == "elasticity" else _REFERENCE.get(cand.parameter, 1.0)
            args = (states["L"], states["P"], states["branch"])
            term = isometric_tension(*args, cand.apply(params, ref)) - isometric_tension(*args, params)
            x = (-states["branch"] if name == "coulomb_friction"
                 else isometric_tension(*args, params) if name == "slack" else term)  # slack: where it acts, < 0
            out[name] = {"against": cand.regressor, **_fit_line(missing, term, ref), "x": x, "missing": missing}
        return out
    speed = (states["Ldot"] if isotonic else states["V"]) * 1e3
    for name in names:
        cand = CANDIDATES[name]
        ref = params.C1 if name == "elasticity" else _REFERENCE.get(cand.parameter, 1.0)
        if name in ("pressure_lag", "dead_time", "asymmetric_lag"):  # first order: P = P_cmd - T dP_cmd/dt
            rate_e, rate_f = states["Pe_rate"], states["Pf_rate"]
            if name == "asymmetric_lag":  # tau_exhaust acts only while the pressure falls
                rate_e, rate_f = np.minimum(rate_e, 0.0), np.minimum(rate_f, 0.0)
            term = _knee_force(states, params, states["Pe"] - ref * rate_e, states["Pf"] - ref * rate_f) \
                - _knee_force(states, params)
            x = rate_e / 1e3
        else:
            with_effect = cand.apply(params, ref)
            if isotonic:
                term = (actuator.tension(states["L"], states["P"], states["Ldot"], with_effect)
                        - actuator.tension(states["L"], states["P"], states["Ldot"], params))
            else:
                term = _knee_force(states, with_effect) - _knee_force(states, params)
            if name == "coulomb_friction":  # friction acts through the direction of motion
                x = np.tanh(speed / (params.vs * 1e3))
            elif name == "slack" and not isotonic:  # the smaller tension: slack acts where it would be < 0
                forces = knee.knee_force(knee.geometry_at_X(states["X"], params), states["V"], states["Pe"],
                                         states["Pf"], params)
                x = np.minimum(forces.fe, forces.ff)
            elif name == "pressure_threshold":  # its picture's axis: the gauge pressure (the extensor's on the knee)
                x = (states["P"] if isotonic else states["Pe"]) / 1e3
            elif name == "pressure_friction":  # friction as strong as the pressure, through the direction of motion
                x = (states["P"] if isotonic else states["Pe"]) / 1e3 * np.tanh(speed / (params.vs * 1e3))
            else:
                x = term if name in ("elasticity", "slack") else speed
        out[name] = {"against": cand.regressor, **_fit_line(missing, term, ref), "x": x, "missing": missing}
    return out


def _fit_line(missing, term, ref) -> dict:
    """Correlation of the missing force with a candidate's term, and the parameter its slope suggests."""
    term = np.asarray(term, dtype=float)
    if np.ptp(term) == 0 or np.ptp(missing) == 0:
        return {"correlation": 0.0, "estimate": None}
    r = float(np.corrcoef(missing, term)[0, 1])
    slope = float(np.polyfit(term, missing, 1)[0])
    return {"correlation": r, "estimate": slope * ref}


# --- The result -------------------------------------------------------------------------------------

#: Verdicts of a diagnosis.
VERDICTS = ("diagnosed", "nothing missing", "undecided", "incomplete", "not diagnosed")


@dataclass(repr=False)
class DiagnosisResult(Result):
    """What :func:`diagnose` found, in python-control's manner: named attributes, arrays for the pictures.

    ``to_dict()`` gives the JSON of model-spec section 6 (plus context), ``to_dataframe()`` one row per
    candidate per round. RMSE are in the units of the file's output column, parameters SI.
    """

    file: str
    experiment: str
    baseline: str
    baseline_effects: list
    output: str  #: the output column's name (``x_mm``)
    output_unit: str
    samples: int
    verdict: str  #: one of :data:`VERDICTS`
    missing: list  #: effects added, in order
    params: dict  #: their fitted values (final joint fit on the whole record), SI
    uncertainty: dict  #: standard error of each fitted parameter, SI
    rmse_before: float
    rmse_after: float
    fit_percent_before: float
    fit_percent_after: float
    steps: list = field(default_factory=list)  #: one dict per accepted step (see docs/diagnosis.md)
    stopped: dict | None = None  #: the last round, that added nothing: reason, candidates, ties
    undecided: list = field(default_factory=list)  #: [{"effects": [...], "experiment": ...}]
    problems: list = field(default_factory=list)  #: why the record was not diagnosed (sanity checks)
    notes: list = field(default_factory=list)  #: what was done to the record before fitting, in words
    input_noise: dict = field(default_factory=dict)  #: input -> {"sigma", "unit", "smoothed"}
    output_noise: float | None = None  #: estimated noise of the measured output, file units
    output_noise_correlation: float = 0.0  #: its lag-one correlation between samples (0: white)
    adequacy: dict | None = None  #: the final model's residual against the noise (:func:`verdict_of`)
    saturation: dict | None = None  #: where the baseline could not follow (see :func:`saturation_note`)
    offset: float | None = None  #: fitted constant sensor offset, file units (``fit_offset`` only)
    pressure_lag: dict | None = None  #: the lag judged on measured pressures (:func:`lag_from_pressures`)
    discovery: dict | None = None  #: spec 6b, when incomplete (:func:`mkctl.analysis.discovery.discover`)
    #: on a tie, each explanation as a whole model: effects, params, uncertainty, rmse, adequate
    #: (see docs/diagnosis.md); the top level then holds only what they share
    alternatives: list = field(default_factory=list)
    rule: dict = field(default_factory=dict)
    pictures: dict = field(default_factory=dict)
    # arrays for the pictures (SI), not part of the JSON
    params_after: Params | None = field(default=None, repr=False)  #: the final model's parameters
    simulated_before: np.ndarray | None = field(default=None, repr=False)
    simulated_after: np.ndarray | None = field(default=None, repr=False)
    error_steps: list = field(default_factory=list, repr=False)  #: RMSE after each step, file units
    signatures: dict = field(default_factory=dict, repr=False)  #: first round's signatures
    signature_order: list = field(default_factory=list, repr=False)
    #: each alternative's simulation over every sample [SI]
    alternative_simulated: list = field(default_factory=list, repr=False)

    @property
    def units(self) -> dict:
        return {k: UNITS[k] for k in self.params}

    def summary_lines(self) -> list[str]:
        """The repr: file, verdict, what is missing with its values, the error before and after."""
        lines = [f"{Path(self.file).name}: {self.experiment}, verdict {self.verdict!r}, missing {self.missing}"]
        for name, value in self.params.items():
            error = self.uncertainty.get(name)
            lines.append(f"{name} = {value:.4g}" + (f" +- {error:.2g}" if error is not None else "") + f" {UNITS[name]}")
        lines.append(f"RMSE {self.rmse_before:.4g} -> {self.rmse_after:.4g} {self.output_unit}")
        lines += [f"cannot tell {' from '.join(u['effects'])}" for u in self.undecided]
        for a in self.alternatives:
            values = ", ".join(f"{k} = {v:.4g}" for k, v in a["params"].items())
            lines.append(f"alternative: {', '.join(a['effects'])}: {values}")
        lines += [f"problem: {text}" for text in self.problems]
        return lines

    def to_dict(self) -> dict:
        """The report as plain JSON values (model-spec section 6 keys first; NaN and infinity become None)."""
        data = {
            "experiment": self.experiment, "baseline": self.baseline, "output": self.output,
            "rmse_before": self.rmse_before, "rmse_after": self.rmse_after, "missing": list(self.missing),
            "params": dict(self.params), "steps": self.steps,
            "verdict": self.verdict, "undecided": self.undecided, "problems": self.problems,
            "uncertainty": dict(self.uncertainty), "units": self.units,
            "fit_percent_before": self.fit_percent_before, "fit_percent_after": self.fit_percent_after,
            "stopped": self.stopped, "notes": self.notes, "input_noise": self.input_noise,
            "output_noise": self.output_noise, "output_noise_correlation": self.output_noise_correlation,
            "adequacy": self.adequacy, "saturation": self.saturation, "offset": self.offset,
            "pressure_lag": self.pressure_lag,
            "discovery": self.discovery, "alternatives": self.alternatives,
            "file": self.file, "baseline_effects": list(self.baseline_effects), "output_unit": self.output_unit,
            "samples": self.samples, "rule": self.rule, "pictures": self.pictures,
        }
        return plain(data)

    def table(self) -> list[dict]:
        """One row per candidate per round (``to_dataframe()``): round, effect, parameter, value, delta_bic,
        rmse_holdout, passes_bic, passes_holdout, physical, at_bound, switched_off, added."""
        rounds = self.steps + ([self.stopped] if self.stopped and self.stopped.get("candidates") else [])
        rows = []
        for number, step in enumerate(rounds, 1):
            added = [step.get("added"), *step.get("added_with", [])]
            for row in step["candidates"]:
                (name, value), = row["params"].items()
                rows.append({"round": number, "effect": row["effect"], "parameter": name, "value": value,
                             "delta_bic": row.get("delta_bic"), "rmse_holdout": row.get("rmse_holdout"),
                             "passes_bic": row.get("passes_bic"), "passes_holdout": row.get("passes_holdout"),
                             "physical": row.get("physical"), "at_bound": row.get("at_bound"),
                             "switched_off": row.get("switched_off"), "added": row["effect"] in added})
        return rows

    def __getitem__(self, key):
        """Dict-style access to the JSON keys (``result["missing"]``), for scripts written against the
        dict this function used to return."""
        return self.to_dict()[key]


def public(result: DiagnosisResult) -> dict:
    """The result as plain JSON values: ``result.to_dict()``."""
    return result.to_dict()


summary = diagnosis_report.summary
save_pictures = diagnosis_report.save_pictures

# --- The loop --------------------------------------------------------------------------------------

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


def _blocked_problem(problem: _Problem, baseline: Params, full_before, out_sigma: float, notes: list, say) -> _Problem:
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


def _fit_candidate(problem: _Problem, baseline: Params, current: _Fit, added: list, individual: dict, name: str,
                   say, rule: Rule = RULE, hint: float | None = None):
    """Fit one candidate against the current model; returns (fit or None, value, simulations, values).

    ``hint``: the value its signature suggests (see :func:`_fit_one`). A candidate that refines an effect
    already added (asymmetric_lag: the lag's exhausting time constant) is always refitted jointly with it: with
    tau held at the compromise the symmetric lag found, tau_exhaust alone gains little.
    """
    cand = CANDIDATES[name]
    value, evaluations = _fit_one(problem, current.params, cand, current.rss_train, say, hint)
    if not added:
        individual[name] = value
    values = {**current.values, cand.parameter: value}
    if math.isnan(value):
        return None, value, evaluations, values
    fit = current if value == 0.0 else _evaluate(problem, cand.apply(current.params, value), values)
    refines = bool(set(effects.get(name).requires) & set(added))
    promising = fit is not None and fit is not current and (rule.promising(fit.score.bic - current.score.bic)
                                                            or refines)
    if added and promising:
        # effects interact (damping and a lag both calm the leg): refit jointly with the effects already
        # added, from this round's value and from the values each took alone in round 1
        starts = [values] if value > 0 else []
        alone = {CANDIDATES[e].parameter: individual.get(e, 0.0) for e in [*added, name]}
        if all(v > 0 for v in alone.values()) and alone != values:
            starts.append(alone)
        for start in starts:
            joint_values, _, result, params = _joint_fit(problem, baseline, [*added, name], start, train_only=True,
                                                         rough=True)
            evaluations += result.nfev + 1
            joint = _evaluate(problem, params, joint_values)
            if joint is not None and joint.rss_train < fit.rss_train:
                fit, values = joint, joint_values
    if fit is not None and fit is not current:
        value = values[cand.parameter]
    return fit, value, evaluations + 1, values


def _row(name: str, fit, value: float, evaluations: int, current: _Fit, problem: _Problem, sig, to_file: float,
         rule: Rule = RULE):
    """A candidate's line in the report, and its outcome for the rule (its flags are the rule's own judgement)."""
    cand = CANDIDATES[name]
    bounds = cand.bounds[problem.measurement.experiment]
    row = {"effect": name, "params": {cand.parameter: value}, "simulations": evaluations,
           "signature": None if sig is None else {k: sig[k] for k in ("against", "correlation", "estimate")}}
    if fit is None:
        row.update({"rmse": None, "bic": None, "delta_bic": None, "failed": True, "physical": False})
        return row, Outcome(name, None)
    switched_off = fit is current
    score = fit.score if not switched_off else dataclasses.replace(current.score, k=current.score.k + 1)
    pinned = at_bound(value, bounds) and not cand.switch
    outcome = Outcome(name, score, switched_off=switched_off, at_bound=pinned,
                      signature=None if sig is None else sig["correlation"])
    judgement = judge(current.score, outcome, rule)
    row.update({
        "params_with_added": dict(fit.values) if not switched_off else dict(current.values),
        "rmse": rmse(problem.measured, fit.simulated + fit.offset) * to_file,
        "rmse_train": score.rmse_train * to_file,
        "rmse_holdout": score.rmse_holdout * to_file,
        "bic": score.bic,
        "delta_bic": judgement.delta_bic,
        "explained_fraction": 1.0 - score.rss_train / current.rss_train if current.rss_train > 0 else 0.0,
        "switched_off": switched_off,
        "at_bound": pinned,
        "physical": judgement.physical,
        "passes_bic": judgement.passes_bic,
        "passes_holdout": judgement.passes_holdout,
        "signature_agrees": judgement.signature_agrees,
    })
    return row, outcome


def _motion_record(m: Measurement, baseline: Params, rule: Rule, notes: list, say):
    """The lag judged on measured pressures (or None), and the record and baseline the motion is fitted with.

    With measured pressures that follow the commands through the lag (or without a lag) to within a few
    times their noise, the motion is driven by the commands through the lag found, noise-free; pressures
    that depart from that (a supply that sags) drive the motion themselves, smoothed.
    """
    lag = lag_from_pressures(m, baseline, rule)
    if lag is None:
        return None, m, baseline, False
    tau = lag["tau"] if lag["accepted"] else 0.0
    path = lag["path"]
    noise = max(input_noise(m.inputs["pe"]), input_noise(m.inputs["pf"])) / 1e3  # kPa
    model_rmse = lag["candidate"]["rmse_train_kPa"]
    found = (f"found, tau = {tau:.4g} s" if lag["accepted"] else "not found: " + lag["reason"])
    others = [e for e in path["effects"] if e != "pressure_lag"]
    if others:
        found += "; " + ", ".join(f"{e.replace('_', ' ')} found, {PRESSURE_PATH[e]} = "
                                  f"{path['values'][PRESSURE_PATH[e]]:.4g} s" for e in others)
    if path.get("motion"):
        found += "; they show a dead time, placed by them only to within a sample: it is fitted on the motion"
    if model_rmse > 5.0 * max(noise, 1e-6):
        notes.append(f"the file holds measured bladder pressures: the pressure lag is judged on them directly "
                     f"({found}); they depart from the lagged commands by {model_rmse:.3g} kPa RMS (noise "
                     f"{noise:.2g} kPa), so they drive the motion themselves")
        say(notes[-1])
        return lag, m, baseline, True
    inputs = {k: v for k, v in m.inputs.items() if k not in ("pe", "pf")}
    notes.append(f"the file holds measured bladder pressures: the pressure lag is judged on them directly ({found}); "
                 f"they follow the commands through it to within their noise ({model_rmse:.3g} kPa RMS), so the "
                 f"motion is driven by the commands through that lag, free of the pressure sensors' noise")
    say(notes[-1])
    return lag, dataclasses.replace(m, inputs=inputs), baseline.replace(**path["values"]) if path["values"] else \
        baseline, True


def diagnose(measurement: Measurement, progress: Callable[[str], None] | None = None, fit_offset: bool = False,
             rule: Rule = RULE) -> DiagnosisResult:
    """Find the effects the baseline misses, fit them, and report (see the module docstring).

    Parameters
    ----------
    measurement : Measurement
        The record (:func:`mkctl.io.measurements.read_measurement`).
    progress : callable, optional
        Receives one line per stage (for a long run on the command line).
    fit_offset : bool
        Fit a constant sensor offset of the measured output (profiled out of every residual).
    rule : Rule
        The acceptance rule's thresholds (:data:`mkctl.analysis.diagnosis_rule.RULE`).

    Returns
    -------
    DiagnosisResult
        ``verdict`` is ``"diagnosed"``, ``"nothing missing"``, ``"undecided"`` (the record cannot tell the
        effects in ``undecided`` apart), ``"incomplete"`` (the final model, with what was added or with nothing
        added, leaves many times the output noise: something outside the candidates is missing, or the record
        cannot show which) or ``"not diagnosed"`` (``problems`` says why).
    """
    say = progress or (lambda text: None)
    m = measurement
    record = _prepare(m, rule, fit_offset, say)
    if record.problems:
        return _not_diagnosed(record, say)
    problem = _problem(record.prepared, fit_offset, rule, record.noise)
    problem = _with_input_noise(problem, record, say)
    problem = _blocked_problem(problem, record.start, record.full_before, record.noise.sigma, record.notes, say)
    say(f"{Path(m.source).name}: {m.experiment}, {m.samples} samples, baseline {m.baseline} "
        f"(effects: {', '.join(m.params.effects) or 'none'}); fitting on {problem.grid.size} samples")
    state, offset_before = _select(problem, record, rule, say)
    final = _final_fit(problem, record, state, offset_before, say)
    return _result(record, state, final, offset_before, rule, say)


@dataclass
class _Record:
    """The record as prepared for the search: the inputs the model is driven by, the baseline's simulation,
    the output noise, and what the report says about them."""

    measurement: Measurement  #: as read
    prepared: Measurement  #: inputs smoothed (and the lag's pressures replaced by the commands through it)
    start: Params  #: the baseline, with a lag found on measured pressures
    lag: dict | None  #: the lag judged on measured pressures (:func:`lag_from_pressures`)
    exclude: set  #: candidates judged elsewhere (the lag, on measured pressures)
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


def _prepare(m: Measurement, rule: Rule, fit_offset: bool, say) -> _Record:
    """Step 0 of the module docstring: the lag on measured pressures, the noisy inputs smoothed, the output
    noise, the baseline simulated, the saturation and the sanity checks."""
    notes: list = []
    lag, motion, start, lag_judged = _motion_record(m, m.params, rule, notes, say)
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
                  rule={**rule.as_dict(), "fit_offset": fit_offset}, pressure_lag=lag)
    problems = sanity_problems(m, full_before, m.params, fit_offset)
    judged = set(PRESSURE_PATH) - ({lag["path"]["motion"]} if lag_judged and lag["path"].get("motion") else set())
    # a quasi-static record passes its inputs' noise straight to the output, sample by sample: one
    # realisation of it is a poor measure of what it gives a candidate, so the null test takes the
    # worst of several
    seeds = range(2, QUASI_STATIC_NULL_REALISATIONS + 1) if m.experiment in QUASI_STATIC else ()
    more = [renoised_inputs(motion, prepared, noise_info, seed) for seed in seeds]
    return _Record(m, prepared, start, lag, judged if lag_judged else set(), noise, full_before, notes,
                   common, problems, fit_offset, renoised_inputs(motion, prepared, noise_info),
                   [r for r in more if r is not None])


#: Records whose model follows its measured inputs sample by sample (no dynamics to filter their
#: noise).
QUASI_STATIC = ("isotonic", "isometric")
#: How many realisations of the noise the null test of such a record draws (criterion 5: the worst
#: counts).
QUASI_STATIC_NULL_REALISATIONS = 4


def input_noise_through_model(record: "_Record", params: Params) -> tuple[float, float]:
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
    return float(np.sqrt(np.mean(difference ** 2))), _lag_one_correlation(difference)


def _with_input_noise(problem: "_Problem", record: "_Record", say) -> "_Problem":
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


def _output_noise_model(m: Measurement, baseline) -> NoiseModel:
    """The output noise (:func:`noise_model`) of a time series; white for a blocked-force record (points, not a
    time series). Where the signal changes too fast for the local cubic (pressure held on levels a few samples
    long), the estimate is made again on the baseline's residual, from which the model took that signal out."""
    if not m.has_time or m.experiment == "isometric":
        return NoiseModel(output_noise(m.output))
    noise = noise_model(m.output)
    if noise.unresolved:
        again = noise_model(m.output - baseline)
        if not again.unresolved and again.sigma > noise.sigma:
            return again
    return noise


def _not_diagnosed(record: _Record, say) -> DiagnosisResult:
    """The result for a record whose output cannot be this model's (a unit or zero mistake)."""
    for text in record.problems:
        say("not diagnosed: " + text)
    y, sim = record.output, record.full_before * record.to_file
    before, fit_before = rmse(y, sim), fit_percent(y, sim)
    return DiagnosisResult(**record.common, verdict="not diagnosed", missing=[], params={}, uncertainty={},
                           rmse_before=before, rmse_after=before, fit_percent_before=fit_before,
                           fit_percent_after=fit_before, problems=record.problems, notes=record.notes,
                           simulated_before=record.full_before, simulated_after=record.full_before,
                           error_steps=[before], params_after=record.measurement.params)


def _select(problem: _Problem, record: _Record, rule: Rule, say):
    """Steps 1-4: forward selection from the baseline, and the wider search when what it added leaves many
    times the noise. Returns the search (added effects, steps, ties) and the baseline's fitted offset."""
    m, start = record.measurement, record.start
    first = _evaluate(problem, m.params, {})
    if first is None:
        raise MkctlError(f"{m.source}: the model cannot simulate this record")
    current = first if start is m.params else _evaluate(problem, start, {})
    pending_all = [e for e in candidates_for(m, start) if e not in record.exclude]
    state = _Search(problem, start, pending_all, rule, record.to_file, say, record.noise)
    state.renoised = record.renoised
    state.renoised_more = record.renoised_more
    state.forward(current)
    if record.lag is not None:  # what the measured pressures could not tell apart
        state.undecided = [*record.lag["path"]["undecided"], *state.undecided]
    if (state.added or state.undecided) and len(pending_all) >= 2:
        # the noise the model should leave includes the measured inputs' noise through it (a
        # quasi-static record passes it on sample by sample): without it, 4 kPa of pressure noise
        # looked like 10 times the output noise
        through_model, _ = input_noise_through_model(record, state.current.params)
        sigma = math.hypot(record.noise.sigma, through_model)
        inadequate = _inadequacy(problem, state.current, sigma)
        if inadequate > WIDER_SEARCH_FACTOR:
            say(f"the model leaves {inadequate:.3g} times the noise (output, and inputs' through "
                f"the model): trying the candidates in pairs and threes")
            if state.wider():
                state.forward(state.current)
    return state, first.offset


@dataclass
class _Final:
    """The final model: the added effects (with a lag judged on pressures first), their values and standard
    errors from the joint fit on the whole record, its offset and its simulation over every sample [SI]."""

    added: list
    values: dict
    uncertainty: dict
    offset: float
    simulated: np.ndarray
    params: Params


def _final_fit(problem: _Problem, record: _Record, state: "_Search", offset_before: float, say) -> _Final:
    """Step 5: the added parameters fitted jointly on the whole record, with their standard errors (widened by
    the spread a lag found on the pressures brings)."""
    m, start, lag = record.measurement, record.start, record.lag
    added = list(state.added)
    uncertainty: dict = {}
    final_params, final_values, offset = start, {}, offset_before
    if added:
        say("final fit of " + ", ".join(added) + " on the whole record")
        final_values, uncertainty, _, final_params = _joint_fit(problem, start, added, state.current.values,
                                                                train_only=False)
        offset = problem.offset(problem.measured - problem.simulate(final_params)) if problem.fit_offset else 0.0
    simulated = (simulate_output(record.prepared, final_params) + offset if (added or start is not m.params)
                 else record.full_before + offset_before)
    if added and m.experiment in QUASI_STATIC and record.renoised is not None:
        # the measured inputs' noise moves the values too (a friction follows the wiggles the
        # smoothed pressure leaves): refitted with the model driven by other realisations of the
        # inputs' noise, the values' RMS shift is added (in quadrature) to their standard errors
        shifts = []
        for renoised in [record.renoised, *record.renoised_more]:
            moved = dataclasses.replace(problem, measurement=dataclasses.replace(
                problem.measurement, inputs=renoised.inputs))
            values, _, _, _ = _joint_fit(moved, start, added, final_values, train_only=False,
                                         rough=True)
            shifts.append(values)
        for name in final_values:
            rms = math.sqrt(sum((v[name] - final_values[name]) ** 2 for v in shifts) / len(shifts))
            uncertainty[name] = math.hypot(uncertainty.get(name, 0.0), rms)
    if lag is not None and lag["accepted"] and added and lag["uncertainty"]:
        # tau was fixed from the pressures: its own uncertainty moves the motion's parameters too
        # (first order: refit at tau -+ its standard error, add the spread in quadrature)
        spread = []
        for sign in (-1.0, 1.0):
            shifted = start.replace(tau=max(lag["tau"] + sign * lag["uncertainty"], 1e-6))
            values, _, _, _ = _joint_fit(problem, shifted, added, final_values, train_only=False, rough=True)
            spread.append(values)
        for name in final_values:
            moved = 0.5 * abs(spread[1][name] - spread[0][name])
            uncertainty[name] = math.hypot(uncertainty.get(name, 0.0), moved)
    if lag is not None and lag["path"]["effects"]:
        path = lag["path"]
        added = [*path["effects"], *added]
        final_values = {**path["values"], **final_values}
        uncertainty = {**path["uncertainty"], **uncertainty}
    return _Final(added, final_values, uncertainty, offset, simulated, final_params)


def verdict_of(added: list, undecided: list, fit: Adequacy, noise_text: str,
               tied: tuple[list, Adequacy] | None = None) -> tuple[str, str | None]:
    """The verdict, and the note that explains an ``"incomplete"`` one (else None): the one place where a
    diagnosis is found incomplete (and handed to the discovery of model-spec section 6b).

    What was added (or the baseline) must leave only what the noise explains
    (:func:`mkctl.analysis.diagnosis_rule.adequacy`, over the whole record and window by window): then
    ``"diagnosed"`` (or ``"nothing missing"``), else ``"incomplete"``. A tie is judged on the best of the tied
    explanations instead of on the model with neither: ``tied`` is (the effects of the best, the adequacy of the
    model refitted with them) (:func:`_tied_rivals`; None when not judged). A tie stays ``"undecided"`` unless
    even the best of them leaves clearly more than the noise: then neither explains the record, and it is
    ``"incomplete"`` (the tie is still reported).
    """
    if undecided and (tied is None or tied[1].adequate):
        return "undecided", None
    if undecided:
        rivals, best = tied
        pairs = "; ".join(" from ".join(e.replace("_", " ") for e in u["effects"]) for u in undecided)
        return "incomplete", (f"this record cannot tell {pairs}, and neither explains it: with the best of them "
                              f"({', '.join(rivals)}) {best.text()} ({noise_text}): something outside the "
                              f"candidates is missing")
    if fit.adequate:
        return ("diagnosed" if added else "nothing missing"), None
    left = f"{fit.text()} ({noise_text})"
    if added:
        return "incomplete", (f"with {', '.join(added)} {left}: something outside the candidates is missing, or "
                              f"effects this record cannot separate; do not trust the values as physical")
    return "incomplete", (f"no candidate passes the rule, yet {left}: something is missing that the candidates do "
                          f"not supply, or this record cannot show which (see why the last round stopped); if this "
                          f"is your own muscle, its static parameters (b, n, C1, C2) may not be the ones assumed "
                          f"here: calibrate it (mkctl calibrate) and diagnose with --params MUSCLE.json")


def _final_noise(record: _Record, simulated) -> NoiseModel:
    """The noise a final model (its simulation over every sample [SI]) should leave: the record's estimate, or,
    where the signal changed too fast to resolve it (:attr:`NoiseModel.unresolved`), the estimate on the model's
    residual when that is resolved and larger (the model took the signal out; a residual that still changes with
    the signal stays unresolved)."""
    if not record.noise.unresolved:
        return record.noise
    again = noise_model(record.measurement.output - simulated)
    return again if not again.unresolved and again.sigma > record.noise.sigma else record.noise


def _adequacy_at(record: _Record, params: Params, simulated, offset: float,
                 rule: Rule) -> tuple[Adequacy, NoiseModel, float]:
    """The adequacy test of a final model (its simulation over every sample [SI], offset included): (adequacy,
    the output noise it should leave, the measured inputs' noise through it [SI])."""
    floor = record.input_floor(params, simulated - offset)
    noise = _final_noise(record, simulated)
    sigma = math.hypot(noise.sigma, floor)
    return adequacy(record.measurement.output - simulated, sigma, noise.correlation, rule), noise, floor


def _tied_rivals(record: _Record, state: "_Search", rule: Rule, say) -> tuple[list, Adequacy] | None:
    """The best of the tied explanations and its adequacy: the final model refitted on the whole record with each
    (one effect from each tie in ``state.undecided``), the best being one that passes the adequacy test, else the
    one that leaves least. None when none could be fitted (the tie is then left undecided)."""
    alternatives = _alternative_models(record, state, rule, say)
    return _best_alternative(alternatives)


def _best_alternative(alternatives: list) -> tuple[list, Adequacy] | None:
    """(the rivals, the adequacy) of the alternative that passes the adequacy test, else leaves
    least; None."""
    best = None
    for alternative in alternatives:
        fit = alternative.adequacy
        if best is None or (fit.adequate, -fit.ratio) > (best[1].adequate, -best[1].ratio):
            best = (alternative.rivals, fit)
    return best


@dataclass
class _Alternative:
    """One explanation of a tie as a whole model: the final model refitted on the whole record with
    one effect from each tie (``rivals``): its effects, values, standard errors, simulation over
    every sample [SI] (offset included) and adequacy."""

    rivals: list
    effects: list
    values: dict
    uncertainty: dict
    simulated: np.ndarray
    params: Params
    adequacy: Adequacy
    offset: float = 0.0

    def report(self, record: _Record) -> dict:
        """The alternative as the report's JSON gives it (RMSE over every sample, file units)."""
        y = record.output
        return {"effects": list(self.effects), "with": list(self.rivals),
                "params": dict(self.values),
                "uncertainty": dict(self.uncertainty),
                "rmse": rmse(y, self.simulated * record.to_file),
                "fit_percent": fit_percent(y, self.simulated * record.to_file),
                "adequate": self.adequacy.adequate, "noise_ratio": self.adequacy.ratio,
                "text": self.adequacy.text()}


def _alternative_models(record: _Record, state: "_Search", rule: Rule, say) -> list:
    """Each explanation of the ties in ``state.undecided`` as a whole model (:class:`_Alternative`):
    the effects added (and a pressure path found on measured pressures) with one effect from each
    tie, all refitted jointly on the whole record, with the standard errors of that fit."""
    problem, current = state.problem, state.current
    found = []
    path = (record.lag["path"] if record.lag is not None
            else {"effects": [], "values": {}, "uncertainty": {}})
    for combo in itertools.product(*[u["effects"] for u in state.undecided]):
        rivals = [e for e in dict.fromkeys(combo) if e not in state.added and e in CANDIDATES]
        if not rivals:
            continue
        start = dict(current.values)
        for name in rivals:
            parameter = CANDIDATES[name].parameter
            fit = state.fits.get(name)
            value = fit.values.get(parameter, 0.0) if fit is not None else 0.0
            if not value > 0:  # a tie judged elsewhere (the pressure path): fitted alone against the current model
                value, _ = _fit_one(problem, current.params, CANDIDATES[name], current.rss_train, None)
            start[parameter] = value
        if not all(start[CANDIDATES[e].parameter] > 0 for e in rivals):
            continue
        values, errors, _, params = _joint_fit(problem, record.start, [*state.added, *rivals],
                                               start, train_only=False)
        on_grid = problem.simulate(params)
        if on_grid is _FAILED:
            continue
        offset = problem.offset(problem.measured - on_grid)
        try:
            simulated = simulate_output(record.prepared, params) + offset
        except MkctlError:
            continue
        fit, _, _ = _adequacy_at(record, params, simulated, offset, rule)
        say(f"  the tie judged with {' and '.join(rivals)}: {fit.text()}")
        on_path = [e for e in path["effects"] if e not in state.added and e not in rivals]
        found.append(_Alternative(rivals, [*on_path, *state.added, *rivals],
                                  {**path["values"], **values}, {**path["uncertainty"], **errors},
                                  simulated, params, fit, offset))
    return found


def _shared_values(alternatives: list) -> tuple[list, dict, dict, list]:
    """What the top level of a tied report holds: the effects every alternative has, and each of
    their parameters on which the alternatives agree (every pair within twice their combined
    standard error), as their inverse-variance mean with a standard error that covers their spread.
    A shared parameter on which they disagree belongs to each alternative alone: it is left out and
    named (returned last)."""
    shared = [e for e in alternatives[0].effects if all(e in a.effects for a in alternatives[1:])]
    params, uncertainty, disputed = {}, {}, []
    for name in alternatives[0].values:
        if not all(name in a.values for a in alternatives):
            continue
        if not any(name in _effect_parameters(e) for e in shared):
            continue
        values = np.array([a.values[name] for a in alternatives])
        errors = np.array([a.uncertainty.get(name, math.inf) for a in alternatives])
        agree = all(abs(values[i] - values[j]) <= 2.0 * math.hypot(errors[i], errors[j])
                    for i in range(values.size) for j in range(i + 1, values.size))
        if not agree or not np.all(np.isfinite(errors)) or not np.all(errors > 0):
            disputed.append(name)
            continue
        weights = 1.0 / errors ** 2
        mean = float(np.sum(weights * values) / np.sum(weights))
        params[name] = mean
        uncertainty[name] = float(max(1.0 / math.sqrt(np.sum(weights)), 0.5 * np.ptp(values)))
    return shared, params, uncertainty, disputed


def _effect_parameters(name: str) -> tuple:
    """The parameters an effect brings (the registry's), its fitted one first."""
    fitted = CANDIDATES[name].parameter if name in CANDIDATES else None
    own = list(effects.get(name).parameter_names)
    return tuple(dict.fromkeys([p for p in (fitted,) if p] + own))


def _result(record: _Record, state: "_Search", final: _Final, offset_before: float, rule: Rule,
            say) -> DiagnosisResult:
    """The report: the error after each step over every sample, the adequacy of the final model, the verdict."""
    m, to_file, y = record.measurement, record.to_file, record.output
    steps_rmse = [rmse(y, (record.full_before + offset_before) * to_file)]
    for params, offset in state.step_params:
        steps_rmse.append(rmse(y, (simulate_output(record.prepared, params) + offset) * to_file))
    for step, value in zip(state.steps, steps_rmse[1:]):
        step["rmse"] = value
    before = record.full_before + offset_before
    fit, noise, floor = _adequacy_at(record, final.params, final.simulated, final.offset, rule)
    sigma = math.hypot(noise.sigma, floor)
    noise_text = f"estimated output noise {noise.sigma * to_file:.2g} {m.output_unit}" + (
        f", correlated {noise.correlation:.2f} between samples" if noise.correlation else "") + (
        f", and {floor * to_file:.2g} {m.output_unit} of the measured inputs' noise through the model" if floor else "")
    # a tie is judged on the best of the tied explanations, not on the model with neither (issue
    # 21); each explanation is reported as a whole model, and the top level holds only what they
    # share (issue 32)
    alternatives = _alternative_models(record, state, rule, say) if state.undecided else []
    tied = _best_alternative(alternatives) if alternatives and not fit.adequate else None
    undecided = [{**u, "explains": tied[1].adequate} if tied else dict(u) for u in state.undecided]
    verdict, note = verdict_of(final.added, undecided, fit, noise_text, tied)
    notes = list(record.notes)
    if note:
        notes.append(note)
        say(note)
    missing, values, uncertainty = final.added, final.values, final.uncertainty
    simulated, params_after = final.simulated, final.params
    without_tied = None
    if len(alternatives) >= 2:
        without_tied = {"adequate": fit.adequate, "ratio": fit.ratio, "limit": fit.limit,
                        "text": fit.text()}
        missing, values, uncertainty, disputed = _shared_values(alternatives)
        best = min(alternatives, key=lambda a: (not a.adequacy.adequate, a.adequacy.ratio))
        fit, simulated, params_after = best.adequacy, best.simulated, best.params
        per_alternative = "; ".join(
            ", ".join(f"{k} = {a.values[k]:.4g}" for k in disputed)
            + f" with {' and '.join(a.rivals)}" for a in alternatives)
        text = (f"the record holds {len(alternatives)} explanations that it cannot tell apart, "
                f"each reported as a whole model under 'alternatives'; the top level keeps only "
                f"what they share" + (f" ({', '.join(missing)})" if missing else " (nothing)")
                + (f", without {', '.join(disputed)}, whose value depends on the explanation: "
                   f"{per_alternative}" if disputed else "")
                + f"; its error after is the best explanation's ({' and '.join(best.rivals)})")
        notes.append(text)
        say(text)
    # spec 6b: what the baseline cannot explain is regressed on a library of physical terms (registered effects
    # it lacks show as their own terms, "matches" naming them)
    found = discover(record.prepared, record.start, progress=say, effects=discovery_effects()) \
        if verdict == "incomplete" else None
    worst = dict(fit.worst)
    if worst:
        worst.update({"from_s": float(m.time[worst.pop("start")]), "to_s": float(m.time[worst.pop("stop")])})
    order, sigs = state.signatures_first if state.signatures_first else ([], {})
    return DiagnosisResult(
        **record.common, discovery=found, verdict=verdict, missing=missing, params=values,
        uncertainty=uncertainty, alternatives=[a.report(record) for a in alternatives],
        alternative_simulated=[a.simulated for a in alternatives],
        rmse_before=rmse(y, before * to_file), rmse_after=rmse(y, simulated * to_file),
        fit_percent_before=fit_percent(y, before * to_file),
        fit_percent_after=fit_percent(y, simulated * to_file),
        steps=state.steps, stopped=state.stopped, undecided=undecided, notes=notes,
        offset=final.offset * to_file if record.fit_offset else None,
        adequacy={"adequate": fit.adequate, "ratio": fit.ratio, "limit": fit.limit, "worst_window": worst,
                  "noise": sigma * to_file, "input_noise_through_model": floor * to_file,
                  "text": fit.text(), **({"without_tied": without_tied} if without_tied else {})},
        simulated_before=before, simulated_after=simulated, error_steps=steps_rmse,
        params_after=params_after,
        signatures=sigs, signature_order=order)


#: When what was added leaves more than this many times the output noise, the candidates are tried in pairs and
#: threes.
WIDER_SEARCH_FACTOR = 3.0
# Whether the final model is "incomplete" is decided by :func:`verdict_of` with the rule's adequacy test.


def _inadequacy(problem: _Problem, fit: _Fit, out_sigma: float) -> float:
    """Training RMSE of a fit in units of the estimated output noise (0 when the noise is unknown)."""
    return fit.score.rmse_train / out_sigma if out_sigma > 0 else 0.0


class _Search:
    """Forward selection with the rule, and the wider search in pairs and threes; collects the report's steps."""

    def __init__(self, problem: _Problem, start: Params, pending: list, rule: Rule, to_file: float, say,
                 noise: "NoiseModel | None" = None):
        self.problem, self.start, self.pending_all, self.rule = problem, start, pending, rule
        self.to_file, self.say, self.noise = to_file, say, noise
        self.fits: dict = {}
        self.context: dict = {}
        self.renoised: Measurement | None = None  #: drives the null test's simulation (:func:`renoised_inputs`)
        #: other realisations of it (quasi-static records), each drawn too
        self.renoised_more: list = []
        self.added: list[str] = []
        self.individual: dict = {}
        self.steps: list[dict] = []
        self.step_params: list = []
        self.undecided: list[dict] = []
        self.stopped = None
        self.signatures_first = None
        self.current = None
        self.hints: dict = {}  #: each candidate's value its signature suggests, this round
        self.outcomes: dict = {}  #: this round's outcomes for the rule (null-tested ones included)

    def forward(self, current: _Fit) -> None:
        """Forward selection from ``current`` (:func:`mkctl.analysis.diagnosis_rule.forward_selection`): each
        accepted round goes to ``steps``, the round that ended it to ``stopped`` (and a tie to ``undecided``)."""
        self.current = current
        decision = forward_selection(current.score, self._remaining, self._fit_round, self._add, self.rule,
                                     null_test=self._null_test if self.noise is not None else None,
                                     break_tie=self._break_tie,
                                     with_requirements=self._with_requirements)
        self._stop(decision)

    def _remaining(self) -> list[str]:
        """The candidates not added yet whose required effects are on (asymmetric_lag: once pressure_lag is)."""
        on = set(self.start.effects) | set(self.added)
        return [e for e in self.pending_all if e not in self.added and set(effects.get(e).requires) <= on]

    def _fit_round(self, pending: list[str]) -> list[Outcome]:
        """Fit every pending candidate against the current model; keeps the report's rows and the fits."""
        problem, current = self.problem, self.current
        self.say(f"round {len(self.steps) + 1}: fitting {', '.join(pending)}")
        sigs = self._signatures(pending)
        self.hints = {name: sig.get("estimate") for name, sig in sigs.items()}
        rows, outcomes, fits = [], [], {}
        for name in pending:
            fit, value, evaluations, _ = _fit_candidate(problem, self.start, current, self.added, self.individual,
                                                        name, self.say, self.rule, self.hints.get(name))
            row, outcome = _row(name, fit, value, evaluations, current, problem, sigs.get(name), self.to_file,
                                self.rule)
            rows.append(row)
            outcomes.append(outcome)
            fits[name] = fit
        rows.sort(key=lambda r: math.inf if r["bic"] is None else r["bic"])
        self.fits = fits
        self.outcomes = {outcome.effect: outcome for outcome in outcomes}
        self.context = {"bic_before": current.score.bic,
                        "rmse_holdout_before": current.score.rmse_holdout * self.to_file, "candidates": rows,
                        "ties": []}
        return outcomes

    def _signatures(self, pending: list[str]) -> dict:
        """The round's signatures (the first round's are kept for the pictures); {} outside the model's domain."""
        problem, current = self.problem, self.current
        try:
            record = problem.measurement if not current.offset else dataclasses.replace(
                problem.measurement, output=problem.measurement.output - current.offset)
            sigs = signatures(record, current.params, pending)
        except MkctlError:  # the measured states lie outside the model's domain: no signatures
            sigs = {}
        if self.signatures_first is None:
            self.signatures_first = (list(pending), sigs)
        return sigs

    def _null_test(self, outcome: Outcome) -> Outcome:
        """The candidate refitted on the current model's own simulation plus the estimated output
        noise: the dBIC it gains there is what noise alone gives it (criterion 5 of the rule). The
        simulation is driven by the measured inputs re-noised (their noise passes through the model
        into the null record); a quasi-static record draws several realisations of both noises and
        the largest gain counts."""
        name, current = outcome.effect, self.current
        gains = []
        realisations = [(self.renoised, self.noise)] + [
            (renoised, dataclasses.replace(self.noise, seed=self.noise.seed + k))
            for k, renoised in enumerate(self.renoised_more, 1)]
        for renoised, noise in realisations:
            output = noise.null_output(self.problem, current, renoised)
            null_problem = dataclasses.replace(self.problem, measurement=dataclasses.replace(
                self.problem.measurement, output=output))
            null_current = _evaluate(null_problem, current.params, current.values)
            if null_current is None:
                continue
            fit, _, _, _ = _fit_candidate(null_problem, self.start, null_current, self.added, {},
                                          name, None, self.rule, self.hints.get(name))
            k_more = dataclasses.replace(null_current.score, k=null_current.score.k + 1)
            null_score = fit.score if fit is not None and fit is not null_current else k_more
            gains.append(null_score.bic - null_current.score.bic)
        if not gains:
            return outcome
        tested = dataclasses.replace(outcome, null_delta_bic=min(gains))
        self.outcomes[name] = tested
        judgement = judge(current.score, tested, self.rule)
        row = next(r for r in self.context["candidates"] if r["effect"] == name)
        row.update({"null_delta_bic": tested.null_delta_bic, "beats_noise": judgement.beats_noise})
        self.say(f"  null test of {name}: dBIC {tested.null_delta_bic:+.1f} on the model's simulation plus noise")
        return tested

    def _break_tie(self, decision):
        """A tie: the best and each rival fitted together; an ``add`` of both when each is needed."""
        self.context["ties"] = [{"effects": [decision.effect, r], "experiment": experiment_to_separate(
            [decision.effect, r])} for r in decision.rivals]
        pair = _try_pairs(self.problem, self.start, self.added, decision, self.fits, self.say, self.rule)
        if pair is None:
            return decision
        rival, fit = pair
        self.fits[decision.effect] = fit
        return dataclasses.replace(decision, verdict="add", together=(rival,))

    def _joint_with_added(self, names: list, start: dict) -> tuple[_Fit | None, bool]:
        """``names`` fitted jointly with the effects already added (training part, full tolerance),
        from the current values and ``start``: (the fit or None, whether a parameter of ``names``
        sits on a bound)."""
        values, _, _, params = _joint_fit(self.problem, self.start, [*self.added, *names],
                                          {**self.current.values, **start}, train_only=True)
        fit = _evaluate(self.problem, params, values)
        return fit, _pinned(values, names, self.problem.measurement.experiment)

    def _with_requirements(self, decision):
        """A round that ends in a tie or a stop: an effect that requires another (the registry's
        ``requires``) is no candidate until its prerequisite is on, so a prerequisite that is tied
        (or, in a stop, any fitted candidate) is fitted together with each effect that requires it,
        and the combination is judged by the same rule against the current model and the round's
        candidates (:func:`decide`: physical, BIC, held-out gain, held-out margin over every rival);
        the winner is then fitted with each of the prerequisite's rivals in turn, kept when the
        rival passes BIC and the held-out gain beside it
        (:func:`mkctl.analysis.diagnosis_rule.extension_needed`). Returns an ``add`` of the
        prerequisite with the others ``together``, or the decision unchanged."""
        on = set(self.start.effects) | set(self.added)
        undecided = decision.verdict == "undecided"
        tied = [decision.effect, *decision.rivals] if undecided else list(self.fits)
        compounds, rows = {}, []
        for prerequisite in tied:
            fit = self.fits.get(prerequisite)
            if fit is None or fit is self.current:
                continue
            for dependent in _dependents(self.pending_all, on, prerequisite):
                names = [prerequisite, dependent]
                start = {CANDIDATES[dependent].parameter: _dependent_start(dependent, fit.values)}
                together, pinned = self._joint_with_added(names, {**fit.values, **start})
                if together is None:
                    continue
                key = " + ".join(names)
                compounds[key] = (names, together, pinned)
                own = [CANDIDATES[e].parameter for e in names]
                rows.append({"effects": names, "params": {p: together.values[p] for p in own},
                             "delta_bic": together.score.bic - self.current.score.bic,
                             "rmse_train": together.score.rmse_train * self.to_file,
                             "rmse_holdout": together.score.rmse_holdout * self.to_file,
                             "at_bound": pinned})
                self.say(f"  {key} together: dBIC {rows[-1]['delta_bic']:+.1f}, held-out "
                         f"{rows[-1]['rmse_holdout']:.4g}"
                         + (" (a parameter on its bound)" if pinned else ""))
        if not compounds:
            return decision
        self.context["with_requirements"] = rows
        outcomes = [*self.outcomes.values(), *(Outcome(key, fit.score, at_bound=pinned)
                                               for key, (_, fit, pinned) in compounds.items())]
        second = decide(self.current.score, outcomes, self.rule)
        if second.verdict != "add" or second.effect not in compounds:
            self.say(f"  with what requires it: {second.reason}")
            return decision
        names, fit, _ = compounds[second.effect]
        for rival in (r for r in tied if r not in names and undecided):
            alone = self.fits.get(rival)
            if alone is None or alone is self.current:
                continue
            parameter = CANDIDATES[rival].parameter
            start = {**fit.values, parameter: alone.values[parameter]}
            more, pinned = self._joint_with_added([*names, rival], start)
            if more is not None and not pinned and extension_needed(fit.score, more.score,
                                                                    self.rule):
                names, fit = [*names, rival], more
        for row in rows:
            row["accepted"] = row["effects"] == names[:2]
        self.fits[names[0]] = fit
        self.say(f"  {' and '.join(names)} are added together")
        return dataclasses.replace(second, verdict="add", effect=names[0], rivals=(),
                                   together=tuple(names[1:]),
                                   reason=f"{' + '.join(names)} together pass every criterion")

    def _add(self, decision) -> Score:
        """Adopt the decision's effect(s), drop what no longer earns its place, refit, record the round."""
        name, together = decision.effect, list(decision.together)
        self.added.extend([name, *together])
        self.current = self.fits[name]
        dropped = self._drop(len(together) + 1)
        self.current = self._refit(self.current)
        self._record({"added": name, "added_with": together, "dropped": dropped, **self.context})
        return self.current.score

    def _stop(self, decision) -> None:
        """Record why the selection ended: nothing left, nothing passing, or a tie the record cannot break."""
        if not decision.judgements:
            self.stopped = {"reason": decision.reason, "candidates": [], "ties": []}
            return
        if decision.verdict == "undecided":
            effects = [decision.effect, *decision.rivals]
            text = f"this record cannot tell {' from '.join(e.replace('_', ' ') for e in effects)}: {decision.reason}"
            self.undecided.append({"effects": effects, "experiment": experiment_to_separate(effects), "text": text})
            self.stopped = {"reason": text, **self.context}
            self.say(f"  undecided: {text}")
            return
        self.stopped = {"reason": decision.reason, **self.context}
        self.say(f"  stop: {decision.reason}")

    def _refit(self, fit: _Fit) -> _Fit:
        """The added effects refitted jointly (full tolerance), so that the next round starts from their
        best values and no later candidate is credited with what a better refit of these would give."""
        values, _, _, params = _joint_fit(self.problem, self.start, self.added, fit.values, train_only=True)
        refit = _evaluate(self.problem, params, values)
        return refit if refit is not None and refit.rss_train < fit.rss_train else fit

    def _drop(self, newest: int) -> list:
        """Drop earlier effects that no longer earn their place (the rule's drop step)."""
        dropped = []
        while len(self.added) > newest:
            without = {}
            for earlier in self.added[:-newest]:
                rest = [e for e in self.added if e != earlier]
                if any(earlier in effects.get(e).requires for e in rest):  # the lag under an asymmetric lag
                    continue
                rest_values = {CANDIDATES[e].parameter: self.current.values[CANDIDATES[e].parameter] for e in rest}
                values, _, _, params = _joint_fit(self.problem, self.start, rest, rest_values, train_only=True)
                without[earlier] = _evaluate(self.problem, params, values)
            gone = to_drop(self.current.score, {e: f.score if f else None for e, f in without.items()}, self.rule)
            if gone is None:
                break
            dropped.append(gone)
            self.added.remove(gone)
            self.current = without[gone]
        return dropped

    def _record(self, step: dict) -> None:
        current = self.current
        step.update({"rmse": None, "params": dict(current.values),
                     "rmse_holdout": current.score.rmse_holdout * self.to_file})
        self.steps.append(step)
        self.step_params.append((current.params, current.offset))
        added = [step["added"], *step.get("added_with", [])]
        self.say(f"  added {' and '.join(added)}" + (f", dropped {', '.join(step['dropped'])}" if step["dropped"]
                                                    else "") + ": "
                 + ", ".join(diagnosis_report.parameter_text(k, v) for k, v in current.values.items()))

    def wider(self) -> bool:
        """Fit every pair, then every three, of candidates jointly (from their round-1 values) and judge the best
        (by BIC, not on a bound) against the forward model by the rule; adopt it (replacing what forward
        selection added) when it passes. Three effects at once leave every pair short, and forward selection
        then stops on a tie it cannot break."""
        problem, say = self.problem, self.say
        before = self.current
        names = [e for e in self.pending_all if self.individual.get(e, 0.0) > 0]
        experiment = problem.measurement.experiment
        best, tried = None, []
        base = set(self.start.effects)

        def consider(combo, start):
            nonlocal best
            values, _, _, params = _joint_fit(problem, self.start, list(combo), start,
                                              train_only=True, rough=True)
            fit = _evaluate(problem, params, values)
            if fit is None:
                return None
            pinned = _pinned(values, combo, experiment)
            say(f"  {' + '.join(combo)}: training RMSE {fit.score.rmse_train * self.to_file:.4g}, "
                f"held-out {fit.score.rmse_holdout * self.to_file:.4g}"
                + (" (on a bound)" if pinned else ""))
            if not pinned:
                tried.append((combo, fit))
                if best is None or fit.score.bic < best[1].score.bic:
                    best = (combo, fit)
            return fit

        for size in (2, 3):
            for combo in itertools.combinations(names, size):
                start = {CANDIDATES[e].parameter: self.individual[e] for e in combo}
                fit = consider(combo, start) if set(combo) != set(self.added) else self.current
                # an effect that requires one of these (the registry's requires) is tried on top of
                # them, from their fitted values: it was never a candidate of round 1, so it has no
                # value of its own there
                for prerequisite in combo:
                    for dependent in _dependents(self.pending_all, base | set(combo), prerequisite):
                        if fit is None or set((*combo, dependent)) == set(self.added):
                            continue
                        values = dict(fit.values)
                        consider((*combo, dependent), {**values, CANDIDATES[dependent].parameter:
                                                       _dependent_start(dependent, values)})
        if best is None:
            return False
        # an effect of the best combination whose removal costs less than the rule's BIC threshold
        # does not earn its place there (the rule's drop step): the combination without it is taken
        # instead, so that a spurious fourth effect (a friction beside damping, a lag and its
        # exhausting time constant) cannot make the best combination one that a rival of equal error
        # ties
        tried_sets = {frozenset(c): (c, f) for c, f in tried}
        smaller = True
        while smaller:
            smaller = False
            for effect in best[0]:
                without = tried_sets.get(frozenset(best[0]) - {effect})
                if without is not None and not self.rule.passes_bic(best[1].score.bic
                                                                    - without[1].score.bic):
                    best, smaller = without, True
                    break
        combo, fit = best
        # two combinations that explain the record equally well are a finding, not an answer: another that is
        # neither part of the best nor contains it must be beaten on the held-out part by the margin
        rivals = [other for other, other_fit in tried
                  if not (set(other) <= set(combo) or set(combo) <= set(other))
                  and not self.rule.beats(fit.score.rmse_holdout, other_fit.score.rmse_holdout)]
        if rivals:
            say(f"  the best combination ({' + '.join(combo)}) does not beat "
                f"{'; '.join(' + '.join(r) for r in rivals)} on the held-out part by {self.rule.holdout_margin:.0%}")
            return False
        decision = decide(before.score, [Outcome("+".join(combo), fit.score)], self.rule)
        if decision.verdict != "add" or not fit.score.rss_train < before.score.rss_train:
            say(f"  the best combination ({' + '.join(combo)}) does not pass the rule against "
                f"{', '.join(self.added) or 'the baseline'}")
            return False
        replaced = list(self.added)
        self.added = list(combo)
        self.current = self._refit(fit)
        self.undecided, self.stopped = [], None  # the combination settles what forward selection could not
        self._record({"added": combo[0], "added_with": list(combo[1:]),
                      "dropped": [e for e in replaced if e not in combo], "replaced": replaced,
                      "bic_before": before.score.bic, "rmse_holdout_before": before.score.rmse_holdout * self.to_file,
                      "candidates": [], "ties": [], "wider_search": True})
        return True


def _dependents(pending: list, on: set, prerequisite: str) -> list[str]:
    """The candidates of ``pending`` that require ``prerequisite`` (the registry's ``requires``) and
    become possible once it is on beside the effects ``on``."""
    return [e for e in pending if e not in on and prerequisite in effects.get(e).requires
            and set(effects.get(e).requires) <= on | {prerequisite}]


def _dependent_start(name: str, values: dict) -> float:
    """Where a dependent effect's parameter starts a joint fit: at its prerequisite's fitted value
    when that has the same unit (an exhausting time constant at the lag's tau: the symmetric lag),
    else at the parameter's typical value (the registry's), else the middle of its search range in
    log space."""
    effect, parameter = effects.get(name), CANDIDATES[name].parameter
    for required in effect.requires:
        other = CANDIDATES[required].parameter if required in CANDIDATES else None
        same_unit = other is not None and UNITS.get(other) == UNITS.get(parameter)
        if same_unit and values.get(other, 0.0) > 0:
            return float(values[other])
    typical = getattr(effect.parameter(parameter), "typical", None)
    if typical:
        return float(typical)
    low, high = next(iter(CANDIDATES[name].bounds.values()))
    return math.sqrt(low * high)


def _pinned(values: dict, effects, experiment: str) -> bool:
    """Whether a joint fit left a parameter of ``effects`` on a bound of its search range (switches excepted)."""
    return any(at_bound(values[CANDIDATES[e].parameter], CANDIDATES[e].bounds[experiment]) and not CANDIDATES[e].switch
               for e in effects)


def _try_pairs(problem: _Problem, baseline: Params, added: list, decision, fits: dict, say, rule: Rule = RULE):
    """Fit the best candidate together with each rival; (rival, fit) of the first pair that needs both."""
    best = decision.effect
    for rival in decision.rivals:
        if fits.get(best) is None or fits.get(rival) is None:
            continue
        effects = [*added, best, rival]
        start = {**fits[best].values, **fits[rival].values}
        if any(start.get(CANDIDATES[e].parameter, 0.0) <= 0 for e in effects):
            continue
        values, _, _, params = _joint_fit(problem, baseline, effects, start, train_only=True)
        both = _evaluate(problem, params, values)
        if both is None:
            continue
        pinned = _pinned(values, effects, problem.measurement.experiment)
        say(f"  {best} and {rival} together: dBIC {both.score.bic - fits[best].score.bic:+.1f} against {best} "
            f"alone" + (" (a parameter on its bound)" if pinned else ""))
        if not pinned and pair_needed([fits[best].score, fits[rival].score], both.score, rule):
            return rival, both
    return None
