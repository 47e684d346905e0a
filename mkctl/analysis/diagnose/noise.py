"""The noise of a record: of its measured inputs (second differences), of its output (AR(1), read through a
local cubic) and of its inputs as the model passes it to the output.
"""
from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import numpy as np

from ...errors import MkctlError
from ...io.measurements import Measurement
from ..compare import simulate_output
from ..statistics import robust_sigma


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
    return robust_sigma(d2) / math.sqrt(6.0)


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
        from ..filters import ar1_filter

        z = np.random.default_rng(self.seed).standard_normal(n) * self.sigma
        phi = self.correlation
        if phi <= 0:
            return z
        z[1:] *= math.sqrt(1.0 - phi * phi)
        return ar1_filter(z, phi)

    def null_output(self, problem, fit, renoised: Measurement | None = None) -> np.ndarray:
        """The output a record would hold if the fitted model ``fit`` (:class:`.problem.Fit`) of ``problem``
        (:class:`.problem.Problem`) were the truth: its simulation (driven by the
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
    """(1.4826 MAD)^2 (:func:`mkctl.analysis.statistics.robust_sigma`): the variance of the bulk of x, blind
    to the few samples a kink or a step spoils."""
    return robust_sigma(x) ** 2


def _residual_filter(window: int) -> np.ndarray:
    """Impulse response of "signal minus its local cubic" (Savitzky-Golay, centre point) over ``window``."""
    from ..filters import savgol_coeffs

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
    from ..filters import fir_valid

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


#: Records whose model follows its measured inputs sample by sample (no dynamics to filter their
#: noise): a driven-length record's tension follows its measured pressure so too.
QUASI_STATIC = ("isotonic", "isometric", "actuator")

#: How many realisations of the noise the null test of such a record draws (criterion 5: the worst
#: counts).
QUASI_STATIC_NULL_REALISATIONS = 4


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

