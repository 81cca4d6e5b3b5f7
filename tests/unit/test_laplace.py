"""The Laplace marginal-likelihood estimator on a small weak-constraint problem whose answer can be
computed densely: a first-order state driven by a latent disturbance through a gain,

    x_{k+1} = x_k + h (-a x_k + g (f_k + s_w w_k)),  w_k ~ N(0, 1),  y_k = x_k + e_k,  e_k ~ N(0, SIGMA^2),

f_k a known forcing (which fixes the sign of g), s_w the disturbance's size, a and g the
parameters (g with a prior). Linear in (x, w) for fixed (a, g), so the Laplace approximation is
exact there, and the joint MAP of the gain g is biased upward (a larger g explains the data with smaller
disturbances, which the prior rewards) while the marginal maximum likelihood is not."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.optimize import minimize

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.engine.checks import covariance_or_fail
from casrecon.estimation.engine.laplace import (
    STALL_STEP_TOL,
    STEP_TOL,
    LatentSplit,
    half_log_det,
    log_det_curvature,
    maximise_marginal,
    outer_stop,
    solve_latent,
)
from casrecon.estimation.engine.nlp import Nlp, assemble_nlp
from casrecon.estimation.engine.solve import solve

N_INTERVALS = 60
STEP = 0.1
SIGMA = 0.05
TRUTH = (0.5, 1.0)  # a (1/s), g
FORCING = 2.0  # amplitude of the known forcing f_k
DISTURBANCE = 0.5  # s_w, the disturbance's size against it
GAIN_PRIOR_SIGMA = 0.5  # g ~ N(1, 0.5^2): without a prior the joint MAP has none (g -> inf, w -> 0)


def driven_nlp(seed: int) -> Nlp:
    """z = [x_0 .. x_N, w_0 .. w_{N-1}, a, g] for data of seed ``seed``."""
    rng = np.random.default_rng(seed)
    a, g = TRUTH
    w = rng.normal(size=N_INTERVALS)
    forcing = FORCING * np.sin(0.5 * STEP * np.arange(N_INTERVALS))
    x = np.zeros(N_INTERVALS + 1)
    x[0] = 1.0
    for k in range(N_INTERVALS):
        x[k + 1] = x[k] + STEP * (-a * x[k] + g * (forcing[k] + DISTURBANCE * w[k]))
    y = x + SIGMA * rng.normal(size=x.size)
    n_x = N_INTERVALS + 1
    n_z = n_x + N_INTERVALS + 2
    local, yk, fk = ca.SX.sym("v", 5), ca.SX.sym("y"), ca.SX.sym("f")
    xa, xb, wk, pa, pg = (local[i] for i in range(5))
    interval = BlockKind("interval", local, [yk, fk], ca.vertcat((yk - xb) / SIGMA, wk),
                         xb - xa - STEP * (-pa * xa + pg * (fk + DISTURBANCE * wk)))
    cols = np.array([[k, k + 1, n_x + k, n_z - 2, n_z - 1] for k in range(N_INTERVALS)])
    first_local, y0 = ca.SX.sym("v0", 1), ca.SX.sym("y0")
    first = BlockKind("first", first_local, [y0], (y0 - first_local[0]) / SIGMA, None)
    gain = ca.SX.sym("g")
    prior = BlockKind("prior", gain, [], (gain - TRUTH[1]) / GAIN_PRIOR_SIGMA, None)
    terms = [Term("y", (BlockSet(interval, cols, [ca.DM(y[1:]).T, ca.DM(forcing).T]),)),
             Term("y0", (BlockSet(first, np.array([[0]]), [ca.DM(y[0])]),)),
             Term("prior", (BlockSet(prior, np.array([[n_z - 1]]), []),))]
    return assemble_nlp(terms, n_z, dependent=np.arange(1, n_x), parameter_names={n_z - 2: "a", n_z - 1: "g"})


def dense_latent(nlp: Nlp, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(J_u Z, Z) with Z = [-A_D^-1 A_I; I] the latent directions in independent coordinates (x_0, w)."""
    split = LatentSplit.of(nlp)
    a = nlp.derivatives.jacobian_g(z).toarray()[:, split.latent]
    j = nlp.derivatives.jacobian_r(z).toarray()[:, split.latent]
    dep = nlp.dependent  # latent columns are 0..n_z-3, so latent index == z column here
    indep = np.setdiff1d(np.arange(split.latent.size), dep)
    basis = np.zeros((split.latent.size, indep.size))
    basis[indep] = np.eye(indep.size)
    basis[dep] = -np.linalg.solve(a[:, dep], a[:, indep])
    return j @ basis, basis


def dense_marginal_objective(nlp: Nlp, theta: np.ndarray, z_start: np.ndarray, log_det_only: bool = False) -> float:
    """F(theta) computed densely: for fixed theta the defects are linear in (x, w) and so are the
    residuals, so the inner problem is linear least squares over u = u_p + Z v (u_p: zero
    independent coordinates, the states propagated by the defects); plus 1/2 log det(Z^T J_u^T J_u Z)
    (that term alone with ``log_det_only``)."""
    z = z_start.copy()
    z[-2:] = theta
    z[:-2] = 0.0
    dep = nlp.dependent
    c0 = nlp.derivatives.constraints(z)
    a = nlp.derivatives.jacobian_g(z).toarray()
    z[dep] = -np.linalg.solve(a[:, dep], c0)
    jz, basis = dense_latent(nlp, z)
    v = np.linalg.lstsq(jz, -nlp.residual_vector(z), rcond=None)[0]
    z[:-2] += basis @ v
    assert np.abs(nlp.derivatives.constraints(z)).max() < 1e-10
    r = nlp.residual_vector(z)
    sign, log_det = np.linalg.slogdet(jz.T @ jz)
    assert sign > 0
    return 0.5 * log_det if log_det_only else 0.5 * float(r @ r) + 0.5 * log_det


