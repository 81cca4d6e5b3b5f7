"""Covariance of an NLP's estimate from the KKT matrix at the solution.

For min 1/2 |r(z)|^2 s.t. g(z) = 0 the covariance of z is the z-block of the inverse of
K = [[H, A^T], [A, 0]], A = dg/dz and H the Gauss-Newton Hessian J^T J (the expected, Fisher
information) or the exact Hessian of the Lagrangian at the solution (the observed information; see
:func:`compute_covariance`).
With Z a basis of the null space of A that block equals Z (Z^T H Z)^-1 Z^T, which is how it is
computed when the null space is small: the determining constraints (collocation defects) fix the
``dependent`` columns given the others, so Z = [-A_D^-1 A_I N; N] with A_D their (sparse LU)
Jacobian in the dependent columns, A_I the rest, and N a basis of the null space of the side
constraints (unit norms) in the independent columns (:mod:`.constraint_split`). Z has as many columns as there are free
directions, so marginal variances of every node state and every derived output cost a few small
dense products. ``tests/unit/test_covariance.py`` checks this against a dense inverse of K.

*Eliminated* columns (``Nlp.eliminated``: unknowns in no constraint whose Hessian block H_EE is
sparse, e.g. one latent error value per GPS fix with a Gauss-Markov prior) are kept out of Z: with
Z_c the null-space basis of the other columns, the reduced precision of (w_c, z_E) is
[[Z_c^T H Z_c, B^T], [B, H_EE]], B = H_Ec Z_c, and H_EE is eliminated by its sparse LU:
cov(w_c) = S^-1 with S = Z_c^T H Z_c - B^T H_EE^-1 B, cov(z_E) = H_EE^-1 + M S^-1 M^T and
cov(z_c, z_E) = -Z_c S^-1 M^T with M = H_EE^-1 B. Storing -M as the rows of the eliminated
columns in the basis makes every covariance read the same formula, plus the H_EE^-1 block where
two eliminated columns meet.

With latent process values at every node (``Nlp.latent``, the weak constraint) Z would have
thousands of columns, and the z-block is instead read from solves with K itself
(:class:`KktCovariance`): the parameters' columns once, each requested node's columns on demand.
K is factorised by its block without the parameters' dense rows and columns and their Schur
complement (:mod:`.bordered_kkt`).

Two covariances are reported: the absolute one (noise sigmas taken as given) and the one scaled
by the reduced chi-square chi2 / dof (as lmfit does), dof = measurements - free directions.
"""

from __future__ import annotations

import dataclasses
import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps
from scipy.sparse.linalg import splu

from casrecon.estimation.engine.constraint_split import ConstraintSplit, constraint_split
from casrecon.estimation.engine.information import INFORMATION
from casrecon.estimation.engine.kkt_covariance import MAX_CONDITION, KktCovariance, SingularCovariance
from casrecon.estimation.engine.nlp import Nlp
from casrecon.estimation.engine.projected_gram import projected_gram, wide_congruence, wide_gram
from casrecon.parallel import in_threads, single_threaded_blas

LOG = logging.getLogger(__name__)

@dataclass(frozen=True)
class Elimination:
    """The eliminated columns of a reduced system (see the module docstring).

    Attributes
    ----------
    cols : int array
        The eliminated z columns E, sorted.
    lu : scipy SuperLU
        Sparse LU of H_EE.
    """

    cols: np.ndarray
    lu: object

    def inverse_block(self, idx: np.ndarray) -> np.ndarray:
        """(len(idx), len(idx)) block of H_EE^-1 between the z columns ``idx``, zero where an index
        is not eliminated."""
        idx = np.asarray(idx, int)
        pos = np.searchsorted(self.cols, idx)
        pos = np.minimum(pos, self.cols.size - 1)
        mine = self.cols[pos] == idx
        out = np.zeros((idx.size, idx.size))
        if mine.any():
            e = np.zeros((self.cols.size, int(mine.sum())))
            e[pos[mine], np.arange(e.shape[1])] = 1.0
            out[np.ix_(mine, mine)] = self.lu.solve(e)[pos[mine]]
        return out


