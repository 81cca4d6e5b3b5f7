"""The solver of a kinematic fit: Levenberg-Marquardt on the least-squares problem with the
quaternions kept on the unit sphere (docs/design.md: Kinematic reconstruction).

The problem is unconstrained least squares whose residuals do not depend on each quaternion's
scale. Ipopt's steps on the scale-free quaternions wander from a poor guess (the attitude of a
tumbling body can be tens of degrees off) and, at the optimum, its step computation fails on the
singular Gauss-Newton Hessian. Here each iteration tries the Gauss-Newton step (H + Q Q^T) dz = -J^T r
(:mod:`.kinematic_covariance`: Q Q^T fixes the quaternions' scale), renormalises the quaternions,
and keeps it when the chi-square falls; otherwise it damps the step, (H + Q Q^T + lambda diag) dz =
-J^T r with lambda raised tenfold until the chi-square falls (a Marquardt damping kept as a
fallback only: with it on every step, the stiff IMU rows' diagonal damps the soft directions the
fixes determine and the iterations crawl). Converged when the full Gauss-Newton step
(lambda = 0) predicts a chi-square decrease of at most ``decrement_tol`` (the stopping test of the
other fits: the iterate is then within sqrt(decrement_tol) sigma of the optimum).
"""

from __future__ import annotations

import logging
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps
from scipy.sparse.linalg import splu

from casrecon.estimation.engine.nlp import Nlp
from casrecon.estimation.kinematic_covariance import gauge_matrix

LOG = logging.getLogger(__name__)


#: Largest predicted chi-square decrease of a full Gauss-Newton step at a converged iterate.
DECREMENT_TOL = 1e-3


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


def levenberg_marquardt(nlp: Nlp, z0: np.ndarray, gauge_cols: np.ndarray, max_iter: int = 50,
                        decrement_tol: float = DECREMENT_TOL, label: str = "kinematic fit") -> LmResult:
    """Minimise |r(z)|^2 from ``z0`` (scaled) with the quaternion columns ``gauge_cols`` (K, 4) on
    the unit sphere, until the Gauss-Newton decrement is at most ``decrement_tol`` (converged) or
    ``max_iter`` steps or no step with lambda up to 1e12 lowers the chi-square (not converged)."""
    t0 = time.perf_counter()
    d = nlp.derivatives
    z = _normalised(z0, gauge_cols)
    r = nlp.residual_vector(z)
    chi2 = float(r @ r)
    lam, decrement = 1e-3, float("nan")
    for it in range(max_iter + 1):
        grad = d.gradient(z)
        upper = d.gauss_newton(z)
        a = upper + sps.triu(upper, 1).T + gauge_matrix(z, gauge_cols, nlp.n_z)[0]
        # grad is J^T r, the gradient of |r|^2 / 2: the full step dz = -A^-1 grad lowers |r|^2 by -grad.dz
        step = _solve(a, -grad)
        decrement = float(-grad @ step)
        if decrement <= decrement_tol:
            return LmResult(z, chi2, it, True, decrement, time.perf_counter() - t0)
        if it == max_iter:
            break
        z_new, chi2_new = _trial(nlp, z, step, gauge_cols)
        if not chi2_new < chi2:  # the Gauss-Newton step failed: damp it
            diag = np.maximum(a.diagonal(), 1e-12)
            lam = max(lam, 1e-6)
            while lam < 1e12:
                z_new, chi2_new = _trial(nlp, z, _solve(a + sps.diags(lam * diag), -grad), gauge_cols)
                if chi2_new < chi2:
                    break
                lam *= 10.0
            else:
                break
            lam /= 10.0
        z, chi2 = z_new, chi2_new
        LOG.info("%s: iteration %d: chi-square %.6g (Gauss-Newton decrement %.3g)", label, it + 1, chi2, decrement)
    return LmResult(z, chi2, max_iter, False, decrement, time.perf_counter() - t0)


def _trial(nlp: Nlp, z: np.ndarray, step: np.ndarray, gauge_cols: np.ndarray) -> tuple[np.ndarray, float]:
    """The renormalised iterate after ``step`` and its chi-square (inf when not finite)."""
    z_new = _normalised(z + step, gauge_cols)
    r = nlp.residual_vector(z_new)
    chi2 = float(r @ r)
    return z_new, chi2 if np.isfinite(chi2) else float("inf")


def _solve(a: sps.spmatrix, b: np.ndarray) -> np.ndarray:
    return splu(a.tocsc(), permc_spec="MMD_AT_PLUS_A").solve(b)
