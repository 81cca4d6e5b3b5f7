"""engine.submatrix: remembered gathers give SciPy's slices, for new values of the same pattern."""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps

from casrecon.estimation.engine.submatrix import submatrix


def test_equals_scipy_slicing_for_new_values_of_the_same_pattern():
    rng = np.random.default_rng(5)
    pattern = sps.random(60, 50, density=0.1, format="csc", random_state=6)
    rows, cols = rng.permutation(60)[:25], np.sort(rng.permutation(50)[:20])
    for trial in range(3):
        m = pattern.copy()
        m.data = rng.normal(size=m.nnz)
        if trial == 2:
            m.data[::7] = 0.0  # stored zeros stay stored
        for r, c in [(rows, cols), (slice(0, 30), cols), (slice(30, 60), slice(0, 50))]:
            got, want = submatrix(m, r, c), m[r][:, c].tocsc()
            assert got.shape == want.shape
            np.testing.assert_array_equal(got.toarray(), want.toarray())


def test_the_callers_matrix_is_not_modified():
    m = sps.csc_matrix((np.array([1.0, 2.0, 3.0]), np.array([2, 0, 1]), np.array([0, 2, 3])), shape=(3, 2))
    assert not m.has_sorted_indices
    before = (m.data.copy(), m.indices.copy())
    np.testing.assert_array_equal(submatrix(m, slice(0, 3), np.array([0])).toarray(), [[2.0], [0.0], [1.0]])
    np.testing.assert_array_equal(m.data, before[0])
    np.testing.assert_array_equal(m.indices, before[1])



def test_gathered_equals_the_build_and_follows_new_values():
    """A latent KKT assembly (mirror a triangle, slice, transpose, stack) by the remembered gather
    equals the direct build, at the first call and for new values of the same patterns."""
    import scipy.sparse as sps

    from casrecon.estimation.engine.submatrix import gathered

    rng = np.random.default_rng(3)
    dense = rng.standard_normal((12, 12)) * (rng.random((12, 12)) < 0.4)
    h_upper = sps.csc_matrix(np.triu(dense @ dense.T))
    a = sps.csc_matrix(rng.standard_normal((4, 12)) * (rng.random((4, 12)) < 0.5))
    keep = np.array([0, 2, 3, 5, 7, 8, 11])

    def build(h, jac):
        full = (h + sps.triu(h, 1).T).tocsc()
        return sps.bmat([[full[keep][:, keep], jac[:, keep].T], [jac[:, keep], None]], format="csc")

    for scale in (1.0, -2.5):
        h2, a2 = h_upper.copy(), a.copy()
        h2.data *= scale
        a2.data *= scale + 1.0
        got = gathered(build, h2, a2, key=("test", keep.tobytes()))
        np.testing.assert_array_equal(got.toarray(), build(h2, a2).toarray())
