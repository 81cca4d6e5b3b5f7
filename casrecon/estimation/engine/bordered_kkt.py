"""Sparse LU of a KKT matrix with a few dense rows and columns (the parameters), by its sparse block
and their Schur complement.

With latent process values at every node the KKT matrix K = [[H, A^T], [A, 0]] is sparse and, in
time order, banded, except for the parameter rows and columns: an aerodynamic factor, a sensor bias
or the clock offset couples every node (H_tu = J_t^T J_u and A_t are dense). A general sparse LU
pivots those dense rows into the factor and fills it: on a whole ees-drop-3 gust fit (39,592 rows,
2.8M nonzeros, 19 parameters) SuperLU's COLAMD order gives 521M LU nonzeros, 169 s and 6 GB; on a
27 s window (26,774 rows) 232M, 15 s, 5.4 GB. Without those 19 rows and columns the same window's
matrix factorises to 2.1M nonzeros in 0.07 s and 280 MB.

So, ordering the unknowns as (latent u with the constraint rows, parameters theta),

    K = [[K_uu, B], [B^T, C]],   S = C - B^T K_uu^-1 B,

K_uu is factorised by sparse LU, T = K_uu^-1 B (one solve with p right-hand sides, p the number of
parameters) and the small dense S (the parameters' profile Hessian: its inverse is their
covariance) by a dense LU. Then K [x; y] = [f; g] is solved by y = S^-1 (g - T^T f), x = K_uu^-1 f -
T y, and log |det K| = log |det K_uu| + log |det S|.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse as sps
from scipy.sparse.linalg import splu


class BorderedKkt:
    """Factor of a symmetric KKT matrix by its block without the ``border`` rows and columns and the
    border's Schur complement (see the module docstring).

    Parameters
    ----------
    kkt : sparse matrix (n, n)
        The symmetric KKT matrix.
    border : int array
        Indices of the dense rows and columns (the parameters' z columns).

    Raises
    ------
    RuntimeError
        When SuperLU finds the sparse block singular, or the Schur complement is singular.
    """

    def __init__(self, kkt: sps.spmatrix, border: np.ndarray) -> None:
        csc = sps.csc_matrix(kkt)
        n = csc.shape[0]
        self.shape = csc.shape
        self.border = np.asarray(border, np.int64)
        self.inner = np.setdiff1d(np.arange(n), self.border)
        rows_inner = csc[self.inner]
        self._lu = splu(rows_inner[:, self.inner].tocsc())
        b = rows_inner[:, self.border].toarray()
        self._t = self._lu.solve(b) if self.border.size else np.zeros((self.inner.size, 0))
        c = csc[self.border][:, self.border].toarray()
        s = c - b.T @ self._t
        self.schur = 0.5 * (s + s.T)
        if self.border.size:
            self._schur_lu = scipy.linalg.lu_factor(self.schur, check_finite=True)
            if np.any(np.diag(self._schur_lu[0]) == 0.0):
                raise RuntimeError("the parameters' Schur complement is singular")

    @property
    def fill(self) -> int:
        """Nonzeros of the sparse block's LU factors (read when asked: SuperLU copies them out)."""
        return int(self._lu.L.nnz + self._lu.U.nnz)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """K^-1 rhs for a vector or the columns of a matrix ``rhs`` (n rows)."""
        rhs = np.asarray(rhs, float)
        f, g = rhs[self.inner], rhs[self.border]
        x_inner = self._lu.solve(np.ascontiguousarray(f))
        out = np.empty_like(rhs)
        if self.border.size:
            y = scipy.linalg.lu_solve(self._schur_lu, g - self._t.T @ f)
            x_inner -= self._t @ y
            out[self.border] = y
        out[self.inner] = x_inner
        return out

    def log_abs_det(self) -> float:
        """log |det K| = log |det K_uu| + log |det S|."""
        inner = float(np.sum(np.log(np.abs(self._lu.U.diagonal()))))
        if not self.border.size:
            return inner
        return inner + float(np.sum(np.log(np.abs(np.diag(self._schur_lu[0])))))
