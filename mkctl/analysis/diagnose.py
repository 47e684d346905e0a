"""Diagnosis: which effect of model-spec section 4 is the model missing, and with what parameter?

Given a measurement (:mod:`mkctl.io.measurements`), :func:`diagnose` starts from the file's baseline and
adds effects one at a time, forward stepwise, while the evidence supports it:

1. **Split** the record in time: the first 70 % trains, the last 30 % is held out. (Simulations always
   start at the beginning of the record; a held-out error is a prediction from the trained parameters.)
2. **Candidates** are the effects the experiment can show that the model does not have yet
   (:data:`CANDIDATES`): the isotonic test shows elasticity, Coulomb friction and viscous damping (its
   pressure is measured in the bladder, so a lag cannot show); the knee shows all four.
3. **Fit** each candidate's one parameter on simulation error over the training part: the model is
   simulated on the file's inputs and compared with the measured output, never with differentiated
   data. The search runs in log space between bounds (:data:`CANDIDATES`): a grid of one point per
   decade, then bounded Brent around the best grid point. "Off" (value 0) is an option too: a
   candidate the data do not call for comes back as 0. Already added parameters stay at their values.
4. **Score** each fitted candidate by the Bayesian information criterion on the training part,
   ``BIC = n ln(RSS / n) + k ln n`` (k: parameters fitted so far), and by its RMSE on the held-out part.
5. **Accept** the best-BIC candidate only if it lowers BIC by more than :data:`BIC_THRESHOLD` (10:
   "very strong" evidence, Kass & Raftery 1995) *and* lowers the held-out RMSE by at least
   :data:`HOLDOUT_GAIN` (2 %). Then refit all added parameters jointly (``least_squares``) and repeat.
   Stop when no candidate passes both tests. In data without a missing effect every candidate comes
   back switched off (or tiny), RSS does not move and the ``k ln n`` penalty keeps BIC from improving:
   nothing is added.
6. **Report** a final joint fit of all added parameters on the whole record, with standard errors from
   the Jacobian of the residuals at the optimum, ``cov = s^2 (J^T J)^-1`` with ``s^2 = RSS / (n - k)``.

To explain the choice, every round also reports each candidate's *signature*: the correlation of the
current residual with the physical quantity the effect acts through (velocity for damping, direction
of motion for friction, the pressure-command rate for the lag, the rubber's tension for elasticity),
and near-ties (BIC within :data:`TIE_BIC`) together with the experiment that would tell them apart.

For the knee, fits are evaluated on every ``stride``-th sample (about :data:`FIT_POINTS` points; the
integrator still runs through every change of the commands, see :func:`mkctl.analysis.compare.simulate_output`),
so n in BIC is the number of those samples. RMSE in the steps and before/after is over every sample.
All RMSE are in the units of the file's output column; parameters are SI.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Callable

import numpy as np
from scipy.optimize import least_squares, minimize_scalar

from ..physics import actuator, knee
from ..physics.isometric import isometric_tension
from .compare import fit_percent, fit_text, plot_overlay, plot_residuals, rmse, simulate_output
from ..errors import MkctlError
from ..io.measurements import Measurement
from ..physics.params import UNITS, Params
from ..io.plotting import new_figure, save_png

#: Share of the record (at its end) held out from fitting.
HOLDOUT_FRACTION = 0.3
#: An effect is added only if it lowers BIC by more than this.
BIC_THRESHOLD = 10.0
#: ... and lowers the held-out RMSE by at least this fraction.
HOLDOUT_GAIN = 0.02
#: Candidates whose BIC lie within this of the best are reported as a near-tie.
TIE_BIC = 10.0
#: About how many samples the knee's fits are evaluated on.
FIT_POINTS = 300


@dataclass(frozen=True)
class Candidate:
    """An effect of spec section 4 as a diagnosis candidate: the one parameter it fits and its bounds."""

    effect: str
    parameter: str
    bounds: dict  #: experiment -> (lower, upper) [SI], searched in log space
    regressor: str  #: the force term its signature is checked against
    why: str

    def apply(self, params: Params, value: float) -> Params:
        """params with this effect switched on at ``value``."""
        if self.effect == "elasticity":
            return params.replace(model=2, C1=value)
        if self.effect == "slack":  # a switch: any value searched (its bounds are [1, 1 + 1e-6]) means on
            return params.replace(slack=1 if value > 0 else 0)
        return params.replace(**{self.parameter: value})


#: The candidates, in the spec's order. Elasticity fits C1 with C2 kept at its (Table I) value: C2 is
#: 150 times smaller and its share of the tension is not separable from C1's in these experiments.
CANDIDATES = {
    "elasticity": Candidate("elasticity", "C1", {"isotonic": (1e3, 1e7), "knee": (1e3, 1e7), "isometric": (1e3, 1e7)},
                            "the rubber's tension (model 2 minus model 1) at the measured length",
                            "model 2 instead of model 1: the rubber's Mooney-Rivlin tension"),
    "viscous_damping": Candidate("viscous_damping", "c", {"isotonic": (1e-2, 1e5), "knee": (1e-2, 1e4)},
                                 "the damping force per N s/m at the measured velocity", "f += c Ldot"),
    "coulomb_friction": Candidate("coulomb_friction", "Fc", {"isotonic": (1e-3, 100.0), "knee": (1e-3, 100.0),
                                                             "isometric": (1e-3, 100.0)},
                                  "the friction force per N at the measured direction of motion",
                                  "f += Fc tanh(Ldot / vs) (a play operator in the isotonic test)"),
    "pressure_lag": Candidate("pressure_lag", "tau", {"knee": (1e-3, 2.0)},
                              "the force a lag of 1 s takes away at the measured pressure-command rate",
                              "tau dP/dt = P_cmd - P"),
    # slack is a switch (0 or 1): its one-point search interval just compares on with off
    "slack": Candidate("slack", "slack", {"isometric": (1.0, 1.0 + 1e-6)},
                       "the model's tension, where it is negative (a slack muscle carries nothing there)",
                       "f = max(f, 0), applied last: a braided muscle cannot push"),
}

#: The experiment that tells two candidates apart, for near-ties.
DISCRIMINATING_EXPERIMENTS = {
    frozenset({"viscous_damping", "pressure_lag"}):
        "a pressure step with the leg clamped (a lag delays the force even without motion, damping needs "
        "motion), or a slow command ramp followed by a fast step (damping grows with speed, a lag delays "
        "both by tau)",
    frozenset({"viscous_damping", "coulomb_friction"}):
        "an isotonic sweep at two rates: friction leaves a rate-independent hysteresis loop, damping's "
        "loop shrinks to nothing at low rates",
    frozenset({"coulomb_friction", "pressure_lag"}):
        "a slow ramp of the pressure command: friction makes the leg stick and then slip, a lag only "
        "delays the response by tau",
    frozenset({"elasticity", "viscous_damping"}):
        "an isotonic test held at constant pressures under several loads: elasticity changes where the "
        "length settles, damping only how fast it gets there",
    frozenset({"elasticity", "coulomb_friction"}):
        "an isotonic sweep down to low pressure under several loads: elasticity bends the "
        "contraction-pressure curve (most at low pressure), friction shifts up- and down-sweeps apart",
    frozenset({"elasticity", "pressure_lag"}):
        "slow steady states at several pressures (isotonic): elasticity changes them, a lag cannot",
    frozenset({"elasticity", "slack"}):
        "a blocked-force test at a short length from zero pressure up: slack reads zero until the tension turns "
        "positive, elasticity bends the whole curve",
    frozenset({"viscous_damping", "slack"}):
        "a blocked-force test at a short length: slack reads zero at low pressure with nothing moving, damping "
        "needs motion",
    frozenset({"pressure_lag", "slack"}):
        "settled readings at a short length from zero pressure up: slack reads zero until the tension turns "
        "positive, a lag only delays each reading",
    frozenset({"coulomb_friction", "slack"}):
        "a blocked-force test with the pressure stepped up and back down: friction separates the branches "
        "everywhere, slack only flattens them at zero",
}

_LN10 = math.log(10.0)
_FAILED = object()


@dataclass
class _Problem:
    """The measurement, the samples the fits look at, and the train/hold-out split."""

    measurement: Measurement
    grid: np.ndarray  #: sample indices fits are evaluated on
    train: np.ndarray  #: bool over grid: in the training part
    n_train: int  #: samples (of the record) the training simulations run over

    def simulate(self, params: Params, train_only: bool = False):
        """Model output [m] on the grid (the training grid only if train_only), or _FAILED."""
        try:
            if train_only:
                return simulate_output(self.measurement, params, self.grid[self.train], stop=self.n_train)
            return simulate_output(self.measurement, params, self.grid)
        except MkctlError:
            return _FAILED

    def residual(self, simulated, train_only: bool = False):
        measured = self.measurement.output[self.grid[self.train] if train_only else self.grid]
        return measured - simulated


def _problem(measurement: Measurement) -> _Problem:
    n = measurement.samples
    stride = 1 if measurement.experiment in ("isotonic", "isometric") else max(1, n // FIT_POINTS)
    grid = np.arange(0, n, stride)
    if grid[-1] != n - 1:
        grid = np.append(grid, n - 1)
    t = measurement.time
    split = t[0] + (1.0 - HOLDOUT_FRACTION) * (t[-1] - t[0])
    n_train = int(np.searchsorted(t, split, side="right"))
    train = grid < n_train
    if train.sum() < 5 or (~train).sum() < 3:
        raise MkctlError(f"{measurement.source}: too few samples to diagnose ({n}); need at least 20")
    return _Problem(measurement, grid, train, n_train)


def candidates_for(measurement: Measurement, params: Params) -> list[str]:
    """The candidate effects the experiment can show that params do not have yet."""
    return [name for name, c in CANDIDATES.items()
            if measurement.experiment in c.bounds and name not in params.effects]


def _bic(rss: float, n: int, k: int) -> float:
    return n * math.log(max(rss, 1e-300) / n) + k * math.log(n)


@dataclass
class _Fit:
    """A model on the problem: its parameters and its errors (SI, on the grid)."""

    params: Params
    values: dict  #: fitted parameter values by name
    rss_train: float
    n_train: int
    rmse_holdout: float  #: [m]
    rmse_grid: float  #: [m], whole record on the grid
    simulated: np.ndarray  #: grid output [m]

    def bic(self, k: int) -> float:
        return _bic(self.rss_train, self.n_train, k)


def _evaluate(problem: _Problem, params: Params, values: dict):
    """Simulate params over the whole record on the grid and score it, or None if it fails."""
    simulated = problem.simulate(params)
    if simulated is _FAILED:
        return None
    measured = problem.measurement.output[problem.grid]
    r_train = problem.residual(simulated)[problem.train]
    hold = ~problem.train
    return _Fit(params, dict(values), float(r_train @ r_train), int(problem.train.sum()),
                rmse(measured[hold], simulated[hold]), rmse(measured, simulated), simulated)


def _fit_one(problem: _Problem, base: Params, candidate: Candidate, rss_off: float, progress) -> tuple[float, int]:
    """Best value of the candidate's parameter on the training part (log-space grid + bounded Brent).

    The effect switched off (value 0, training RSS ``rss_off``) is one of the options: a candidate the
    data do not call for comes back as 0, not as a small but visible value at its lower bound.
    """
    low, high = candidate.bounds[problem.measurement.experiment]
    measured = problem.measurement.output[problem.grid[problem.train]]
    evaluations = [0]

    def cost(log_value):
        evaluations[0] += 1
        simulated = problem.simulate(candidate.apply(base, 10.0 ** log_value), train_only=True)
        if simulated is _FAILED:
            return math.inf
        r = measured - simulated
        return float(r @ r)

    logs = np.arange(math.log10(low), math.log10(high) + 1e-9, 1.0)
    if logs[-1] < math.log10(high) - 1e-9:
        logs = np.append(logs, math.log10(high))
    costs = np.array([cost(x) for x in logs])
    if not np.isfinite(costs).any():
        return math.nan, evaluations[0]
    penalty = 10.0 * np.max(costs[np.isfinite(costs)]) + 1.0  # Brent needs finite values
    i = int(np.argmin(costs))
    lo, hi = logs[max(i - 1, 0)], logs[min(i + 1, logs.size - 1)]
    result = minimize_scalar(lambda x: min(cost(x), penalty), bounds=(lo, hi), method="bounded",
                             options={"xatol": 1e-3})
    best_cost, best = (float(result.fun), float(result.x)) if result.fun <= costs[i] else (costs[i], float(logs[i]))
    value = 10.0 ** best
    if best_cost >= rss_off:  # the effect switched off does at least as well: its fitted value is 0
        value = 0.0
    if progress:
        progress(f"    {candidate.effect}: {candidate.parameter} = {value:.4g} {UNITS[candidate.parameter]} "
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
    x0 = np.clip(np.log10([start[c.parameter] for c in cands]), lows + 1e-9, highs - 1e-9)
    measured = problem.measurement.output[problem.grid[problem.train] if train_only else problem.grid]

    def params_at(x):
        params = base
        for c, value in zip(cands, x):
            params = c.apply(params, 10.0 ** value)
        return params

    def residual(x):
        simulated = problem.simulate(params_at(x), train_only=train_only)
        if simulated is _FAILED:
            return np.full(measured.size, 1.0)  # 1 m everywhere: far worse than any fit
        return measured - simulated

    tolerance = 1e-4 if rough else 1e-6
    result = least_squares(residual, x0, bounds=(lows, highs), x_scale=1.0, diff_step=1e-4, xtol=tolerance,
                           ftol=tolerance * 1e-2, max_nfev=(6 if rough else 25) * (len(cands) + 1))
    values = {c.parameter: float(10.0 ** v) for c, v in zip(cands, result.x)}
    n, k = measured.size, len(cands)
    rss = float(result.fun @ result.fun)
    errors = {}
    jac = result.jac
    if n > k:
        cov = rss / (n - k) * np.linalg.pinv(jac.T @ jac)
        for i, c in enumerate(cands):
            errors[c.parameter] = float(values[c.parameter] * _LN10 * math.sqrt(max(cov[i, i], 0.0)))
    return values, errors, result, params_at(result.x)


# --- Signatures: the force the model lacks, against what each effect acts through ------------------

#: Savitzky-Golay smoothing window for the signatures: the knee's in seconds, the isotonic test's in samples.
KNEE_SMOOTHING_S = 0.1
ISOTONIC_SMOOTHING_SAMPLES = 11


def missing_force(measurement: Measurement, params: Params):
    """The equation error: the force the model lacks at the measured, smoothed states [N].

    Isotonic (quasi-static): ``F_load - f(L, P, Ldot)``. Knee (Eq. 17): ``m (Xddot + g) - F - F_stop``
    with X, V, Xddot from a cubic Savitzky-Golay fit of the measured X. Only for explanation: the fits
    themselves compare simulations with the data, never differentiated data.
    Returns (missing force, states) with states a dict of the smoothed signals (SI).
    """
    from scipy.signal import savgol_filter

    m = measurement
    if m.experiment == "isometric":  # nothing moves: the measured tension against the model's, point by point
        L, P = m.inputs["length"], m.inputs["pressure"]
        return m.output - isometric_tension(L, P, m.branch, params), {"L": L, "P": P, "branch": m.branch}
    n = m.samples
    dt = float(np.mean(np.diff(m.time)))
    window = (ISOTONIC_SMOOTHING_SAMPLES if m.experiment == "isotonic" else int(round(KNEE_SMOOTHING_S / dt)))
    window = max(5, min(window, n - 1 if n % 2 == 0 else n))
    window += 1 - window % 2  # odd
    if window > n:
        window -= 2
    order = min(3, window - 2)
    y = savgol_filter(m.output, window, order)
    ydot = savgol_filter(m.output, window, order, deriv=1, delta=dt)
    if m.experiment == "isotonic":
        P, F = m.inputs["pressure"], m.inputs["force"]
        states = {"L": y, "Ldot": ydot, "P": P}
        return F - actuator.tension(y, P, ydot, params), states
    yddot = savgol_filter(m.output, window, order, deriv=2, delta=dt)
    # the pressures go through the same smoothing as the acceleration, so that a command step does not
    # show up as a force the model lacks while the smoothed acceleration ramps up to it
    pressures = _model_pressures(m, params)  # a loop over the samples when there is a lag: once
    Pe, Pf = (savgol_filter(p, window, order) for p in pressures)
    rates = [savgol_filter(p, window, order, deriv=1, delta=dt) for p in pressures]
    states = {"X": y, "V": ydot, "Pe": Pe, "Pf": Pf, "A": yddot, "Pe_rate": rates[0], "Pf_rate": rates[1]}
    return params.m * (yddot + params.g) - _knee_force(states, params), states


def _knee_force(states: dict, params: Params, Pe=None, Pf=None):
    geo = knee.geometry_at_X(states["X"], params)
    Pe = states["Pe"] if Pe is None else Pe
    Pf = states["Pf"] if Pf is None else Pf
    return (knee.knee_force(geo, states["V"], Pe, Pf, params).F
            + knee.end_stop_force(states["X"], states["V"], params))


def _model_pressures(m: Measurement, params: Params):
    """The actuator pressures the model sees: the commands, or the commands through the model's lag."""
    pe, pf = m.inputs["pe_cmd"], m.inputs["pf_cmd"]
    if params.tau <= 0:
        return pe, pf
    return _lagged(m.time, pe, params.tau), _lagged(m.time, pf, params.tau)


