"""White plus first-order Gauss-Markov fits of normalised error series
(casrecon.analysis.gps_error_statistics), on synthetic AR(1) + white series of known r, f and tau.

Tolerances come from the sample size: with N samples and a correlation time of tau samples the
autocovariances are known to about s = sqrt((1 + f^2 tau) / N) (Bartlett's formula for an AR(1) part
of weight f); f is asked within 5 s, r (relative) and ln tau within 5 s sqrt(tau) (a correlation time
is estimated from about N / tau independent stretches). The jackknife standard errors the functions
return are checked against the scatter over seeds.
"""

from __future__ import annotations

import numpy as np
import pytest

from casrecon.analysis.gps_error_statistics import (
    expected_differenced_sums,
    expected_lagged_sums,
    fit_gauss_markov,
    fit_gauss_markov_variogram,
    gauss_markov_series,
    lagged_products,
    polynomial_basis,
    variogram,
)


def scale(f: float, tau_samples: float, n: int) -> float:
    return float(np.sqrt((1.0 + f * f * tau_samples) / n))


def assert_recovered(fit, r: float, f: float, tau_s: float, dt_s: float, n: int) -> None:
    tau = tau_s / dt_s
    s = scale(f, tau, n)
    assert abs(fit.correlated_fraction - f) < 5 * s, (fit, s)
    assert abs(fit.variance_ratio / r - 1) < 5 * s * np.sqrt(tau), (fit, s)
    assert abs(np.log(fit.tau_s / tau_s)) < 5 * s * np.sqrt(tau), (fit, s)
    assert not fit.tau_at_bound


@pytest.mark.parametrize("n, phi, order", [(40, 0.8, 0), (57, 0.95, 2), (30, 0.0, 1), (25, 0.5, -1)])
def test_expected_lagged_sums_match_the_dense_matrix(n, phi, order):
    r = phi ** np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    q = polynomial_basis(n, order)
    a = np.eye(n) - q @ q.T
    m = a @ r @ a.T
    dense = [np.trace(m, offset=lag) for lag in range(12)]
    np.testing.assert_allclose(expected_lagged_sums(n, 11, phi, order), dense, atol=1e-10)


@pytest.mark.parametrize("phi, order", [(0.7, 1), (0.0, 2), (0.9, 2), (0.4, 3)])
def test_expected_differenced_sums_match_the_dense_matrix(phi, order):
    n = 30
    r = phi ** np.abs(np.subtract.outer(np.arange(n), np.arange(n)))
    d = np.diff(np.eye(n), order, axis=0)
    m = d @ r @ d.T
    dense = [np.trace(m, offset=lag) for lag in range(8)]
    np.testing.assert_allclose(expected_differenced_sums(n, 7, phi, order), dense, atol=1e-10)


def test_gauss_markov_series_has_the_model_statistics():
    rng = np.random.default_rng(0)
    x = gauss_markov_series(400_000, 0.7, 5.0, rng, 2.0)
    sums, counts = lagged_products([x], 3)
    acov = sums / counts
    s = scale(0.7, 5.0, x.size)
    assert abs(acov[0] / 2.0 - 1) < 5 * s * np.sqrt(5.0)
    np.testing.assert_allclose(acov[1:] / acov[0], 0.7 * np.exp(-np.arange(1, 4) / 5.0), atol=5 * s)


def test_recovers_f_tau_r_without_detrending():
    rng = np.random.default_rng(1)
    segs = [gauss_markov_series(2000, 0.6, 10.0, rng, 0.3) for _ in range(20)]
    fit = fit_gauss_markov(segs, 0.1, 40)
    assert_recovered(fit, 0.3, 0.6, 1.0, 0.1, 40_000)
    assert fit.n_samples == 40_000 and fit.n_segments == 20


def test_recovers_tau_longer_than_the_mean_removed_segments_where_the_naive_acf_is_biased():
    rng = np.random.default_rng(2)
    segs = [gauss_markov_series(100, 0.8, 30.0, rng, 2.0) + 50.0 * rng.standard_normal() for _ in range(200)]
    sums, counts = lagged_products([x - x.mean() for x in segs], 1)
    naive_lag1 = sums[1] / counts[1] / (sums[0] / counts[0])
    true_lag1 = 0.8 * np.exp(-1 / 30)
    s = scale(0.8, 30.0, 20_000)
    assert naive_lag1 < true_lag1 - 3 * s  # removing each segment's mean shortens the naive correlation
    fit = fit_gauss_markov(segs, 1.0, 40, detrend_order=0)
    assert_recovered(fit, 2.0, 0.8, 30.0, 1.0, 20_000)


