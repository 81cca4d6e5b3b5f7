"""The split evidence (casrecon.estimation.numerics.split_evidence) against a dense evaluation of the same
Laplace evidence, and its gradient against finite differences."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sps

from casrecon.estimation.numerics.split_evidence import RowGroup, SplitQuadraticModel

N_C, N_E = 5, 8


def chain_rows(rng, n: int) -> np.ndarray:
    """(n, N_E) rows each reaching one z_E value or two neighbours (a Gauss-Markov chain's)."""
    out = np.zeros((n, N_E))
    for i in range(n):
        j = rng.integers(N_E - 1)
        out[i, j:j + 1 + int(rng.integers(2))] = rng.normal(size=1 + int(rng.integers(2)))[:1]
    return out


def problem(seed: int, chains: bool = False):
    """A random fit: rest rows in (w, z_E) and three groups (w only, z_E only, both); ``chains``: the
    rows reach z_E as a Gauss-Markov chain's do (H_EE tridiagonal, the banded factor)."""
    rng = np.random.default_rng(seed)
    rest = rng.normal(size=(20, N_C + N_E))
    rest[:, N_C:] = chain_rows(rng, 20) if chains else rest[:, N_C:] * (rng.uniform(size=(20, N_E)) > 0.6)
    shapes = [(3, True, False), (9, False, True), (8, True, True)]
    groups, dense = [], []
    for n, in_c, in_e in shapes:
        a = np.zeros((n, N_C + N_E))
        if in_c:
            a[:, :N_C] = rng.normal(size=(n, N_C))
        if in_e:
            sparse = rng.normal(size=(n, N_E)) * (rng.uniform(size=(n, N_E)) > 0.5)
            a[:, N_C:] = chain_rows(rng, n) if chains else sparse
        u = rng.normal(size=n)
        dense.append((a, u))
        groups.append(RowGroup(a[:, :N_C] if in_c else None, sps.csr_matrix(a[:, N_C:]) if in_e else None, u, n))
    h = rest.T @ rest + sum(a.T @ a for a, _ in dense)
    model = SplitQuadraticModel(h[:N_C, :N_C], h[N_C:, :N_C], sps.csc_matrix(h[N_C:, N_C:]), groups)
    return model, rest, dense


def dense_log_evidence(rest, dense, x):
    """log Z of the rest rows plus the groups ``dense`` [(A_k, u_k)] at ratios exp(x), up to a constant."""
    s = np.exp(-2 * np.asarray(x))
    h_rest = rest.T @ rest
    grad_rest = -sum(a.T @ u for a, u in dense)
    h = h_rest + sum(k * a.T @ a for k, (a, _) in zip(s, dense))
    g = grad_rest + sum(k * a.T @ u for k, (a, u) in zip(s, dense))
    d = -np.linalg.solve(h, g)
    chi2 = 2 * grad_rest @ d + d @ h_rest @ d + sum(k * np.sum((u + a @ d) ** 2) for k, (a, u) in zip(s, dense))
    counts = np.array([a.shape[0] for a, _ in dense])
    return -0.5 * chi2 - 0.5 * np.linalg.slogdet(h)[1] - counts @ x


@pytest.mark.parametrize("seed, chains", [(0, False), (1, False), (2, False), (3, True), (4, True)])
def test_split_evidence_equals_the_dense_one(seed, chains):
    model, rest, dense = problem(seed, chains)
    assert model.tridiagonal == chains
    rng = np.random.default_rng(10 + seed)
    for x in (np.zeros(3), rng.normal(scale=0.7, size=3)):
        value, grad = model.log_evidence(x)
        assert value == pytest.approx(dense_log_evidence(rest, dense, x), rel=1e-9, abs=1e-9)
        step = 1e-6
        numeric = [(dense_log_evidence(rest, dense, x + step * e) - dense_log_evidence(rest, dense, x - step * e))
                   / (2 * step) for e in np.eye(3)]
        np.testing.assert_allclose(grad, numeric, rtol=1e-5, atol=1e-6)


def test_a_hessian_not_positive_definite_is_penalised():
    model, _, _ = problem(0)
    indefinite = SplitQuadraticModel(model.h_cc_rest - 1e3 * np.eye(N_C), model.b_rest,
                                     model.h_ee_rest, model.groups)
    value, grad = indefinite.log_evidence(np.zeros(3))
    assert value < -1e11 and np.all(grad < 0)


def test_groups_rebuilt_keep_the_fit_s_rest():
    """with_groups: other rows for the groups (a prior at another correlation time) over the same held
    part, the fit's Hessian less the fit's own rows; the log normaliser is added."""
    model, rest, dense = problem(3)
    rng = np.random.default_rng(7)
    other = [(a * (1 + 0.3 * rng.normal(size=a.shape)) * (a != 0), u + 0.2 * rng.normal(size=u.size))
             for a, u in dense]
    groups = [RowGroup(a[:, :N_C] if g.a_c is not None else None,
                       sps.csr_matrix(a[:, N_C:]) if g.a_e is not None else None, u, g.count)
              for (a, u), g in zip(other, model.groups)]
    rebuilt = model.with_groups(groups, 1.5)
    # the dense reference: rest rows and the new groups, the gradient of the rest the fit's own
    # (its stationarity), which the new groups' do not balance
    grad_rest = -sum(a.T @ u for a, u in dense)
    for x in (np.zeros(3), np.array([0.3, -0.2, 0.5])):
        s = np.exp(-2 * x)
        h_rest = rest.T @ rest
        h = h_rest + sum(k * a.T @ a for k, (a, _) in zip(s, other))
        g = grad_rest + sum(k * a.T @ u for k, (a, u) in zip(s, other))
        d = -np.linalg.solve(h, g)
        chi2 = 2 * grad_rest @ d + d @ h_rest @ d + sum(k * np.sum((u + a @ d) ** 2) for k, (a, u) in zip(s, other))
        expected = -0.5 * chi2 - 0.5 * np.linalg.slogdet(h)[1] - np.array([g.count for g in groups]) @ x + 1.5
        assert rebuilt.log_evidence(x)[0] == pytest.approx(expected, rel=1e-9)
