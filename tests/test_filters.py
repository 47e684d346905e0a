"""mkctl.analysis.filters computes what scipy.signal's filters compute (the diagnosis uses them so as not to import
scipy.signal and scipy.stats at every start): compared on noisy steps, ramps and sines, every window and order the
diagnosis uses, derivatives included."""
import numpy as np
import pytest
from scipy import signal

from mkctl.analysis import filters


def signals():
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 3.0, 3000)
    yield np.where(t < 1.2, 0.85, 0.84) + 1e-5 * rng.standard_normal(t.size)  # a step with noise [m]
    yield 1.7e6 + 2e3 * rng.standard_normal(t.size) + 1e5 * t                 # a ramp of pressure [Pa]
    yield np.sin(7.0 * t) + 0.01 * rng.standard_normal(t.size)


@pytest.mark.parametrize("window, order", [(5, 2), (9, 2), (11, 3), (31, 3), (51, 3), (8, 2), (101, 3)])
def test_savgol_coeffs_are_scipys(window, order):
    for deriv, delta in ((0, 1.0), (1, 1e-3), (2, 1e-3)):
        ours = filters.savgol_coeffs(window, order, deriv=deriv, delta=delta)
        theirs = signal.savgol_coeffs(window, order, deriv=deriv, delta=delta)
        np.testing.assert_allclose(ours, theirs, rtol=1e-13, atol=1e-13 * np.max(np.abs(theirs)))


@pytest.mark.parametrize("window, order", [(5, 2), (9, 2), (11, 3), (31, 3), (51, 3)])
def test_savgol_filter_is_scipys(window, order):
    for x in signals():
        for deriv, delta in ((0, 1.0), (1, 1e-3), (2, 1e-3)):
            ours = filters.savgol_filter(x, window, order, deriv=deriv, delta=delta)
            theirs = signal.savgol_filter(x, window, order, deriv=deriv, delta=delta)
            np.testing.assert_allclose(ours, theirs, rtol=1e-12, atol=1e-12 * np.max(np.abs(theirs)))
    with pytest.raises(ValueError):
        filters.savgol_filter(np.ones(4), 5, 2)


def test_the_fir_and_ar1_filters_are_lfilters():
    h = -signal.savgol_coeffs(31, 3)
    h[15] += 1.0
    for x in signals():
        theirs = signal.lfilter(h, [1.0], x)[h.size - 1:]
        np.testing.assert_allclose(filters.fir_valid(h, x), theirs, rtol=1e-12, atol=1e-12 * np.max(np.abs(x)))
        for phi in (0.0, 0.5, 0.97):
            np.testing.assert_array_equal(filters.ar1_filter(x, phi), signal.lfilter([1.0], [1.0, -phi], x))