def _lagged(time, command, tau):
    """A command held from each sample to the next, through the lag tau dP/dt = P_cmd - P, P(0) = P_cmd(0)."""
    out = np.empty(time.size)
    out[0] = command[0]
    dt = np.diff(time)
    for k in range(1, time.size):
        out[k] = actuator.lagged_pressure(out[k - 1], command[k - 1], tau, dt[k - 1])
    return out


#: Reference value of each candidate's parameter for its unit force term (elasticity: the model's C1).
_REFERENCE = {"c": 1.0, "Fc": 1.0, "tau": 1.0}
#: How the signature pictures label their x axis.
_AXIS = {"viscous_damping": "velocity [mm/s]", "coulomb_friction": "velocity [mm/s]",
         "pressure_lag": "extensor pressure rate (smoothed) [kPa/s]",
         "elasticity": "rubber tension of the model's C1, C2 [N]",
         "slack": "tension the slack muscle would not carry [N]",
         ("isometric", "coulomb_friction"): "friction's sign at a clamped length: -1 rising, +1 falling pressure",
         ("isometric", "elasticity"): "rubber tension of the model's C1, C2 [N]"}


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
            x = -states["branch"] if name == "coulomb_friction" else term
            out[name] = {"against": cand.regressor, **_fit_line(missing, term, ref), "x": x, "missing": missing}
        return out
    speed = (states["Ldot"] if isotonic else states["V"]) * 1e3
    for name in names:
        cand = CANDIDATES[name]
        ref = params.C1 if name == "elasticity" else _REFERENCE[cand.parameter]
        if name == "pressure_lag":
            rate_e, rate_f = states["Pe_rate"], states["Pf_rate"]
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
            x = term if name == "elasticity" else speed
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


