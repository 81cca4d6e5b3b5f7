"""The start solve of a kinematic fit: Levenberg-Marquardt on the least-squares problem with the
quaternions kept on the unit sphere (docs/design.md: Kinematic reconstruction).

From a poor guess (the attitude of a tumbling body can be tens of degrees off) Ipopt's steps on the
scale-free quaternions wander; here each step solves (H + Q Q^T + lambda diag(H)) dz = -J^T r with
the Gauss-Newton H (:mod:`.kinematic_covariance`: Q Q^T fixes the quaternions' scale), the
quaternions are renormalised after the step, and the step is kept only when the chi-square falls
(lambda shrinks) or retried with a larger lambda. Ipopt then finishes from the result.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps
from scipy.sparse.linalg import splu

from casrecon.estimation.engine.nlp import Nlp
from casrecon.estimation.kinematic_covariance import gauge_matrix

LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class StartSolve:
    """Result of :func:`levenberg_marquardt`: the iterate, its chi-square, iterations made and
    whether the relative chi-square change fell below the tolerance."""

    z: np.ndarray
    chi2: float
    iterations: int
    converged: bool


def _normalised(z: np.ndarray, gauge_cols: np.ndarray) -> np.ndarray:
    out = z.copy()
    q = out[gauge_cols]
    out[gauge_cols] = q / np.linalg.norm(q, axis=1, keepdims=True)
    return out


def levenberg_marquardt(nlp: Nlp, z0: np.ndarray, gauge_cols: np.ndarray, max_iter: int = 50,
                        tol: float = 1e-4, label: str = "kinematic start") -> StartSolve:
    """Minimise |r(z)|^2 from ``z0`` (scaled) with the quaternion columns ``gauge_cols`` (K, 4)
    on the unit sphere; stops when a kept step changes the chi-square by less than ``tol``
    relative, after ``max_iter`` steps, or when lambda exceeds 1e12."""
    d = nlp.derivatives
    z = _normalised(z0, gauge_cols)
    r = nlp.residual_vector(z)
    chi2 = float(r @ r)
    lam = 1e-3
    for it in range(1, max_iter + 1):
        grad = d.gradient(z)
        upper = d.gauss_newton(z)
        h = upper + sps.triu(upper, 1).T
        gauge, _ = gauge_matrix(z, gauge_cols, nlp.n_z)
        diag = np.maximum(h.diagonal(), 1e-12)
        while lam < 1e12:
            step = splu((h + gauge + sps.diags(lam * diag)).tocsc(), permc_spec="MMD_AT_PLUS_A").solve(-grad)
            z_new = _normalised(z + step, gauge_cols)
            r_new = nlp.residual_vector(z_new)
            chi2_new = float(r_new @ r_new)
            if np.isfinite(chi2_new) and chi2_new < chi2:
                break
            lam *= 10.0
        else:
            return StartSolve(z, chi2, it, False)
        change = (chi2 - chi2_new) / max(chi2, 1e-300)
        z, chi2, lam = z_new, chi2_new, max(lam / 10.0, 1e-9)
        LOG.info("%s: iteration %d: chi-square %.6g (lambda %.2g)", label, it, chi2, lam)
        if change < tol:
            return StartSolve(z, chi2, it, True)
    return StartSolve(z, chi2, max_iter, False)
