"""Sparse LU of a square matrix that falls apart into independent diagonal blocks (the collocation
defects' Jacobian of a joint fit: one block per drop), factorised and solved block by block.

:class:`BlockLu` finds the blocks as the connected components of the bipartite row-column graph
of the matrix's pattern, so it needs no knowledge of drops and works for any row and column
order. Solving a right-hand side that is zero on a block costs nothing for that block: a joint
fit's null-space basis has, for each drop's own free directions, nonzeros in that drop's rows
only, so forming it costs about the per-drop fits' sum instead of the number of drops times it.
The blocks are solved on :data:`BLOCK_THREADS` threads (SuperLU releases the GIL), so a joint
fit's drops share the cores a single drop's one block cannot; they are factorised in the calling
thread: scipy's SuperLU ties a factor's memory to the thread that made it, and a factor that
outlives that thread leaks it (scipy issues 15921 and 25759: 14 GB instead of 0.7 GB for 120
factors of a 200 000-row banded matrix made on a pool and used after it, scipy 1.17.1).
"""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import scipy.sparse as sps
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu

from casrecon.estimation.engine.submatrix import pattern_key, sorted_csc, submatrix
from casrecon.parallel import in_threads

#: Threads over which the blocks are factorised and solved (1: in the calling thread); fewer on a
#: machine of fewer cores, one in a worker of a parallel study (its siblings hold the other cores;
#: :func:`casrecon.parallel.threads_for_one_task`). The results do not depend on it: each block is
#: factorised and solved alone, as on one thread.
BLOCK_THREADS = 2
#: Right-hand sides per solve when a matrix of one block is solved for many (an atmosphere-profile
#: fit's hundreds of null-space directions): the chunks are solved on BLOCK_THREADS threads. They
#: do not depend on the number of threads, so neither do the numbers.
SOLVE_CHUNK_COLUMNS = 128

#: The blocks of the last few patterns seen (an iteration's defect Jacobian has the previous one's
#: pattern): pattern key -> list of (rows, columns) of each block, or None for one block.
_BLOCKS: dict[tuple, list | None] = {}


def components(m: sps.csc_matrix) -> tuple[int, np.ndarray]:
    """(number of blocks, block label of each row then each column) of the square matrix ``m``:
    the connected components of its bipartite row-column graph."""
    graph = sps.bmat([[None, m], [m.T, None]], format="csr")
    return connected_components(graph, directed=False)


def as_slice(index: np.ndarray) -> np.ndarray | slice:
    """A sorted index array as the equal slice when it is a contiguous range (a view instead of a
    copy when rows are taken; a drop's rows and columns usually are), else the array itself."""
    if index.size and index[-1] - index[0] + 1 == index.size:
        return slice(int(index[0]), int(index[-1]) + 1)
    return index


def block_layout(m: sps.csc_matrix, key: tuple | None = None) -> list | None:
    """The (rows, columns) of each diagonal block of the square CSC matrix ``m`` (sorted indices;
    each a slice when contiguous), None for a matrix of one block; remembered by pattern.
    RuntimeError for a block that is not square. ``key``: ``m``'s :func:`pattern_key`, if known."""
    key = pattern_key(m) if key is None else key
    if key in _BLOCKS:
        return _BLOCKS[key]
    n_blocks, labels = components(m)
    n = m.shape[0]
    layout = None
    if n_blocks > 1:
        layout = []
        for b in range(n_blocks):
            rows, cols = np.flatnonzero(labels[:n] == b), np.flatnonzero(labels[n:] == b)
            if rows.size != cols.size:
                raise RuntimeError(f"structurally singular: a block of {rows.size} rows and {cols.size} columns")
            layout.append((as_slice(rows), as_slice(cols)))
    if len(_BLOCKS) >= 8:
        _BLOCKS.clear()
    _BLOCKS[key] = layout
    return layout


