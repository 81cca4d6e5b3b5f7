"""The solver of a kinematic fit: Levenberg-Marquardt on the least-squares problem with the
quaternions kept on the unit sphere (docs/design.md: Kinematic reconstruction).

The problem is unconstrained least squares whose residuals do not depend on each quaternion's
scale. Ipopt's steps on the scale-free quaternions wander from a poor guess (the attitude of a
tumbling body can be tens of degrees off) and, at the optimum, its step computation fails on the
singular Gauss-Newton Hessian. Here each iteration computes the Gauss-Newton step v from
(H + Q Q^T) v = -J^T r (:mod:`.covariance`: Q Q^T fixes the quaternions' scale) and its
geodesic acceleration a from (H + Q Q^T) a = -J^T r''_v, r''_v the second directional derivative
of the residuals along v by a finite difference (Transtrum and Sethna 2012): the step
alpha v + alpha^2 a / 2 follows a curved valley of the chi-square, such as a heading the fixes
hardly see, where every rotation of the attitudes must turn the velocities with it. alpha = 1,
1/2, ... 1/16 is tried (renormalising the quaternions) until the chi-square falls; only when that
fails, the step is damped, (H + Q Q^T + lambda diag) dz = -J^T r with lambda raised tenfold (a
Marquardt damping kept as a fallback: the stiff IMU rows' diagonal damps the soft directions the
fixes determine, and along such a direction the damped steps crawl). Converged when the full
Gauss-Newton step predicts a chi-square decrease of at most ``decrement_tol`` (the stopping test
of the other fits: the iterate is then within sqrt(decrement_tol) sigma of the optimum).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps

from casrecon.estimation.engine.nlp import Nlp
from casrecon.estimation.kinematic.covariance import gauge_matrix
from casrecon.estimation.numerics.banded_factor import SymmetricFactor

LOG = logging.getLogger(__name__)


#: Largest predicted chi-square decrease of a full Gauss-Newton step at a converged iterate.
DECREMENT_TOL = 1e-3
#: Step fractions of the line search along the accelerated Gauss-Newton step.
STEP_FRACTIONS = (1.0, 0.5, 0.25, 0.125, 0.0625)
#: Finite-difference step (fraction of v) of the second directional derivative.
ACCELERATION_STEP = 0.1


@dataclass(frozen=True)
class LmResult:
    """Result of :func:`levenberg_marquardt`: the iterate, its chi-square, iterations made, whether
    it converged, the last Gauss-Newton decrement tested (chi-square units) and seconds taken."""

    z: np.ndarray
    chi2: float
    iterations: int
    converged: bool
    decrement: float = float("nan")
    solve_s: float = 0.0

    @property
    def status(self) -> str:
        if self.converged:
            return f"Converged (Gauss-Newton decrement {self.decrement:.2g} chi2)"
        return f"not converged after {self.iterations} iterations (Gauss-Newton decrement {self.decrement:.3g} chi2)"


def _normalised(z: np.ndarray, gauge_cols: np.ndarray) -> np.ndarray:
    out = z.copy()
    q = out[gauge_cols]
    out[gauge_cols] = q / np.linalg.norm(q, axis=1, keepdims=True)
    return out


def residual_jacobian(nlp: Nlp, z: np.ndarray) -> sps.csr_matrix:
    """The whitened residuals' Jacobian J (n_r x n_z, sparse) at ``z`` (scaled), assembled from
    every block set's derivative values."""
    d = nlp.derivatives
    rows, cols, vals = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)], [np.zeros(0)]
    for bs, r_row, out in zip(d.sets, d.r_rows, d.evaluator(z)):
        local_rows, local_cols = bs.kind.patterns["jr"]
        if not local_rows.size:
            continue
        block = r_row + np.arange(bs.n_blocks)[:, None] * bs.kind.n_residuals
        rows.append((block + local_rows[None, :]).ravel())
        cols.append(bs.cols[:, local_cols].ravel())
        vals.append(np.asarray(out[1]).reshape(bs.n_blocks, -1).ravel())
    return sps.csr_matrix((np.concatenate(vals), (np.concatenate(rows), np.concatenate(cols))), shape=(d.n_r, d.n_z))


