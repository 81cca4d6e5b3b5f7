"""The widened bands' floor from the sensors' residuals, and the p-value over block lengths
(analysis/widened_uncertainty.py): what the residuals show beyond their stated noise, window by
window."""

import numpy as np

from casrecon.analysis.widened_uncertainty import floored_bands, local_excess

RATE_HZ, SIGMA = 500.0, 0.01
T = np.arange(0.0, 20.0, 1.0 / RATE_HZ)
NODES = np.arange(0.5, 19.5, 0.5)


def test_white_noise_of_the_stated_size_shows_almost_no_excess():
    residual = np.random.default_rng(1).normal(0.0, SIGMA, T.size)
    excess = local_excess(T, residual, np.full(T.size, SIGMA), np.ones(T.size, bool), NODES, 0.2)
    assert np.all(excess >= 0.0)
    # the mean of 200 squared samples scatters by sqrt(2/200) = 10 % of sigma^2: the floor stays small
    assert np.sqrt(np.max(excess)) < 0.6 * SIGMA and np.median(excess) < 0.05 * SIGMA**2


def test_a_discrepancy_the_model_cannot_follow_is_found_where_it_is():
    """Residual = true minus fitted (a 1 Hz burst between 8 and 12 s, 5 sigma) plus noise: the
    floor is about the burst's mean square where it is, and small elsewhere."""
    rng = np.random.default_rng(2)
    burst = np.where((T > 8.0) & (T < 12.0), 5 * SIGMA * np.sin(2 * np.pi * T), 0.0)
    residual = burst + rng.normal(0.0, SIGMA, T.size)
    excess = local_excess(T, residual, np.full(T.size, SIGMA), np.ones(T.size, bool), NODES, 0.5)
    inside = (NODES > 8.6) & (NODES < 11.4)
    outside = (NODES < 7.4) | (NODES > 12.6)
    assert np.all(np.abs(excess[inside] - 12.5 * SIGMA**2) < 0.3 * 12.5 * SIGMA**2)
    assert np.all(excess[outside] < 0.3 * SIGMA**2)


def test_invalid_samples_and_empty_windows_add_nothing():
    residual = np.full(T.size, 10 * SIGMA)
    valid = T < 10.0  # saturated after 10 s
    excess = local_excess(T, residual, np.full(T.size, SIGMA), valid, np.array([5.0, 15.0, 30.0]), 0.2)
    assert abs(excess[0] - 99 * SIGMA**2) < 1e-12
    assert excess[1] == 0.0 and excess[2] == 0.0


def test_floored_bands_add_variances_to_the_named_columns_only():
    sigma = np.array([[3.0, 1.0], [4.0, 2.0]])
    out = floored_bands(sigma, ("pos_n_m", "p_dps"), {"pos_n_m": np.array([16.0, 9.0]), "absent": np.ones(2)})
    np.testing.assert_allclose(out, [[5.0, 1.0], [5.0, 2.0]])
    assert sigma[0, 0] == 3.0  # not modified


def test_a_block_length_without_a_p_value_is_left_out():
    from types import SimpleNamespace

    from casrecon.analysis.widened_uncertainty import p_value

    lengths = [SimpleNamespace(p_value=v) for v in (float("nan"), 0.004, 0.3)]
    assert p_value(lengths) == 3 * 0.004
    assert p_value([SimpleNamespace(p_value=float("nan"))]) == 1.0
