"""The time-block sandwich widening (estimation/engine/block_sandwich.py, sixdof/row_times.py) on
linear least squares, where the truth of the estimate's spread is known by Monte Carlo."""

import numpy as np
import scipy.sparse as sps

from casrecon.estimation.engine.block_sandwich import block_sandwich
from casrecon.estimation.sixdof.row_times import residual_row_times, time_blocks

RATE_HZ, DURATION_S, SIGMA = 50.0, 40.0, 1.0
T = np.arange(0.0, DURATION_S, 1.0 / RATE_HZ)
#: Whitened design of y = a + b t / T + c sin(2 pi t / 10 s): three constants seen all along.
DESIGN = np.column_stack([np.ones_like(T), T / DURATION_S, np.sin(2 * np.pi * T / 10.0)]) / SIGMA


def fit(errors: np.ndarray, block_s: float = 1.0):
    """(estimate error, model covariance, widened covariance) of the linear fit of ``errors``."""
    cov = np.linalg.inv(DESIGN.T @ DESIGN)
    r_white = errors / SIGMA
    dw = cov @ DESIGN.T @ r_white
    residuals = r_white - DESIGN @ dw
    blocks = time_blocks(T, block_s)
    sw = block_sandwich(sps.csr_matrix(DESIGN), np.eye(3), cov, residuals, blocks)
    return dw, cov, cov + sw.extra_w, sw


def z_scores(n_cases: int, draw) -> tuple[np.ndarray, np.ndarray]:
    rng = np.random.default_rng(49)
    model, widened = [], []
    for _ in range(n_cases):
        dw, cov, wide, _ = fit(draw(rng))
        model.append(dw / np.sqrt(np.diag(cov)))
        widened.append(dw / np.sqrt(np.diag(wide)))
    return np.array(model), np.array(widened)


def ar1(rng, tau_s: float, size: float) -> np.ndarray:
    """Gauss-Markov errors of correlation time ``tau_s`` and 1-sigma ``size`` at the samples."""
    phi = np.exp(-1.0 / (RATE_HZ * tau_s))
    e = np.empty(T.size)
    e[0] = rng.normal() * size
    noise = rng.normal(size=T.size) * size * np.sqrt(1 - phi**2)
    for k in range(1, T.size):
        e[k] = phi * e[k - 1] + noise[k]
    return e


def test_white_errors_are_barely_widened():
    rng = np.random.default_rng(1)
    factors, excess = [], []
    for _ in range(100):
        _, cov, wide, sw = fit(rng.normal(size=T.size) * SIGMA)
        factors.append(np.sqrt(np.diag(wide) / np.diag(cov)))
        excess.append(sw.excess)
    assert abs(np.mean(excess)) < 0.1  # the sandwich's expectation under the model is right (sd of the mean 0.02)
    assert np.median(factors) < 1.1
    model, widened = z_scores(200, lambda rng: rng.normal(size=T.size) * SIGMA)
    assert np.mean(np.abs(widened) <= 3.0) >= 0.99


def test_correlated_errors_the_model_calls_white_are_covered_after_widening():
    """Errors correlated over 0.3 s, twice the stated size: the model's sigmas are far too narrow
    (its z-scores spread by several), the widened ones cover the truth at 3 sigma."""
    model, widened = z_scores(200, lambda rng: ar1(rng, 0.3, 2.0 * SIGMA) + rng.normal(size=T.size) * SIGMA)
    assert np.std(model) > 3.0  # the failure the widening is for
    assert np.mean(np.abs(model) <= 3.0) < 0.7
    assert np.mean(np.abs(widened) <= 3.0) >= 0.97
    assert 0.6 < np.std(widened) < 1.3


def test_row_times_follow_the_nodes_and_leave_constants_out():
    """Rows on nodes get the nodes' mean time, a latent value seen by one node's rows gets its time
    and so does its prior row; a prior on a parameter seen everywhere has none."""
    node_time = np.array([0.0, 1.0, 2.0, 3.0, 4.0])
    node_cols = np.arange(5)[:, None]  # one state per node: columns 0-4; parameter 5; latent 6
    rows = [[0, 1, 5], [1, 2, 5], [2, 3, 5], [3, 4, 5, 6], [6], [5]]
    j = sps.lil_matrix((len(rows), 7))
    for i, cols in enumerate(rows):
        j[i, cols] = 1.0
    t = residual_row_times(j.tocsr(), node_cols, node_time)
    np.testing.assert_allclose(t[:4], [0.5, 1.5, 2.5, 3.5])
    assert t[4] == 3.5  # the latent value's prior: when its only measurement happens
    assert np.isnan(t[5])  # the parameter's prior: no block
    np.testing.assert_array_equal(time_blocks(t, 2.0), [0, 0, 1, 1, 1, -1])


def test_the_sandwich_p_value_is_uniform_under_the_model_and_small_off_it():
    rng = np.random.default_rng(3)
    p = np.array([fit(rng.normal(size=T.size) * SIGMA)[3].p_value for _ in range(400)])
    assert 0.0 <= np.mean(p < 0.01) <= 0.03 and 0.02 <= np.mean(p < 0.05) <= 0.09 and 0.42 <= np.mean(p < 0.5) <= 0.58
    p = np.array([fit(ar1(rng, 0.3, 2.0 * SIGMA) + rng.normal(size=T.size) * SIGMA)[3].p_value for _ in range(30)])
    assert np.all(p < 0.01)