def _binned(x, y, bins: int = 12):
    """Mean of y in bins of equal counts of x (for the signature pictures)."""
    order = np.argsort(x)
    groups = np.array_split(order, bins)
    return ([float(np.mean(x[g])) for g in groups if g.size], [float(np.mean(y[g])) for g in groups if g.size])


# --- The loop --------------------------------------------------------------------------------------

def diagnose(measurement: Measurement, progress: Callable[[str], None] | None = None) -> dict:
    """Find the effects the baseline misses, fit them, and report (a dict shaped as spec section 6).

    ``progress`` receives one line per stage (for a long run on the command line).
    """
    say = progress or (lambda text: None)
    m = measurement
    problem = _problem(m)
    baseline = m.params
    to_file = 1.0 / m.output_factor
    say(f"{Path(m.source).name}: {m.experiment}, {m.samples} samples, baseline {m.baseline} "
        f"(effects: {', '.join(baseline.effects) or 'none'}); fitting on {problem.grid.size} samples")

    try:
        full_before = simulate_output(m, baseline)
    except MkctlError as error:
        raise MkctlError(f"{m.source}: the model cannot simulate this record: {error}") from None
    current = _evaluate(problem, baseline, {})
    added: list[str] = []
    individual: dict = {}  # each candidate's value fitted alone against the baseline (round 1)
    steps: list[dict] = []
    stopped = None
    signatures_first = None
    full_rmse_steps = [rmse(m.output, full_before) * to_file]

    while True:
        pending = candidates_for(m, current.params)
        if not pending:
            stopped = {"reason": "no candidate effect left for this experiment", "candidates": [], "ties": []}
            break
        say(f"round {len(steps) + 1}: fitting {', '.join(pending)}")
        try:
            sigs = signatures(m, current.params, pending)
        except MkctlError:  # the measured states lie outside the model's domain: no signatures
            sigs = {}
        k_now = len(added)
        bic_now = current.bic(k_now)
        rows = []
        for name in pending:
            cand = CANDIDATES[name]
            value, evaluations = _fit_one(problem, current.params, cand, current.rss_train, say)
            if not added:
                individual[name] = value
            values = {**current.values, cand.parameter: value}
            if math.isnan(value):
                fit = None
            elif value == 0.0:
                fit = current
            else:
                fit = _evaluate(problem, cand.apply(current.params, value), values)
            if added and fit is not None:
                # effects interact (damping and a lag both calm the leg): refit jointly with the effects
                # already added, from this round's value and from the values each took alone in round 1
                starts = [values] if value > 0 else []
                alone = {CANDIDATES[e].parameter: individual.get(e, 0.0) for e in [*added, name]}
                if all(v > 0 for v in alone.values()):
                    starts.append(alone)
                for start_values in starts:
                    joint_values, _, result, params = _joint_fit(problem, baseline, [*added, name], start_values,
                                                                 train_only=True, rough=True)
                    evaluations += result.nfev + 1
                    joint = _evaluate(problem, params, joint_values)
                    if joint is not None and joint.rss_train < fit.rss_train:
                        fit, values = joint, joint_values
            value = values[cand.parameter] if fit is not None and fit is not current else value
            sig = sigs.get(name)
            row = {"effect": name, "params": {cand.parameter: value}, "simulations": evaluations + 1,
                   "signature": None if sig is None else {k: sig[k] for k in ("against", "correlation", "estimate")}}
            if fit is None:
                row.update({"rmse": None, "bic": None, "delta_bic": None, "failed": True})
            else:
                low, high = cand.bounds[m.experiment]
                bic = fit.bic(k_now + 1)
                row.update({
                    "params_with_added": dict(values) if fit is not current else dict(current.values),
                    "rmse": fit.rmse_grid * to_file,
                    "rmse_train": math.sqrt(fit.rss_train / fit.n_train) * to_file,
                    "rmse_holdout": fit.rmse_holdout * to_file,
                    "bic": bic,
                    "delta_bic": bic - bic_now,
                    "explained_fraction": 1.0 - fit.rss_train / current.rss_train if current.rss_train > 0 else 0.0,
                    "switched_off": value == 0.0,
                    "at_bound": bool(value != 0.0 and (value <= low * 1.0001 or value >= high * 0.9999)),
                    "passes_bic": bool(bic - bic_now < -BIC_THRESHOLD),
                    "passes_holdout": bool(fit.rmse_holdout < (1.0 - HOLDOUT_GAIN) * current.rmse_holdout),
                })
                row["_fit"] = fit
            rows.append(row)
        rows.sort(key=lambda r: math.inf if r["bic"] is None else r["bic"])
        ties = _ties(rows)
        if signatures_first is None:
            signatures_first = ([r["effect"] for r in rows], sigs)
        best = rows[0]
        accepted = best["bic"] is not None and best["passes_bic"] and best["passes_holdout"]
        public_rows = [{k: v for k, v in r.items() if not k.startswith("_")} for r in rows]
        context = {"bic_before": bic_now, "rmse_holdout_before": current.rmse_holdout * to_file,
                   "candidates": public_rows, "ties": ties}
        if not accepted:
            stopped = {"reason": _stop_reason(best), **context}
            say(f"  stop: {stopped['reason']}")
            break
        name = best["effect"]
        added.append(name)
        current = best["_fit"]
        dropped = []
        for earlier in list(added[:-1]):  # does every earlier effect still earn its place?
            rest = [e for e in added if e != earlier]
            rest_values = {CANDIDATES[e].parameter: current.values[CANDIDATES[e].parameter] for e in rest}
            values, _, _, params = _joint_fit(problem, baseline, rest, rest_values, train_only=True)
            without = _evaluate(problem, params, values)
            if without is not None and without.bic(len(rest)) < current.bic(len(added)) + BIC_THRESHOLD:
                dropped.append(earlier)
                added, current = rest, without
        full_rmse = rmse(m.output, simulate_output(m, current.params)) * to_file
        full_rmse_steps.append(full_rmse)
        steps.append({"added": name, "dropped": dropped, "rmse": full_rmse, "params": dict(current.values),
                      "rmse_holdout": current.rmse_holdout * to_file, **context})
        say(f"  added {name}" + (f", dropped {', '.join(dropped)}" if dropped else "") + ": "
            + ", ".join(f"{k} = {v:.4g} {UNITS[k]}" for k, v in current.values.items())
            + f"; RMSE {full_rmse:.4g} {m.output_unit}")

    # final joint fit on the whole record
    uncertainty: dict = {}
    final_params, final_values = baseline, {}
    if added:
        say("final fit of " + ", ".join(added) + " on the whole record")
        final_values, uncertainty, _, final_params = _joint_fit(problem, baseline, added, current.values,
                                                                train_only=False)
    full_after = simulate_output(m, final_params) if added else full_before
    y = m.output * to_file
    report = {
        "file": str(m.source),
        "experiment": m.experiment,
        "baseline": m.baseline,
        "baseline_effects": list(baseline.effects),
        "output": m.output_column,
        "output_unit": m.output_unit,
        "samples": m.samples,
        "rmse_before": rmse(y, full_before * to_file),
        "rmse_after": rmse(y, full_after * to_file),
        "fit_percent_before": fit_percent(y, full_before * to_file),
        "fit_percent_after": fit_percent(y, full_after * to_file),
        "missing": list(added),
        "params": final_values,
        "uncertainty": uncertainty,
        "units": {k: UNITS[k] for k in final_values},
        "steps": steps,
        "stopped": stopped,
        "rule": {
            "holdout_fraction": HOLDOUT_FRACTION,
            "bic_threshold": BIC_THRESHOLD,
            "holdout_gain": HOLDOUT_GAIN,
            "tie_bic": TIE_BIC,
            "fit_samples": int(problem.grid.size),
            "train_samples": int(problem.train.sum()),
            "text": f"add the best-BIC candidate while it lowers BIC (training part, n ln(RSS/n) + k ln n) "
                    f"by more than {BIC_THRESHOLD:g} and the held-out RMSE (last "
                    f"{HOLDOUT_FRACTION:.0%} of the record) by at least {HOLDOUT_GAIN:.0%}",
        },
    }
    report["_curves"] = {"before": full_before, "after": full_after, "steps": full_rmse_steps,
                         "signatures": signatures_first}
    return report


