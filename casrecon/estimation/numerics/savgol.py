"""Savitzky-Golay smoothing and differentiation with numpy and ``scipy.linalg`` only.

:func:`savgol_coeffs` and :func:`savgol_filter` give the numbers of ``scipy.signal.savgol_coeffs`` and
``scipy.signal.savgol_filter`` (mode ``"interp"``) bit for bit (the same least-squares solve, and the
same sums in the same order as ``scipy.ndimage.correlate1d``; near the ends the same polynomial fit
to the first and last window), without importing ``scipy.signal``, which
costs about 0.7 s (it imports ``scipy.stats``) in every ``casrecon fit``.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import lstsq

__all__ = ["savgol_coeffs", "savgol_filter"]

EPS = np.finfo(float).eps


def savgol_coeffs(window: int, order: int, deriv: int = 0, delta: float = 1.0, pos: float | None = None,
                  use: str = "conv") -> np.ndarray:
    """Weights of a Savitzky-Golay filter, as ``scipy.signal.savgol_coeffs`` computes them.

    Parameters
    ----------
    window : int
        Window length, samples.
    order : int
        Polynomial order (< window).
    deriv : int
        Derivative order (0: smoothing).
    delta : float
        Sample spacing (s for a time series); derivative weights are per ``delta ** deriv``.
    pos : float, optional
        Position in the window of the evaluated point, samples (default the middle; a fraction
        evaluates the fitted polynomial between samples).
    use : {"conv", "dot"}
        ``"dot"``: weights in window order (a dot product with the window); ``"conv"``: reversed.

    Returns
    -------
    (window,) array
    """
    if order >= window:
        raise ValueError("order must be less than window")
    half, rem = divmod(window, 2)
    pos = (half if rem else half - 0.5) if pos is None else pos
    if not 0 <= pos < window:
        raise ValueError("pos must be nonnegative and less than window")
    if deriv > order:
        return np.zeros(window)
    x = np.arange(-pos, window - pos, dtype=np.float64)
    if use == "conv":
        x = np.flip(x)
    a = x ** np.arange(order + 1, dtype=np.float64).reshape(-1, 1)
    y = np.zeros(order + 1)
    y[deriv] = float(math.factorial(deriv)) / (delta ** deriv)
    return lstsq(a, y, cond=EPS * max(a.shape[-1], a.shape[-2]))[0]


def _correlate(x: np.ndarray, w: np.ndarray, rows: np.ndarray) -> np.ndarray:
    """sum_j x[rows + j - c] w[j] along axis 0 (c the middle of the odd-length ``w``), in the order
    ``scipy.ndimage.correlate1d`` adds them (pairs of samples for (anti)symmetric weights)."""
    c = w.size // 2
    if np.all(np.abs(w[c + 1:] - w[c - 1::-1][:c]) <= EPS):
        sign = 1.0
    elif np.all(np.abs(w[c + 1:] + w[c - 1::-1][:c]) <= EPS):
        sign = -1.0
    else:
        out = x[rows + c] * w[-1]
        for j in range(-c, c):
            out += x[rows + j] * w[c + j]
        return out
    out = x[rows] * w[c]
    for j in range(-c, 0):
        out += (x[rows + j] + x[rows - j]) * w[c + j] if sign > 0 else (x[rows + j] - x[rows - j]) * w[c + j]
    return out


def savgol_filter(x: np.ndarray, window: int, order: int, deriv: int = 0, delta: float = 1.0,
                  rows: np.ndarray | None = None) -> np.ndarray:
    """Savitzky-Golay filter along axis 0, as ``scipy.signal.savgol_filter(..., mode="interp", axis=0)``.

    Parameters
    ----------
    x : (n, ...) array
        Samples, uniformly spaced by ``delta`` along axis 0.
    window, order, deriv, delta
        As in :func:`savgol_coeffs` (``window`` odd, at most n).
    rows : (m,) int array, optional
        The samples wanted (default all).

    Returns
    -------
    (m, ...) array
        Smoothed samples, or their ``deriv``-th derivative per ``delta ** deriv``, at ``rows``.
    """
    x = np.asarray(x, dtype=np.float64)
    n, half = x.shape[0], window // 2
    if window % 2 == 0 or window > n:
        raise ValueError("window must be odd and at most the number of samples")
    rows = np.arange(n) if rows is None else np.asarray(rows, dtype=np.intp)
    w = savgol_coeffs(window, order, deriv, delta)[::-1]  # correlation weights, as scipy.ndimage.convolve1d
    inner = (rows >= half) & (rows < n - half)
    out = np.empty((rows.size, *x.shape[1:]))
    out[inner] = _correlate(x, w, rows[inner])
    for part in (slice(0, window), slice(n - window, n)):
        at = ~inner & (rows >= part.start) & (rows < part.stop)
        if at.any():
            out[at] = _edge(x[part], rows[at] - part.start, order, deriv, delta)
    return out


def _edge(x: np.ndarray, at: np.ndarray, order: int, deriv: int, delta: float) -> np.ndarray:
    """The filter near an end, as scipy's mode ``"interp"`` computes it: a polynomial of ``order``
    fitted to the first (or last) window ``x`` (scaled Vandermonde, least squares), differentiated
    ``deriv`` times and evaluated at the window positions ``at``."""
    window = x.shape[0]
    y = x.reshape(window, -1)
    t = np.arange(0, window, dtype=np.float64)
    lhs = t[:, None] ** np.flip(np.arange(order + 1, dtype=np.float64))[None, :]
    scale = np.sqrt(np.sum(lhs * lhs, axis=0))
    lhs /= scale
    c = (lstsq(lhs, y, cond=window * EPS)[0].T / scale).T
    if deriv > 0:
        m = c.shape[0]
        if m <= deriv:
            c = np.zeros_like(c[:1])
        else:
            c = c[:-deriv].copy()
            for k in range(deriv):
                c *= np.arange(m - k - 1, deriv - k - 1, -1, dtype=np.float64).reshape(-1, 1)
    u = np.asarray(at, dtype=np.float64).reshape(-1, 1)
    v = np.zeros_like(u)
    for j in range(c.shape[0]):
        v = v * u + c[j]
    return (v / (delta ** deriv)).reshape(u.shape[0], *x.shape[1:])
