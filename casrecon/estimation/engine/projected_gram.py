"""The reduced Gauss-Newton Hessian's products (J Z)^T (J Z) and J_E^T (J Z) from the residual
Jacobian J itself: chunk by chunk of residual rows for a null-space basis Z that is block-sparse
(a joint fit's: each drop's rows reach its own directions and the shared ones,
:func:`projected_gram`), chunk by chunk of Z's columns for a wide dense one (an
atmosphere-profile fit's hundreds of directions, :func:`wide_gram`); see
:func:`.covariance.reduced_hessian_from_jacobian`.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps

from casrecon.estimation.engine import block_lu
from casrecon.estimation.engine.submatrix import pattern_key
from casrecon.parallel import in_threads

#: Residual rows per chunk of :func:`projected_gram`.
GRAM_CHUNK_ROWS = 4096
#: Columns of Z per chunk of :func:`wide_gram`; a basis at most this wide is multiplied whole.
GRAM_CHUNK_COLUMNS = 128
#: Chunk layouts of :func:`projected_gram` by residual-Jacobian pattern (the last few NLPs').
_GRAM_CHUNKS: dict[tuple, list[tuple[int, int, int, int, np.ndarray, np.ndarray, np.ndarray]]] = {}


def gram_chunks(jr: sps.csr_matrix) -> list[tuple[int, int, int, int, np.ndarray, np.ndarray, np.ndarray]]:
    """Row chunks of the CSR matrix ``jr`` as :func:`projected_gram` uses them, worked out once per
    pattern (an iteration's Jacobian has the last one's): (first row, end row, first and end
    position in ``jr.data``, the columns the chunk reaches, its column indices renumbered into
    those, its row pointer)."""
    key = (GRAM_CHUNK_ROWS, *pattern_key(jr))
    if key not in _GRAM_CHUNKS:
        seen = np.zeros(jr.shape[1], bool)
        chunks = []
        for start in range(0, jr.shape[0], GRAM_CHUNK_ROWS):
            end = min(start + GRAM_CHUNK_ROWS, jr.shape[0])
            lo, hi = int(jr.indptr[start]), int(jr.indptr[end])
            seen[:] = False
            seen[jr.indices[lo:hi]] = True
            position = np.cumsum(seen) - 1  # z column -> its place among the chunk's columns
            chunks.append((start, end, lo, hi, np.flatnonzero(seen), position[jr.indices[lo:hi]],
                           jr.indptr[start:end + 1] - lo))
        if len(_GRAM_CHUNKS) >= 8:
            _GRAM_CHUNKS.clear()
        _GRAM_CHUNKS[key] = chunks
    return _GRAM_CHUNKS[key]


def projected_gram(jr: sps.spmatrix, basis: np.ndarray, je: sps.spmatrix) -> tuple[np.ndarray, np.ndarray]:
    """((J Z)^T (J Z), J_E^T (J Z)) chunk by chunk of residual rows, each chunk multiplied only
    with the columns of Z it can reach (a row of J sees a few z columns, whose Z rows are zero
    outside their drop's directions and the shared ones in a joint fit): the cost of the per-drop
    products' sum, not the number of drops times the whole. The chunks' products are computed on
    :data:`~.block_lu.BLOCK_THREADS` threads and added up in chunk order, so the sums are those of
    one thread to the last bit."""
    jr, je = sps.csr_matrix(jr), sps.csr_matrix(je)
    n_w = basis.shape[1]
    hr, b = np.zeros((n_w, n_w)), np.zeros((je.shape[1], n_w))

    def products(chunk: tuple) -> tuple | None:
        start, end, lo, hi, cols, local_indices, local_indptr = chunk
        if not cols.size:
            return None
        sub = basis[cols]
        used = np.flatnonzero(np.any(sub != 0.0, axis=0))
        local = sps.csr_matrix((jr.data[lo:hi], local_indices, local_indptr), shape=(end - start, cols.size))
        jz = local @ sub[:, used]
        return used, jz.T @ jz, je[start:end].T @ jz if je.shape[1] else None

    for out in in_threads(products, gram_chunks(jr), block_lu.BLOCK_THREADS):
        if out is None:
            continue
        used, gram, coupling = out
        hr[np.ix_(used, used)] += gram
        if coupling is not None:
            b[:, used] += coupling
    return hr, b


def wide_product(m: sps.spmatrix, dense: np.ndarray) -> list[np.ndarray]:
    """``m @ dense`` as its column chunks (one when ``dense`` has at most GRAM_CHUNK_COLUMNS
    columns), computed on :data:`~.block_lu.BLOCK_THREADS` threads (SciPy's sparse products release
    the GIL); the chunks are :func:`~.block_lu.column_chunks` of that size, whatever the threads."""
    if dense.shape[1] <= GRAM_CHUNK_COLUMNS:
        return [m @ dense]
    chunks = block_lu.column_chunks(dense.shape[1], GRAM_CHUNK_COLUMNS)
    return list(in_threads(lambda c: m @ np.ascontiguousarray(dense[:, c]), chunks, block_lu.BLOCK_THREADS))


#: A chunk whose nonzero rows are more than this fraction of its rows is multiplied whole.
DENSE_SUPPORT = 0.9


def symmetric_from_chunks(lefts: list[np.ndarray], rights: list[np.ndarray],
                          supports: list[np.ndarray] | None = None) -> np.ndarray:
    """The symmetric matrix X^T Y from the column chunks of X (``lefts``) and Y (``rights``, chunked
    alike), X^T Y symmetric (J Z twice for a Gram matrix, Z and H Z for a congruence): the blocks
    (i, j), i <= j, each as X_i^T Y_j or (X_j^T Y_i)^T, whichever of X_i, X_j has fewer nonzero
    rows, on those rows only; the blocks below the diagonal their transposes (exactly symmetric).
    An atmosphere-profile direction is zero before the capsule reaches its level, so that is about
    a third of the whole product. The blocks are computed on :data:`~.block_lu.BLOCK_THREADS`
    threads (BLAS releases the GIL); neither the chunks nor the rows depend on the number of
    threads, so neither do the numbers. ``supports``: each left chunk's nonzero rows, when the
    caller has them (:func:`row_support`)."""
    edges = np.cumsum([0] + [part.shape[1] for part in rights])
    chunks = [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]
    support = [row_support(x) for x in lefts] if supports is None else supports

    def block(ij: tuple[int, int]) -> np.ndarray:
        i, j = ij
        k, other = (i, j) if support[i].size <= support[j].size else (j, i)
        rows = support[k]
        if rows.size > DENSE_SUPPORT * lefts[k].shape[0]:
            product = lefts[k].T @ rights[other]
        else:
            product = lefts[k][rows].T @ rights[other][rows]
        if i == j:  # X_i^T Y_i is symmetric only to round-off unless X = Y
            return 0.5 * (product + product.T)
        return product if k == i else product.T

    pairs = [(i, j) for i in range(len(chunks)) for j in range(i, len(chunks))]
    out = np.zeros((edges[-1], edges[-1]))
    for (i, j), values in zip(pairs, in_threads(block, pairs, block_lu.BLOCK_THREADS)):
        out[chunks[i], chunks[j]] = values
        out[chunks[j], chunks[i]] = values.T
    return out


def wide_gram(jr: sps.spmatrix, basis: np.ndarray, je: sps.spmatrix) -> tuple[np.ndarray, np.ndarray]:
    """((J Z)^T (J Z), J_E^T (J Z)) for a dense basis Z: J Z by :func:`wide_product` (at once when
    Z has at most GRAM_CHUNK_COLUMNS columns, else by chunks of that many computed on
    :data:`~.block_lu.BLOCK_THREADS` threads), and the Gram matrix block by block of those chunks
    (:func:`symmetric_from_chunks`)."""
    jr, je = sps.csr_matrix(jr), sps.csr_matrix(je)
    parts = wide_product(jr, basis)
    hr = symmetric_from_chunks(parts, parts)
    b = np.zeros((je.shape[1], basis.shape[1]))
    if je.shape[1]:
        start = 0
        for part in parts:
            b[:, start:start + part.shape[1]] = je.T @ part
            start += part.shape[1]
    return hr, b


def wide_congruence(h: sps.spmatrix, basis: np.ndarray, rows: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(Z^T H Z, (H Z)[rows]) for a symmetric sparse H and a dense basis Z: H Z by column chunks of
    GRAM_CHUNK_COLUMNS on threads, each from the columns of H on the chunk's nonzero rows, and
    Z^T H Z block by block of them
    (:func:`symmetric_from_chunks`: the upper blocks only, on their nonzero rows, on threads, and
    no copy of H Z into one array)."""
    h = sps.csc_matrix(h)
    lefts = [np.ascontiguousarray(basis[:, c]) for c in block_lu.column_chunks(basis.shape[1], GRAM_CHUNK_COLUMNS)]

    rows = np.asarray(rows, np.int64)
    if not lefts:  # no free direction
        return np.zeros((0, 0)), np.zeros((rows.size, 0))
    supports = [row_support(x) for x in lefts]

    def product(k: int) -> np.ndarray:  # H x on x's nonzero rows only
        x, support = lefts[k], supports[k]
        return h @ x if support.size > DENSE_SUPPORT * x.shape[0] else h[:, support] @ x[support]

    parts = list(in_threads(product, range(len(lefts)), block_lu.BLOCK_THREADS))
    return symmetric_from_chunks(lefts, parts, supports), np.hstack([part[rows] for part in parts])


def row_support(x: np.ndarray) -> np.ndarray:
    """The rows of the 2-D array ``x`` with a nonzero entry."""
    return np.flatnonzero(np.any(x != 0.0, axis=1))
