"""The KKT evidence (casrecon.estimation.numerics.kkt_evidence) against a dense null-space evaluation of the
same Laplace evidence, and its gradient against finite differences of that evaluation."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.linalg
import scipy.sparse as sps

from casrecon.estimation.numerics.kkt_evidence import KktQuadraticModel, ScaledRows

N_Z, N_G = 12, 4


def problem(seed: int):
    """A random constrained fit: held rows, three scaled groups, four linear constraints."""
    rng = np.random.default_rng(seed)
    held_j = rng.normal(size=(10, N_Z)) * (rng.uniform(size=(10, N_Z)) > 0.5)
    held_r = rng.normal(size=10)
    groups = []
    for n in (5, 7, 6):
        groups.append((rng.normal(size=(n, N_Z)) * (rng.uniform(size=(n, N_Z)) > 0.4), rng.normal(size=n)))
    a = rng.normal(size=(N_G, N_Z))
    model = KktQuadraticModel(sps.csr_matrix(held_j), held_r, sps.csr_matrix(a),
                              [ScaledRows(sps.csr_matrix(j), r, j.shape[0]) for j, r in groups])
    return model, (held_j, held_r), groups, a


def dense_log_evidence(held, groups, a, x) -> float:
    """log Z on the null space N of ``a``: -1/2 min chi2 - 1/2 log det(N^T H N) - sum n_k x_k."""
    s = np.exp(-2 * np.asarray(x))
    rows = np.vstack([held[0]] + [j * np.sqrt(k) for k, (j, _) in zip(s, groups)])
    res = np.concatenate([held[1]] + [r * np.sqrt(k) for k, (_, r) in zip(s, groups)])
    n = scipy.linalg.null_space(a)
    jn = rows @ n
    w = -np.linalg.lstsq(jn, res, rcond=None)[0]
    chi2 = float(np.sum((res + jn @ w) ** 2))
    counts = np.array([j.shape[0] for j, _ in groups])
    return -0.5 * chi2 - 0.5 * np.linalg.slogdet(jn.T @ jn)[1] - counts @ x


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_value_differences_and_gradient_match_the_dense_null_space_evidence(seed):
    model, held, groups, a = problem(seed)
    rng = np.random.default_rng(100 + seed)
    x0 = np.zeros(3)
    for _ in range(3):
        x = rng.uniform(-1.5, 1.5, size=3)
        value, grad = model.log_evidence(x)
        # the KKT determinant differs from det(N^T H N) by a constant: compare differences
        expected = dense_log_evidence(held, groups, a, x) - dense_log_evidence(held, groups, a, x0)
        assert value - model.log_evidence(x0)[0] == pytest.approx(expected, rel=1e-8, abs=1e-8)
        h = 1e-6
        numeric = [(dense_log_evidence(held, groups, a, x + h * e) - dense_log_evidence(held, groups, a, x - h * e))
                   / (2 * h) for e in np.eye(3)]
        # the log det's part is a forward difference (kkt_evidence.STEP): agreement to ~1e-4 per unit
        np.testing.assert_allclose(grad, numeric, rtol=1e-4, atol=1e-3)


def test_with_groups_replaces_the_groups_and_adds_the_normaliser():
    model, held, groups, a = problem(7)
    swapped = model.with_groups(model.groups[::-1], 2.5)
    x = np.array([0.3, -0.2, 0.1])
    assert swapped.log_evidence(x[::-1])[0] == pytest.approx(model.log_evidence(x)[0] + 2.5, rel=1e-10)


def test_a_singular_kkt_matrix_gives_the_penalty_not_an_exception():
    j = sps.csr_matrix(np.array([[1.0, 0.0, 0.0]]))  # the third unknown in no row and no constraint
    model = KktQuadraticModel(j, np.array([1.0]), sps.csr_matrix(np.array([[0.0, 1.0, 0.0]])),
                              [ScaledRows(sps.csr_matrix(np.array([[2.0, 0.0, 0.0]])), np.array([0.5]), 1)])
    value, grad = model.log_evidence(np.zeros(1))
    assert value <= -1e11 and np.all(grad == 0)


@pytest.mark.parametrize("seed", [0, 1])
def test_the_average_information_matches_its_dense_formula(seed):
    """2 (diag(s_k |m_k|^2) - q^T P q), q_k = s_k J_k^T m_k, P = N (N^T H N)^-1 N^T, densely."""
    model, held, groups, a = problem(seed)
    x = np.array([0.3, -0.4, 0.8])
    value, grad, info = model.log_evidence_with_information(x)
    assert (value, *grad) == pytest.approx((*[model.log_evidence(x)[0]], *model.log_evidence(x)[1]))
    s = np.exp(-2 * x)
    h = held[0].T @ held[0] + sum(k * j.T @ j for k, (j, _) in zip(s, groups))
    g = held[0].T @ held[1] + sum(k * j.T @ r for k, (j, r) in zip(s, groups))
    n = scipy.linalg.null_space(a)
    p = n @ np.linalg.solve(n.T @ h @ n, n.T)
    d = -p @ g
    misfit = [r + j @ d for j, r in groups]
    q = np.column_stack([k * j.T @ m for k, (j, _), m in zip(s, groups, misfit)])
    expected = 2 * (np.diag([k * m @ m for k, m in zip(s, misfit)]) - q.T @ p @ q)
    np.testing.assert_allclose(info, expected, rtol=1e-7, atol=1e-9 * np.abs(expected).max())
