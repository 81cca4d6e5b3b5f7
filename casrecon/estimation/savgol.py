"""Savitzky-Golay smoothing and differentiation with numpy and ``scipy.linalg`` only.

:func:`savgol_coeffs` and :func:`savgol_filter` give the numbers of ``scipy.signal.savgol_coeffs`` and
``scipy.signal.savgol_filter`` (mode ``"interp"``) bit for bit (the same least-squares solve, and the
same sums in the same order as ``scipy.ndimage.correlate1d``), without importing ``scipy.signal``,
which costs about 0.7 s (it imports ``scipy.stats``) in every ``casrecon fit``. Samples within half a
window of either end (where scipy fits a polynomial to the edge) are computed by ``scipy.signal``
itself, imported only then.
"""

from __future__ import annotations

import math

import numpy as np
from scipy.linalg import lstsq

__all__ = ["savgol_coeffs", "savgol_filter"]

EPS = np.finfo(float).eps


def savgol_coeffs(window: int, order: int, deriv: int = 0, delta: float = 1.0, pos: int | None = None,
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
    pos : int, optional
        Position in the window of the evaluated sample (default the middle).
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
        The samples wanted (default all); ``scipy.signal`` is imported only when one of them lies
        within half a window of an end.

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
    if not inner.all():
        from scipy.signal import savgol_filter as scipy_savgol  # the edges: polynomial fits

        for part in (slice(0, window), slice(n - window, n)):
            at = ~inner & (rows >= part.start) & (rows < part.stop)
            if at.any():
                edge = scipy_savgol(x[part], window, order, deriv=deriv, delta=delta, axis=0, mode="interp")
                out[at] = edge[rows[at] - part.start]
    return out