def _ties(rows) -> list[dict]:
    """Near-ties among the candidates that would each pass BIC: within TIE_BIC of the best."""
    passing = [r for r in rows if r["bic"] is not None and r.get("passes_bic")]
    if len(passing) < 2:
        return []
    best = passing[0]
    ties = []
    for other in passing[1:]:
        gap = other["bic"] - best["bic"]
        if gap <= TIE_BIC:
            pair = frozenset({best["effect"], other["effect"]})
            ties.append({"effects": [best["effect"], other["effect"]], "bic_difference": gap,
                         "experiment": DISCRIMINATING_EXPERIMENTS.get(pair, "")})
    return ties


def _stop_reason(best) -> str:
    if best["bic"] is None:
        return "no candidate could be simulated on this record"
    parts = []
    if not best["passes_bic"]:
        parts.append(f"the best candidate ({best['effect']}) changes BIC by only {best['delta_bic']:+.1f} "
                     f"(needs < {-BIC_THRESHOLD:g})")
    if not best["passes_holdout"]:
        parts.append(f"{'it' if parts else 'the best candidate (' + best['effect'] + ')'} does not lower the "
                     f"held-out RMSE by {HOLDOUT_GAIN:.0%}")
    return "; ".join(parts) or "nothing more helps"


def public(report: dict) -> dict:
    """The report without its arrays, as plain JSON values (a NaN or infinity becomes None)."""
    def clean(value):
        if isinstance(value, dict):
            return {k: clean(v) for k, v in value.items() if not str(k).startswith("_")}
        if isinstance(value, (list, tuple)):
            return [clean(v) for v in value]
        if isinstance(value, (bool, np.bool_)):
            return bool(value)
        if isinstance(value, (int, np.integer)):
            return int(value)
        if isinstance(value, (float, np.floating)):
            return float(value) if math.isfinite(value) else None
        return value

    return clean(report)


