"""The statistics and the sampled-signal operations of :mod:`mkctl.analysis.statistics` and
:mod:`mkctl.analysis.signals`, each against an independent computation, and each defined once.

The references: AR(1) noise made with scipy.signal.lfilter (not mkctl's filter) and the spread of
many of its realisations; BIC and the least-squares covariance by their textbook formulas with
numpy's inverse; the median absolute deviation of scipy.stats; a held command through a lag against
the exponential's closed form.
"""
from __future__ import annotations

import ast
import math
from pathlib import Path

import numpy as np
import pytest
from scipy.signal import lfilter
from scipy.stats import median_abs_deviation

from mkctl.analysis import signals, statistics

PACKAGE = Path(__file__).resolve().parents[1] / "mkctl"


def ar1(rng, phi: float, shape) -> np.ndarray:
    """Stationary AR(1) noise of unit variance along the last axis, by scipy's lfilter."""
    z = rng.standard_normal(shape)
    z[..., 1:] *= math.sqrt(1.0 - phi * phi)
    return lfilter([1.0], [1.0, -phi], z, axis=-1)


def test_effective_samples_of_ar1_noise_is_what_the_spread_of_its_mean_says():
    phi, n = 0.6, 400
    means = ar1(np.random.default_rng(1), phi, (4000, n)).mean(axis=1)
    # var(mean) = sigma^2 / n_eff: the count of white samples that give the same spread
    measured = 1.0 / np.var(means)
    assert statistics.effective_samples(n, phi) == pytest.approx(measured, rel=0.06)
    assert statistics.effective_samples(n, phi) == pytest.approx(n * 0.4 / 1.6)
    assert statistics.effective_samples(n, 0.0) == n and statistics.effective_samples(n, -0.2) == n


def test_the_integrated_count_agrees_with_the_ar1_count_on_ar1_noise():
    phi, n = 0.8, 20000
    x = ar1(np.random.default_rng(2), phi, n)
    assert statistics.lag_one_correlation(x) == pytest.approx(phi, abs=0.02)
    assert statistics.integrated_effective_samples(x) == pytest.approx(
        statistics.effective_samples(n, phi), rel=0.15)
    white = np.random.default_rng(3).standard_normal(n)
    assert statistics.integrated_effective_samples(white) == pytest.approx(n, rel=0.05)


def test_lag_one_correlation_is_capped_and_zero_for_a_constant():
    ramp = np.linspace(0, 1, 100)
    assert statistics.lag_one_correlation(ramp) == statistics.MAX_LAG_ONE_CORRELATION
    assert statistics.lag_one_correlation(np.ones(10)) == 0.0


def test_bic_is_the_hand_formula():
    rss, n, k = 3.7, 250, 3
    assert statistics.bic(rss, n, k) == pytest.approx(n * math.log(rss / n) + k * math.log(n))
    m = 80.0
    assert statistics.bic(rss, n, k, m) == pytest.approx(m * math.log(rss / n) + k * math.log(m))
    assert statistics.bic(rss, n, k, 1e6) == statistics.bic(rss, n, k)  # m never above n
    assert math.isfinite(statistics.bic(0.0, n, k))


def test_robust_sigma_is_the_normal_scaled_mad_and_ignores_outliers():
    rng = np.random.default_rng(4)
    x = rng.normal(5.0, 2.0, 5000)
    x[:50] = 1e4  # a few spoiled samples
    mad = median_abs_deviation(x, scale="normal")
    assert statistics.robust_sigma(x) == pytest.approx(mad, rel=1e-4)
    assert statistics.robust_sigma(x) == pytest.approx(2.0, rel=0.05)


