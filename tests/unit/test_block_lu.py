"""Block-by-block LU of a matrix made of independent diagonal blocks (a joint fit's defect
Jacobian), and the chunked projected Gram matrix, against dense linear algebra."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sps

from casrecon.estimation.engine.block_lu import BlockLu
from casrecon.estimation.engine.projected_gram import projected_gram


def shuffled_blocks(rng, sizes=(7, 12, 5)) -> tuple[sps.csc_matrix, np.ndarray, np.ndarray]:
    """A block-diagonal matrix with well-conditioned random sparse blocks, rows and columns shuffled."""
    blocks = [sps.random(n, n, density=0.4, random_state=rng) + sps.eye(n) * 3 for n in sizes]
    m = sps.block_diag(blocks).tocsr()
    rows, cols = rng.permutation(m.shape[0]), rng.permutation(m.shape[1])
    return m[rows][:, cols].tocsc(), rows, cols


def test_block_lu_solves_like_a_dense_solve():
    rng = np.random.default_rng(4)
    m, _, _ = shuffled_blocks(rng)
    lu = BlockLu(m)
    assert lu.n_blocks == 3
    dense = m.toarray()
    b = rng.normal(size=(m.shape[0], 4))
    assert lu.solve(b) == pytest.approx(np.linalg.solve(dense, b), abs=1e-12)
    assert lu.solve(b, trans="T") == pytest.approx(np.linalg.solve(dense.T, b), abs=1e-12)
    assert lu.solve(b[:, 0]) == pytest.approx(np.linalg.solve(dense, b[:, 0]), abs=1e-12)


def test_a_right_hand_side_zero_on_a_block_gives_zeros_there():
    rng = np.random.default_rng(5)
    m, _, _ = shuffled_blocks(rng)
    lu = BlockLu(m)
    rows, cols, _ = lu.blocks[1]
    b = np.zeros((m.shape[0], 2))
    b[rows, 0] = rng.normal(size=rows.size)  # column 0 lives on block 1 only; column 1 is zero
    x = lu.solve(b)
    assert x == pytest.approx(np.linalg.solve(m.toarray(), b), abs=1e-12)
    others = np.setdiff1d(np.arange(m.shape[1]), cols)
    assert not x[others].any() and not x[:, 1].any()


def test_a_sparse_right_hand_side_gives_the_dense_ones_blocks():
    """A_I N of a joint fit comes sparse: solve_blocks gives the same blocks, columns and values
    as for the dense array, and skips a block's all-zero columns (here column 1 on block 1)."""
    rng = np.random.default_rng(7)
    m, _, _ = shuffled_blocks(rng)
    lu = BlockLu(m)
    rows, _, _ = lu.blocks[1]
    b = rng.normal(size=(m.shape[0], 3))
    b[rows, 1] = 0.0
    dense_parts = list(lu.solve_blocks(b))
    sparse_parts = list(lu.solve_blocks(sps.csr_matrix(b)))
    assert len(sparse_parts) == len(dense_parts) == 3
    for (into_d, used_d, x_d), (into_s, used_s, x_s) in zip(dense_parts, sparse_parts):
        np.testing.assert_array_equal(into_s, into_d)
        np.testing.assert_array_equal(x_s, x_d)
        assert (used_d is None and used_s is None) or np.array_equal(used_s, used_d)
    assert sparse_parts[1][1].tolist() == [0, 2]


def test_a_structurally_singular_matrix_is_refused():
    m = sps.csc_matrix(np.array([[1.0, 2.0, 0.0], [3.0, 4.0, 0.0], [0.0, 5.0, 0.0]]))  # column 2 empty
    with pytest.raises(RuntimeError, match="structurally singular"):
        BlockLu(m)


def test_projected_gram_equals_the_dense_products(monkeypatch):
    rng = np.random.default_rng(6)
    n_r, n_z, n_w = 300, 80, 9
    jr = sps.random(n_r, n_z, density=0.05, random_state=rng, format="csr")
    basis = rng.normal(size=(n_z, n_w))
    basis[:40, :4] = 0.0  # block-sparse, as a joint fit's Z
    basis[40:, 4:7] = 0.0
    elim = np.array([3, 50, 77])
    basis[elim] = 0.0
    monkeypatch.setattr("casrecon.estimation.engine.projected_gram.GRAM_CHUNK_ROWS", 64)
    for _ in range(2):  # the second time with new values on the remembered pattern
        hr, b = projected_gram(jr, basis, jr[:, elim])
        jz = jr.toarray() @ basis
        assert hr == pytest.approx(jz.T @ jz, abs=1e-12)
        assert b == pytest.approx(jr[:, elim].toarray().T @ jz, abs=1e-12)
        jr = jr.copy()
        jr.data = rng.normal(size=jr.nnz)


