"""Sparse LU of a square matrix that falls apart into independent diagonal blocks (the collocation
defects' Jacobian of a joint fit: one block per drop), factorised and solved block by block.

:class:`BlockLu` finds the blocks as the connected components of the bipartite row-column graph
of the matrix's pattern, so it needs no knowledge of drops and works for any row and column
order. Solving a right-hand side that is zero on a block costs nothing for that block: a joint
fit's null-space basis has, for each drop's own free directions, nonzeros in that drop's rows
only, so forming it costs about the per-drop fits' sum instead of the number of drops times it.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps
from scipy.sparse.csgraph import connected_components
from scipy.sparse.linalg import splu

#: Components of the last few patterns seen (an iteration's defect Jacobian has the previous one's
#: pattern): pattern key -> (number of blocks, labels of the rows then the columns).
_COMPONENTS: dict[tuple, tuple[int, np.ndarray]] = {}


def components(m: sps.csc_matrix) -> tuple[int, np.ndarray]:
    """(number of blocks, block label of each row then each column) of the square matrix ``m``:
    the connected components of its bipartite row-column graph, remembered by pattern."""
    key = (m.shape, m.nnz, hash(m.indptr.tobytes()), hash(m.indices.tobytes()))
    if key not in _COMPONENTS:
        graph = sps.bmat([[None, m], [m.T, None]], format="csr")
        if len(_COMPONENTS) >= 8:
            _COMPONENTS.clear()
        _COMPONENTS[key] = connected_components(graph, directed=False)
    return _COMPONENTS[key]


class BlockLu:
    """LU of a square sparse matrix by its independent diagonal blocks (one SuperLU each).

    Parameters
    ----------
    matrix : sparse matrix, (n, n)
    permc_spec : str
        SuperLU's column ordering for each block.

    Raises
    ------
    RuntimeError
        A block is not square (the matrix is structurally singular) or SuperLU finds it singular.
    """

    def __init__(self, matrix: sps.spmatrix, permc_spec: str = "COLAMD") -> None:
        m = sps.csc_matrix(matrix)
        n = m.shape[0]
        n_blocks, labels = components(m)
        rows_of, cols_of = labels[:n], labels[n:]
        self.n = n
        self.blocks: list[tuple[np.ndarray, np.ndarray, object]] = []
        if n_blocks == 1:  # no copy of the matrix
            every = np.arange(n)
            self.blocks.append((every, every, splu(m, permc_spec=permc_spec)))
            return
        for b in range(n_blocks):
            rows, cols = np.flatnonzero(rows_of == b), np.flatnonzero(cols_of == b)
            if rows.size != cols.size:
                raise RuntimeError(f"structurally singular: a block of {rows.size} rows and {cols.size} columns")
            self.blocks.append((rows, cols, splu(m[rows][:, cols].tocsc(), permc_spec=permc_spec)))

    @property
    def n_blocks(self) -> int:
        return len(self.blocks)

    def solve(self, rhs: np.ndarray, trans: str = "N") -> np.ndarray:
        """x with M x = rhs (``trans="T"``: M^T x = rhs), for a vector or a 2-D array of right-hand
        sides; a block's columns of ``rhs`` that are zero on it are not solved for."""
        rhs = np.asarray(rhs, float)
        x = np.zeros_like(rhs)
        for rows, cols, lu in self.blocks:
            into, source = (cols, rows) if trans == "N" else (rows, cols)
            part = rhs[source]
            if part.ndim == 1:
                x[into] = lu.solve(part, trans=trans)
                continue
            used = np.flatnonzero(np.any(part != 0.0, axis=0))
            if used.size:
                x[np.ix_(into, used)] = lu.solve(np.ascontiguousarray(part[:, used]), trans=trans)
        return x