def map_fit(seed: int) -> tuple[Nlp, np.ndarray]:
    nlp = driven_nlp(seed)
    z0 = np.zeros(nlp.n_z)
    z0[-2:] = (0.3, 0.5)
    sol = solve(nlp, z0)
    assert sol.converged, sol.status
    return nlp, sol.z


def test_sparse_log_det_equals_the_dense_one():
    nlp, z = map_fit(1)
    z = z + 0.01 * np.random.default_rng(0).normal(size=z.size)  # anywhere, not only at the optimum
    jz, _ = dense_latent(nlp, z)
    sign, log_det = np.linalg.slogdet(jz.T @ jz)
    assert sign > 0
    assert half_log_det(nlp, z) == pytest.approx(0.5 * log_det, rel=1e-10, abs=1e-8)


def test_inner_solve_reaches_the_dense_inner_minimum():
    nlp, z = map_fit(2)
    held = z.copy()
    held[-2:] = (0.7, 1.3)
    inner = solve_latent(nlp, LatentSplit.of(nlp), held)
    assert inner.converged
    f_dense = dense_marginal_objective(nlp, held[-2:], z)
    f_sparse = 0.5 * float(inner.kkt.r @ inner.kkt.r) + 0.5 * inner.kkt.log_det
    assert f_sparse == pytest.approx(f_dense, abs=1e-3)


@pytest.mark.parametrize("seed", [3, 4])
def test_marginal_estimate_is_the_minimum_of_the_dense_marginal_objective(seed):
    nlp, z_map = map_fit(seed)
    run = maximise_marginal(nlp, z_map)
    assert run.converged, run.status
    best = minimize(lambda t: dense_marginal_objective(nlp, t, z_map), run.z[-2:], method="Nelder-Mead",
                    options={"xatol": 1e-7, "fatol": 1e-9})
    cov = covariance_or_fail(nlp, run.z, nlp.residual_vector(run.z))
    sigma = np.sqrt(np.diag(cov.covariance_of(np.array([nlp.n_z - 2, nlp.n_z - 1]))))
    assert np.all(np.abs(run.z[-2:] - best.x) / sigma < 0.05), (run.z[-2:], best.x, sigma)
    assert run.shift_sigma > 0.5  # the MAP estimate really was somewhere else


def test_marginal_removes_the_map_bias_of_the_gain():
    """Across 40 seeds the joint MAP's gain is biased upward by 2.5 sigma on average; the marginal's mean
    normalised error is within 3 standard errors of zero."""
    z_map, z_marginal = [], []
    for seed in range(10, 50):
        nlp, z = map_fit(seed)
        run = maximise_marginal(nlp, z)
        assert run.converged, run.status
        for zz, out in ((z, z_map), (run.z, z_marginal)):
            cov = covariance_or_fail(nlp, zz, nlp.residual_vector(zz))
            out.append((zz[-1] - TRUTH[1]) / np.sqrt(cov.covariance_of(np.array([nlp.n_z - 1]))[0, 0]))
    print("MAP z", np.round(z_map, 2), "marginal z", np.round(z_marginal, 2))
    assert np.mean(z_map) > 1.5, z_map
    assert abs(np.mean(z_marginal)) < 3 * np.std(z_marginal) / np.sqrt(len(z_marginal)), z_marginal


def test_log_det_curvature_matches_the_dense_log_det_hessian():
    """L (the curvature the estimator leaves out of the parameter covariance) against central
    differences of the dense 1/2 log det along the inner optimum."""
    nlp, z_map = map_fit(3)
    run = maximise_marginal(nlp, z_map)
    cur = log_det_curvature(nlp, run.z)
    theta = run.z[-2:]
    sigma = np.sqrt(np.diag(np.linalg.inv(cur.profile_hessian)))
    h = 0.05 * sigma

    def g(t):
        return dense_marginal_objective(nlp, t, run.z, log_det_only=True)

    dense = np.zeros((2, 2))
    for i in range(2):
        for j in range(2):
            ei, ej = np.eye(2)[i] * h[i], np.eye(2)[j] * h[j]
            dense[i, j] = (g(theta + ei + ej) - g(theta + ei - ej) - g(theta - ei + ej) + g(theta - ei - ej)) / (
                4 * h[i] * h[j])
    scale = np.outer(sigma, sigma)  # compare in sigma units, where P is the identity
    assert np.max(np.abs(cur.log_det_hessian - dense) * scale) < 0.05 * max(np.max(np.abs(dense) * scale), 1e-3)


def test_outer_stop_on_a_short_step_or_a_stalled_objective():
    """The outer iteration ends at an inner optimum on a Newton step under STEP_TOL, or, once F has
    stopped moving for two accepted steps, on one under STALL_STEP_TOL; never before an inner optimum."""
    assert outer_stop(0.5 * STEP_TOL, 0, True).startswith("Converged (marginal likelihood; Newton step")
    assert outer_stop(0.5 * STEP_TOL, 0, False) is None
    assert outer_stop(0.1, 1, True) is None                      # one stalled step is not enough
    assert "F stationary: the last 2 Newton steps" in outer_stop(0.1, 2, True)
    assert outer_stop(1.5 * STALL_STEP_TOL, 5, True) is None      # too long a step is a real distance
    assert outer_stop(0.1, 2, False) is None
