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

Many small blocks of K^-1 (a covariance read node by node) come from the selected inverse of K_uu
(:mod:`casrecon.estimation.numerics.banded_inverse`, O(n b^2) for its bandwidth b in a
reverse Cuthill-McKee order) when that costs less than a solve per column, O(fill) each:

    K^-1 = [[G + T S^-1 T^T, -T S^-1], [-S^-1 T^T, S^-1]],   G = K_uu^-1.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg
import scipy.sparse as sps
from scipy.sparse.linalg import splu

from casrecon.estimation.numerics.banded_inverse import (
    BandedInverse,
    NotBanded,
    banded_order,
    order_span,
    selected_flops,
)

#: Largest relative difference between a block from the selected inverse and the same block from
#: column solves (checked on the first block asked for) for the selected inverse to be used.
SELECTED_TOLERANCE = 1e-6


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
        self._inner_matrix = rows_inner[:, self.inner].tocsc()
        self._lu = splu(self._inner_matrix)
        self._selected: BandedInverse | NotBanded | None = None
        self._schur_inverse: np.ndarray | None = None
        self._checked = False
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

    def inverse_blocks(self, sets: list[np.ndarray]) -> list[np.ndarray]:
        """K^-1[s][:, s] for each index set ``s`` from the selected inverse of K_uu (see the module
        docstring; a set of border indices only is read off S^-1). Raises NotBanded
        (:mod:`casrecon.estimation.numerics.banded_inverse`) when
        that does not apply (a band too wide, a set spanning distant blocks, a block the
        recurrences cannot invert, a check against column solves that fails) or costs more than
        solving for the sets' columns, which the caller then does."""
        sets = [np.asarray(s, np.int64) for s in sets]
        inner_pos = np.full(self.shape[0], -1, np.int64)
        inner_pos[self.inner] = np.arange(self.inner.size)
        inner_sets = [inner_pos[s][inner_pos[s] >= 0] for s in sets]
        selected = self._selected_inverse(inner_sets) if any(s.size for s in inner_sets) else None
        if self._schur_inverse is None:
            self._schur_inverse = (np.linalg.inv(self.schur) if self.border.size else np.zeros((0, 0)))
        border_pos = np.full(self.shape[0], -1, np.int64)
        border_pos[self.border] = np.arange(self.border.size)
        s_inv = self._schur_inverse
        out = []
        for s in sets:
            i_in = np.flatnonzero(inner_pos[s] >= 0)
            i_b = np.flatnonzero(border_pos[s] >= 0)
            rows_in, rows_b = inner_pos[s[i_in]], border_pos[s[i_b]]
            t = self._t[rows_in]  # (n_in, p)
            block = np.empty((s.size, s.size))
            t_s = t @ s_inv
            if rows_in.size:
                block[np.ix_(i_in, i_in)] = selected.block_of(rows_in) + t_s @ t.T
            cross = -t_s[:, rows_b]
            block[np.ix_(i_in, i_b)] = cross
            block[np.ix_(i_b, i_in)] = cross.T
            block[np.ix_(i_b, i_b)] = s_inv[np.ix_(rows_b, rows_b)]
            out.append(block)
        if selected is not None and not self._checked:
            for k in sorted({0, len(sets) // 2, len(sets) - 1}):
                self._check(sets[k], out[k])
            self._checked = True
        return out

    def _selected_inverse(self, inner_sets: list[np.ndarray]) -> BandedInverse:
        """The selected inverse of K_uu, made at the first call that pays for it, in blocks wide
        enough for ``inner_sets`` (positions in K_uu); NotBanded otherwise (a refusal for a reason
        other than cost is kept)."""
        if isinstance(self._selected, NotBanded):
            raise self._selected
        if self._selected is None:
            order = banded_order(self._inner_matrix)
            span = order_span(order, inner_sets)
            n_columns = sum(int(s.size) for s in inner_sets)
            if selected_flops(self.inner.size, max(order[1], span)) > 2.0 * n_columns * self.fill:
                raise NotBanded("column solves cost less")
            try:
                self._selected = BandedInverse(self._inner_matrix, order, span)
            except NotBanded as err:
                self._selected = err
                raise
        return self._selected

    def _check(self, s: np.ndarray, block: np.ndarray) -> None:
        """Compare one block of the selected inverse with column solves (the first call checks its
        first, middle and last set); on a mismatch the selected inverse is dropped (NotBanded)."""
        e = np.zeros((self.shape[0], s.size))
        e[s, np.arange(s.size)] = 1.0
        exact = self.solve(e)[s]
        scale = max(float(np.abs(exact).max()), 1e-300)
        if float(np.abs(block - exact).max()) > SELECTED_TOLERANCE * scale:
            self._selected = NotBanded("the selected inverse disagrees with column solves")
            raise self._selected
