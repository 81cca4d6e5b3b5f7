"""Laplace-marginal profile of one parameter of a weak-constraint (disturbance-state) fit.

The fit maximises the joint posterior of states, disturbances and parameters. When a parameter
scales the effect of the disturbances (a slope multiplier times a gust-induced angle of attack),
the joint maximum is biased: the joint objective lacks the term 1/2 log det(H_ll) of the marginal
likelihood, where H_ll is the Gauss-Newton Hessian of the latent unknowns (node states and
disturbances, the states through the defects: independent coordinates are the first node and the
disturbance values) at fixed parameters. This module profiles one parameter under both:

    joint(v)    = min over the rest of 1/2 |r|^2     with the parameter held at v,
    marginal(v) = joint(v) + 1/2 log det(Z_l^T H Z_l) at that minimum,

Z_l the latent directions that satisfy the linearised constraints, in independent coordinates; the
log-determinant is the marginal-likelihood estimator's own, from sparse factorisations
(:func:`casrecon.estimation.engine.laplace.half_log_det`). The other parameters are profiled, not
marginalised; the estimator ``[estimation] method = "marginal"`` marginalises all of them at once.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import numpy as np

from casrecon.analysis.observability import refit_with_held
from casrecon.estimation.engine.laplace import half_log_det
from casrecon.estimation.sixdof.fit import FitResult

LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class MarginalProfile:
    """Joint and Laplace-marginal profiles of parameter ``name`` over ``values`` (SI).

    ``joint`` and ``marginal`` are objective differences from their grid minima (half chi-square
    units); ``converged`` flags each refit.
    """

    name: str
    values: np.ndarray
    joint: np.ndarray
    marginal: np.ndarray
    converged: np.ndarray

    @staticmethod
    def _minimum(x: np.ndarray, y: np.ndarray) -> float:
        """Vertex of the parabola through the grid minimum and its neighbours (up to 5 points)."""
        k = int(np.argmin(y))
        lo, hi = max(k - 2, 0), min(k + 3, x.size)
        c = np.polyfit(x[lo:hi], y[lo:hi], 2)
        return float(-c[1] / (2 * c[0])) if c[0] > 0 else float(x[k])

    @property
    def joint_minimum(self) -> float:
        return self._minimum(self.values, self.joint)

    @property
    def marginal_minimum(self) -> float:
        return self._minimum(self.values, self.marginal)


def marginal_profile(result: FitResult, name: str, values: np.ndarray, max_iter: int = 150) -> MarginalProfile:
    """Refit ``result`` with ``name`` held at each of ``values`` (SI, warm-started from the fit)
    and return the joint and Laplace-marginal profiles. Logs one line per value (INFO); the refits'
    Ipopt iterations at DEBUG."""
    values = np.asarray(values, float)
    joint, half_log_dets, converged = [], [], []
    for i, v in enumerate(values, 1):
        sol = refit_with_held(result, name, v, max_iter)
        joint.append(sol.objective)
        half_log_dets.append(half_log_det(result.nlp, sol.z))
        converged.append(sol.converged)
        LOG.info("marginal profile %s: point %d of %d, %s = %.6g: objective %.6g, 1/2 log det %.6g%s", name, i,
                 len(values), name, v, joint[-1], half_log_dets[-1], "" if sol.converged else " (not converged)")
    joint = np.array(joint)
    marginal = joint + np.array(half_log_dets)
    return MarginalProfile(name, values, joint - joint.min(), marginal - marginal.min(), np.array(converged))
