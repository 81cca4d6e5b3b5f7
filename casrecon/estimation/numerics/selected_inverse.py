"""Entries of the inverse of a symmetric positive definite band-arrow matrix, without the inverse.

A kinematic fit's covariance is read node by node: each node's state block, and its covariance with
the IMU parameters. Solving for those columns costs O(n^2 w) for n unknowns and band w (tens of
seconds for a 50-s recording). Here the matrix, in :func:`band_arrow_order`, is split into its band
B (the node states and GPS error processes), its arrow C (band x dense) and its dense corner D (the
parameters). The band's Cholesky factor L (LAPACK's banded factorisation) gives every entry of
B^-1 within the band by Takahashi's recurrence, from the last column back:

    Z[i, j] = -(1 / L[j, j]) sum_{k > j} Z[i, k] L[k, j]   (i > j),
    Z[j, j] = 1 / L[j, j]^2 - (1 / L[j, j]) sum_{k > j} Z[j, k] L[k, j],

which only reads entries within the band, because L fills the band and nothing else: O(n w^2).
The arrow enters through the Schur complement S = D - C^T W, W = B^-1 C:

    A^-1 = [[B^-1 + W S^-1 W^T, -W S^-1], [-S^-1 W^T, S^-1]],

so any block of A^-1 whose band entries lie within w of each other is available exactly.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg as sla
import scipy.sparse as sps

from casrecon.estimation.numerics.banded_factor import band_arrow_order

#: Widest band (in unknowns) stored; wider matrices are left to column solves.
MAX_BANDWIDTH = 400


class OutsideBand(ValueError):
    """A requested entry of the inverse lies outside the band and the arrow."""


class BandArrowInverse:
    """The band and arrow entries of A^-1 for a symmetric positive definite sparse A.

    Parameters
    ----------
    a : sparse matrix (n, n)

    Raises
    ------
    OutsideBand
        When the band, in :func:`band_arrow_order`, is wider than :data:`MAX_BANDWIDTH`.
    numpy.linalg.LinAlgError
        When A is not positive definite.
    """

    def __init__(self, a: sps.spmatrix) -> None:
        csc = sps.csc_matrix(a)
        order = band_arrow_order(csc)
        counts = np.diff(csc.indptr)[order]
        n_dense = int(np.sum(counts > np.median(counts) * 10.0)) if order.size else 0
        n_band = order.size - n_dense
        self.position = np.empty(order.size, np.int64)
        self.position[order] = np.arange(order.size)
        self.n_band = n_band
        permuted = csc[order][:, order].tocsc()
        band = permuted[:n_band, :n_band].tocoo()
        lower = band.row >= band.col
        width = int(np.max(band.row[lower] - band.col[lower], initial=0))
        if width > MAX_BANDWIDTH:
            raise OutsideBand(f"band {width} wider than {MAX_BANDWIDTH}")
        self.width = width
        ab = np.zeros((width + 1, n_band))
        ab[band.row[lower] - band.col[lower], band.col[lower]] = band.data[lower]
        chol = sla.cholesky_banded(ab, lower=True)
        self._band = _band_inverse(chol)
        arrow = permuted[:n_band, n_band:].toarray()
        corner = permuted[n_band:, n_band:].toarray()
        self._w = sla.cho_solve_banded((chol, True), arrow) if n_dense else np.zeros((n_band, 0))
        schur = corner - arrow.T @ self._w
        self._schur_inv = sla.cho_solve(sla.cho_factor(schur), np.eye(n_dense)) if n_dense else np.zeros((0, 0))
        self._w_schur = self._w @ self._schur_inv

    def block(self, idx: np.ndarray) -> np.ndarray:
        """A^-1[idx][:, idx].

        Raises
        ------
        OutsideBand
            When two of the band unknowns in ``idx`` are further apart than the band.
        """
        pos = self.position[np.asarray(idx, np.int64)]
        in_band = pos < self.n_band
        pb, pd = pos[in_band], pos[~in_band] - self.n_band
        out = np.empty((pos.size, pos.size))
        if pb.size:
            gap = pb[:, None] - pb[None, :]
            if np.abs(gap).max() > self.width:
                raise OutsideBand(f"unknowns {np.abs(gap).max()} apart in a band of {self.width}")
            lo = np.minimum(pb[:, None], pb[None, :])
            zb = self._band[np.abs(gap), lo] + self._w_schur[pb] @ self._w[pb].T
            out[np.ix_(in_band, in_band)] = zb
            cross = -self._w_schur[np.ix_(pb, pd)]
            out[np.ix_(in_band, ~in_band)] = cross
            out[np.ix_(~in_band, in_band)] = cross.T
        out[np.ix_(~in_band, ~in_band)] = self._schur_inv[np.ix_(pd, pd)]
        return out


def _band_inverse(chol: np.ndarray) -> np.ndarray:
    """Entries of B^-1 within the band, stored like ``chol`` (lower: [d, j] holds (j + d, j)), from
    the banded lower Cholesky factor ``chol`` of B (module docstring)."""
    width, n = chol.shape[0] - 1, chol.shape[1]
    z = np.zeros_like(chol)
    rows, cols = np.meshgrid(np.arange(width), np.arange(width), indexing="ij")
    gap, low = np.abs(rows - cols), np.minimum(rows, cols)
    for j in range(n - 1, -1, -1):
        m = min(width, n - 1 - j)
        diag = chol[0, j]
        if m == 0:
            z[0, j] = 1.0 / diag**2
            continue
        l_col = chol[1:m + 1, j]
        window = z[gap[:m, :m], j + 1 + low[:m, :m]]
        column = -(window @ l_col) / diag
        z[1:m + 1, j] = column
        z[0, j] = 1.0 / diag**2 - (l_col @ column) / diag
    return z
