"""The profile sizes' uncertainty carried into a covariance (casrecon.estimation.error_models.size_uncertainty)
and the covariance of a maximum from its gradient (information_ascent.covariance_at_maximum), on
linear-Gaussian problems whose answers are known in closed form."""

from __future__ import annotations

import numpy as np
import pytest

from casrecon.estimation.error_models.size_uncertainty import added_covariance, sensitivity
from casrecon.estimation.numerics.information_ascent import covariance_at_maximum


def linear_problem(seed: int = 0):
    """min 1/2 |X w - y|^2 + 1/2 sum_k |(A_k w - b_k) / rho_k|^2: data rows X, two prior groups."""
    rng = np.random.default_rng(seed)
    n_w = 6
    x = rng.normal(size=(40, n_w))
    y = rng.normal(size=40)
    groups = [(rng.normal(size=(5, n_w)), rng.normal(size=5)), (rng.normal(size=(3, n_w)), rng.normal(size=3))]

    def solution(log_rho: np.ndarray) -> np.ndarray:
        h = x.T @ x + sum(a.T @ a * np.exp(-2 * s) for (a, _), s in zip(groups, log_rho))
        g = x.T @ y + sum(a.T @ b * np.exp(-2 * s) for (a, b), s in zip(groups, log_rho))
        return np.linalg.solve(h, g)

    return x, groups, solution


def test_the_sensitivity_is_the_derivative_of_the_estimate_in_each_log_size():
    """D = 2 H^-1 A_k^T u_k against central differences of the closed-form estimate."""
    x, groups, solution = linear_problem()
    w = solution(np.zeros(2))
    cov_w = np.linalg.inv(x.T @ x + sum(a.T @ a for a, _ in groups))
    d = sensitivity(cov_w, [a for a, _ in groups], [a @ w - b for a, b in groups])
    h = 1e-5
    for k in range(2):
        step = np.zeros(2)
        step[k] = h
        numeric = (solution(step) - solution(-step)) / (2 * h)
        assert d[:, k] == pytest.approx(numeric, rel=1e-6, abs=1e-9)


def test_the_added_covariance_is_d_v_dt_and_positive_semidefinite():
    x, groups, solution = linear_problem(1)
    w = solution(np.zeros(2))
    cov_w = np.linalg.inv(x.T @ x + sum(a.T @ a for a, _ in groups))
    rows, residuals = [a for a, _ in groups], [a @ w - b for a, b in groups]
    v = np.array([[0.04, 0.01], [0.01, 0.09]])
    added = added_covariance(cov_w, rows, residuals, v)
    d = sensitivity(cov_w, rows, residuals)
    assert added == pytest.approx(d @ v @ d.T)
    assert np.linalg.eigvalsh(0.5 * (added + added.T)).min() > -1e-12 * np.abs(added).max()
    assert np.linalg.matrix_rank(added, tol=1e-10 * np.abs(added).max()) == 2  # two groups, rank two


def test_the_covariance_at_a_maximum_inverts_its_curvature_holding_the_others():
    """On a concave quadratic the result is the inverse of the Hessian's block over ``which`` (the
    other variables held: conditional, not marginal); a curved-up function has none."""
    rng = np.random.default_rng(2)
    m = rng.normal(size=(4, 4))
    precision = m @ m.T + 4 * np.eye(4)
    centre = rng.normal(size=4)

    def gradient(x):
        return -precision @ (x - centre)

    cov = covariance_at_maximum(gradient, centre, [0, 2])
    assert cov == pytest.approx(np.linalg.inv(precision[np.ix_([0, 2], [0, 2])]), rel=1e-8)
    assert covariance_at_maximum(lambda x: precision @ (x - centre), centre, [1]) is None
