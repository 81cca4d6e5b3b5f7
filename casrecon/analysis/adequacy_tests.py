"""The statistical tests of the model-adequacy verdict (:mod:`casrecon.analysis.adequacy`), pure numpy
and ``scipy.special``: per residual channel the reduced chi-square against its two-sided interval and
the Ljung-Box whiteness test (:func:`channel_test`); for the priors each parameter's z and the NEES of
the prior deviations on the directions the data inform (:func:`prior_nees`). The verdict, and the
prior-process size tests (:mod:`casrecon.analysis.process_scale`), are built on these.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: Eigenvalues of S (share of a direction's prior variance the data remove) kept in the NEES.
INFORMED = 0.1
#: Most lags of the Ljung-Box test.
MAX_LAGS = 10


def _special():
    """``scipy.special`` (chi-square and normal quantiles, as ``scipy.stats`` computes them, without
    importing ``scipy.stats``: ~1 s), imported at first use: its import costs 0.3 to 0.5 s, which a
    ``casrecon fit`` pays in the forked child that computes the verdict, off the critical path."""
    from scipy import special

    return special


def chi2_ppf(p: float, dof: float) -> float:
    """Chi-square quantile: the x with P(X <= x) = p for ``dof`` degrees of freedom (what
    ``scipy.stats.chi2.ppf`` computes, 2 gammaincinv(dof / 2, p))."""
    return float(2 * _special().gammaincinv(dof / 2, p))


def two_sided_z(alpha: float) -> float:
    """The |z| a standard normal exceeds with probability ``alpha`` (both tails together)."""
    return float(-_special().ndtri(alpha / 2))


def lag1_autocorrelation(x: np.ndarray) -> float:
    """Lag-1 autocorrelation of a series about its mean (NaN for fewer than 3 samples or a constant)."""
    x = np.asarray(x, dtype=float)
    if x.size < 3:
        return float("nan")
    d = x - x.mean()
    den = float(d @ d)
    return float(d[:-1] @ d[1:] / den) if den > 0 else float("nan")


def ljung_box_lags(n: int) -> int:
    """Lags of the Ljung-Box test for n samples: min(10, n // 5) (at least 1)."""
    return max(1, min(MAX_LAGS, n // 5))


def ljung_box(x: np.ndarray, lags: int) -> tuple[float, float]:
    """Ljung-Box statistic Q = n (n + 2) sum_{k=1}^{lags} rho_k^2 / (n - k) of a series (about its
    mean) and its p-value from chi-square(lags); white noise gives p uniform on [0, 1]."""
    x = np.asarray(x, dtype=float)
    n = x.size
    d = x - x.mean()
    den = float(d @ d)
    if n <= lags + 1 or den <= 0:
        return float("nan"), float("nan")
    rho = np.array([d[:-k] @ d[k:] for k in range(1, lags + 1)]) / den
    q = float(n * (n + 2) * np.sum(rho ** 2 / (n - np.arange(1, lags + 1))))
    return q, float(_special().chdtrc(lags, q))


@dataclass(frozen=True)
class ChannelTest:
    """Whiteness and scale of one residual channel (residuals divided by their sigma).

    Attributes
    ----------
    name : str
        E.g. ``"IMU accel x"``, ``"GPS vel n"``, ``"baro"``.
    n : int
        Samples tested.
    reduced_chi2 : float
        Mean squared normalised residual, -.
    chi2_interval : tuple of float
        Its two-sided interval at the per-test level (chi-square(n) quantiles over n).
    lag1 : float
        Lag-1 autocorrelation, -.
    lags : int
        Lags of the Ljung-Box test.
    ljung_box_q, ljung_box_p : float
        Ljung-Box statistic and its p-value.
    alpha : float
        Per-test level.
    """

    name: str
    n: int
    reduced_chi2: float
    chi2_interval: tuple[float, float]
    lag1: float
    lags: int
    ljung_box_q: float
    ljung_box_p: float
    alpha: float

    @property
    def below(self) -> bool:
        """Reduced chi-square below its interval (residuals smaller than their sigmas)."""
        return bool(self.n and self.reduced_chi2 < self.chi2_interval[0])

    @property
    def above(self) -> bool:
        """Reduced chi-square above its interval (residuals larger than their sigmas)."""
        return bool(self.n and self.reduced_chi2 > self.chi2_interval[1])

    @property
    def scale_ok(self) -> bool:
        return not (self.below or self.above)

    @property
    def white(self) -> bool:
        return not (self.ljung_box_p < self.alpha)


def channel_test(name: str, normalized: np.ndarray, alpha: float) -> ChannelTest:
    """:class:`ChannelTest` of one channel's normalised residuals (NaN entries dropped) at level ``alpha``."""
    r = np.asarray(normalized, dtype=float)
    r = r[np.isfinite(r)]
    n = int(r.size)
    if n == 0:
        return ChannelTest(name, 0, float("nan"), (float("nan"), float("nan")), float("nan"), 0,
                           float("nan"), float("nan"), alpha)
    lags = ljung_box_lags(n)
    q, p = ljung_box(r, lags)
    interval = (float(chi2_ppf(alpha / 2, n) / n), float(_special().chdtri(n, alpha / 2) / n))
    return ChannelTest(name, n, float(r @ r / n), interval, lag1_autocorrelation(r), lags, q, p, alpha)


@dataclass(frozen=True)
class PriorDeviation:
    """A parameter's estimate against its zero-mean prior: z = value / prior_sigma."""

    name: str
    value: float
    prior_sigma: float
    z: float
    unit: str = "-"


@dataclass(frozen=True)
class PriorNees:
    """NEES of the prior deviations (see the module docstring).

    Attributes
    ----------
    nees : float
        u^T S^+ u on the informed directions, -.
    dof : int
        Informed directions (eigenvalues of S above :data:`INFORMED`).
    interval : tuple of float
        Two-sided chi-square(dof) interval at the per-test level.
    p_value : float
        Upper-tail probability of chi-square(dof) beyond ``nees``.
    prior_chi2 : float
        sum u_i^2, the prior residual groups' chi-square (expected below the number of priors).
    n_priors : int
    """

    nees: float
    dof: int
    interval: tuple[float, float]
    p_value: float
    prior_chi2: float
    n_priors: int

    @property
    def too_large(self) -> bool:
        return bool(self.dof and self.nees > self.interval[1])


def prior_nees(values: np.ndarray, prior_sigma: np.ndarray, posterior_cov: np.ndarray, alpha: float) -> PriorNees:
    """:class:`PriorNees` of estimates with zero-mean priors ``prior_sigma`` and posterior covariance
    ``posterior_cov`` (same units), at the per-test level ``alpha``."""
    s0 = np.asarray(prior_sigma, dtype=float)
    u = np.asarray(values, dtype=float) / s0
    n = u.size
    if n == 0:
        return PriorNees(0.0, 0, (0.0, 0.0), 1.0, 0.0, 0)
    s = np.eye(n) - np.asarray(posterior_cov, dtype=float) / np.outer(s0, s0)
    lam, vec = np.linalg.eigh(0.5 * (s + s.T))
    keep = lam > INFORMED
    proj = vec[:, keep].T @ u
    nees = float(np.sum(proj ** 2 / lam[keep]))
    dof = int(keep.sum())
    interval = (float(chi2_ppf(alpha / 2, dof)), float(_special().chdtri(dof, alpha / 2))) if dof else (0.0, 0.0)
    p = float(_special().chdtrc(dof, nees)) if dof else 1.0
    return PriorNees(nees, dof, interval, p, float(u @ u), n)