@dataclass(frozen=True)
class ReducedSystem:
    """Z (with -M in the eliminated rows) and the reduced Hessian S (the Schur complement of the
    eliminated block when there is one): see the module docstring."""

    basis: np.ndarray
    hessian: np.ndarray
    elimination: Elimination | None = None
    coupling: np.ndarray | None = None   # M = H_EE^-1 B, (n_E, n_w)
    split: ConstraintSplit | None = None  # the constraint Jacobian's split it was formed with


@dataclass(frozen=True)
class Covariance:
    """Covariance of the fit in reduced coordinates w: dz = Z w, cov(w) = Hr^-1.

    Attributes
    ----------
    basis : (n_z, n_w) array
        Z, in scaled z units (eliminated columns: -M, see the module docstring).
    cov_w : (n_w, n_w) array
        (Z^T H Z)^-1 (absolute: noise sigmas as given); with eliminated columns, S^-1.
    reduced_chi2 : float
        chi2 / dof; multiply variances by it for the chi-square-scaled covariance.
    condition : float
        Condition number of Z^T H Z (of S).
    elimination : Elimination or None
        The eliminated columns and the LU of their Hessian block.
    information : str
        Which curvature was inverted: "observed" (exact Hessian of the Lagrangian) or "expected"
        (J^T J), the latter with the reason when the observed one was asked for (see
        :func:`compute_covariance`).
    split : ConstraintSplit or None
        The constraint Jacobian's split at the solution the basis was formed with (another
        curvature's reduced system at the same z reuses it: :func:`gauss_newton_system`).
    """

    basis: np.ndarray
    cov_w: np.ndarray
    reduced_chi2: float
    condition: float
    elimination: Elimination | None = None
    information: str = "expected"
    split: ConstraintSplit | None = None

    def rows(self, idx) -> np.ndarray:
        """Z rows of the given z indices (scaled units)."""
        return self.basis[np.asarray(idx)]

    def covariance_of(self, idx, scale=None) -> np.ndarray:
        """Absolute covariance matrix of z[idx] (times ``scale`` per entry, e.g. to SI)."""
        zr = self.rows(idx)
        c = zr @ self.cov_w @ zr.T
        if self.elimination is not None:
            c = c + self.elimination.inverse_block(idx)
        if scale is not None:
            c = c * np.outer(scale, scale)
        return c

    #: Index sets per batch of :meth:`output_variances` (bounds its work array).
    BATCH = 128

    def output_variances(self, index_sets: list[np.ndarray], jacobians: np.ndarray) -> np.ndarray:
        """Variances (len(index_sets), n_out) of outputs y_i = J_i z[index_sets[i]], J_i =
        ``jacobians[i]`` (n_out, len(set)), scaled units: diag(J_i C_i J_i^T), batched into one
        product with cov_w per BATCH sets (with eliminated columns the H_EE^-1 term is added).
        Only the directions w that reach a batch's rows of Z enter (exactly: the others contribute
        zero), so one drop of a joint fit costs what its own fit's bands cost, not the number of
        drops squared times it; and in a profile fit, whose directions reach the nodes from the
        time the capsule passes their level on, a batch of early nodes costs a fraction of a late
        one's (the sets come in node order: a third of the work overall)."""
        out = np.zeros((len(index_sets), jacobians.shape[1]))
        if not index_sets:
            return out

        def batch(start: int) -> np.ndarray:
            sets = np.stack([np.asarray(s, np.int64) for s in index_sets[start:start + self.BATCH]])  # (b, n_v)
            reached = np.flatnonzero(np.any(self.basis[np.unique(sets)] != 0.0, axis=0))
            rows = self.basis[np.ix_(sets.ravel(), reached)].reshape(*sets.shape, reached.size)
            m = np.matmul(jacobians[start:start + sets.shape[0]], rows)  # (b, n_y, n_w)
            v = (m.reshape(-1, reached.size) @ self.cov_w[np.ix_(reached, reached)]).reshape(m.shape)
            return np.einsum("byw,byw->by", v, m)

        # the batches on two threads (numpy's products release the GIL; each batch is computed alone)
        starts = range(0, len(index_sets), self.BATCH)
        for start, variances in zip(starts, in_threads(batch, starts)):
            out[start:start + variances.shape[0]] = variances
        if self.elimination is not None:
            for k, s in enumerate(index_sets):
                extra = self.elimination.inverse_block(s)
                if extra.any():
                    out[k] += np.einsum("yi,ij,yj->y", jacobians[k], extra, jacobians[k])
        return out

    def variance_of_combination(self, idx, weights) -> float:
        """Variance of sum_j weights[j] z[idx[j]] (scaled z units, not chi-square-scaled), e.g. of a
        time mean of a node history."""
        weights = np.asarray(weights, float)
        w = self.rows(idx).T @ weights
        extra = 0.0
        if self.elimination is not None:
            extra = float(weights @ self.elimination.inverse_block(idx) @ weights)
        return float(w @ self.cov_w @ w) + extra

    def blocks(self, index_sets: list[np.ndarray]) -> list[np.ndarray]:
        """Covariance matrices of z[idx] for each idx of ``index_sets`` (scaled units)."""
        return [self.covariance_of(idx) for idx in index_sets]


