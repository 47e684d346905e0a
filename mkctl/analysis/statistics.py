"""The statistics of identification, each defined once: the diagnosis, the calibration and the
discovery call these.

- :func:`robust_sigma`: the standard deviation of the bulk of a sample, ``1.4826 MAD``;
- :func:`lag_one_correlation`: a residual's lag-one autocorrelation (capped, for the widening);
- :func:`effective_samples`: how many independent samples n samples of AR(1) noise are worth,
  ``n (1 - phi) / (1 + phi)``; :func:`integrated_effective_samples`: the same count read from a
  residual's integrated autocorrelation, for a residual whose colour is not AR(1) (the discovery's;
  see its docstring);
- :func:`bic`: ``m ln(RSS / n) + k ln m``, m the effective sample count;
- :func:`covariance` and :func:`standard_errors`: ``s^2 (J^T J)^+``, ``s^2 = RSS / (n - k)``, with
  the one widening rule for correlated residuals: multiplied by ``n / n_eff`` (for AR(1) residuals
  of lag-one correlation rho that is ``(1 + rho) / (1 - rho)``);
- the held-out strategies: :func:`last_part` (in time: a prediction), :func:`every_kth`
  (interleaved points), :func:`alternate_blocks` (contiguous blocks, every other one fits);
- :func:`forward_stepwise`: the one forward stepwise engine (fit what is left, judge, add or stop)
  that the diagnosis's and the calibration's :func:`mkctl.analysis.diagnosis_rule.forward_selection`
  (the rule's criteria, null tests, ties, requirements) and the discovery's
  :func:`mkctl.analysis.discovery.select_terms` run on, each with its own criteria.
"""
from __future__ import annotations

import math
from typing import Callable

import numpy as np

#: 1 / Phi^-1(3/4): the median absolute deviation of Gaussian noise times this is its standard
#: deviation.
MAD_TO_SIGMA = 1.4826
#: The lag-one correlation :func:`lag_one_correlation` reports at most (the widening stays finite).
MAX_LAG_ONE_CORRELATION = 0.95
#: The AR(1) correlation :func:`effective_samples` takes at most.
MAX_AR1_CORRELATION = 0.99


def robust_sigma(x) -> float:
    """Standard deviation of the bulk of ``x`` [its unit]: ``1.4826 median(|x - median(x)|)``.

    Blind to the few samples a kink or a step spoils; for Gaussian noise it estimates sigma.
    """
    x = np.asarray(x, dtype=float)
    return float(MAD_TO_SIGMA * np.median(np.abs(x - np.median(x))))


def lag_one_correlation(residual, cap: float = MAX_LAG_ONE_CORRELATION) -> float:
    """``sum r_k r_(k-1) / sum r_k^2`` of the residual less its mean, at most ``cap``; 0 for fewer
    than 3 samples or a constant residual."""
    r = np.asarray(residual, dtype=float) - np.mean(residual)
    denominator = float(r @ r)
    if r.size < 3 or denominator == 0:
        return 0.0
    return float(min(cap, (r[1:] @ r[:-1]) / denominator))


def effective_samples(n: int, correlation: float) -> float:
    """The effective count of independent samples among n whose noise is AR(1) with lag-one
    ``correlation`` phi: ``n (1 - phi) / (1 + phi)`` (the variance of a mean of AR(1) noise is that
    many times sigma^2 / n larger); n for phi <= 0. phi is taken at most
    :data:`MAX_AR1_CORRELATION`."""
    phi = min(float(correlation), MAX_AR1_CORRELATION)
    return float(n) if phi <= 0 else n * (1.0 - phi) / (1.0 + phi)


def integrated_effective_samples(residual) -> float:
    """``n / (1 + 2 sum rho_k)``: the effective samples of a residual from its autocorrelation
    rho_k, summed until it first falls below 0.05; between 2 and n.

    For AR(1) noise this is :func:`effective_samples` (``1 + 2 sum phi^k = (1 + phi) / (1 - phi)``).
    The discovery's missing force is not AR(1): it is the smoothed equation error, which a
    Savitzky-Golay window correlates over the whole window, so its lag-one correlation alone
    misjudges how much it holds. Measured: with the AR(1) count (at the residual's lag-one
    correlation) in :func:`mkctl.analysis.discovery.select_terms` the discovery proposes nothing
    for a threshold pressure (``test_a_threshold_pressure_is_named_and_its_p0_estimated`` in
    ``tests/test_discovery.py`` fails), so the discovery keeps this definition and the diagnosis,
    whose output noise is AR(1) (:func:`mkctl.analysis.diagnose.noise_model`), the other.
    """
    r = np.asarray(residual, dtype=float)
    r = r - r.mean()
    n = r.size
    denominator = float(r @ r)
    if n < 4 or denominator == 0:
        return float(n)
    spectrum = np.fft.rfft(r, 2 * n)
    acf = np.fft.irfft(spectrum * np.conj(spectrum))[:n] / denominator
    below = np.flatnonzero(acf[1:] < 0.05)
    stop = int(below[0]) + 1 if below.size else n
    integrated = 1.0 + 2.0 * float(np.sum(acf[1:stop]))
    return float(max(min(n / max(integrated, 1.0), n), 2.0))


