"""The null-space Gauss-Newton solver against Ipopt on a small collocation problem: a damped
pendulum whose frequency and damping are fitted to noisy angles, the node states fixed by
trapezoidal defects (so the null space is the initial state and the two parameters)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from casrecon.estimation.engine import gauss_newton
from casrecon.estimation.engine import solve as solve_module
from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.engine.checks import covariance_or_fail
from casrecon.estimation.engine.nlp import Nlp, assemble_nlp
from casrecon.estimation.engine.solve import solve

N_NODES = 60
STEP_S = 0.05
SIGMA = 0.01
TRUTH = (4.0, 0.3)  # omega0^2 (1/s^2), damping (1/s)


def pendulum(x, p):
    return ca.vertcat(x[1], -p[0] * ca.sin(x[0]) - p[1] * x[1])


def pendulum_nlp(seed: int = 0, staged: bool = False) -> tuple[Nlp, np.ndarray, np.ndarray]:
    """(NLP, the noise-free states (N, 2), the noisy angles) of a pendulum released at 1.2 rad;
    ``staged``: with each state's node (:attr:`Nlp.stages`), for the full-space solver.

    z = [theta_k, omega_k for every node, omega0^2, damping]."""
    f = ca.Function("f", [x := ca.SX.sym("x", 2), p := ca.SX.sym("p", 2)], [pendulum(x, p)])
    states = [np.array([1.2, 0.0])]
    for _ in range(N_NODES - 1):  # a fine RK4 truth
        x = states[-1]
        for _ in range(10):
            h = STEP_S / 10
            k1 = np.asarray(f(x, TRUTH)).ravel()
            k2 = np.asarray(f(x + h / 2 * k1, TRUTH)).ravel()
            k3 = np.asarray(f(x + h / 2 * k2, TRUTH)).ravel()
            k4 = np.asarray(f(x + h * k3, TRUTH)).ravel()
            x = x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        states.append(x)
    states = np.array(states)
    angles = states[:, 0] + SIGMA * np.random.default_rng(seed).normal(size=N_NODES)
    n_z = 2 * N_NODES + 2
    local, y = ca.SX.sym("v", 6), ca.SX.sym("y")
    xa, xb, prm = local[0:2], local[2:4], local[4:6]
    defect = xb - xa - STEP_S / 2 * (pendulum(xa, prm) + pendulum(xb, prm))
    interval = BlockKind("interval", local, [y], (y - xb[0]) / SIGMA, defect)
    cols = np.array([[2 * k, 2 * k + 1, 2 * k + 2, 2 * k + 3, n_z - 2, n_z - 1] for k in range(N_NODES - 1)])
    first_local, y0 = ca.SX.sym("v0", 1), ca.SX.sym("y0")
    first = BlockKind("first", first_local, [y0], (y0 - first_local[0]) / SIGMA, None)
    terms = [Term("angles", (BlockSet(interval, cols, [ca.DM(angles[1:]).T]),)),
             Term("angle0", (BlockSet(first, np.array([[0]]), [ca.DM(angles[0])]),))]
    stages = np.r_[np.repeat(np.arange(N_NODES), 2), -1, -1] if staged else None
    nlp = assemble_nlp(terms, n_z, dependent=np.arange(2, 2 * N_NODES), parameter_names={n_z - 2: "w2", n_z - 1: "c"},
                       stages=stages)
    return nlp, states, angles


def start_from(angles: np.ndarray, params) -> np.ndarray:
    """A poor start: the measured angles, zero rates, the given parameters."""
    z0 = np.zeros(2 * N_NODES + 2)
    z0[0:-2:2] = angles
    z0[-2:] = params
    return z0


def test_gauss_newton_is_the_default_and_matches_ipopt():
    nlp, _, angles = pendulum_nlp()
    assert gauss_newton.applies(nlp)
    z0 = start_from(angles, (2.0, 1.0))  # frequency 30 % off, damping 3x
    gn = solve(nlp, z0)
    ip = solve(nlp, z0, method="ipopt", tol=1e-10)
    assert gn.method == "gauss-newton" and gn.converged, gn.status
    assert ip.method == "ipopt" and ip.converged
    cov = covariance_or_fail(nlp, gn.z, nlp.residual_vector(gn.z), gn.reduced)
    sigma = np.sqrt(np.diag(cov.covariance_of(np.arange(nlp.n_z))))
    assert np.max(np.abs(gn.z - ip.z) / sigma) < 1e-3
    assert np.abs(nlp.derivatives.constraints(gn.z)).max() < 1e-8
    # the reduced system handed to the covariance was formed at the solution
    fresh = covariance_or_fail(nlp, gn.z, nlp.residual_vector(gn.z))
    assert cov.covariance_of([nlp.n_z - 2]) == pytest.approx(fresh.covariance_of([nlp.n_z - 2]), rel=1e-10)


def test_truth_within_three_sigma_across_seeds():
    nees = []
    for seed in range(8):
        nlp, _, angles = pendulum_nlp(seed)
        sol = solve(nlp, start_from(angles, (3.0, 0.5)))
        assert sol.method == "gauss-newton" and sol.converged
        cov = covariance_or_fail(nlp, sol.z, nlp.residual_vector(sol.z), sol.reduced).covariance_of([nlp.n_z - 2,
                                                                                                   nlp.n_z - 1])
        err = sol.z[-2:] - np.array(TRUTH)
        nees.append(float(err @ np.linalg.solve(cov, err)))
    # 8 seeds x 2 dof (the trapezoid rule's bias at 50 ms is far below the sigmas): chi2(16) 99.9 % point 39.3
    assert sum(nees) < 39.3


def test_a_bound_is_held_like_ipopt_holds_it():
    nlp, _, angles = pendulum_nlp()
    lo, hi = np.full(nlp.n_z, -np.inf), np.full(nlp.n_z, np.inf)
    hi[-1] = 0.2  # the damping (truth 0.3) may not exceed 0.2
    z0 = start_from(angles, (3.0, 0.1))
    gn = solve(nlp, z0, bounds=(lo, hi))
    ip = solve(nlp, z0, bounds=(lo, hi), method="ipopt", tol=1e-10)
    assert gn.method == "gauss-newton" and gn.converged, gn.status
    assert gn.z[-1] == pytest.approx(0.2, abs=1e-12)
    assert gn.z[-2] == pytest.approx(ip.z[-2], abs=1e-5)


def test_an_unconverged_gauss_newton_run_is_finished_by_ipopt(monkeypatch):
    nlp, _, angles = pendulum_nlp()
    monkeypatch.setattr(solve_module, "GAUSS_NEWTON_MAX_ITER", 1)
    sol = solve(nlp, start_from(angles, (2.0, 1.0)))
    assert sol.method == "gauss-newton, then ipopt"
    assert sol.converged and "iteration limit" in sol.status
    ip = solve(nlp, start_from(angles, (2.0, 1.0)), method="ipopt")
    assert sol.z[-2:] == pytest.approx(ip.z[-2:], abs=1e-5)


def test_a_latent_or_exact_hessian_nlp_goes_to_ipopt():
    nlp, _, angles = pendulum_nlp()
    exact = assemble_nlp([], 0, dependent=np.zeros(0, int), parameter_names={}, hessian="exact")
    assert not gauss_newton.applies(exact)
    with pytest.raises(ValueError, match="expected one of"):
        solve(nlp, start_from(angles, TRUTH), method="newton")


def test_the_full_space_solver_takes_the_same_steps(monkeypatch):
    """With more free directions than the null-space solver takes (here: none allowed) and nodes to
    order its KKT matrix by, the same Gauss-Newton iteration is solved in the full space: the same
    optimum, the constraints met, the multipliers those of the null-space solver."""
    nlp, _, angles = pendulum_nlp(staged=True)
    z0 = start_from(angles, (2.0, 1.0))
    reference = solve(nlp, z0)
    monkeypatch.setattr(gauss_newton, "MAX_REDUCED", 0)
    assert not gauss_newton.applies(nlp) and solve_module.full_space_applies(nlp)
    full = solve(nlp, z0)
    assert full.method == "gauss-newton (full space)" and full.converged, full.status
    assert full.linear_solver == "superlu (time-ordered KKT)"
    cov = covariance_or_fail(nlp, reference.z, nlp.residual_vector(reference.z), reference.reduced)
    sigma = np.sqrt(np.diag(cov.covariance_of(np.arange(nlp.n_z))))
    assert np.max(np.abs(full.z - reference.z) / sigma) < 1e-2
    assert np.abs(nlp.derivatives.constraints(full.z)).max() <= 1e-8
    np.testing.assert_allclose(full.lam_g, reference.lam_g, rtol=1e-3, atol=1e-6 * np.abs(reference.lam_g).max())
    # without nodes the NLP goes to Ipopt, as before
    plain, _, _ = pendulum_nlp()
    assert not solve_module.full_space_applies(plain)
    assert solve(plain, z0).method == "ipopt"


def test_the_full_space_solver_holds_a_bound_like_the_null_space_one(monkeypatch):
    """The same optimum within 0.01 sigma (the full-space solver stops at a decrement of 1e-3, the
    null-space one at 1e-6: within 0.03 and 0.001 sigma of the optimum), the bound held exactly."""
    nlp, _, angles = pendulum_nlp(staged=True)
    lo, hi = np.full(nlp.n_z, -np.inf), np.full(nlp.n_z, np.inf)
    hi[-1] = 0.2  # the damping (truth 0.3) may not exceed 0.2
    z0 = start_from(angles, (3.0, 0.1))
    reference = solve(nlp, z0, bounds=(lo, hi))
    monkeypatch.setattr(gauss_newton, "MAX_REDUCED", 0)
    full = solve(nlp, z0, bounds=(lo, hi))
    assert full.method == "gauss-newton (full space)" and full.converged, full.status
    assert full.z[-1] == pytest.approx(0.2, abs=1e-12)
    assert np.abs(nlp.derivatives.constraints(full.z)).max() <= 1e-8
    cov = covariance_or_fail(nlp, reference.z, nlp.residual_vector(reference.z), reference.reduced)
    sigma = np.sqrt(cov.covariance_of(np.array([nlp.n_z - 2]))[0, 0])
    assert abs(full.z[-2] - reference.z[-2]) < 1e-2 * sigma


@pytest.mark.parametrize("full_space", [False, True])
def test_the_decrement_tolerance_reaches_the_stop_test(monkeypatch, full_space):
    """``decrement_tol`` (the default path's first fit stops at a looser one) is the test's: a looser
    one never stops later and leaves a decrement at most it (here the constraints, not the
    decrement, set the last iteration: the same iterate); one no step can meet (negative) leaves
    the Gauss-Newton solver unconverged and Ipopt finishes, as for any such run."""
    nlp, _, angles = pendulum_nlp(staged=True)
    if full_space:
        monkeypatch.setattr(gauss_newton, "MAX_REDUCED", 0)
    method = "gauss-newton (full space)" if full_space else "gauss-newton"
    z0 = start_from(angles, (2.0, 1.0))
    tight = solve(nlp, z0)
    loose = solve(nlp, z0, decrement_tol=1.0)
    assert tight.method == loose.method == method and loose.converged and tight.converged
    assert loose.decrement <= 1.0 and loose.iterations <= tight.iterations
    never = solve(nlp, z0, decrement_tol=-1.0)
    assert never.method == f"{method}, then ipopt" and never.converged
    assert never.z[-2:] == pytest.approx(tight.z[-2:], abs=1e-4)
