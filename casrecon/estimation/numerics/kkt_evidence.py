"""The Laplace evidence of a constrained fit as a function of the sizes of some of its row groups, on
the KKT matrix of the fit's Gauss-Newton model: for a fit whose covariance is the KKT inverse
(:class:`~casrecon.estimation.engine.kkt_covariance.KktCovariance`, e.g. the GPS-only point-mass
fit with area processes), where the split form of :mod:`.split_evidence` (the covariance's
null-space basis) does not exist.

Near the fit z*, every residual row is r + J d (d = z - z*, J the residual Jacobian there: exact
for the linear rows, the Gauss-Newton linearisation for the others) and the constraints
A d = 0 (A their Jacobian; they hold at the fit). Group k's rows (J_k, r_k) have their sigma
scaled by rho_k, which divides them by rho_k; the other rows are held. With s_k = rho_k^-2,
H = J_held^T J_held + sum_k s_k J_k^T J_k and the KKT matrix K = [[H, A^T], [A, 0]]:

    log Z(rho) = -1/2 chi2_min(rho) - 1/2 log |det K(rho)| - sum_k n_k log rho_k + const,

since det K = (-1)^m det(A_B)^2 det(N^T H N) for a null-space basis N of A, and A does not depend
on rho: log |det K| is the log det of the reduced Hessian up to a constant. Its gradient in
log rho_k is s_k |r_k + J_k d|^2 + s_k tr(J_k P J_k^T) - n_k, d the constrained minimiser and P
the z block of K^-1 (N (N^T H N)^-1 N^T); the trace is the log det's own slope, taken here by
forward differences. ``tests/unit/test_kkt_evidence.py`` checks value and
gradient against a dense null-space evaluation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps
from scipy.sparse.linalg import splu

from casrecon.estimation.numerics.banded_factor import band_arrow_order
from casrecon.parallel import in_threads

#: Penalty (nats) of sizes at which the KKT matrix is singular.
SINGULAR = 1e12
#: Step in log rho of the log det's forward differences (its curvature in log rho is at most 4 n_k:
#: a truncation error below 4e-5 n_k nats per unit log rho; round-off on a log det of 1e4, 1e-6).
STEP = 1e-5


@dataclass(frozen=True)
class ScaledRows:
    """One group's rows near the fit.

    Attributes
    ----------
    jacobian : (n, n_z) sparse matrix
        Their Jacobian in the fit's (scaled) unknowns.
    residuals : (n,) array
        Their residuals at the fit.
    count : int
        Rows the group's normalisation counts (n_k).
    """

    jacobian: sps.csr_matrix
    residuals: np.ndarray
    count: int


class KktQuadraticModel:
    """The fit's Gauss-Newton model with groups of rows whose sigmas scale (see the module docstring).

    Parameters
    ----------
    held_jacobian : (n_held, n_z) sparse matrix
    held_residuals : (n_held,) array
        The rows whose sigmas are held.
    constraint_jacobian : (n_g, n_z) sparse matrix
        A, the constraints' Jacobian at the fit (of full row rank).
    groups : list of ScaledRows
        The scaled groups.
    log_normaliser : float
        Added to log Z (e.g. the log det of a prior's whitening rebuilt at another correlation time,
        less the fit's).
    """

    def __init__(self, held_jacobian: sps.spmatrix, held_residuals: np.ndarray, constraint_jacobian: sps.spmatrix,
                 groups: list[ScaledRows], log_normaliser: float = 0.0) -> None:
        held = _pruned(held_jacobian)  # a block's structural zeros (e.g. spline coefficients far from its nodes)
        self.held_hessian = (held.T @ held).tocsc()
        self.held_gradient = held.T @ np.asarray(held_residuals, float)
        self.held_chi2 = float(np.dot(held_residuals, held_residuals))
        self.held_jacobian, self.held_residuals = held, np.asarray(held_residuals, float)
        self.constraints = _pruned(constraint_jacobian)
        self._order = None  # the KKT matrix's band-arrow order, worked out at the first factorisation
        self._set_groups(groups, log_normaliser)

    def _set_groups(self, groups: list[ScaledRows], log_normaliser: float) -> None:
        self.groups = [ScaledRows(_pruned(g.jacobian), np.asarray(g.residuals, float), g.count) for g in groups]
        self._grams = [(g.jacobian.T @ g.jacobian).tocsc() for g in self.groups]
        self.log_normaliser = float(log_normaliser)

    def with_groups(self, groups: list[ScaledRows], log_normaliser: float) -> KktQuadraticModel:
        """The same held rows and constraints with other groups (e.g. a prior rebuilt at another
        correlation time)."""
        out = object.__new__(KktQuadraticModel)
        out.__dict__.update(self.__dict__)
        out._order = None  # the groups' pattern may differ
        out._set_groups(groups, log_normaliser)
        return out

    def log_evidence(self, log_ratio: np.ndarray) -> tuple[float, np.ndarray]:
        """(log Z, its gradient in log rho) at the groups' log sigma ratios ``log_ratio`` (up to a
        constant: differences between ratios are what matter); -SINGULAR and a zero gradient where
        the KKT matrix is singular. The chi-square's part of the gradient is exact (the minimiser's
        own: s_k |r_k + J_k d|^2); the log det's by forward differences of STEP in each log rho_k
        (a factorisation each, on two threads: the trace's solves, one per row of J_k, cost ten times
        more)."""
        value, gradient, _ = self._evaluated(log_ratio, information=False)
        return value, gradient

    def log_evidence_with_information(self, log_ratio: np.ndarray) -> tuple[float, np.ndarray, np.ndarray | None]:
        """(log Z, its gradient, the average information) at ``log_ratio``, as :meth:`log_evidence`;
        the information (None where K is singular) is average-information REML's approximation of
        -d2 log Z / d log rho2 (as :meth:`.split_evidence.SplitQuadraticModel.log_evidence_with_information`):
        2 (diag(s_k |m_k|^2) - q^T P q), q_k = s_k J_k^T m_k, m_k the group's fitted residuals, P the
        z block of K^-1 (one more solve with the base point's factor, a column per group)."""
        return self._evaluated(log_ratio, information=True)

    def _evaluated(self, log_ratio: np.ndarray, information: bool) -> tuple[float, np.ndarray, np.ndarray | None]:
        x = np.asarray(log_ratio, float)
        if self._order is None:
            self._order = band_arrow_order(self._kkt(x))
        s = np.exp(-2.0 * x)
        n_z, n_g = self.held_hessian.shape[0], self.constraints.shape[0]
        grad = self.held_gradient + sum(sk * (g.jacobian.T @ g.residuals) for sk, g in zip(s, self.groups))
        rhs = np.concatenate([-grad, np.zeros(n_g)])
        # each factor lives and dies in its thread (SuperLU's allocations may belong to the thread
        # that made the factor): the threads return the log det and the base point's solution (and
        # q^T P q for the information)
        steps = [(x, rhs, information)] + [(x + STEP * unit, None, False) for unit in np.eye(x.size)]
        (log_det, d, across), *moved = in_threads(self._log_det_and_solution, steps)
        if log_det is None:
            return -SINGULAR, np.zeros_like(x), None
        d = d[:n_z]
        misfit = [g.residuals + g.jacobian @ d for g in self.groups]
        held = self.held_residuals + self.held_jacobian @ d
        fitted = np.array([sk * float(m @ m) for sk, m in zip(s, misfit)])
        chi2 = float(held @ held) + float(np.sum(fitted))
        value = -0.5 * chi2 - 0.5 * log_det - sum(g.count * xk for g, xk in zip(self.groups, x))
        gradient = np.empty_like(x)
        for k, (g, (log_det_k, _, _)) in enumerate(zip(self.groups, moved)):
            slope = 0.0 if log_det_k is None else (log_det_k - log_det) / STEP
            gradient[k] = fitted[k] - 0.5 * slope - g.count
        info = None if across is None else 2.0 * (np.diag(fitted) - 0.5 * (across + across.T))
        return value + self.log_normaliser, gradient, info

    def _kkt(self, x: np.ndarray) -> sps.csc_matrix:
        """The KKT matrix at the log ratios ``x``."""
        h = self.held_hessian
        for sk, gram in zip(np.exp(-2.0 * x), self._grams):
            h = h + sk * gram
        return sps.bmat([[h, self.constraints.T], [self.constraints, None]], format="csc")

    def _log_det_and_solution(self, point: tuple[np.ndarray, np.ndarray | None, bool]):
        """(log |det K|, K^-1 rhs or None, q^T P q or None) at the log ratios, right-hand side and
        information flag ``point`` (q and P as :meth:`log_evidence_with_information`), by a
        SuperLU factorisation in the band-arrow order with partial pivoting; Nones when K is
        singular."""
        x, rhs, information = point
        try:
            lu = splu(self._kkt(x)[self._order][:, self._order].tocsc(), permc_spec="NATURAL")
        except RuntimeError:
            return None, None, None
        diag = np.abs(lu.U.diagonal())  # L has a unit diagonal
        if not (np.all(np.isfinite(diag)) and diag.min() > 0.0):
            return None, None, None
        if rhs is None:
            return float(np.sum(np.log(diag))), None, None

        def solved(b: np.ndarray) -> np.ndarray:
            out = np.empty_like(b)
            out[self._order] = lu.solve(np.ascontiguousarray(b[self._order]))
            return out

        solution = solved(rhs)
        if not information:
            return float(np.sum(np.log(diag))), solution, None
        n_z = self.held_hessian.shape[0]
        d, s = solution[:n_z], np.exp(-2.0 * x)
        q = np.column_stack([sk * (g.jacobian.T @ (g.residuals + g.jacobian @ d)) for sk, g in zip(s, self.groups)])
        y = solved(np.vstack([q, np.zeros((rhs.size - n_z, q.shape[1]))]))[:n_z]
        return float(np.sum(np.log(diag))), solution, q.T @ y


def _pruned(matrix: sps.spmatrix) -> sps.csr_matrix:
    """A CSR copy of ``matrix`` without its explicit zeros (the caller's matrix is left as it is)."""
    out = sps.csr_matrix(matrix, copy=True)
    out.eliminate_zeros()
    return out