def bic(rss: float, n: int, k: int, n_effective: float | None = None) -> float:
    """Bayesian information criterion ``m ln(RSS / n) + k ln m`` of a least-squares fit, m the
    effective samples (n_effective, else n).

    Parameters
    ----------
    rss : float
        The residual sum of squares [any unit, squared]; a zero RSS is taken as 1e-300.
    n : int
        The samples compared.
    k : int
        The parameters fitted.
    n_effective : float, optional
        The effective count of independent samples when the noise is correlated
        (:func:`effective_samples`), kept within [1, n]; None: n (white noise).

    Returns
    -------
    float
    """
    m = float(n if n_effective is None else min(max(n_effective, 1.0), n))
    return m * math.log(max(float(rss), 1e-300) / n) + k * math.log(m)


def covariance(jacobian, residual=None, parameters: int | None = None,
               n_effective: float | None = None, rss: float | None = None) -> np.ndarray:
    """Covariance of least-squares estimates: ``s^2 (J^T J)^+ n / n_eff``, ``s^2 = RSS / (n - k)``.

    The one widening rule: correlated residuals carry the information of n_eff independent samples,
    so the covariance of white residuals is multiplied by ``n / n_eff`` (AR(1) of lag-one
    correlation rho: ``(1 + rho) / (1 - rho)``, :func:`effective_samples`).

    Parameters
    ----------
    jacobian : array (n, p), or (n,) for one estimate
        The residual's derivatives by the p estimates, at n samples.
    residual : array (n,), optional
        The residual at the estimates (its sum of squares is RSS).
    parameters : int, optional
        k in the degrees of freedom n - k (default p; at least one degree of freedom is kept).
    n_effective : float, optional
        The effective samples (None: n, no widening).
    rss : float, optional
        RSS itself, when it is not the residual's (the calibration's: the training points' RSS).

    Returns
    -------
    array (p, p)
    """
    J = np.asarray(jacobian, dtype=float)
    if J.ndim == 1:
        J = J[:, None]
    n = J.shape[0]
    k = J.shape[1] if parameters is None else parameters
    if rss is None:
        r = np.asarray(residual, dtype=float)
        rss = float(r @ r)
    s2 = float(rss) / max(n - k, 1)
    widen = 1.0 if n_effective is None else n / n_effective
    return widen * s2 * np.linalg.pinv(J.T @ J)


def standard_errors(cov) -> np.ndarray:
    """The square roots of a covariance's diagonal (negative round-off taken as 0)."""
    return np.sqrt(np.clip(np.diag(np.atleast_2d(cov)), 0.0, None))


# --- Held-out strategies ----------------------------------------------------------------------

def last_part(time, fraction: float) -> np.ndarray:
    """Training mask of a record whose last ``fraction`` of the time span is held out (a
    prediction)."""
    t = np.asarray(time, dtype=float)
    return t <= t[0] + (1.0 - fraction) * (t[-1] - t[0])


def every_kth(n: int, k: int) -> np.ndarray:
    """Held-out mask: every k-th point (index k - 1 modulo k)."""
    return np.arange(n) % k == k - 1


def alternate_blocks(used, blocks: int) -> np.ndarray:
    """Training mask: the used samples in ``blocks`` contiguous blocks, the even blocks fit."""
    index = np.flatnonzero(used)
    train = np.zeros(np.size(used), bool)
    for b, part in enumerate(np.array_split(index, blocks)):
        if b % 2 == 0:
            train[part] = True
    return train


# --- The stepwise engine ----------------------------------------------------------------------

def forward_stepwise(remaining: Callable[[], list], fit_round: Callable[[list], object],
                     judge: Callable[[object], tuple[bool, object]], add: Callable[[object], None],
                     exhausted: object = None) -> object:
    """The forward stepwise engine: round after round, fit what is left, judge, add the winner or
    stop.

    The diagnosis and the calibration (:func:`mkctl.analysis.diagnosis_rule.forward_selection`: the
    rule's criteria, null tests, ties and requirements in ``judge``) and the discovery
    (:func:`mkctl.analysis.discovery.select_terms`: BIC at the effective samples and the held-out
    gain) run on it; each brings its own criteria.

    Parameters
    ----------
    remaining : callable
        ``remaining()`` -> what can still be added (asked each round: what was dropped may come
        back).
    fit_round : callable
        ``fit_round(left)`` -> this round's fits of each of ``left`` added to the current model.
    judge : callable
        ``judge(fits)`` -> (whether to add, the decision: what ``add`` adopts, or why the selection
        stops).
    add : callable
        ``add(decision)`` adopts the winner.
    exhausted : optional
        Returned when nothing is left.

    Returns
    -------
    The decision that ended the selection, or ``exhausted``.
    """
    while True:
        left = remaining()
        if not left:
            return exhausted
        accepted, decision = judge(fit_round(left))
        if not accepted:
            return decision
        add(decision)
