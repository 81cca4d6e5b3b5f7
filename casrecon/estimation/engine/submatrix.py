"""Submatrices of sparse matrices that keep their pattern from one iteration to the next.

A solver iteration slices its constraint Jacobian into the same pieces each time (the defects'
rows in the dependent columns, in the independent columns, the side rows). SciPy's fancy
slicing costs tens of milliseconds per piece on a joint fit; :func:`submatrix` works out once per
pattern where each nonzero of a piece comes from, and then cuts a new matrix of that pattern by
one gather of its nonzeros. :func:`gathered` does the same for any assembly of several matrices
that only places nonzeros (slicing, transposing, stacking), e.g. a KKT matrix.
"""

from __future__ import annotations

import threading
from collections.abc import Callable

import numpy as np
import scipy.sparse as sps

#: Remembered gathers: (the parts' pattern keys, the caller's key) -> (positions of the result's
#: nonzeros in the parts' concatenated CSC data, its CSC indices, its CSC index pointer, its shape).
_GATHERS: dict[tuple, tuple[np.ndarray, np.ndarray, np.ndarray, tuple[int, int]]] = {}
#: Gathers kept at most (a few NLPs' worth; the oldest are dropped first).
MAX_GATHERS = 32
#: Guards :data:`_GATHERS` (the blocks of a joint fit are cut on several threads).
_GATHERS_LOCK = threading.Lock()


def sorted_csc(matrix: sps.spmatrix) -> sps.csc_matrix:
    """``matrix`` as CSC with sorted row indices (a copy only when it is not already so: the
    caller's matrix is left as it is)."""
    m = sps.csc_matrix(matrix)
    return m if m.has_sorted_indices else m.sorted_indices()


def pattern_key(m: sps.csc_matrix) -> tuple:
    """A key of the sparsity pattern of a CSC matrix with sorted indices."""
    return m.shape, m.nnz, hash(m.indptr.tobytes()), hash(m.indices.tobytes())


def index_key(index) -> tuple:
    """A key of a row or column selection: a slice or an integer array."""
    if isinstance(index, slice):
        return ("slice", index.start, index.stop, index.step)
    index = np.asarray(index, np.int64)
    return ("array", index.size, hash(index.tobytes()))


def submatrix(matrix: sps.spmatrix, rows, cols, *, pattern: tuple | None = None) -> sps.csc_matrix:
    """``matrix[rows][:, cols]`` as CSC (``rows``, ``cols``: slices or integer arrays), the same
    values as SciPy's slicing, through a gather remembered for the pattern and the selection
    (:func:`gathered`; ``pattern``: ``matrix``'s :func:`pattern_key` if the caller has it, CSC with
    sorted indices then required)."""
    return gathered(lambda m: m[rows][:, cols], matrix, key=("submatrix", index_key(rows), index_key(cols)),
                    patterns=None if pattern is None else (pattern,))


def gathered(build: Callable[..., sps.spmatrix], *parts: sps.spmatrix, key: tuple = (),
             patterns: tuple | None = None) -> sps.csc_matrix:
    """``build(*parts)`` as CSC with sorted indices, through one gather of the parts' nonzeros
    worked out once for their patterns and ``key`` (which must name everything else ``build``
    depends on: the selections it makes). ``build`` may slice, transpose, mirror a triangle and
    stack, but must never add two nonzeros together (each entry of its result comes from one
    nonzero of one part). ``patterns``: the parts' :func:`pattern_key` values when the caller has
    them (each part must then be CSC with sorted indices already), so that they are not hashed again.
    Safe to call from several threads."""
    if patterns is None:
        parts = [sorted_csc(p) for p in parts]
        patterns = tuple(pattern_key(p) for p in parts)
    full_key = (patterns, key)
    entry = _GATHERS.get(full_key)
    if entry is None:
        offsets = np.cumsum([0] + [p.nnz for p in parts])
        # 1-based positions across the parts, so that no stored position is an explicit zero
        positions = [sps.csc_matrix((np.arange(o + 1, o + p.nnz + 1, dtype=float), p.indices, p.indptr), shape=p.shape)
                     for o, p in zip(offsets, parts)]
        piece = sps.csc_matrix(build(*positions))
        piece.sort_indices()
        entry = (piece.data.astype(np.int64) - 1, piece.indices.copy(), piece.indptr.copy(), piece.shape)
        with _GATHERS_LOCK:
            if len(_GATHERS) >= MAX_GATHERS:
                del _GATHERS[next(iter(_GATHERS))]
            _GATHERS[full_key] = entry
    where, indices, indptr, shape = entry
    data = np.concatenate([p.data for p in parts]) if len(parts) > 1 else parts[0].data
    return sps.csc_matrix((data[where], indices, indptr), shape=shape)