def test_every_factor_is_made_in_the_calling_thread(monkeypatch):
    """With two threads allowed, the blocks' SuperLU factors are still made in the thread that keeps
    the BlockLu (a factor made on a pool and used after it leaks its memory: scipy 15921)."""
    import threading

    from casrecon import parallel
    from casrecon.estimation.engine import block_lu

    made_in, original_splu = [], block_lu.splu

    def recording_splu(matrix, **options):
        made_in.append(threading.get_ident())
        return original_splu(matrix, **options)

    monkeypatch.setattr(parallel, "threads_for_one_task", lambda wanted: wanted)
    monkeypatch.setattr(block_lu, "BLOCK_THREADS", 2)
    monkeypatch.setattr(block_lu, "splu", recording_splu)
    rng = np.random.default_rng(8)
    m, _, _ = shuffled_blocks(rng, sizes=(30, 41, 25, 33))
    lu = BlockLu(m)
    assert lu.n_blocks == 4 and made_in == [threading.get_ident()] * 4
    b = rng.normal(size=(m.shape[0], 3))
    assert lu.solve(b) == pytest.approx(np.linalg.solve(m.toarray(), b), abs=1e-12)


@pytest.mark.parametrize("threads", [1, 2, 3])
def test_threads_do_not_change_a_bit(monkeypatch, threads):
    """The blocks factorised and solved on several threads, and the Gram chunks computed on them,
    give the one-thread numbers exactly (each block and chunk is computed alone, summed in order)."""
    rng = np.random.default_rng(7)
    m, _, _ = shuffled_blocks(rng, sizes=(30, 41, 25, 33))
    b = rng.normal(size=(m.shape[0], 5))
    jr = sps.random(500, 90, density=0.05, random_state=rng, format="csr")
    basis = rng.normal(size=(90, 8))
    basis[:45, :3] = 0.0
    monkeypatch.setattr("casrecon.estimation.engine.projected_gram.GRAM_CHUNK_ROWS", 32)
    monkeypatch.setattr("casrecon.estimation.engine.block_lu.BLOCK_THREADS", 1)
    x1, xt1 = BlockLu(m).solve(b), BlockLu(m).solve(b, trans="T")
    hr1, c1 = projected_gram(jr, basis, jr[:, [2, 60]])
    monkeypatch.setattr("casrecon.estimation.engine.block_lu.BLOCK_THREADS", threads)
    lu = BlockLu(m)
    assert lu.n_blocks == 4
    assert np.array_equal(lu.solve(b), x1) and np.array_equal(lu.solve(b, trans="T"), xt1)
    hr, c = projected_gram(jr, basis, jr[:, [2, 60]])
    assert np.array_equal(hr, hr1) and np.array_equal(c, c1)


@pytest.mark.parametrize("threads", [1, 2])
def test_wide_products_and_solves_by_column_chunks(monkeypatch, threads):
    """A basis wider than the chunk size is multiplied and solved for by column chunks: the same
    numbers as whole dense products and solves (to round-off), whatever the number of threads."""
    from casrecon.estimation.engine.projected_gram import wide_gram, wide_product

    rng = np.random.default_rng(8)
    monkeypatch.setattr("casrecon.estimation.engine.block_lu.BLOCK_THREADS", threads)
    monkeypatch.setattr("casrecon.estimation.engine.block_lu.SOLVE_CHUNK_COLUMNS", 16)
    monkeypatch.setattr("casrecon.estimation.engine.projected_gram.GRAM_CHUNK_COLUMNS", 16)
    n = 120
    m = (sps.random(n, n, density=0.05, random_state=rng) + sps.eye(n) * 3).tocsc()
    b = rng.normal(size=(n, 53))  # 4 chunks of 13 or 14 columns
    x = BlockLu(m).solve(b)
    assert x == pytest.approx(np.linalg.solve(m.toarray(), b), abs=1e-12)
    jr = sps.random(400, n, density=0.05, random_state=rng, format="csr")
    je = jr[:, [3, 70]]
    hr, c = wide_gram(jr, b, je)
    jz = jr.toarray() @ b
    assert hr == pytest.approx(jz.T @ jz, abs=1e-10) and np.array_equal(hr, hr.T)
    assert c == pytest.approx(je.toarray().T @ jz, abs=1e-10)
    assert np.hstack(wide_product(jr, b)) == pytest.approx(jz, abs=1e-12)
    monkeypatch.setattr("casrecon.estimation.engine.block_lu.BLOCK_THREADS", 1)
    assert np.array_equal(BlockLu(m).solve(b), x)
    hr1, c1 = wide_gram(jr, b, je)
    assert np.array_equal(hr1, hr) and np.array_equal(c1, c)