def test_covariance_is_ordinary_least_squares_and_matches_the_spread_of_estimates():
    rng = np.random.default_rng(5)
    n = 200
    A = np.column_stack([np.ones(n), np.linspace(0, 1, n)])
    y = A @ [1.0, 2.0] + rng.normal(0, 0.3, n)
    b, *_ = np.linalg.lstsq(A, y, rcond=None)
    r = y - A @ b
    expected = float(r @ r) / (n - 2) * np.linalg.inv(A.T @ A)
    np.testing.assert_allclose(statistics.covariance(A, r), expected, rtol=1e-10)
    # the widening rule: AR(1) residuals of correlation phi widen by n / n_eff = (1+phi) / (1-phi)
    phi = 0.5
    wide = statistics.covariance(A, r, n_effective=statistics.effective_samples(n, phi))
    np.testing.assert_allclose(wide, expected * (1 + phi) / (1 - phi), rtol=1e-10)
    # and that widening is what the spread of the estimates under AR(1) noise shows
    noise = 0.3 * ar1(rng, phi, (3000, n))
    estimates = np.linalg.lstsq(A, (A @ [1.0, 2.0])[:, None] + noise.T, rcond=None)[0]
    spread = np.std(estimates, axis=1)
    sample_r = noise[0] - A @ np.linalg.lstsq(A, noise[0], rcond=None)[0]
    predicted = statistics.standard_errors(statistics.covariance(
        A, sample_r, n_effective=statistics.effective_samples(n, phi)))
    np.testing.assert_allclose(predicted, spread, rtol=0.2)


def test_covariance_of_one_estimate_and_a_given_rss():
    j = np.array([1.0, 2.0, 3.0, 4.0])
    r = np.array([0.1, -0.1, 0.2, 0.0])
    one = statistics.covariance(j, r, parameters=2)[0, 0]
    assert one == pytest.approx(float(r @ r) / 2 / float(j @ j))
    assert statistics.covariance(j, rss=0.6)[0, 0] == pytest.approx(0.6 / 3 / float(j @ j))


def test_held_out_strategies():
    t = np.linspace(0.0, 10.0, 11)
    assert statistics.last_part(t, 0.3).tolist() == [True] * 8 + [False] * 3
    assert np.flatnonzero(statistics.every_kth(10, 4)).tolist() == [3, 7]
    train = statistics.alternate_blocks(np.ones(12, bool), 4)
    assert train.tolist() == [True] * 3 + [False] * 3 + [True] * 3 + [False] * 3


def test_the_stepwise_engine_finds_the_terms_of_a_hand_built_problem():
    rng = np.random.default_rng(6)
    n = 400
    columns = {f"x{i}": rng.standard_normal(n) for i in range(1, 6)}
    y = 3.0 * columns["x1"] + 0.5 * columns["x3"] + rng.normal(0, 0.05, n)
    selected = []

    def rss_of(names):
        if not names:
            return float(y @ y)
        A = np.column_stack([columns[c] for c in names])
        coef, *_ = np.linalg.lstsq(A, y, rcond=None)
        r = y - A @ coef
        return float(r @ r)

    def judge(tried):
        name = min(tried, key=tried.get)
        k = len(selected)
        gain = statistics.bic(tried[name], n, k + 1) - statistics.bic(rss_of(selected), n, k)
        return (True, name) if gain < -10 else (False, f"{name} gains only {gain:.1f}")

    ended = statistics.forward_stepwise(
        lambda: [c for c in columns if c not in selected],
        lambda left: {c: rss_of([*selected, c]) for c in left}, judge, selected.append,
        exhausted="nothing left")
    assert selected == ["x1", "x3"]
    assert rss_of(selected) == pytest.approx(0.05 ** 2 * n, rel=0.2)
    assert ended.startswith("x") and "gains only" in ended
    # with every term needed, it stops when nothing is left
    everything = []
    ended = statistics.forward_stepwise(
        lambda: [c for c in "abc" if c not in everything], lambda left: {c: 0.0 for c in left},
        lambda fits: (True, min(fits)), everything.append, exhausted="nothing left")
    assert everything == ["a", "b", "c"] and ended == "nothing left"