def fisher_and_jacobian(nlp: Nlp, z: np.ndarray) -> tuple[sps.csc_matrix, sps.csc_matrix]:
    """(H, A) at ``z`` (scaled): the full symmetric Gauss-Newton Hessian J^T J and dg/dz."""
    d = nlp.derivatives
    a = d.jacobian_g(z)
    h_upper = d.gauss_newton(z)
    return h_upper + sps.triu(h_upper, 1).T, a


@single_threaded_blas()
def reduced_hessian(nlp: Nlp, h: sps.csc_matrix, a: sps.csc_matrix,
                    split: ConstraintSplit | None = None) -> ReducedSystem:
    """The null-space basis of the constraint Jacobian and the reduced Hessian, the eliminated
    columns' block taken out by its Schur complement (NLPs without latent process values at the
    nodes: with them Z would have thousands of columns). ``split``: the split of ``a`` already
    made and not yet in a reduced system (e.g. :func:`reusable_split` of one at the same z); the
    returned system's basis is its basis, written to in the eliminated rows. Computed with
    BLAS on one thread, whoever calls: the reduced Hessian's condition number reaches 1e10, at
    which the rounding of a threaded product moves covariances by 1e-9 relative, so the same z
    must give the same bits."""
    elim = np.asarray(nlp.eliminated, np.int64)
    if split is None:
        split = _split_of(nlp, a)
    hr, b = wide_congruence(h, split.basis, elim)
    return _reduced(split, hr, b, lambda: h[elim][:, elim].tocsc(), elim, a)


@single_threaded_blas()
def reduced_hessian_from_jacobian(nlp: Nlp, jr: sps.csc_matrix, a: sps.csc_matrix) -> ReducedSystem:
    """:func:`reduced_hessian` of H = J_r^T J_r from the residual Jacobian ``jr`` itself, without
    forming H: (J_r Z)^T (J_r Z), and J_E^T J_E for the eliminated columns."""
    elim = np.asarray(nlp.eliminated, np.int64)
    split = _split_of(nlp, a)
    if split.lu.n_blocks > 1:  # a joint fit: Z is block-sparse
        hr, b = projected_gram(jr, split.basis, jr[:, elim])
    else:  # dense products (by column chunks when Z is wide) are faster than row chunks when every row
        hr, b = wide_gram(jr, split.basis, jr[:, elim])  # reaches every column
    return _reduced(split, hr, b, lambda: (jr[:, elim].T @ jr[:, elim]).tocsc(), elim, a)


def _split_of(nlp: Nlp, a: sps.csc_matrix) -> ConstraintSplit:
    """The split of ``nlp``'s constraint Jacobian ``a`` (its eliminated columns get zero rows in Z)."""
    return constraint_split(a, nlp.dependent, nlp.n_determining, np.asarray(nlp.eliminated, np.int64))


def reusable_split(split: ConstraintSplit, eliminated: np.ndarray) -> ConstraintSplit:
    """The split of a reduced system, for another reduced system at the same z: its basis copied
    and zero again in the ``eliminated`` rows, where the first wrote -M (the same split when there
    are none: the basis is then only read)."""
    eliminated = np.asarray(eliminated, np.int64)
    if not eliminated.size:
        return split
    basis = split.basis.copy()
    basis[eliminated] = 0.0
    return dataclasses.replace(split, basis=basis)


