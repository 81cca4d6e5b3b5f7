"""The null-space basis of a fit's constraints: the split of the constraint Jacobian A into the
defects' rows in the dependent columns (A_D, factorised), in the independent columns (A_I) and the
side rows (unit norms), and the basis Z with A Z = 0 that the reduced Hessian, the Gauss-Newton
step and the covariance are built on (see :mod:`.covariance`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps
from scipy.linalg import null_space
from scipy.sparse.csgraph import connected_components

from casrecon.estimation.engine.block_lu import BlockLu, as_slice
from casrecon.estimation.engine.submatrix import index_key, pattern_key, sorted_csc, submatrix

#: Column ordering of the LU of A_D. The dependent columns run node by node and the defects interval
#: by interval, so A_D is block-bidiagonal already: the natural order factorises it without fill
#: beyond the band (ees-drop-1: 22 ms against COLAMD's 34, solves 22 ms against 25; residuals 3e-14).
A_D_ORDERING = "NATURAL"
#: SuperLU's diagonal-pivot threshold for A_D. A defect's derivative in the next node's states is
#: near the identity, so its diagonal is kept (the threshold is never reached on the shipped drops)
#: and the factor is causal: a direction that starts at a node (an atmosphere-profile coefficient,
#: from the time the capsule passes its level) is exactly zero in Z's rows before it. Partial
#: pivoting (1.0) took rows of later intervals as pivots and left 1e-16 residues there instead, so
#: the covariance's products could not skip them: on ees-drop-1's profile fit 55 % of Z is zero
#: with 0.1 against 13 % with 1.0, |A Z| 6e-15 against 3e-14, the split 0.9 s against 1.1 s.
A_D_PIVOT_THRESHOLD = 0.1


@dataclass(frozen=True)
class ConstraintSplit:
    """The constraint Jacobian A split as the module docstring describes: the determining rows'
    sparse LU in the ``dependent`` columns, the side rows (e.g. unit norms, which must not touch the
    dependent columns) in the independent ones, and the null-space basis Z they give.

    Attributes
    ----------
    basis : (n_z, n_w) array
        Z with A Z = 0 (zero rows for excluded columns).
    lu : BlockLu
        LU of A_D (determining rows, dependent columns), block by block (a joint fit's drops).
    dep, indep : int arrays
        Dependent columns; independent columns (excluded ones left out).
    a_indep : sparse matrix
        Determining rows in the independent columns, A_I.
    a_side : (n_side, len(indep)) array
        Side rows in the independent columns.
    """

    basis: np.ndarray
    lu: object
    dep: np.ndarray
    indep: np.ndarray
    a_indep: sps.csr_matrix
    a_side: np.ndarray

    def particular(self, c: np.ndarray) -> np.ndarray:
        """A step dz with A dz = -c (to first order this zeroes the constraint values ``c``): the
        least-norm change of the independent columns that zeroes the side rows, then the dependent
        columns from the determining rows; zero in the excluded columns."""
        n_det = self.dep.size
        dz = np.zeros(self.basis.shape[0])
        c_side = c[n_det:]
        if c_side.size:
            dz[self.indep] = -np.linalg.lstsq(self.a_side, c_side, rcond=None)[0]
        dz[self.dep] = -self.lu.solve(c[:n_det] + self.a_indep @ dz[self.indep])
        return dz


def side_null_basis(a_side: np.ndarray) -> sps.csc_matrix:
    """An orthonormal basis N (n, n - rank), sparse, of the null space of the side rows ``a_side``
    (n_side, n) (unit norms) that keeps them apart: the identity on the columns no side row
    touches, and a null-space basis of each group of side rows linked by shared columns on its
    own columns. A joint fit's unit norms (one per drop) thus give each drop's directions rows in
    that drop only, so the basis Z stays block-sparse and its products and solves cost the
    per-drop sum (one SVD of all side rows together would mix every drop into every direction).
    Sparse because it is mostly the identity: its product with A_I then costs A_I's nonzeros, not
    a dense (n_defects, n - rank) product."""
    n_side, n = a_side.shape
    if not n_side:
        return sps.identity(n, format="csc")
    touched = np.flatnonzero(np.any(a_side != 0.0, axis=0))
    free = np.setdiff1d(np.arange(n), touched)
    pattern = sps.csr_matrix(a_side[:, touched] != 0.0)
    n_groups, labels = connected_components(sps.bmat([[None, pattern], [pattern.T, None]]), directed=False)
    parts = [(free, np.eye(free.size))]
    for g in range(n_groups):
        rows, cols = np.flatnonzero(labels[:n_side] == g), touched[labels[n_side:] == g]
        if cols.size:  # a group of side rows without columns (all-zero rows) takes no direction away
            parts.append((cols, null_space(a_side[np.ix_(rows, cols)])))
    rows, cols, values, k = [], [], [], 0
    for part_cols, b in parts:
        r, c = np.nonzero(b)
        rows.append(part_cols[r])
        cols.append(c + k)
        values.append(b[r, c])
        k += b.shape[1]
    return sps.csc_matrix((np.concatenate(values), (np.concatenate(rows), np.concatenate(cols))), shape=(n, k))


#: Remembered independent column sets: (n_z, dependent key, excluded key) -> columns.
_INDEPENDENT: dict[tuple, np.ndarray] = {}


def independent_columns(n_z: int, dep: np.ndarray, excluded: np.ndarray) -> np.ndarray:
    """The columns of 0..n_z-1 neither dependent nor excluded, in order (remembered: a solver
    asks at every iterate)."""
    key = (n_z, index_key(dep), index_key(excluded))
    if key not in _INDEPENDENT:
        if len(_INDEPENDENT) >= 16:
            _INDEPENDENT.clear()
        _INDEPENDENT[key] = np.setdiff1d(np.arange(n_z), np.union1d(dep, excluded))
    return _INDEPENDENT[key]


def constraint_split(a: sps.csc_matrix, dep: np.ndarray, n_determining: int,
                     excluded: np.ndarray = ()) -> ConstraintSplit:
    """The :class:`ConstraintSplit` of a constraint Jacobian whose first ``n_determining`` rows fix
    the columns ``dep`` given the others (the rest are side constraints, e.g. unit norms); the
    ``excluded`` columns (in no constraint) get zero rows in Z."""
    n_z, n_g = a.shape[1], a.shape[0]
    n_def = n_determining
    dep = np.asarray(dep, np.int64)
    indep = independent_columns(n_z, dep, np.asarray(excluded, np.int64))
    # the pieces by remembered gathers (the pattern is the same at every iterate; hashed once)
    a = sorted_csc(a)
    pattern = pattern_key(a)
    a_d = submatrix(a, slice(0, n_def), dep, pattern=pattern)
    a_i = submatrix(a, slice(0, n_def), indep, pattern=pattern).tocsr()
    side = slice(n_def, n_g)
    if n_g > n_def and abs(submatrix(a, side, dep, pattern=pattern)).sum() != 0:
        raise ValueError("a side constraint involves a dependent column")
    a_side_i = submatrix(a, side, indep, pattern=pattern).toarray()
    n_basis = side_null_basis(a_side_i)
    lu = BlockLu(a_d, permc_spec=A_D_ORDERING, diag_pivot_thresh=A_D_PIVOT_THRESHOLD)
    basis = np.zeros((n_z, n_basis.shape[1]))  # calloc: only the pages written below are touched
    n_coo = n_basis.tocoo()
    basis[indep[n_coo.row], n_coo.col] = n_coo.data
    for into, used, part in lu.solve_blocks(a_i @ n_basis):  # basis[dep] = -A_D^-1 A_I N
        rows = dep[into]
        cols = slice(None) if used is None else used
        run = as_slice(rows)  # a drop's dependent columns: one run of rows
        if isinstance(run, slice) and isinstance(cols, slice):
            np.negative(part, out=basis[run, cols])  # written in place (a profile fit's Z is 86 MB)
        else:
            basis[run if isinstance(run, slice) else rows[:, None], cols] = -part
    return ConstraintSplit(basis, lu, dep, indep, a_i, a_side_i)