def levenberg_marquardt(nlp: Nlp, z0: np.ndarray, gauge_cols: np.ndarray, max_iter: int = 50,
                        decrement_tol: float = DECREMENT_TOL, label: str = "kinematic fit") -> LmResult:
    """Minimise |r(z)|^2 from ``z0`` (scaled) with the quaternion columns ``gauge_cols`` (K, 4) on
    the unit sphere, until the Gauss-Newton decrement is at most ``decrement_tol`` (converged) or
    ``max_iter`` steps or no step lowers the chi-square (not converged)."""
    t0 = time.perf_counter()
    z = _normalised(z0, gauge_cols)
    r = nlp.residual_vector(z)
    chi2 = float(r @ r)
    lam, decrement = 1e-6, float("nan")
    for it in range(max_iter + 1):
        jac = residual_jacobian(nlp, z)
        grad = jac.T @ r
        a = (jac.T @ jac + gauge_matrix(z, gauge_cols, nlp.n_z)[0]).tocsc()
        lu = SymmetricFactor(a)
        # grad is J^T r, the gradient of |r|^2 / 2: the full step dz = -A^-1 grad lowers |r|^2 by -grad.dz
        step = lu.solve(-grad)
        decrement = float(-grad @ step)
        if decrement <= decrement_tol:
            return LmResult(z, chi2, it, True, decrement, time.perf_counter() - t0)
        if it == max_iter:
            break
        z_new, chi2_new, how = _line_search(nlp, z, r, jac, lu, step, chi2, gauge_cols)
        if z_new is None:  # no fraction of the accelerated step lowers the chi-square: damp it
            diag = np.maximum(a.diagonal(), 1e-12)
            while lam < 1e12:
                z_new, chi2_new = _trial(nlp, z, SymmetricFactor(a + sps.diags(lam * diag)).solve(-grad), gauge_cols)
                if chi2_new < chi2:
                    break
                lam *= 10.0
            else:
                break
            how, lam = f"damped, lambda {lam:.1g}", max(lam / 10.0, 1e-9)
        z, chi2 = z_new, chi2_new
        r = nlp.residual_vector(z)
        LOG.info("%s: iteration %d: chi-square %.6g (Gauss-Newton decrement %.3g; %s)", label, it + 1, chi2,
                 decrement, how)
    return LmResult(z, chi2, max_iter, False, decrement, time.perf_counter() - t0)


def _line_search(nlp: Nlp, z: np.ndarray, r: np.ndarray, jac: sps.csr_matrix, lu, step: np.ndarray, chi2: float,
                 gauge_cols: np.ndarray):
    """The first of alpha in :data:`STEP_FRACTIONS` whose step alpha v + alpha^2 a / 2 (v the
    Gauss-Newton step, a its geodesic acceleration) lowers the chi-square: (z, chi2, note), or
    (None, chi2, "") when none does."""
    h = ACCELERATION_STEP
    second = (2.0 / h) * ((nlp.residual_vector(z + h * step) - r) / h - jac @ step)
    accel = lu.solve(-(jac.T @ second))
    if not np.all(np.isfinite(accel)):
        accel = np.zeros_like(step)
    for alpha in STEP_FRACTIONS:
        z_new, chi2_new = _trial(nlp, z, alpha * step + 0.5 * alpha * alpha * accel, gauge_cols)
        if chi2_new < chi2:
            return z_new, chi2_new, f"step {alpha:g}"
    return None, chi2, ""


def _trial(nlp: Nlp, z: np.ndarray, step: np.ndarray, gauge_cols: np.ndarray) -> tuple[np.ndarray, float]:
    """The renormalised iterate after ``step`` and its chi-square (inf when not finite)."""
    z_new = _normalised(z + step, gauge_cols)
    r = nlp.residual_vector(z_new)
    chi2 = float(r @ r)
    return z_new, chi2 if np.isfinite(chi2) else float("inf")