def staircase(rng, n: int, n_w: int) -> np.ndarray:
    """A dense basis whose column k is zero above a row that grows with k (an atmosphere-profile
    direction is zero before the capsule passes its level)."""
    z = rng.normal(size=(n, n_w))
    starts = np.linspace(0, 0.8 * n, n_w).astype(int)
    z[np.arange(n)[:, None] < starts[None, :]] = 0.0
    return z


@pytest.mark.parametrize("threads", [1, 2])
def test_wide_congruence_of_a_staircase_basis_equals_the_dense_products(monkeypatch, threads):
    """Z^T H Z and (H Z)[rows] by chunks on their nonzero rows: the dense products' numbers (to
    round-off), whatever the number of threads; the chunks of few nonzero rows take the row-restricted
    path and those of many the whole one (both are exercised)."""
    from casrecon.estimation.engine import projected_gram

    rng = np.random.default_rng(9)
    monkeypatch.setattr("casrecon.estimation.engine.block_lu.BLOCK_THREADS", threads)
    monkeypatch.setattr("casrecon.estimation.engine.projected_gram.GRAM_CHUNK_COLUMNS", 8)
    n = 200
    a = sps.random(n, n, density=0.03, random_state=rng)
    h = (a + a.T + sps.eye(n) * 4).tocsc()
    z = staircase(rng, n, 37)
    rows = np.array([5, 77, 150])
    supports = [np.any(z[:, c] != 0.0, axis=1).mean() for c in projected_gram.block_lu.column_chunks(37, 8)]
    assert min(supports) < projected_gram.DENSE_SUPPORT < max(supports)
    hr, b = projected_gram.wide_congruence(h, z, rows)
    hz = h.toarray() @ z
    assert hr == pytest.approx(z.T @ hz, abs=1e-10) and np.array_equal(hr, hr.T)
    assert b == pytest.approx(hz[rows], abs=1e-12)
    monkeypatch.setattr("casrecon.estimation.engine.block_lu.BLOCK_THREADS", 1)
    hr1, b1 = projected_gram.wide_congruence(h, z, rows)
    assert np.array_equal(hr1, hr) and np.array_equal(b1, b)


def test_the_defect_factor_is_causal_so_a_late_direction_is_exactly_zero_before_it_starts():
    """A block lower-bidiagonal A_D whose later block has larger entries than the diagonal one
    (partial pivoting then takes the later row): with the defects' threshold the diagonal is
    kept, and a right-hand side that starts at a block gives exact zeros in the blocks before it."""
    from casrecon.estimation.engine.constraint_split import A_D_ORDERING, A_D_PIVOT_THRESHOLD

    rng = np.random.default_rng(10)
    k, m = 12, 3  # 12 intervals of 3 states: defect j reaches nodes j (sub-diagonal) and j + 1 (diagonal)
    diag = sps.block_diag([np.eye(m) + 0.05 * rng.normal(size=(m, m)) for _ in range(k)])
    sub = sps.block_diag([-3.0 * np.eye(m) + 0.5 * rng.normal(size=(m, m)) for _ in range(k - 1)])
    below = sps.vstack([sps.csr_matrix((m, k * m)), sps.hstack([sub, sps.csr_matrix(((k - 1) * m, m))])])
    a_d = (diag + below).tocsc()
    rhs = np.zeros((k * m, 2))
    rhs[6 * m:7 * m, 0] = rng.normal(size=m)  # a direction entering at interval 6
    rhs[:, 1] = rng.normal(size=k * m)
    x = BlockLu(a_d, permc_spec=A_D_ORDERING, diag_pivot_thresh=A_D_PIVOT_THRESHOLD).solve(rhs)
    assert x == pytest.approx(np.linalg.solve(a_d.toarray(), rhs), rel=1e-12)
    assert np.all(x[:6 * m, 0] == 0.0) and np.all(x[6 * m:, 0] != 0.0)
    pivoting = BlockLu(a_d, permc_spec=A_D_ORDERING).solve(rhs)  # partial pivoting: not causal
    assert pivoting == pytest.approx(x, rel=1e-12)
    assert np.any(pivoting[:6 * m, 0] != 0.0)
