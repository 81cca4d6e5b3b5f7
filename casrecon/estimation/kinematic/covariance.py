"""Covariance of a kinematic fit: least squares whose residuals do not depend on the scale of each
node's quaternion (every use divides by its norm), with a unit-norm constraint that only fixes that
scale.

The Gauss-Newton Hessian H then has exactly the quaternions q_k (unit, in their z columns) as null
directions, and the constrained covariance (the z-block of the inverse KKT matrix) is its
pseudo-inverse H^+ = Z (Z^T H Z)^-1 Z^T over the tangent space. With Q the orthonormal columns
(one per node, q_k in its four entries), H + Q Q^T is positive definite and
H^+ = P (H + Q Q^T)^-1 P with P = I - Q Q^T: one sparse factorisation of a block-banded matrix with
an arrow (the IMU parameters; :mod:`casrecon.estimation.numerics.banded_factor`), no KKT matrix and no
pivoting for the zero block. The blocks the fits read (each node's states, with the IMU parameters)
come from the selected inverse of :mod:`casrecon.estimation.numerics.selected_inverse` in O(n w^2)
for band w; other entries from column solves.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps

from casrecon.estimation.engine.covariance import SingularCovariance, fisher_and_jacobian
from casrecon.estimation.engine.nlp import Nlp
from casrecon.estimation.numerics.banded_factor import SymmetricFactor
from casrecon.estimation.numerics.selected_inverse import BandArrowInverse, OutsideBand

#: Largest parameter-covariance condition number accepted.
MAX_CONDITION = 1e12


def gauge_matrix(z: np.ndarray, gauge_cols: np.ndarray, n_z: int) -> tuple[sps.csc_matrix, np.ndarray]:
    """(Q Q^T, unit quaternions (K, 4)): the sparse n_z x n_z matrix with each node's unit
    quaternion's outer product in its columns (see the module docstring)."""
    gauge_cols = np.asarray(gauge_cols, np.int64)
    q = z[gauge_cols]
    q = q / np.linalg.norm(q, axis=1, keepdims=True)
    rows = np.repeat(gauge_cols, 4, axis=1).ravel()
    cols = np.tile(gauge_cols, (1, 4)).ravel()
    vals = (q[:, :, None] * q[:, None, :]).ravel()
    return sps.csc_matrix((vals, (rows, cols)), shape=(n_z, n_z)), q


