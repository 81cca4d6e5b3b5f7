"""Time correlation of GPS errors: white noise plus a first-order Gauss-Markov process, estimated
from series of normalised errors (pure numpy/scipy).

Model, per error component and fix k (sigma_k the receiver's reported accuracy)::

    e_k / sigma_k = sqrt(r) * (sqrt(1 - f) w_k + sqrt(f) g_k),   g_k = phi g_{k-1} + sqrt(1 - phi^2) u_k

with w, u white N(0, 1), phi = exp(-dt / tau). So the normalised error has variance r (the
variance ratio: 1 when the reported accuracies are right, below 1 when they are pessimistic) and
autocorrelation rho(lag) = f phi^lag for lag >= 1.

The series rarely reach us bare: the truth is unknown, so it has to be removed first, and how it
is removed decides which estimator is exact:

- :func:`fit_gauss_markov`: each segment is detrended (its mean removed where the truth is a
  constant, a low-order polynomial where it is smooth) or differenced. Detrending also removes the
  errors' lowest frequencies, which biases a naive autocorrelation towards short correlation times,
  so the pooled empirical autocovariances at lags 0..L are fitted to their *expected* values under
  the model after the same detrending or differencing (computed exactly, segment by segment), not to
  the model's own. For a given phi the expected values are linear in r (1 - f) and r f (non-negative
  least squares); phi is found by a grid and a bounded line search on log tau.
- :func:`fit_gauss_markov_variogram`: for errors known up to a constant per segment (such as the
  position minus the integrated velocity), the structure function D(lag) = E[(x[k + lag] - x[k])^2]
  / sigma^2 = 2 r (1 - f) + 2 r f (1 - phi^lag) needs no detrending and no correction; it is fitted
  in relative units at the given lags.

Standard errors come from a jackknife over groups of segments. A tau that runs to its upper bound
(``tau_at_bound``) means the data only see the start of the correlated part: its variance grows
linearly with the lag over the lags seen, and only r f / tau is determined.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from functools import lru_cache

import numpy as np
from scipy.optimize import minimize_scalar, nnls
from scipy.signal import lfilter


@dataclass(frozen=True)
class GaussMarkovFit:
    """White plus first-order Gauss-Markov fit of normalised error series.

    Attributes
    ----------
    variance_ratio : float
        r: variance of the normalised error (empirical error variance / reported sigma^2), before
        any detrending or differencing, dimensionless.
    correlated_fraction : float
        f: share of that variance in the Gauss-Markov part, in [0, 1].
    tau_s : float
        Correlation time of the Gauss-Markov part, s (meaningless when f is near 0).
    tau_at_bound : bool
        True when tau ran to its upper search bound: the data only say tau is long (longer than
        the detrended segments allow to see).
    n_samples, n_segments : int
        Samples and contiguous segments used.
    max_lag : int
        Largest lag fitted, samples.
    detrend_order : int
        Polynomial order removed from each segment (-1: none, 0: mean, 1: line, ...).
    differences : int
        Order of the differencing applied instead (0: none).
    variance_ratio_se, correlated_fraction_se : float
        Jackknife standard errors (NaN with fewer than 4 groups of segments).
    tau_factor : float
        Jackknife 1-sigma multiplicative uncertainty of tau (tau x/ this factor), NaN as above.
    """

    variance_ratio: float
    correlated_fraction: float
    tau_s: float
    tau_at_bound: bool
    n_samples: int
    n_segments: int
    max_lag: int
    detrend_order: int
    differences: int = 0
    variance_ratio_se: float = float("nan")
    correlated_fraction_se: float = float("nan")
    tau_factor: float = float("nan")


def gauss_markov_series(n: int, f: float, tau_samples: float, rng: np.random.Generator,
                        variance_ratio: float = 1.0) -> np.ndarray:
    """A stationary draw of the model: ``n`` samples of sqrt(r) (sqrt(1 - f) w + sqrt(f) g) with g a
    unit-variance AR(1) of correlation time ``tau_samples`` (in samples) started in steady state."""
    phi = float(np.exp(-1.0 / tau_samples))
    u = rng.standard_normal(n) * np.sqrt(1.0 - phi * phi)
    u[0] = rng.standard_normal()
    g = lfilter([1.0], [1.0, -phi], u)
    return np.sqrt(variance_ratio) * (np.sqrt(1.0 - f) * rng.standard_normal(n) + np.sqrt(f) * g)


def polynomial_basis(n: int, order: int) -> np.ndarray:
    """(n, order + 1) orthonormal basis of the polynomials of degree <= ``order`` on n equally spaced
    samples ((n, 0) for order -1)."""
    if order < 0:
        return np.zeros((n, 0))
    x = np.linspace(-1.0, 1.0, n)
    q, _ = np.linalg.qr(np.vander(x, order + 1, increasing=True))
    return q


def detrend(x: np.ndarray, order: int) -> np.ndarray:
    """``x`` minus its least-squares polynomial of degree ``order`` (unchanged for order -1)."""
    q = polynomial_basis(x.size, order)
    return x - q @ (q.T @ x)


def lagged_products(segments: Sequence[np.ndarray], max_lag: int) -> tuple[np.ndarray, np.ndarray]:
    """Sums over all segments of x[k] x[k + lag] and the number of such pairs, lags 0..max_lag."""
    sums, counts = np.zeros(max_lag + 1), np.zeros(max_lag + 1)
    for x in segments:
        for lag in range(min(max_lag, x.size - 1) + 1):
            sums[lag] += float(x[:x.size - lag] @ x[lag:])
            counts[lag] += x.size - lag
    return sums, counts


def _ar1_apply(phi: float, q: np.ndarray) -> np.ndarray:
    """R q for R[k, l] = phi^|k - l| (columns of q), by a forward and a backward recursion."""
    if phi == 0.0:
        return q.copy()
    fwd = lfilter([1.0], [1.0, -phi], q, axis=0)
    bwd = lfilter([1.0], [1.0, -phi], q[::-1], axis=0)[::-1]
    return fwd + bwd - q


def expected_lagged_sums(n: int, max_lag: int, phi: float, order: int) -> np.ndarray:
    """Expected sum over k of z[k] z[k + lag], lags 0..max_lag, for z = (I - P) x with x of
    covariance R[k, l] = phi^|k - l| (phi = 0: white) on n samples and P the projection on the
    polynomials of degree <= ``order``: the lag-diagonal sums of R - Q B^T - B Q^T + Q D Q^T with
    Q the orthonormal basis, B = R Q and D = Q^T R Q."""
    lags = np.arange(max_lag + 1)
    out = np.where(lags < n, (n - lags) * phi ** lags, 0.0)
    q = polynomial_basis(n, order)
    if q.shape[1] == 0:
        return out
    b = _ar1_apply(phi, q)
    d = q.T @ b
    for lag in range(min(max_lag, n - 1) + 1):
        qa, qb, ba, bb = q[:n - lag], q[lag:], b[:n - lag], b[lag:]
        out[lag] += -np.sum(qa * bb) - np.sum(ba * qb) + np.sum(d * (qa.T @ qb))
    return out


def expected_differenced_sums(n: int, max_lag: int, phi: float, order: int) -> np.ndarray:
    """Expected sum over k of z[k] z[k + lag], lags 0..max_lag, for z the ``order``-th difference
    of n samples of a stationary series of autocovariance phi^|lag| (phi = 0: white): with h the
    difference coefficients, cov(z[k], z[k + lag]) = sum_ij h_i h_j phi^|lag + j - i|."""
    h = np.array([1.0])
    for _ in range(order):
        h = np.convolve(h, [-1.0, 1.0])
    lags = np.arange(max_lag + 1)
    shift = np.subtract.outer(np.arange(h.size), np.arange(h.size))  # i - j
    cov = np.array([np.sum(np.outer(h, h) * phi ** np.abs(lag - shift)) for lag in lags])
    return np.maximum(n - order - lags, 0) * cov


@lru_cache(maxsize=4096)
def _expected(n: int, max_lag: int, phi: float, order: int, differences: int) -> np.ndarray:
    """Expected lagged sums of a segment of n samples, detrended or differenced (cached: the search
    grid is the same for every jackknife replicate)."""
    if differences:
        return expected_differenced_sums(n, max_lag, phi, differences)
    return expected_lagged_sums(n, max_lag, phi, order)


def _design(lengths: dict[int, int], max_lag: int, phi: float, how: tuple[int, int], counts: np.ndarray) -> np.ndarray:
    """Columns: expected pooled autocovariances of a unit white and a unit AR(1) part."""
    white = sum(m * _expected(n, max_lag, 0.0, *how) for n, m in lengths.items())
    corr = sum(m * _expected(n, max_lag, phi, *how) for n, m in lengths.items())
    return np.column_stack([white, corr]) / counts[:, None]


def _search(solve, tau_max: float, n_grid: int = 40) -> tuple[float, float, float]:
    """Minimise ``solve(log tau) -> (cost, (white, correlated) variances)`` over tau in [0.2, tau_max]
    samples (grid, then a bounded line search around the best point); (r, f, tau in samples)."""
    grid = np.linspace(np.log(0.2), np.log(tau_max), n_grid)
    costs = [solve(g)[0] for g in grid]
    i = int(np.argmin(costs))
    lo, hi = grid[max(i - 1, 0)], grid[min(i + 1, grid.size - 1)]
    best = minimize_scalar(lambda g: solve(g)[0], bounds=(lo, hi), method="bounded", options={"xatol": 1e-4}).x
    if solve(best)[0] > costs[i]:
        best = grid[i]
    coef = solve(best)[1]
    total = float(coef.sum())
    return total, float(coef[1] / total) if total > 0 else 0.0, float(np.exp(best))


def _jackknife(fit_of, items: list, n_groups: int) -> dict[str, float]:
    """Jackknife standard errors of (r, f) and the multiplicative one of tau, leaving out groups of
    consecutive items in turn; empty with fewer than 4 groups."""
    groups = np.array_split(np.arange(len(items)), min(n_groups, len(items)))
    if len(groups) < 4:
        return {}
    jack = np.array([fit_of([x for i, x in enumerate(items) if i not in set(g)]) for g in groups])
    k = len(groups)
    jack[:, 2] = np.log(jack[:, 2])
    se = np.sqrt((k - 1) / k * np.sum((jack - jack.mean(axis=0)) ** 2, axis=0))
    return dict(variance_ratio_se=float(se[0]), correlated_fraction_se=float(se[1]), tau_factor=float(np.exp(se[2])))


def _fit(segments: list[tuple[int, np.ndarray]], max_lag: int, how: tuple[int, int],
         tau_max: float, shape: tuple[float, float] | None = None) -> tuple[float, float, float]:
    """(variance ratio, f, tau in samples) from (raw length, processed series) pairs; with ``shape``
    = (f, tau in samples) only the variance ratio is fitted."""
    sums, counts = lagged_products([z for _, z in segments], max_lag)
    ok = counts > 0
    c = sums[ok] / counts[ok]
    lengths: dict[int, int] = {}
    for n, _ in segments:
        lengths[n] = lengths.get(n, 0) + 1

    def solve(log_tau: float) -> tuple[float, np.ndarray]:
        a = _design(lengths, max_lag, float(np.exp(-np.exp(-log_tau))), how, np.where(ok, counts, 1.0))[ok]
        coef, resid = nnls(a, c)
        return resid, coef

    if shape is not None:
        f, tau = shape
        col = _design(lengths, max_lag, float(np.exp(-1.0 / tau)), how, np.where(ok, counts, 1.0))[ok] @ [1 - f, f]
        return max(float(col @ c / (col @ col)), 0.0), f, tau
    return _search(solve, tau_max)


def fit_gauss_markov(segments: Sequence[np.ndarray], dt_s: float, max_lag: int, detrend_order: int = -1,
                     differences: int = 0, n_groups: int = 10,
                     shape: tuple[float, float] | None = None) -> GaussMarkovFit:
    """Fit white plus first-order Gauss-Markov noise to series of normalised errors.

    Parameters
    ----------
    segments : sequence of numpy.ndarray
        Contiguous, uniformly sampled series of error / reported sigma (dimensionless), each
        possibly plus an unknown trend that the detrending or differencing removes. Segments too
        short for them (fewer than ``detrend_order + 3`` or ``differences + 3`` samples) are ignored.
    dt_s : float
        Sampling interval, s.
    max_lag : int
        Largest lag of the autocovariances fitted, samples (>= 2).
    detrend_order : int
        Polynomial removed from each segment: -1 none (the truth is known, e.g. zero velocity at
        rest), 0 its mean, 1 a line, 2 a parabola.
    differences : int
        Instead of detrending (``detrend_order`` must then be -1), fit the ``differences``-th
        difference of each segment (2: x[k+1] - 2 x[k] + x[k-1], which removes a locally linear trend).
    n_groups : int
        Groups of consecutive segments for the jackknife standard errors (at most one per segment).
    shape : tuple of float, optional
        (f, tau in s) held fixed: only the variance ratio is fitted (e.g. to scale a shape measured
        elsewhere to series that show only part of it, such as differences).

    Returns
    -------
    GaussMarkovFit
        r, f and tau (s) of the series before detrending or differencing, with jackknife standard
        errors; tau is searched from 0.2 samples up to 10 times the longest segment
        (``tau_at_bound`` tells when it went there).
    """
    if max_lag < 2 or dt_s <= 0 or differences < 0 or (differences and detrend_order >= 0):
        raise ValueError("need max_lag >= 2, dt_s > 0, differences >= 0 and not both detrending and differencing")
    segs = []
    for x in segments:
        x = np.asarray(x, dtype=float)
        if x.size >= max(detrend_order, differences) + 3:
            segs.append((x.size, np.diff(x, differences) if differences else detrend(x, detrend_order)))
    if not segs:
        raise ValueError("no segment long enough")
    how = (detrend_order, differences)
    tau_max = 10.0 * max(n for n, _ in segs)
    fixed = None if shape is None else (float(shape[0]), float(shape[1]) / dt_s)
    r, f, tau = _fit(segs, max_lag, how, tau_max, fixed)
    fit = dict(variance_ratio=r, correlated_fraction=f, tau_s=tau * dt_s,
               tau_at_bound=bool(fixed is None and tau > 0.95 * tau_max), n_samples=int(sum(n for n, _ in segs)),
               n_segments=len(segs), max_lag=max_lag, detrend_order=detrend_order, differences=differences)
    fit.update(_jackknife(lambda sel: _fit(sel, max_lag, how, tau_max, fixed), segs, n_groups))
    return GaussMarkovFit(**fit)


def variogram(segments: Sequence[np.ndarray], sigmas: Sequence[np.ndarray], lags: Sequence[int]
              ) -> tuple[np.ndarray, np.ndarray]:
    """Normalised structure function D(lag) = mean of (x[k + lag] - x[k])^2 / s^2 over all pairs
    within the segments, s^2 = (sigma[k]^2 + sigma[k + lag]^2) / 2, and the number of pairs per lag.
    A constant offset of a segment (an unknown truth) cancels; for the model D = 2 r (1 - f) +
    2 r f (1 - phi^lag) for lag >= 1."""
    d, counts = np.zeros(len(lags)), np.zeros(len(lags))
    for x, s in zip(segments, sigmas):
        x, s2 = np.asarray(x, dtype=float), np.asarray(s, dtype=float) ** 2
        for i, lag in enumerate(lags):
            if 0 < lag < x.size:
                d[i] += float(np.sum((x[lag:] - x[:-lag]) ** 2 / ((s2[lag:] + s2[:-lag]) / 2)))
                counts[i] += x.size - lag
    with np.errstate(invalid="ignore"):
        return d / counts, counts


def _fit_variogram(d: np.ndarray, lags: np.ndarray, tau_max: float) -> tuple[float, float, float]:
    """(r, f, tau in samples) fitted to a normalised structure function, in relative units."""
    ok = np.isfinite(d) & (d > 0)
    w = 1.0 / d[ok]

    def solve(log_tau: float) -> tuple[float, np.ndarray]:
        phi = np.exp(-np.exp(-log_tau))
        a = np.column_stack([np.full(ok.sum(), 2.0), 2.0 * (1.0 - phi ** lags[ok])]) * w[:, None]
        coef, resid = nnls(a, d[ok] * w)
        return resid, coef

    return _search(solve, tau_max, 60)


def fit_gauss_markov_variogram(segments: Sequence[np.ndarray], sigmas: Sequence[np.ndarray], dt_s: float,
                               lags: Sequence[int], n_groups: int = 10, tau_max_s: float | None = None
                               ) -> GaussMarkovFit:
    """Fit white plus first-order Gauss-Markov noise to the normalised structure function of error
    series known only up to a constant per segment (:func:`variogram`).

    Parameters
    ----------
    segments : sequence of numpy.ndarray
        Contiguous, uniformly sampled errors (any unit) plus an unknown constant per segment.
    sigmas : sequence of numpy.ndarray
        The reported 1-sigma of each sample (same unit), same shapes as ``segments``.
    dt_s : float
        Sampling interval, s.
    lags : sequence of int
        Lags fitted, samples (>= 1); the fit minimises the relative misfit of D at these lags, so
        it describes the errors on the time scales they span and says nothing beyond the longest.
    n_groups : int
        Groups of consecutive segments for the jackknife standard errors.
    tau_max_s : float, optional
        Upper bound of the tau search, s (default 10 times the longest lag).

    Returns
    -------
    GaussMarkovFit
        r, f and tau (s); ``tau_at_bound`` when the structure function still grows linearly at the
        longest lag (only r / tau is then determined). ``detrend_order`` is -1 and ``max_lag`` the
        longest lag.
    """
    lag_arr = np.asarray(lags, dtype=int)
    if lag_arr.size < 3 or np.any(lag_arr < 1) or dt_s <= 0:
        raise ValueError("need at least 3 lags >= 1 and dt_s > 0")
    pairs = [(np.asarray(x, dtype=float), np.asarray(s, dtype=float)) for x, s in zip(segments, sigmas)
             if np.asarray(x).size > 1]
    if not pairs:
        raise ValueError("no segment long enough")
    tau_max = (tau_max_s / dt_s) if tau_max_s else 10.0 * float(lag_arr.max())

    def fit_of(sel: list[tuple[np.ndarray, np.ndarray]]) -> tuple[float, float, float]:
        d, _ = variogram([x for x, _ in sel], [s for _, s in sel], lag_arr)
        return _fit_variogram(d, lag_arr.astype(float), tau_max)

    r, f, tau = fit_of(pairs)
    fit = dict(variance_ratio=r, correlated_fraction=f, tau_s=tau * dt_s, tau_at_bound=bool(tau > 0.95 * tau_max),
               n_samples=int(sum(x.size for x, _ in pairs)), n_segments=len(pairs), max_lag=int(lag_arr.max()),
               detrend_order=-1)
    fit.update(_jackknife(fit_of, pairs, n_groups))
    return GaussMarkovFit(**fit)
