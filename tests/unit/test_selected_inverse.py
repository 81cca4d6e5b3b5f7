"""The band-arrow factorisation and selected inverse of the kinematic fit's normal matrices against
dense linear algebra, on shuffled band-arrow matrices like the fit's (nodes coupled to neighbours,
a few parameters coupled to everything)."""

import numpy as np
import pytest
import scipy.sparse as sps

from casrecon.estimation.numerics.banded_factor import SymmetricFactor, band_arrow_order
from casrecon.estimation.numerics.selected_inverse import BandArrowInverse, OutsideBand


def band_arrow_matrix(n_nodes=120, per_node=6, n_params=5, seed=0):
    """A shuffled SPD matrix: J^T J of residuals coupling consecutive nodes and all parameters."""
    rng = np.random.default_rng(seed)
    n = n_nodes * per_node + n_params
    rows = []
    for k in range(n_nodes - 1):
        cols = np.r_[np.arange(k * per_node, (k + 2) * per_node), n - n_params + np.arange(n_params)]
        for _ in range(2 * per_node):
            row = np.zeros(n)
            row[cols] = rng.normal(size=cols.size)
            rows.append(row)
    j = sps.csr_matrix(np.array(rows))
    a = (j.T @ j + sps.eye(n) * 1e-3).tocsc()
    shuffle = rng.permutation(n)
    return a[shuffle][:, shuffle].tocsc()


def test_the_factor_solves_like_a_dense_solve_with_little_fill():
    a = band_arrow_matrix()
    b = np.random.default_rng(1).normal(size=(a.shape[0], 3))
    factor = SymmetricFactor(a)
    assert np.allclose(factor.solve(b), np.linalg.solve(a.toarray(), b), rtol=1e-8, atol=1e-10)
    # band 2 nodes wide plus the arrow: far below the dense n^2
    assert factor.fill < 0.15 * a.shape[0] ** 2


def test_the_dense_columns_go_last():
    a = band_arrow_matrix()
    counts = np.diff(a.indptr)
    order = band_arrow_order(a)
    assert sorted(order) == list(range(a.shape[0]))
    assert set(order[-5:]) == set(np.argsort(counts)[-5:])


def test_the_selected_blocks_equal_the_dense_inverse():
    a = band_arrow_matrix()
    dense = np.linalg.inv(a.toarray())
    inverse = BandArrowInverse(a)
    params = np.flatnonzero(inverse.position >= inverse.n_band)
    assert params.size == 5
    by_position = np.argsort(inverse.position)
    for start in (0, 200, inverse.n_band - 8):
        idx = np.r_[by_position[start:start + 8], params]
        ref = dense[np.ix_(idx, idx)]
        assert np.abs(inverse.block(idx) - ref).max() < 1e-8 * np.abs(ref).max()


def test_entries_outside_the_band_are_refused():
    a = band_arrow_matrix()
    inverse = BandArrowInverse(a)
    by_position = np.argsort(inverse.position)
    with pytest.raises(OutsideBand):
        inverse.block(by_position[[0, inverse.n_band - 1]])


def test_a_matrix_that_is_not_positive_definite_is_refused():
    a = band_arrow_matrix().tolil()
    a[3, 3] = -1.0
    with pytest.raises(np.linalg.LinAlgError):
        BandArrowInverse(a.tocsc())
