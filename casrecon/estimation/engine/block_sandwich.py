"""Widening of a least-squares covariance for errors the noise model does not contain: the
time-block (cluster-robust) sandwich, less what it is expected to be under the model.

For min 1/2 |r(z)|^2 with the reduced coordinates w of :mod:`.covariance` (dz = Z w, G = J Z the
residuals' Jacobian in w, S = G^T G, C = S^-1 the model covariance), the estimate moves by
dw = -C G^T r for a perturbation r of the whitened residuals. If the residual rows of a block b
(one time slice of every measurement and process prior the fit has) are correlated with each
other in ways the model does not say, but the blocks are nearly independent, the covariance of the
estimate is the sandwich C (sum_b g_b g_b^T) C with g_b = G_b^T r_b (Liang and Zeger's cluster-robust
form; Morelli and Klein correct aircraft system-identification fits for coloured residuals the same
way, by a residual autocorrelation).

The residuals of a fit are smaller than its errors: the fit absorbed part of them. Under the model
(white, unit-variance whitened errors) E[g_b g_b^T] = G_b^T (I - P)_bb G_b = S_b - S_b C S_b with
S_b = G_b^T G_b and P = G C G^T, so C (sum_b S_b - S_b C S_b) C is what the sandwich would be if the
model were right. What the sandwich shows beyond that expectation is what the model misses:
:func:`block_sandwich` returns its positive part, an addition to C. A right model's data add
little (the positive part of a zero-mean noise matrix); errors the model does not have add what
they do to the estimate, block by block. Errors correlated over longer than a block are seen only
in part (their share inside each block).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps


@dataclass(frozen=True)
class BlockSandwich:
    """The widening of a covariance by the time-block sandwich (see the module docstring).

    Attributes
    ----------
    extra_w : (n_w, n_w) array
        Positive semi-definite addition to the model covariance C in the reduced coordinates w
        (scaled units).
    n_blocks : int
        Number of blocks with residual rows.
    excess : float
        trace(C^-1 (sandwich - expectation)) / n_w: the mean excess of the sandwich over its
        expectation under the model, in units of the model covariance (about 0 when the model is
        right; 1 when the errors double the variances on average).
    p_value : float
        Probability under the model of a sandwich trace T = sum_b g_b^T C g_b at least as large
        as this one (T is a quadratic form in the white errors: its mean and variance are exact,
        its distribution taken as a scaled chi-square of the same two moments).
    """

    extra_w: np.ndarray
    n_blocks: int
    excess: float
    p_value: float


class _Accumulator:
    """The sums of one block length over the blocks seen so far (see :func:`block_sandwiches`)."""

    def __init__(self, n_w: int) -> None:
        self.meat = np.zeros((n_w, n_w))
        self.expected = np.zeros((n_w, n_w))
        self.sum_scs = np.zeros((n_w, n_w))  # sum_b S_b C S_b
        self.tr2 = self.tr3 = 0.0  # sum_b tr((C S_b)^2), sum_b tr((C S_b)^3)
        self.n_blocks = 0

    def add(self, g: np.ndarray, s_b: np.ndarray, cov_w: np.ndarray) -> None:
        cs = cov_w @ s_b
        s_c_s = s_b @ cs
        self.meat += np.outer(g, g)
        self.expected += s_b - s_c_s
        self.sum_scs += s_c_s
        cs2 = cs @ cs
        self.tr2 += float(np.trace(cs2))
        self.tr3 += float(np.sum(cs2 * cs.T))
        self.n_blocks += 1

    def result(self, cov_w: np.ndarray) -> BlockSandwich:
        n_w = cov_w.shape[0]
        diff = cov_w @ (self.meat - self.expected) @ cov_w
        lam, vec = np.linalg.eigh(0.5 * (diff + diff.T))
        keep = lam > 0
        extra = (vec[:, keep] * lam[keep]) @ vec[:, keep].T
        excess = float(np.trace(np.linalg.solve(cov_w, diff))) / max(n_w, 1)
        # T = r^T B r, B = blockdiag(G_b C G_b^T), r = (I - P) e: E[T] = tr(B (I - P)),
        # Var[T] = 2 tr((B (I - P))^2) = 2 (sum tr((C S_b)^2) - 2 sum tr((C S_b)^3) + tr((M C)^2)),
        # M = sum_b S_b C S_b
        statistic = float(np.sum(self.meat * cov_w))
        mean = float(np.sum(self.expected * cov_w))
        mc = self.sum_scs @ cov_w
        variance = 2.0 * (self.tr2 - 2.0 * self.tr3 + float(np.sum(mc * mc.T)))
        return BlockSandwich(extra, self.n_blocks, excess, scaled_chi2_sf(statistic, mean, variance))


def block_sandwiches(jacobian_r: sps.spmatrix, basis: np.ndarray, cov_w: np.ndarray, residuals: np.ndarray,
                     row_block: np.ndarray, merges: tuple[int, ...] = (1,)) -> list[BlockSandwich]:
    """The widening of ``cov_w`` by the time-block sandwich, for blocks of each length in ``merges``
    (in units of the ``row_block`` blocks: 2 joins blocks 0-1, 2-3, ...), from one pass over the
    rows.

    Parameters
    ----------
    jacobian_r : sparse (n_r, n_z)
        The whitened residuals' Jacobian at the solution (scaled z).
    basis : (n_z, n_w) array
        Z: dz = Z w (with the eliminated columns' rows, see :mod:`.covariance`).
    cov_w : (n_w, n_w) array
        The model covariance of w.
    residuals : (n_r,) array
        The whitened residuals at the solution.
    row_block : (n_r,) int array
        The block of every residual row, 0, 1, ... in time order, -1 for rows in no block (priors
        on constants: they are neither left out nor counted).
    merges : tuple of int
        Block lengths, in blocks.

    Returns
    -------
    list of BlockSandwich, one per entry of ``merges``
    """
    jr = sps.csr_matrix(jacobian_r)
    row_block = np.asarray(row_block, np.int64)
    n_w = cov_w.shape[0]
    sums = [_Accumulator(n_w) for _ in merges]
    pending = [(np.zeros(n_w), np.zeros((n_w, n_w)), 0) for _ in merges]  # (g, S, blocks) of the open merged block
    last = int(row_block.max()) if row_block.size else -1
    for b in range(last + 1):
        rows = np.flatnonzero(row_block == b)
        if rows.size:
            g_rows = np.asarray(jr[rows] @ basis)  # (rows, n_w)
            g, s_b = g_rows.T @ residuals[rows], g_rows.T @ g_rows
        else:
            g, s_b = np.zeros(n_w), np.zeros((n_w, n_w))
        for k, m in enumerate(merges):
            pg, ps, count = pending[k]
            pg, ps, count = pg + g, ps + s_b, count + 1
            if count == m or b == last:
                if ps.any():
                    sums[k].add(pg, ps, cov_w)
                pg, ps, count = np.zeros(n_w), np.zeros((n_w, n_w)), 0
            pending[k] = (pg, ps, count)
    return [acc.result(cov_w) for acc in sums]


def block_sandwich(jacobian_r: sps.spmatrix, basis: np.ndarray, cov_w: np.ndarray, residuals: np.ndarray,
                   row_block: np.ndarray) -> BlockSandwich:
    """:func:`block_sandwiches` for the blocks of ``row_block`` themselves."""
    return block_sandwiches(jacobian_r, basis, cov_w, residuals, row_block)[0]


def covering(cov: np.ndarray, others: list[np.ndarray]) -> np.ndarray:
    """A covariance at least as large as ``cov`` and each of ``others`` (Loewner order): in
    ``cov``'s Cholesky frame each other's eigenvalues above 1 are kept, one after the other (a
    covering matrix, not in general the one of least volume)."""
    out = cov
    for other in others:
        chol = np.linalg.cholesky(0.5 * (out + out.T))
        inv = np.linalg.inv(chol)
        m = inv @ other @ inv.T
        lam, vec = np.linalg.eigh(0.5 * (m + m.T))
        a = chol @ vec
        out = (a * np.maximum(lam, 1.0)) @ a.T
    return out


def grown_along(cov_w: np.ndarray, rows: np.ndarray, factor: float) -> np.ndarray:
    """C + (k - 1) C R^T (R C R^T)^-1 R C: the covariance ``cov_w`` (C, reduced coordinates) with
    the covariance of the combinations ``rows`` (R, one per row) ``factor`` (k) times its own and
    everything else grown with them by its regression on them (its covariance given them unchanged)."""
    c_r = rows @ cov_w
    return cov_w + (factor - 1.0) * c_r.T @ np.linalg.solve(c_r @ rows.T, c_r)


def grown_to(cov_w: np.ndarray, rows: np.ndarray, target: np.ndarray) -> np.ndarray:
    """C + C R^T P^-1 (P' - P) P^-1 R C, P = R C R^T: the covariance ``cov_w`` (C, reduced
    coordinates) with the covariance of the combinations ``rows`` (R, one per row) made ``target``
    (P', at least P) and everything else grown with them by its regression on them (its covariance
    given them unchanged); :func:`grown_along` is P' = k P."""
    c_r = rows @ cov_w
    gain = np.linalg.solve(c_r @ rows.T, c_r)
    return cov_w + gain.T @ (target - c_r @ rows.T) @ gain


def scaled_chi2_sf(value: float, mean: float, variance: float) -> float:
    """P(X >= value) for X = a chi-square(nu) with X's ``mean`` and ``variance`` (nan when the
    variance is not positive)."""
    from scipy.stats import chi2

    if not (variance > 0 and mean > 0):
        return float("nan")
    scale = variance / (2.0 * mean)
    return float(chi2.sf(value / scale, 2.0 * mean**2 / variance))
