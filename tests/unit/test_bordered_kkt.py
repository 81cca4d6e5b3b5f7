"""The bordered KKT factor against dense linear algebra."""

import numpy as np
import pytest
import scipy.sparse as sps

from casrecon.estimation.engine.bordered_kkt import SELECTED_TOLERANCE, BorderedKkt
from casrecon.estimation.engine.kkt_covariance import KktCovariance


def banded_kkt(n_u: int = 60, n_t: int = 3, n_g: int = 20, seed: int = 0, theta_only_row: bool = False):
    """A KKT matrix of a banded least-squares problem with ``n_t`` dense parameter columns (the
    last of the unknowns) and banded constraints; with ``theta_only_row`` the last constraint
    involves the parameters alone."""
    rng = np.random.default_rng(seed)
    n_z = n_u + n_t
    jac = np.zeros((2 * n_z, n_z))
    for i in range(n_u):
        jac[i, max(0, i - 2):i + 1] = rng.standard_normal(min(i, 2) + 1)
    jac[n_u:, :] = 0.1 * rng.standard_normal((n_z + n_t, n_z))  # dense rows: every unknown
    h = jac.T @ jac
    a = np.zeros((n_g, n_z))
    for i in range(n_g):
        c = 3 * i
        a[i, c:c + 4] = rng.standard_normal(4)
        a[i, n_u + i % n_t] = rng.standard_normal()
    if theta_only_row:
        a[-1, :n_u] = 0.0
    kkt = np.block([[h, a.T], [a, np.zeros((n_g, n_g))]])
    return kkt, n_z, np.arange(n_u, n_z)


def test_solve_and_log_det_equal_the_dense_ones():
    kkt, _, border = banded_kkt()
    factor = BorderedKkt(sps.csc_matrix(kkt), border)
    rhs = np.random.default_rng(1).standard_normal((kkt.shape[0], 5))
    np.testing.assert_allclose(factor.solve(rhs), np.linalg.solve(kkt, rhs), rtol=1e-8, atol=1e-10)
    np.testing.assert_allclose(factor.solve(rhs[:, 0]), np.linalg.solve(kkt, rhs[:, 0]), rtol=1e-8, atol=1e-10)
    assert factor.log_abs_det() == pytest.approx(np.linalg.slogdet(kkt)[1], rel=1e-10)
    # the Schur complement's inverse is the border's block of K^-1
    np.testing.assert_allclose(np.linalg.inv(factor.schur), np.linalg.inv(kkt)[np.ix_(border, border)], rtol=1e-8)


def test_without_border_it_is_a_plain_sparse_lu():
    kkt, _, _ = banded_kkt()
    factor = BorderedKkt(sps.csc_matrix(kkt), np.zeros(0, np.int64))
    rhs = np.arange(kkt.shape[0], dtype=float)
    np.testing.assert_allclose(factor.solve(rhs), np.linalg.solve(kkt, rhs), rtol=1e-8, atol=1e-10)
    assert factor.log_abs_det() == pytest.approx(np.linalg.slogdet(kkt)[1], rel=1e-10)


def test_a_constraint_on_parameters_alone_falls_back_to_one_lu():
    """The block without the border is then singular (a zero row): the bordered factor refuses and
    the covariance factorises the whole matrix, with the same result."""
    kkt, n_z, border = banded_kkt(theta_only_row=True)
    with pytest.raises(RuntimeError):
        BorderedKkt(sps.csc_matrix(kkt), border)
    cov = KktCovariance(sps.csc_matrix(kkt), n_z, chi2=1.0, dof=1, border=border)
    idx = np.r_[0, 7, border]
    want = np.linalg.inv(kkt)[np.ix_(idx, idx)]
    np.testing.assert_allclose(cov.covariance_of(idx), want, rtol=1e-7, atol=1e-12)


def chain_kkt(n_nodes: int = 400, n_x: int = 3, n_t: int = 2, seed: int = 0):
    """The KKT matrix of a time chain like a track's fit: states x_i (n_x each) measured at every
    node with the parameters, defects x_i+1 = F_i x_i + G_i theta; (K, n_z, border, node columns)."""
    rng = np.random.default_rng(seed)
    n_u = n_nodes * n_x
    n_z = n_u + n_t
    jac = sps.lil_matrix((n_u + n_t, n_z))
    a = sps.lil_matrix(((n_nodes - 1) * n_x, n_z))
    for i in range(n_nodes):
        x = slice(i * n_x, (i + 1) * n_x)
        jac[x, x] = np.diag(rng.uniform(0.5, 2.0, n_x))
        jac[x, n_u:] = 0.3 * rng.standard_normal((n_x, n_t))
        if i + 1 < n_nodes:
            a[x, x] = np.eye(n_x) + 0.1 * rng.standard_normal((n_x, n_x))
            a[x, slice((i + 1) * n_x, (i + 2) * n_x)] = -np.eye(n_x)
            a[x, n_u:] = 0.01 * rng.standard_normal((n_x, n_t))
    jac[n_u:, n_u:] = np.eye(n_t)
    jac, a = jac.tocsr(), a.tocsr()
    kkt = sps.bmat([[jac.T @ jac, a.T], [a, None]], format="csc")
    return kkt, n_z, np.arange(n_u, n_z), np.arange(n_u).reshape(n_nodes, n_x)


def test_every_nodes_block_costs_a_few_solves_not_one_per_column(monkeypatch):
    """Reading the covariance node by node (a 25 Hz track's states and areas at every node: 984 s
    of column solves, issue 49) takes the selected inverse of the sparse block and S^-1; column
    solves only check three of the blocks. The blocks are the dense inverse's to SELECTED_TOLERANCE
    of their largest entry (here, condition 1e7, to 1.4e-8; the column solves to 1e-12)."""
    kkt, n_z, border, nodes = chain_kkt()
    solved = []
    solve = BorderedKkt.solve

    def counting(self, rhs):
        solved.append(1 if np.ndim(rhs) == 1 else np.shape(rhs)[1])
        return solve(self, rhs)

    monkeypatch.setattr(BorderedKkt, "solve", counting)
    cov = KktCovariance(kkt, n_z, chi2=1.0, dof=1, border=border)
    sets = [np.concatenate([border, cols]) for cols in nodes] + [cols for cols in nodes]
    solved.clear()
    blocks = cov.blocks(sets)
    assert sum(solved) <= 3 * (border.size + nodes.shape[1])
    inverse = np.linalg.inv(kkt.toarray())
    for s, block in zip(sets, blocks):
        want = inverse[np.ix_(s, s)]
        np.testing.assert_allclose(block, want, rtol=0, atol=SELECTED_TOLERANCE * np.abs(want).max())
    np.testing.assert_allclose(cov.covariance_of(border), inverse[np.ix_(border, border)], rtol=1e-8)