def test_a_held_command_through_a_lag_is_the_exponential():
    time = np.linspace(0.0, 0.5, 501)
    command = np.full(time.size, 1e5)
    command[100:] = 2e5  # held from t_100 on
    tau = 0.03
    rising = 2e5 - 1e5 * np.exp(-(time - time[100]) / tau)
    expected = np.where(np.arange(time.size) >= 100, rising, 1e5)
    np.testing.assert_allclose(signals.lagged(time, command, tau), expected, rtol=1e-9)
    # the pressure path without a dead time and without an exhausting rate is the same lag
    np.testing.assert_allclose(signals.pressure_path(time, command, tau=tau), expected, rtol=1e-9)


def test_a_delay_shifts_the_held_signal_and_an_exhausting_lag_is_slower_going_down():
    time = np.arange(10) * 0.01
    values = np.arange(10.0)
    assert signals.delayed(time, values, 0.03).tolist() == [0, 0, 0, 0, 1, 2, 3, 4, 5, 6]
    np.testing.assert_array_equal(signals.pressure_path(time, values, delay=0.03),
                                  signals.delayed(time, values, 0.03))
    down = np.linspace(0.0, 1.0, 1001)
    step = np.full(down.size, 1e5)
    step[100:] = 0.0
    fast = signals.pressure_path(down, step, tau=0.01)
    slow = signals.pressure_path(down, step, tau=0.01, tau_exhaust=0.05)
    k = 150
    assert slow[k] == pytest.approx(1e5 * math.exp(-(down[k] - down[100]) / 0.05), rel=1e-9)
    assert slow[k] > fast[k]


# --- Each statistic is defined once -----------------------------------------------------------

#: A definition's name -> the one module that may define it.
DEFINED_ONCE = {
    "effective_samples": "statistics", "integrated_effective_samples": "statistics",
    "bic": "statistics", "robust_sigma": "statistics", "covariance": "statistics", "lag_one_correlation": "statistics",
    "standard_errors": "statistics", "forward_stepwise": "statistics",
    "lagged": "signals", "delayed": "signals", "held_at": "signals", "pressure_path": "signals",
}


#: The names the copies had before (the discovery's lag and delay, the diagnosis's lag-one
#: correlation).
OLD_COPIES = {"_lag": "lagged", "_delayed": "delayed",
              "_lag_one_correlation": "lag_one_correlation", "_robust_sigma": "robust_sigma"}


def module_functions(tree) -> list[str]:
    """The names of the functions a module defines at its top level (methods aside)."""
    return [node.name for node in tree.body if isinstance(node, ast.FunctionDef)]


def robust_sigma_copies(tree) -> list[int]:
    """Lines that compute a median absolute deviation or use its 1.4826 factor."""
    lines = []
    for node in ast.walk(tree):
        if isinstance(node, ast.Constant) and node.value == 1.4826:
            lines.append(node.lineno)
        call = isinstance(node, ast.Call) and node.args and isinstance(node.args[0], ast.Call)
        if call and getattr(node.func, "attr", None) == "median" \
                and getattr(node.args[0].func, "attr", None) == "abs":
            lines.append(node.lineno)
        if isinstance(node, ast.Attribute) and node.attr == "pinv":
            lines.append(node.lineno)
    return lines


def test_each_statistic_and_signal_operation_is_defined_once():
    found = {}
    for path in sorted(PACKAGE.rglob("*.py")):
        tree = ast.parse(path.read_text(), str(path))
        where = str(path.relative_to(PACKAGE.parent))
        for name in module_functions(tree):
            name = OLD_COPIES.get(name, name)
            if name in DEFINED_ONCE:
                found.setdefault(name, []).append(where)
        if path.stem != "statistics":
            copies = robust_sigma_copies(tree)
            assert not copies, f"{where}, lines {copies}: a robust sigma or covariance outside statistics"
    for name, module in DEFINED_ONCE.items():
        where = found.get(name)
        assert where == [f"mkctl/analysis/{module}.py"], f"{name} defined in {where}"


def test_the_scan_sees_a_copy(tmp_path):
    source = "import numpy as np\n\ndef s(x):\n    return 1.4826 * np.median(np.abs(x - np.median(x)))\n"
    tree = ast.parse(source)
    assert robust_sigma_copies(tree) == [4, 4]
    assert module_functions(ast.parse("def bic(r, n, k):\n    return 0\n")) == ["bic"]