class GaugeCovariance:
    """Covariance blocks of z from H + Q Q^T (see the module docstring); the interface the fits
    read: ``covariance_of``, ``blocks``, ``variance_of_combination``, ``reduced_chi2``, ``condition``.

    Parameters
    ----------
    nlp : Nlp
    z : array
        Solution (scaled).
    gauge_cols : (K, 4) int array
        z columns of each quaternion.
    chi2 : float
    dof : int
    """

    #: Right-hand sides per solve.
    BATCH = 512

    def __init__(self, nlp: Nlp, z: np.ndarray, gauge_cols: np.ndarray, chi2: float, dof: int) -> None:
        h, _ = fisher_and_jacobian(nlp, z)
        gauge, self._q = gauge_matrix(z, gauge_cols, h.shape[0])
        self._cols = np.asarray(gauge_cols, np.int64)
        self._group = np.full(h.shape[0], -1, np.int64)
        self._group[self._cols.ravel()] = np.repeat(np.arange(self._cols.shape[0]), 4)
        aug = (h + gauge).tocsc()
        try:
            self._lu = SymmetricFactor(aug)
            self._selected = BandArrowInverse(aug)
        except OutsideBand:
            self._selected = None
        except (RuntimeError, np.linalg.LinAlgError) as err:
            raise SingularCovariance(f"Hessian singular ({err}): some combination of the unknowns is not "
                                     "determined by the data") from None
        self.n_z = h.shape[0]
        self.reduced_chi2 = chi2 / max(dof, 1)
        self.condition = float("nan")

    @property
    def gauge_columns(self) -> np.ndarray:
        """(K, 4) z columns of each node's quaternion (the gauge directions)."""
        return self._cols

    def _project(self, x: np.ndarray) -> np.ndarray:
        """P x for the columns of x (n_z, m)."""
        out = x.copy()
        block = out[self._cols]                                   # (K, 4, m)
        dots = np.einsum("ki,kim->km", self._q, block)
        out[self._cols] = block - self._q[:, :, None] * dots[:, None, :]
        return out

    def _columns(self, idx: np.ndarray) -> np.ndarray:
        """Columns idx of H^+ (n_z, len(idx))."""
        out = np.empty((self.n_z, idx.size))
        for start in range(0, idx.size, self.BATCH):
            cols = idx[start:start + self.BATCH]
            e = np.zeros((self.n_z, cols.size))
            e[cols, np.arange(cols.size)] = 1.0
            out[:, start:start + cols.size] = self._project(self._lu.solve(self._project(e)))
        return out

    def _block(self, idx: np.ndarray) -> np.ndarray:
        """H^+[idx][:, idx], from the selected inverse when idx lies within its band (P only mixes
        the four columns of each quaternion, so it is applied to idx widened to whole quaternions),
        else from column solves."""
        groups = np.unique(self._group[idx])
        groups = groups[groups >= 0]
        extra = np.setdiff1d(self._cols[groups].ravel(), idx)
        wide = np.r_[idx, extra]
        try:
            if self._selected is None:
                raise OutsideBand("no selected inverse")
            c = self._selected.block(wide)
        except OutsideBand:
            return self._columns(idx)[idx]
        proj = np.eye(wide.size)
        where = {col: i for i, col in enumerate(wide)}
        for g in groups:
            p = [where[col] for col in self._cols[g]]
            proj[np.ix_(p, p)] -= np.outer(self._q[g], self._q[g])
        c = proj @ c @ proj
        return c[:idx.size, :idx.size]

    def covariance_of(self, idx, scale=None) -> np.ndarray:
        """Covariance of z[idx] (times ``scale`` per entry, e.g. to SI)."""
        idx = np.asarray(idx, np.int64)
        c = self._block(idx)
        c = 0.5 * (c + c.T)
        if scale is not None:
            c = c * np.outer(scale, scale)
        return c

    def blocks(self, index_sets: list[np.ndarray], shared: np.ndarray | None = None) -> list[np.ndarray]:
        """Covariance of z[idx] for each idx of ``index_sets``, followed by the columns ``shared``
        (e.g. the IMU parameters) when given (scaled units)."""
        tail = np.zeros(0, np.int64) if shared is None else np.asarray(shared, np.int64)
        sets = [np.r_[np.asarray(s, np.int64), tail] for s in index_sets]
        if self._selected is not None:
            return [self.covariance_of(s) for s in sets]
        out: list[np.ndarray] = []   # no selected inverse (a band too wide): column solves, in batches
        i = 0
        while i < len(sets):
            batch = [sets[i]]
            while i + len(batch) < len(sets) and sum(s.size for s in batch) < self.BATCH:
                batch.append(sets[i + len(batch)])
            x = self._columns(np.concatenate(batch))
            start = 0
            for s in batch:
                c = x[s, start:start + s.size]
                out.append(0.5 * (c + c.T))
                start += s.size
            i += len(batch)
        return out

    def variance_of_combination(self, idx, weights) -> float:
        """Variance of sum_j weights[j] z[idx[j]] (scaled z units)."""
        e = np.zeros((self.n_z, 1))
        np.add.at(e[:, 0], np.asarray(idx, np.int64), np.asarray(weights, float))
        return float((e[:, 0] @ self._project(self._lu.solve(self._project(e))))[0])

    def check_parameters(self, cols: np.ndarray) -> None:
        """SingularCovariance when the parameters' covariance is not positive definite."""
        eig = np.linalg.eigvalsh(self.covariance_of(cols))
        self.condition = float(eig[-1] / max(eig[0], 1e-300))
        if eig[0] <= 0 or self.condition > MAX_CONDITION:
            raise SingularCovariance(f"parameter covariance not positive definite (condition {self.condition:.3g}): "
                                     "some IMU parameter combination is not determined by the data")