def gauss_newton_system(nlp: Nlp, z: np.ndarray, split: ConstraintSplit | None) -> ReducedSystem:
    """The Gauss-Newton reduced system at ``z`` (scaled), on the constraint split ``split`` already
    made there (e.g. an observed-information covariance's: the null space is the same, only the
    curvature differs; 0.7 s instead of 1.2 to 2 s on an atmosphere-profile fit), else formed."""
    if split is None:
        return reduced_system_at(nlp, z)
    h, a = fisher_and_jacobian(nlp, z)
    return reduced_hessian(nlp, h, a, reusable_split(split, nlp.eliminated))


def reduced_system_at(nlp: Nlp, z: np.ndarray) -> ReducedSystem:
    """The reduced system at ``z`` (scaled), from the residual Jacobian (the solver's way, so the
    covariance recomputed at a solution is the reported one to the last bit)."""
    d = nlp.derivatives
    return reduced_hessian_from_jacobian(nlp, d.jacobian_r(z), d.jacobian_g(z))


def _reduced(split: ConstraintSplit, hr: np.ndarray, b: np.ndarray, h_ee, elim: np.ndarray,
             a: sps.csc_matrix) -> ReducedSystem:
    """The reduced system from Z^T H Z (``hr``), B = H_Ec Z_c (``b``) and ``h_ee()`` (H_EE, sparse)."""
    basis = split.basis
    if not elim.size:
        return ReducedSystem(basis, 0.5 * (hr + hr.T), split=split)
    if abs(a[:, elim]).sum() != 0:
        raise ValueError("an eliminated column appears in a constraint")
    try:
        lu = splu(h_ee())
    except RuntimeError as err:
        raise SingularCovariance(f"the Hessian block of the latent sensor errors is singular ({err})") from None
    m = lu.solve(np.asarray(b))
    hr = hr - b.T @ m
    basis[elim] = -m
    return ReducedSystem(basis, 0.5 * (hr + hr.T), Elimination(elim, lu), m, split)


def compute_covariance(nlp: Nlp, z: np.ndarray, chi2: float, dof: int, reduced: ReducedSystem | None = None, *,
                       information: str = "expected", lam_g: np.ndarray | None = None) -> Covariance | KktCovariance:
    """Covariance at the solution ``z`` (scaled).

    ``information="expected"`` inverts the Gauss-Newton Hessian J^T J (the Fisher information);
    ``reduced`` is the reduced system already formed at ``z`` (the convergence test's), if any.
    ``"observed"`` inverts the exact Hessian of the Lagrangian at ``z`` with the multipliers
    ``lam_g`` on the constraints' null space (the curvature of the objective itself, the Laplace
    approximation's), and falls back to the expected information where that is not positive definite,
    or for fits with disturbance states (their KKT path checks definiteness of the parameter
    block only). The returned covariance's ``information`` says which was inverted and why.
    """
    if information not in INFORMATION:
        raise ValueError(f"information must be one of {', '.join(INFORMATION)}, not {information!r}")
    fallback = "expected"
    if information == "observed":
        if nlp.latent:
            fallback = "expected (the observed information is not used with disturbance states)"
        elif lam_g is None:
            fallback = "expected (no constraint multipliers for the observed information)"
        else:
            observed = _observed_system(nlp, z, lam_g, reduced)
            try:
                return _null_space_covariance(nlp, observed, chi2, dof, "observed")
            except SingularCovariance as err:
                LOG.info("observed information not usable (%s): the expected information is inverted", err)
                fallback = "expected (the observed information is not positive definite at the solution)"
    if nlp.latent:
        h, a = fisher_and_jacobian(nlp, z)
        cov = _kkt_covariance(nlp, h, a, chi2, dof)
        cov.information = fallback
        return cov
    system = reduced if reduced is not None else reduced_system_at(nlp, z)
    return _null_space_covariance(nlp, system, chi2, dof, fallback)


