"""The z-block of the inverse of a fit's KKT matrix from its sparse LU, for fits whose null space
is too wide to form (latent process values at every node): see :class:`KktCovariance`.

:class:`SingularCovariance` is what every covariance of :mod:`.covariance` raises when the data do
not determine some combination of the unknowns.
"""

from __future__ import annotations

import logging

import numpy as np
import scipy.sparse as sps
from scipy.sparse.linalg import splu

from casrecon.estimation.engine.bordered_kkt import BorderedKkt
from casrecon.estimation.numerics.banded_inverse import NotBanded

LOG = logging.getLogger(__name__)

#: A reduced Hessian whose condition number, after scaling it to a unit diagonal, is above this
#: is reported as singular.
MAX_CONDITION = 1e13

class SingularCovariance(RuntimeError):
    """The reduced Hessian is singular: some parameter combination is not determined."""

class KktCovariance:
    """The z-block of K^-1 from a sparse LU of the KKT matrix K (used with disturbance states).

    Same interface as :class:`Covariance` for what the fit reads: ``covariance_of``, ``blocks``,
    ``reduced_chi2`` and ``condition`` (here the condition number of the parameter covariance only:
    the reduced Hessian is never formed).

    Parameters
    ----------
    kkt : sparse matrix
        K, its first ``n_z`` rows and columns the unknowns.
    n_z : int
        Number of unknowns.
    chi2, dof : float, int
        The fit's chi-square and degrees of freedom.
    border : int array, optional
        The parameters' columns. K is then factorised by its block without them and their Schur
        complement (:class:`.bordered_kkt.BorderedKkt`: a whole-drop gust fit's factor shrinks from
        hundreds of millions of nonzeros to a few million); if that block is singular (a constraint
        on parameters alone) or no border is given, by one SuperLU factorisation of K.
    """

    #: Right-hand sides per LU solve (bounds the dense work array: n_kkt x this x 8 bytes).
    BATCH = 256
    #: Fill-reducing ordering for SuperLU (measured on an 8 s weak-constraint window: COLAMD 14.8M LU
    #: nonzeros, MMD_AT_PLUS_A 18.4M, MMD_ATA 20.0M; banded orderings without pivoting are unstable).
    PERMC_SPEC = "COLAMD"

    def __init__(self, kkt: sps.spmatrix, n_z: int, chi2: float, dof: int, border: np.ndarray | None = None) -> None:
        self.n_z, self.reduced_chi2 = n_z, chi2 / max(dof, 1)
        self._lu = None
        if border is not None:
            try:
                self._lu = BorderedKkt(kkt, border)
            except RuntimeError as err:
                LOG.debug("bordered KKT factorisation refused (%s): one LU of the whole matrix", err)
        if self._lu is None:
            try:
                self._lu = splu(sps.csc_matrix(kkt), permc_spec=self.PERMC_SPEC)
            except RuntimeError as err:
                raise SingularCovariance(f"KKT matrix singular ({err}): some combination of the unknowns is not "
                                         "determined by the data") from None
        self.condition = float("nan")
        self.information = "expected"  # see Covariance.information
        self._blocks: dict[bytes, np.ndarray] = {}  # blocks already computed, by their index set

    def _columns(self, idx: np.ndarray) -> np.ndarray:
        """Rows 0..n_z of K^-1 e_j for every j in idx, (n_z, len(idx))."""
        out = np.empty((self.n_z, idx.size))
        n = self._lu.shape[0]
        for start in range(0, idx.size, self.BATCH):
            cols = idx[start:start + self.BATCH]
            e = np.zeros((n, cols.size))
            e[cols, np.arange(cols.size)] = 1.0
            out[:, start:start + cols.size] = self._lu.solve(e)[:self.n_z]
        return out

    def covariance_of(self, idx, scale=None) -> np.ndarray:
        idx = np.asarray(idx, int)
        if isinstance(self._lu, BorderedKkt) and np.isin(idx, self._lu.border).all():
            c = self._lu.inverse_blocks([idx])[0]  # the parameters' S^-1: no solve
        else:
            c = self._columns(idx)[idx]
        c = 0.5 * (c + c.T)
        if scale is not None:
            c = c * np.outer(scale, scale)
        return c

    def variance_of_combination(self, idx, weights) -> float:
        """Variance of sum_j weights[j] z[idx[j]] (scaled z units), from one LU solve."""
        idx, w = np.asarray(idx, int), np.asarray(weights, float)
        e = np.zeros(self._lu.shape[0])
        np.add.at(e, idx, w)
        return float(self._lu.solve(e)[idx] @ w)

    def blocks(self, index_sets: list[np.ndarray]) -> list[np.ndarray]:
        """Covariance of z[idx] for each idx; the indices every set shares (the parameters) are
        solved for once, the rest set by set in batches of about BATCH right-hand sides. Blocks are
        kept, so asking again for the same index sets (the trajectory bands, then the coefficient
        bands, at the same nodes) costs no solve."""
        sets = [np.asarray(s, int) for s in index_sets]
        missing = [s for s in sets if s.tobytes() not in self._blocks]
        if missing:
            for s, block in zip(missing, self._solve_blocks(missing)):
                self._blocks[s.tobytes()] = block
        return [self._blocks[s.tobytes()] for s in sets]

    def output_variances(self, index_sets: list[np.ndarray], jacobians: np.ndarray) -> np.ndarray:
        """See :meth:`Covariance.output_variances` (here from the kept LU blocks)."""
        return np.array([np.einsum("ij,jk,ik->i", j, c, j) for j, c in zip(jacobians, self.blocks(index_sets))])

    def _solve_blocks(self, sets: list[np.ndarray]) -> list[np.ndarray]:
        """The covariance blocks of ``sets``: from the bordered factor's selected inverse where it
        applies and costs less (:meth:`.BorderedKkt.inverse_blocks`: a 25 Hz track's states at
        every node, issue 49), else from LU solves (see :meth:`blocks`)."""
        if isinstance(self._lu, BorderedKkt):
            try:
                return [0.5 * (c + c.T) for c in self._lu.inverse_blocks(sets)]
            except NotBanded as err:
                LOG.debug("covariance blocks by column solves (%s)", err)
        common = sets[0]
        for s in sets[1:]:
            common = np.intersect1d(common, s)
        x_common = self._columns(common)
        out: list[np.ndarray] = []
        pending: list[np.ndarray] = []

        def flush() -> None:
            own = [np.setdiff1d(s, common) for s in pending]
            x_own = self._columns(np.concatenate(own)) if own else None
            start = 0
            for s, o in zip(pending, own):
                cols = np.empty((self.n_z, s.size))
                where_common = np.isin(s, common)
                cols[:, where_common] = x_common[:, np.searchsorted(common, s[where_common])]
                cols[:, ~where_common] = x_own[:, start + np.searchsorted(o, s[~where_common])]
                start += o.size
                c = cols[s]
                out.append(0.5 * (c + c.T))
            pending.clear()

        n_pending = 0  # the pending sets' own (not common) columns: what a flush solves for
        for s in sets:
            pending.append(s)
            n_pending += s.size - np.isin(s, common).sum()
            if n_pending >= self.BATCH:
                flush()
                n_pending = 0
        if pending:
            flush()
        return out