def test_white_noise_gives_no_correlated_part():
    rng = np.random.default_rng(3)
    segs = [0.5 * rng.standard_normal(2000) for _ in range(20)]
    s = scale(0.0, 1.0, 40_000)
    fit = fit_gauss_markov(segs, 0.2, 20)
    assert fit.correlated_fraction < 5 * s
    assert abs(fit.variance_ratio / 0.25 - 1) < 5 * s
    # with each segment's mean removed, a process much slower than the segments is invisible: the fit
    # either finds no correlated part or puts a small one at the tau bound, and says so
    fit = fit_gauss_markov(segs, 0.2, 20, detrend_order=0)
    unseen = fit.tau_at_bound and fit.correlated_fraction < 3 * fit.correlated_fraction_se
    assert fit.correlated_fraction < 5 * s or unseen


def test_differences_with_a_known_shape_give_the_scale_despite_a_trend():
    rng = np.random.default_rng(4)
    n = 5000
    t = np.arange(n) * 0.1
    segs = [gauss_markov_series(n, 0.5, 5.0, rng, 0.04) + 30 * np.sin(t / 60) + 2 * t for _ in range(8)]
    fit = fit_gauss_markov(segs, 0.1, 4, differences=2, shape=(0.5, 0.5))
    assert abs(fit.variance_ratio / 0.04 - 1) < 5 * scale(0.5, 5.0, 8 * n)
    assert fit.correlated_fraction == 0.5 and fit.tau_s == pytest.approx(0.5)


def test_variogram_fit_ignores_offsets_and_follows_the_reported_sigma():
    rng = np.random.default_rng(5)
    n, k = 1000, 20
    sig = [np.linspace(1.0, 2.0, n) * (1 + i % 3) for i in range(k)]
    segs = [gauss_markov_series(n, 0.9, 20.0, rng, 1.5) * s + 100 * rng.standard_normal() for s in sig]
    fit = fit_gauss_markov_variogram(segs, sig, 0.2, [1, 2, 4, 8, 16, 32, 64, 128])
    assert_recovered(fit, 1.5, 0.9, 4.0, 0.2, n * k)
    d, counts = variogram(segs, sig, [1, 1000])
    assert counts[0] == k * (n - 1) and counts[1] == 0 and np.isnan(d[1])


def test_a_random_walk_runs_tau_to_its_bound():
    rng = np.random.default_rng(6)
    segs = [np.cumsum(rng.standard_normal(500)) for _ in range(10)]
    fit = fit_gauss_markov_variogram(segs, [np.ones(500)] * 10, 1.0, [1, 2, 5, 10, 20, 40])
    assert fit.tau_at_bound
    # only the diffusion r f / tau is determined: D(L) = L for a unit random walk, so 2 r / tau = 1
    assert abs(2 * fit.variance_ratio * fit.correlated_fraction / fit.tau_s - 1) < 0.2


def test_jackknife_standard_errors_match_the_scatter_over_seeds():
    est, se = [], []
    for seed in range(20):
        rng = np.random.default_rng(100 + seed)
        fit = fit_gauss_markov([gauss_markov_series(1000, 0.6, 8.0, rng, 0.3) for _ in range(20)], 1.0, 30)
        est.append((fit.variance_ratio, fit.correlated_fraction))
        se.append((fit.variance_ratio_se, fit.correlated_fraction_se))
    z = (np.array(est) - [0.3, 0.6]) / np.array(se)
    rms = np.sqrt(np.mean(z ** 2, axis=0))
    assert np.all((rms > 0.5) & (rms < 1.6)), rms


@pytest.mark.parametrize("kwargs", [dict(max_lag=1), dict(dt_s=0.0), dict(differences=2, detrend_order=0)])
def test_bad_arguments_are_refused(kwargs):
    args = dict(segments=[np.zeros(50)], dt_s=0.1, max_lag=5) | kwargs
    with pytest.raises(ValueError):
        fit_gauss_markov(**args)
    with pytest.raises(ValueError):
        fit_gauss_markov([np.zeros(2)], 0.1, 5, detrend_order=1)
