"""Gauss-Newton steps in the full space that bring a fit with latent process values near its
optimum before Ipopt takes over.

With gust or model-error values at every node the null space of the constraints has thousands of
directions, so :mod:`.gauss_newton`'s dense reduced system does not apply, and Ipopt (exact Hessian)
is the solver. From the initial guess Ipopt spends most of its iterations getting near the optimum
(23 iterations, 17 s on a whole ees-drop-3 gust fit). Each step here solves the linearised problem

    min 1/2 |r + J dz|^2   s.t.   c + A dz = 0

through its KKT system [[J^T J, A^T], [A, 0]] [dz; lambda] = [-J^T r; -c], factorised as a
:class:`.bordered_kkt.BorderedKkt` (0.2 s on that fit), with the l1-merit line search and
second-order correction of :mod:`.gauss_newton`. Measured on that fit: 8 such steps (3.2 s) and
Ipopt's 9 iterations from there (5.9 s) reach the optimum Ipopt reaches alone, to the objective's
last printed digit.

They only start Ipopt: near the optimum Gauss-Newton converges linearly in the weakly determined
latent directions (its constraint curvature is missing), and on a 27 s gust window 50 steps left
it 0.054 sigma from Ipopt's optimum.
"""

from __future__ import annotations

import logging
import time

import numpy as np

from casrecon.estimation.engine import convergence
from casrecon.estimation.engine.bordered_kkt import BorderedKkt
from casrecon.estimation.engine.covariance import fisher_and_jacobian, kkt_matrix
from casrecon.estimation.engine.gauss_newton import bounded_columns, line_search
from casrecon.estimation.engine.nlp import Nlp
from casrecon.parallel import single_threaded_blas

LOG = logging.getLogger(__name__)

#: Gauss-Newton steps taken at most before Ipopt.
WARM_START_STEPS = 8
#: The steps stop early once a full step's predicted chi-square decrease is below this fraction of
#: the chi-square (the rest is Ipopt's).
RELATIVE_DECREASE_TOL = 1e-6


@single_threaded_blas()
def warm_start(nlp: Nlp, z0: np.ndarray, bounds: tuple[np.ndarray, np.ndarray] | None = None,
               max_steps: int = WARM_START_STEPS) -> tuple[np.ndarray, int, float]:
    """Up to ``max_steps`` full-space Gauss-Newton steps from ``z0`` (scaled; trial points clipped
    into ``bounds``). Returns (last iterate, steps taken, seconds). A step that cannot be formed
    (a singular KKT matrix) or a failed line search ends them early, with the iterate reached."""
    t0 = time.perf_counter()
    d = nlp.derivatives
    bounded = bounded_columns(bounds, nlp.n_z)
    border = nlp.parameter_columns
    z = np.asarray(z0, float).copy()
    z[bounded[0]] = np.clip(z[bounded[0]], bounded[1], bounded[2])
    level, label = convergence.iteration_log_settings()
    const_chi2 = float(sum(nlp.const_chi2.values()))
    nu, steps = 0.0, 0
    for steps in range(max_steps):
        d.evaluate(z)
        r, c, grad = d.residuals(z), d.constraints(z), d.gradient(z)
        jr = d.jacobian_r(z)
        violation = float(np.abs(c).max()) if c.size else 0.0
        convergence.log_iteration(level, label, steps, float(r @ r) + const_chi2, violation)
        try:
            factor = BorderedKkt(kkt_matrix(*fisher_and_jacobian(nlp, z)), border)
        except RuntimeError as err:
            LOG.info("Gauss-Newton warm start stopped after %d steps: %s", steps, err)
            break
        dz = factor.solve(np.concatenate([-grad, -c]))[:nlp.n_z]
        jdz = jr @ dz
        predicted = -(2.0 * float(grad @ dz) + float(jdz @ jdz))
        if predicted <= RELATIVE_DECREASE_TOL * float(r @ r) and violation <= convergence.FEASIBILITY_TOL:
            break

        def correct(c_trial: np.ndarray, factor=factor) -> np.ndarray:
            return factor.solve(np.concatenate([np.zeros(nlp.n_z), -c_trial]))[:nlp.n_z]

        z_new, nu, _ = line_search(nlp, z, r, c, grad, jr, dz, nu, bounded, correct)
        if z_new is None:
            LOG.info("Gauss-Newton warm start stopped after %d steps: line search failed", steps)
            break
        z = z_new
    else:
        steps = max_steps
    return z, steps, time.perf_counter() - t0
