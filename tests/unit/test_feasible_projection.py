"""The full-space solver's projection onto the constraints (kkt_gauss_newton.feasible_projection), on
a linear least-squares problem with linear constraints shaped like a fit's (test_time_ordered_kkt's
KKT matrix), where the exact answer is known: min 1/2 |J z - y|^2 s.t. A z = b."""

from types import SimpleNamespace

import numpy as np
import scipy.sparse as sps

from casrecon.estimation.engine import convergence
from casrecon.estimation.engine.gauss_newton import bounded_columns
from casrecon.estimation.engine.kkt_gauss_newton import feasibility_step, feasible_projection
from casrecon.estimation.engine.time_ordered_kkt import OrderedPattern, TimeOrderedKkt
from tests.unit.test_time_ordered_kkt import fit_like_kkt


def linear_problem():
    kkt, n_z, stages, params = fit_like_kkt()
    dense = kkt.toarray()
    h, a = dense[:n_z, :n_z], dense[n_z:, :n_z]
    eig, vec = np.linalg.eigh(h)
    jac = np.sqrt(np.clip(eig, 0.0, None))[:, None] * vec.T  # J^T J = H
    rng = np.random.default_rng(7)
    y, b = rng.standard_normal(n_z), rng.standard_normal(a.shape[0])
    # the optimum: K [z*; lambda] = [J^T y; b]
    z_star = np.linalg.solve(dense, np.r_[jac.T @ y, b])[:n_z]
    marker = kkt.copy()
    marker.data = np.arange(1.0, kkt.nnz + 1)
    factor = TimeOrderedKkt(OrderedPattern(marker, n_z, stages, params), kkt.data)
    nlp = SimpleNamespace(n_z=n_z, derivatives=SimpleNamespace(
        values_only=lambda z: (jac @ z - y, a @ z - b)))
    return nlp, factor, dense, jac, y, a, b, z_star


def step_at(z, factor, jac, y, a, b):
    """(c, gradient, Gauss-Newton step) at z."""
    c, grad = a @ z - b, jac.T @ (jac @ z - y)
    return c, grad, factor.solve(np.r_[-grad, -c])[:z.size]


def decrement(z, jac, y, z_star):
    """The exact predicted chi-square decrease of the full step from a feasible z to the optimum."""
    d = z_star - z
    return -(2.0 * float(jac.T @ (jac @ z - y) @ d) + float((jac @ d) @ (jac @ d)))


def test_a_converged_but_infeasible_iterate_is_projected_onto_the_constraints():
    nlp, factor, dense, jac, y, a, b, z_star = linear_problem()
    z = z_star + 1e-7 * np.random.default_rng(8).standard_normal(z_star.size)  # off the constraints by ~1e-7
    c, grad, dz = step_at(z, factor, jac, y, a, b)
    assert np.abs(c).max() > convergence.FEASIBILITY_TOL
    dz_p = feasibility_step(factor, c, z, bounded_columns(None, z.size))
    out = feasible_projection(nlp, z, grad, sps.csr_matrix(jac), dz, dz_p)
    assert out is not None
    z_p, violation, predicted = out
    assert violation <= convergence.FEASIBILITY_TOL
    assert np.abs(a @ z_p - b).max() == violation
    assert abs(predicted - decrement(z_p, jac, y, z_star)) < 1e-9
    assert np.abs(z_p - z).max() < 1e-5  # a step of the violation's size, not towards the optimum


def test_an_iterate_not_converged_in_the_null_space_is_not_projected():
    nlp, factor, dense, jac, y, a, b, z_star = linear_problem()
    # along the constraints' null space by a sizeable step, then slightly off them
    null = np.linalg.svd(a)[2][a.shape[0]:].T
    z = z_star + null @ (0.3 * np.random.default_rng(9).standard_normal(null.shape[1]))
    assert decrement(z, jac, y, z_star) > 10 * convergence.DECREMENT_TOL
    z = z + 1e-7 * np.random.default_rng(10).standard_normal(z.size)
    c, grad, dz = step_at(z, factor, jac, y, a, b)
    dz_p = feasibility_step(factor, c, z, bounded_columns(None, z.size))
    assert feasible_projection(nlp, z, grad, sps.csr_matrix(jac), dz, dz_p) is None
