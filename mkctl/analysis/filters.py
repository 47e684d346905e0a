"""The signal filters the diagnosis uses, without importing scipy.signal.

scipy.signal imports scipy.stats, together about a third of a second of ``mkctl diagnose``'s start for three
functions. These are the same computations as scipy.signal's, step for step (the least squares of
``scipy.linalg.lstsq``, the convolution of ``scipy.ndimage.convolve1d``, the same polynomial edges), on modules a
diagnosis loads anyway; ``tests/test_filters.py`` compares them with scipy.signal's.

- :func:`savgol_coeffs`: ``scipy.signal.savgol_coeffs`` (centred window, ``use="conv"``);
- :func:`savgol_filter`: ``scipy.signal.savgol_filter`` with its default ``mode="interp"`` on a 1-D array;
- :func:`fir_valid`: ``scipy.signal.lfilter(h, [1.0], x)[len(h) - 1:]``, the samples a FIR filter fills completely;
- :func:`ar1_filter`: ``scipy.signal.lfilter([1.0], [1.0, -phi], z)``, ``y_k = z_k + phi y_(k-1)``.

Example
-------
>>> import numpy as np
>>> from mkctl.analysis.filters import savgol_filter
>>> np.round(savgol_filter(np.array([2, 2, 5, 2, 1, 0, 1, 4, 9.0]), 5, 2), 2)
array([1.66, 3.17, 3.54, 2.86, 0.66, 0.17, 1.  , 4.  , 9.  ])
"""
from __future__ import annotations

import math

import numpy as np


def _lstsq(a, b):
    """Least squares as scipy.signal solves them (LAPACK gelsd, cut-off eps times the larger dimension)."""
    from scipy.linalg import lstsq

    return lstsq(a, b, cond=np.finfo(float).eps * max(a.shape[-1], a.shape[-2]))[0]


def savgol_coeffs(window_length: int, polyorder: int, deriv: int = 0, delta: float = 1.0) -> np.ndarray:
    """Convolution coefficients of a Savitzky-Golay filter: the least-squares polynomial of degree polyorder over
    window_length samples, its deriv-th derivative at the window's centre, samples delta apart."""
    if polyorder >= window_length:
        raise ValueError("polyorder must be less than window_length.")
    if deriv > polyorder:
        return np.zeros(window_length)
    halflen, rem = divmod(window_length, 2)
    pos = halflen - 0.5 if rem == 0 else halflen
    x = np.arange(-pos, window_length - pos, dtype=float)[::-1]
    A = x ** np.arange(polyorder + 1, dtype=float).reshape(-1, 1)
    y = np.zeros(polyorder + 1)
    y[deriv] = float(math.factorial(deriv)) / (delta ** deriv)
    return _lstsq(A, y)


def _polyfit(x, y, degree: int) -> np.ndarray:
    """Old-style polynomial coefficients (highest power first) of the least-squares fit, columns of y."""
    powers = np.arange(degree + 1, dtype=float)[::-1]
    lhs = x[:, None] ** powers[None, :]
    scale = np.sqrt(np.sum(lhs * lhs, axis=0))
    lhs /= scale
    return (_lstsq(lhs, y).T / scale).T


def _polyder(p: np.ndarray, m: int) -> np.ndarray:
    n = p.shape[0]
    if m == 0:
        return p
    if n <= m:
        return np.zeros_like(p[:1, ...])
    dp = np.array(p[:-m, ...], copy=True)
    for k in range(m):
        dp *= np.arange(n - k - 1, m - k - 1, -1, dtype=p.dtype).reshape((n - m,) + (1,) * (p.ndim - 1))
    return dp


def _fit_edge(x, window_start, window_stop, interp_start, interp_stop, polyorder, deriv, delta, y) -> None:
    edge = x[window_start:window_stop].reshape(-1, 1)
    coeffs = _polyder(_polyfit(np.arange(0, window_stop - window_start, dtype=float), edge, polyorder), deriv)
    i = np.arange(interp_start - window_start, interp_stop - window_start, dtype=float).reshape(-1, 1)
    values = np.zeros_like(i)
    for j in range(coeffs.shape[0]):  # Horner, as scipy.signal's polyval
        values = values * i + coeffs[j, ...]
    y[interp_start:interp_stop] = (values / (delta ** deriv)).reshape(-1)


def savgol_filter(x, window_length: int, polyorder: int, deriv: int = 0, delta: float = 1.0) -> np.ndarray:
    """A 1-D signal smoothed (or differentiated, deriv > 0, samples delta apart) by a Savitzky-Golay filter; the
    first and last window_length // 2 samples from the polynomial fitted to the first and last window."""
    from scipy.ndimage import convolve1d

    x = np.asarray(x, dtype=float)
    if window_length > x.shape[0]:
        raise ValueError("If mode is 'interp', window_length must be less than or equal to the size of x.")
    y = convolve1d(x, savgol_coeffs(window_length, polyorder, deriv, delta), mode="constant")
    halflen, n = window_length // 2, x.shape[0]
    _fit_edge(x, 0, window_length, 0, halflen, polyorder, deriv, delta, y)
    _fit_edge(x, n - window_length, n, n - halflen, n, polyorder, deriv, delta, y)
    return y


def fir_valid(h, x) -> np.ndarray:
    """``sum_i h_i x_(k-i)`` at every k where the whole of h lies on x: lfilter(h, [1], x)[len(h) - 1:]."""
    return np.convolve(np.asarray(x, dtype=float), np.asarray(h, dtype=float), mode="valid")


def ar1_filter(z, phi: float) -> np.ndarray:
    """``y_0 = z_0``, ``y_k = z_k + phi y_(k-1)``: AR(1) noise from its innovations z (lfilter([1], [1, -phi], z))."""
    z = np.asarray(z, dtype=float)
    y = z.tolist()
    for k in range(1, len(y)):
        y[k] += phi * y[k - 1]
    return np.array(y)