def column_chunks(n_columns: int, size: int) -> list[slice]:
    """Consecutive slices of at most ``size`` of ``n_columns`` columns, of near-equal widths."""
    n_chunks = -(-n_columns // size)
    edges = np.linspace(0, n_columns, n_chunks + 1).round().astype(int)
    return [slice(int(a), int(b)) for a, b in zip(edges[:-1], edges[1:])]


class BlockLu:
    """LU of a square sparse matrix by its independent diagonal blocks (one SuperLU each).

    Parameters
    ----------
    matrix : sparse matrix, (n, n)
    permc_spec : str
        SuperLU's column ordering for each block.
    diag_pivot_thresh : float
        SuperLU's threshold for keeping the diagonal pivot: 1 is partial pivoting; below it the
        diagonal entry is kept while it is at least this fraction of its column's largest.

    Raises
    ------
    RuntimeError
        A block is not square (the matrix is structurally singular) or SuperLU finds it singular.
    """

    def __init__(self, matrix: sps.spmatrix, permc_spec: str = "COLAMD", diag_pivot_thresh: float = 1.0) -> None:
        m = sorted_csc(matrix)
        self.n = n = m.shape[0]
        self.blocks: list[tuple[np.ndarray | slice, np.ndarray | slice, object]] = []
        pattern = pattern_key(m)
        layout = block_layout(m, pattern)
        if layout is None:  # one block: no copy of the matrix
            every = slice(0, n)
            self.blocks.append((every, every, splu(m, permc_spec=permc_spec, diag_pivot_thresh=diag_pivot_thresh)))
            return
        # each block cut by a remembered gather of the nonzeros; the LUs made here (module docstring)
        self.blocks.extend((rows, cols, splu(submatrix(m, rows, cols, pattern=pattern), permc_spec=permc_spec,
                                             diag_pivot_thresh=diag_pivot_thresh)) for rows, cols in layout)

    @property
    def n_blocks(self) -> int:
        return len(self.blocks)

    def solve(self, rhs: np.ndarray, trans: str = "N") -> np.ndarray:
        """x with M x = rhs (``trans="T"``: M^T x = rhs), for a vector or a 2-D array of right-hand
        sides; a block's columns of ``rhs`` that are zero on it are not solved for."""
        rhs = np.asarray(rhs, float)
        x = np.zeros(rhs.shape)  # calloc: pages of zeros cost nothing until written
        for into, used, part in self.solve_blocks(rhs, trans):
            if used is None:
                x[into] = part
            else:
                x[into if isinstance(into, slice) else into[:, None], used] = part
        return x

    def solve_blocks(self, rhs: np.ndarray | sps.csr_matrix,
                     trans: str = "N") -> Iterator[tuple[np.ndarray | slice, np.ndarray | None, np.ndarray]]:
        """The solution of :meth:`solve` block by block, without the whole array: (rows of x,
        columns of x or None for all, values) for each block and each of its nonzero columns of
        ``rhs`` (2-D; a block solved for many columns gives one piece per chunk of them, its
        columns a slice), so that a caller can place them where it wants them (the null-space basis
        of a joint fit: 60 MB of zeros and a copy per iterate fewer). ``rhs`` may be a sparse CSR
        matrix (each block's nonzero columns are then made dense on their own: a joint fit's
        A_I N, whose columns each reach one drop)."""
        if sps.issparse(rhs):
            rhs = sps.csr_matrix(rhs, dtype=float)
            rhs.eliminate_zeros()
        else:
            rhs = np.asarray(rhs, float)

        def solved(block: tuple) -> list[tuple]:
            rows, cols, lu = block
            into, source = (cols, rows) if trans == "N" else (rows, cols)
            part = rhs[source]
            if part.ndim == 1:
                return [(into, None, lu.solve(part, trans=trans))]
            every = part.shape[1]
            if sps.issparse(part):
                used = np.flatnonzero(part.getnnz(axis=0))
                dense = part.tocsc()[:, used].toarray()
            else:
                used = np.flatnonzero(np.any(part != 0.0, axis=0))
                dense = part if used.size == every else part[:, used]
            if not used.size:
                return []
            pieces = self._solve_dense(lu, dense, trans)
            if used.size == every:
                return [(into, None if len(pieces) == 1 else chunk, x) for chunk, x in pieces]
            return [(into, used[chunk], x) for chunk, x in pieces]

        yield from (piece for pieces in in_threads(solved, self.blocks, BLOCK_THREADS) for piece in pieces)

    def _solve_dense(self, lu, rhs: np.ndarray, trans: str) -> list[tuple[slice, np.ndarray]]:
        """``lu``'s solution for the dense right-hand sides ``rhs`` (n, k) as (columns, values) pieces:
        with one block and more than SOLVE_CHUNK_COLUMNS of them, by chunks of columns solved on
        threads (several blocks are already solved side by side) and left apart, so that the caller
        writes each where it belongs (no copy into one array: 0.2 s on an atmosphere-profile fit)."""
        if self.n_blocks > 1 or rhs.shape[1] <= SOLVE_CHUNK_COLUMNS:
            return [(slice(0, rhs.shape[1]), lu.solve(np.ascontiguousarray(rhs), trans=trans))]
        chunks = column_chunks(rhs.shape[1], SOLVE_CHUNK_COLUMNS)
        parts = in_threads(lambda c: lu.solve(np.ascontiguousarray(rhs[:, c]), trans=trans), chunks, BLOCK_THREADS)
        return list(zip(chunks, parts))