@single_threaded_blas()
def _observed_system(nlp: Nlp, z: np.ndarray, lam_g: np.ndarray, reduced: ReducedSystem | None) -> ReducedSystem:
    """The reduced system of the observed information at ``z`` (see :func:`compute_covariance`),
    on ``reduced``'s constraint split when it has one, else on a split made here. Not on a second
    thread alongside the Hessian's evaluation (0.3 s less on an atmosphere-profile fit): the split
    holds SuperLU factors, which leak their memory when they outlive the thread that made them
    (:mod:`casrecon.estimation.engine.block_lu`)."""
    d = nlp.derivatives
    a = d.jacobian_g(z)
    if reduced is not None and reduced.split is not None:
        return reduced_hessian(nlp, d.observed_information(z, lam_g), a, reusable_split(reduced.split, nlp.eliminated))
    return reduced_hessian(nlp, d.observed_information(z, lam_g), a, _split_of(nlp, a))


def _null_space_covariance(nlp: Nlp, system: ReducedSystem, chi2: float, dof: int, information: str) -> Covariance:
    eig, vec = np.linalg.eigh(system.hessian)
    cond = float(eig[-1] / eig[0]) if eig[0] > 0 else float("inf")
    # Undetermined is judged on the Hessian scaled to a unit diagonal (a correlation-like matrix):
    # its condition does not grow with how stiff the best-determined unknowns are. Unscaled, a
    # drop whose weakest combination was held by its priors alone (eigenvalue 0.034, the priors'
    # own curvature there: the density factor against the density profile's constant part) was
    # refused at condition 1.01e13 because its stiffest was 3.4e11.
    cond_s, weakest = scaled_condition(system.hessian)
    if eig[0] <= 0 or cond_s > MAX_CONDITION:
        raise SingularCovariance(_weakest_direction(nlp, system.basis, weakest, cond_s))
    cov_w = (vec / eig) @ vec.T
    return Covariance(system.basis, cov_w, chi2 / max(dof, 1), cond, system.elimination, information, system.split)


def scaled_condition(hessian: np.ndarray) -> tuple[float, np.ndarray]:
    """(condition number, weakest direction) of a symmetric matrix scaled to a unit diagonal,
    D^-1 H D^-1 with D = sqrt(diag H); the direction in the unscaled coordinates. The condition is
    inf when the scaled matrix is not positive definite."""
    # a diagonal entry <= 0 (an indefinite matrix) is scaled by 1 instead
    diag = np.sqrt(np.where(np.diag(hessian) > 0, np.diag(hessian), 1.0))
    eig, vec = np.linalg.eigh(hessian / np.outer(diag, diag))
    cond = float(eig[-1] / eig[0]) if eig[0] > 0 else float("inf")
    return cond, vec[:, 0] / diag


def kkt_matrix(h: sps.spmatrix, a: sps.spmatrix) -> sps.csc_matrix:
    """K = [[H, A^T], [A, 0]] (CSC) from the full symmetric H and the constraint Jacobian A."""
    return sps.bmat([[h, a.T], [a, None]], format="csc")


def _kkt_covariance(nlp: Nlp, h, a, chi2: float, dof: int) -> KktCovariance:
    kkt = kkt_matrix(h, a)
    cols = nlp.parameter_columns
    cov = KktCovariance(kkt, h.shape[0], chi2, dof, border=cols)
    eig = np.linalg.eigvalsh(cov.covariance_of(cols))
    cov.condition = float(eig[-1] / max(eig[0], 1e-300))
    if eig[0] <= 0 or cov.condition > MAX_CONDITION:
        raise SingularCovariance(f"parameter covariance not positive definite (condition {cov.condition:.3g}): some "
                                 "parameter combination is not determined by the data")
    return cov


def _weakest_direction(nlp: Nlp, basis: np.ndarray, v: np.ndarray, cond: float) -> str:
    dz = basis @ v
    names = nlp.parameter_names
    cols = np.array(list(names))
    order = cols[np.argsort(-np.abs(dz[cols]))[:3]]
    combo = ", ".join(f"{names[int(c)]} ({dz[c]:+.2f})" for c in order)
    return (f"KKT matrix singular (reduced Hessian condition {cond:.3g} at unit diagonal): the combination of {combo} "
            f"is not determined by the data; fix one of them or switch its prior on")