# --- Pictures --------------------------------------------------------------------------------------

def save_pictures(measurement: Measurement, report: dict, folder, stem: str | None = None) -> dict:
    """Save the diagnosis pictures as PNG; returns {what: path}."""
    folder = Path(folder)
    stem = stem or Path(measurement.source).stem
    curves = report["_curves"]
    unit = measurement.output_unit
    paths = {}

    labels = ["baseline"] + [f"+ {s['added']}" for s in report["steps"]]
    fig, ax = new_figure(figsize=(max(4.5, 1.6 * len(labels) + 2), 3.8))
    values = curves["steps"]
    bars = ax.bar(range(len(values)), values, color=["0.6"] + ["tab:blue"] * (len(values) - 1))
    ax.plot(range(len(values)), values, "k.-", lw=0.8)
    for bar, value in zip(bars, values):
        ax.annotate(f"{value:.3g}", (bar.get_x() + bar.get_width() / 2, value), ha="center", va="bottom", fontsize=8)
    ax.set_xticks(range(len(values)), labels, fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel(f"RMSE [{unit}] (log)")
    ax.set_title("the error falls as effects are added")
    paths["error_steps"] = save_png(fig, folder / f"{stem}_error_steps.png")

    after_label = "baseline + " + ", ".join(report["missing"]) if report["missing"] else "baseline (nothing added)"
    paths["overlay"] = plot_overlay(measurement, {"baseline": curves["before"], after_label: curves["after"]},
                                    folder / f"{stem}_overlay.png", "before and after the diagnosis")
    to_file = 1.0 / measurement.output_factor
    paths["residuals"] = plot_residuals(measurement, {
        "before (baseline)": (measurement.output - curves["before"]) * to_file,
        f"after ({after_label})": (measurement.output - curves["after"]) * to_file,
    }, folder / f"{stem}_residuals.png")

    if measurement.experiment == "isometric":  # the blocked-force picture: tension against pressure per length
        from .compare import plot_isometric
        after = measurement.params
        for effect in report["missing"]:
            after = CANDIDATES[effect].apply(after, report["params"][CANDIDATES[effect].parameter])
        paths["isometric"] = plot_isometric(measurement.inputs["length"], measurement.inputs["pressure"],
                                            measurement.output, measurement.branch,
                                            {"baseline": measurement.params, after_label: after},
                                            folder / f"{stem}_isometric.png", "before and after the diagnosis",
                                            L0=measurement.params.L0)

    if curves["signatures"] is not None:
        order, sigs = curves["signatures"]
        names = [name for name in order if name in sigs]
        if names:
            fig, axes = new_figure(1, len(names), figsize=(3.6 * len(names), 3.4), squeeze=False)
            for ax, name in zip(axes[0], names):
                sig = sigs[name]
                ax.plot(sig["x"], sig["missing"], ".", ms=2, color="0.6", alpha=0.4)
                ax.plot(*_binned(sig["x"], sig["missing"]), "o-", color="tab:red", ms=4)
                ax.axhline(0, color="k", lw=0.5)
                ax.set_xlabel(_AXIS.get((measurement.experiment, name), _AXIS[name]), fontsize=7)
                ax.set_title(f"{name}: r = {sig['correlation']:+.2f}", fontsize=9)
            axes[0, 0].set_ylabel("force the baseline lacks [N]")
            fig.suptitle("signatures: the force the baseline lacks (equation error at the smoothed measured states)",
                         fontsize=9)
            paths["signatures"] = save_png(fig, folder / f"{stem}_signatures.png")
    return {k: str(v) for k, v in paths.items()}


def summary(report: dict) -> list[str]:
    """A readable summary of a diagnosis report, line by line."""
    unit = report["output_unit"]
    lines = [f"{report['file']}: {report['experiment']}, {report['samples']} samples, baseline "
             f"{report['baseline']} ({', '.join(report['baseline_effects']) or 'no effects'})",
             f"baseline: RMSE {report['rmse_before']:.4g} {unit} (whole record), "
             f"{fit_text(report['fit_percent_before'])}"]
    rounds = report["steps"] + ([report["stopped"]] if report["stopped"] and report["stopped"]["candidates"] else [])
    fit_samples = report["rule"]["fit_samples"]
    partial = fit_samples < report["samples"]
    for number, step in enumerate(rounds, 1):
        lines.append(f"round {number}: candidates (best first; RMSE over "
                     + (f"the {fit_samples} fit samples" if partial else "the whole record")
                     + f", held-out over the last {report['rule']['holdout_fraction']:.0%})")
        for row in step["candidates"]:
            if row["bic"] is None:
                lines.append(f"  {row['effect']:<17} could not be simulated")
                continue
            (name, value), = row["params"].items()
            sig = row.get("signature") or {}
            estimate = sig.get("estimate")
            lines.append(f"  {row['effect']:<17} {name} = {value:<10.4g} dBIC {row['delta_bic']:+9.1f}  "
                         f"RMSE {row['rmse']:.4g}  held-out {row['rmse_holdout']:.4g} {unit}  "
                         f"signature r = {sig.get('correlation', 0.0):+.2f}"
                         + (f" (slope says {name} ~ {estimate:.3g})" if estimate is not None else ""))
        for tie in step["ties"]:
            lines.append(f"  near-tie: {' ~ '.join(tie['effects'])} (BIC {tie['bic_difference']:.1f} apart); "
                         f"to tell them apart: {tie['experiment']}")
        if step.get("added"):
            dropped = f" (dropped {', '.join(step['dropped'])}: no longer needed)" if step.get("dropped") else ""
            lines.append(f"  -> added {step['added']}{dropped}: RMSE {step['rmse']:.4g} {unit} (whole record, "
                         f"{report['samples']} samples)")
        else:
            lines.append(f"  -> stop: {step['reason']}")
    if report["stopped"] and not report["stopped"]["candidates"]:
        lines.append(f"stop: {report['stopped']['reason']}")
    if report["missing"]:
        lines.append("missing: " + ", ".join(report["missing"]))
        for name, value in report["params"].items():
            error = report["uncertainty"].get(name)
            plus = f" +- {error:.2g}" if error is not None else ""
            lines.append(f"  {name} = {value:.4g}{plus} {UNITS[name]}")
    else:
        lines.append("missing: nothing (no candidate effect is supported by the data)")
    lines.append(f"after: RMSE {report['rmse_after']:.4g} {unit} (whole record), "
                 f"{fit_text(report['fit_percent_after'])}")
    return lines
