"""The parameters' Laplace-approximated marginal likelihood, sparse, and the estimator that maximises it.

Notation (scaled z): theta the parameter columns (``Nlp.parameter_names``), u the others (node
states, disturbance values, atmosphere-profile and GPS-error values). Phi(z) = 1/2 |r(z)|^2 and
c(z) = 0 the constraints, whose determining rows (collocation defects) fix the dependent state
columns D given the others. The joint MAP fit minimises Phi over (u, theta). Integrating u out
instead (Laplace, with the Gauss-Newton Hessian) gives the negative log marginal likelihood

    F(theta) = Phi(u*(theta), theta) + 1/2 log det(Z^T H_uu Z) + const,

u*(theta) the constrained minimiser of Phi with theta held, H_uu = J_u^T J_u, and Z = [-A_D^-1 A_I N; N]
the latent directions in independent coordinates (the disturbance and first-node values whose prior
densities are in r; N an orthonormal basis of the side constraints' null space). The log-determinant
is read from two sparse LU factorisations, never from a dense latent matrix:

    log det(Z^T H_uu Z) = log|det K| - 2 log|det A_D| - log det(A_S A_S^T),   K = [[H_uu, A_u^T], [A_u, 0]],

(transform the columns by [[I, -A_D^-1 A_I], [0, I]], whose determinant is 1, and the KKT
determinant factorises into the constraint blocks and the reduced Hessian). The joint MAP lacks the
second term; when a parameter scales the disturbances' effect (a slope multiplier times a
gust-induced angle of attack, the aero factors under a wind-profile error) that biases it.

:func:`maximise_marginal` minimises F from the joint MAP by Newton steps in theta:

- gradient: the envelope term d Phi*/d theta = J_theta^T (r + J_u du) + A_theta^T lambda from a
  Gauss-Newton step of the inner problem, plus the log-determinant's total derivative by forward
  differences along the tangent (du*/dtheta, e_k) of the inner optimum (du*/dtheta from K);
- Hessian: the profile's Gauss-Newton Hessian P = H_tt - [H_tu, A_t^T] K^-1 [H_ut; A_t] (its
  inverse is the parameter block of the KKT covariance); the log-determinant's curvature is left out;
- a backtracking line search on F, each trial re-solving u with theta held by a sparse
  Gauss-Newton iteration on K (:func:`solve_latent`); a trial whose inner solve stopped short is
  still accepted when it passes (its Phi, hence F, is an upper bound), and the iteration stops only
  at an inner optimum: when the Newton step is under STEP_TOL, or under STALL_STEP_TOL once F has
  stopped moving (see there).
"""

from __future__ import annotations

import dataclasses
import logging
import time
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps
from scipy.sparse.linalg import splu

from casrecon.estimation.engine import convergence
from casrecon.estimation.engine.checks import FitError
from casrecon.estimation.engine.gauss_newton import line_search
from casrecon.estimation.engine.nlp import Nlp
from casrecon.estimation.engine.solve import SolveResult
from casrecon.estimation.engine.submatrix import gathered, index_key, pattern_key, sorted_csc, submatrix
from casrecon.parallel import Forked, single_threaded_blas, spare_core

LOG = logging.getLogger(__name__)

#: The outer iteration stops when its Newton step in theta is shorter than this, in the Mahalanobis
#: norm of the parameter covariance: 0.05 sigma, whose predicted decrease of F (1.2e-3) is at the level
#: of the inner solves' tolerance.
STEP_TOL = 0.05
#: A longer Newton step still ends the outer iteration when it is at most this long (sigma) and
#: F has stopped moving: the last STALLED_STEPS accepted steps each lowered F by less than
#: STALL_FRACTION of the decrease their quadratic model predicted (0.5 length^2). The remaining step
#: is then the error of the gradient (the log-determinant's forward differences, the inner solves'
#: tolerance), not a distance to the optimum: on two whole-drop gust fits on a 12.5 ms mesh the
#: step stayed at 0.075 and 0.1 sigma for 13 Newton steps while F changed by 1e-5 in all.
STALL_STEP_TOL = 0.25
#: See STALL_STEP_TOL.
STALL_FRACTION = 0.1
#: See STALL_STEP_TOL.
STALLED_STEPS = 2
#: Outer (Newton in theta) iterations allowed.
MAX_OUTER = 15
#: Inner (Gauss-Newton in u, theta held) iterations allowed per outer trial point.
MAX_INNER = 30
#: The inner iteration's stopping test: predicted chi-square decrease of one more Gauss-Newton step
#: at most :data:`.convergence.DECREMENT_TOL` (within 0.03 sigma of the inner optimum; F is then
#: within 5e-4 of its value there) with the constraints met to INNER_FEASIBILITY_TOL. With latent
#: values at every node the Gauss-Newton iteration converges linearly (the residuals' curvature is
#: not small against J^T J in the weakly determined latent directions), so the 1e-8 of the fit's
#: own test would cost tens of iterations for nothing F or the estimate can see (Ipopt's own
#: default constraint tolerance is 1e-4). The constraints are met to 1e-9, not less: F at a point
#: whose defects are 7e-7 was 0.01 below F at the same point made feasible (a whole-drop gust fit
#: on a 12.5 ms mesh), more than a 0.05-sigma step's decrease, so the outer line search compared
#: values of unequal accuracy and failed. Restoring feasibility converges quadratically: at most
#: one more inner step.
INNER_FEASIBILITY_TOL = 1e-9
#: Forward-difference step of the log-determinant's derivative along each parameter's tangent, as
#: a fraction of that parameter's sigma.
FD_FRACTION = 0.02
#: Smallest outer step length tried.
MIN_OUTER_STEP = 1.0 / 64


@dataclass(frozen=True)
class LatentSplit:
    """Which z columns are parameters (``theta``) and which are latent (``latent``), both sorted."""

    theta: np.ndarray
    latent: np.ndarray

    @staticmethod
    def of(nlp: Nlp) -> LatentSplit:
        """theta: the columns of ``nlp.parameter_names``; latent: every other column."""
        theta = nlp.parameter_columns
        return LatentSplit(theta, np.setdiff1d(np.arange(nlp.n_z), theta))


class LatentKkt:
    """The latent KKT matrix K at one z, factorised, with what the estimator reads from it.

    Attributes
    ----------
    z, r, c : arrays
        The point (scaled), its whitened residuals and constraint values.
    jr : scipy.sparse.csc_matrix
        The residuals' Jacobian (all columns).
    a : scipy.sparse.csc_matrix
        The constraints' Jacobian (all columns).
    log_det : float
        log det(Z^T H_uu Z) (see the module docstring).
    """

    def __init__(self, nlp: Nlp, split: LatentSplit, z: np.ndarray) -> None:
        d = nlp.derivatives
        self.split, self.z = split, np.asarray(z, float).copy()
        self.lu, self.order, self.log_det, self.a = _latent_factor(nlp, split, self.z)
        self.r, self.c = d.residuals(self.z).copy(), d.constraints(self.z).copy()
        self.jr = d.jacobian_r(self.z).tocsc()
        self.j_u = self.jr[:, split.latent]
        self.n_u = split.latent.size

    def solve(self, rhs_u: np.ndarray, rhs_c: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(du, lambda) with H_uu du + A_u^T lambda = rhs_u, A_u du = rhs_c (columns allowed)."""
        y = self.lu.solve(np.concatenate([rhs_u, rhs_c]))
        x = np.empty_like(y)
        x[self.order] = y  # the factorised matrix is K[:, order]
        return x[:self.n_u], x[self.n_u:]

    def inner_step(self) -> tuple[np.ndarray, np.ndarray, float]:
        """The Gauss-Newton step of the inner problem (theta held): (du, lambda, predicted chi-square
        decrease, i.e. twice the model's decrease of Phi)."""
        g_u = self.j_u.T @ self.r
        du, lam = self.solve(-g_u, -self.c)
        jdu = self.j_u @ du
        return du, lam, -2.0 * float(g_u @ du) - float(jdu @ jdu)

    def profile(self, du: np.ndarray, lam: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(gradient G, Hessian P, tangent du*/dtheta (n_u, n_theta)) of the profile Phi*(theta):
        G = J_t^T (r + J_u du) + A_t^T lambda for the inner step (du, lambda); P and the tangent
        from K (see the module docstring)."""
        j_t = self.jr[:, self.split.theta]
        a_t = self.a[:, self.split.theta]
        h_ut = (self.j_u.T @ j_t).toarray()
        a_t_dense = a_t.toarray()
        tangent, mult = self.solve(-h_ut, -a_t_dense)
        p = (j_t.T @ j_t).toarray() + h_ut.T @ tangent + a_t_dense.T @ mult
        g = j_t.T @ (self.r + self.j_u @ du) + a_t.T @ lam
        return np.asarray(g).ravel(), 0.5 * (p + p.T), tangent


def latent_kkt_matrix(h_upper: sps.spmatrix, a: sps.spmatrix, latent: np.ndarray) -> sps.csc_matrix:
    """K = [[H_uu, A_u^T], [A_u, 0]] from the upper triangle of the Gauss-Newton Hessian and the
    constraint Jacobian (all columns), by one gather of their nonzeros per pattern
    (:func:`.submatrix.gathered`: 10 ms instead of 0.14 s of products and stacking on a whole
    ees-drop-3 gust fit)."""

    def build(h: sps.csc_matrix, jac: sps.csc_matrix) -> sps.csc_matrix:
        h_full = (h + sps.triu(h, 1).T).tocsc()
        a_u = jac[:, latent]
        return sps.bmat([[h_full[latent][:, latent], a_u.T], [a_u, None]], format="csc")

    return gathered(build, h_upper, a, key=("latent kkt", index_key(latent)))


#: Column orders of latent KKT patterns already factorised (pattern key -> order).
_COLUMN_ORDERS: dict[tuple, np.ndarray] = {}


def _column_order(kkt: sps.csc_matrix) -> np.ndarray:
    """SuperLU's COLAMD column order of ``kkt``'s pattern (worked out once per pattern: the
    ordering is a third of a factorisation's time, and the pattern is the same at every point)."""
    key = pattern_key(sorted_csc(kkt))
    if key not in _COLUMN_ORDERS:
        perm_c = splu(kkt).perm_c
        order = np.empty_like(perm_c)
        order[perm_c] = np.arange(perm_c.size)
        if len(_COLUMN_ORDERS) >= 8:
            del _COLUMN_ORDERS[next(iter(_COLUMN_ORDERS))]
        _COLUMN_ORDERS[key] = order
    return _COLUMN_ORDERS[key]


def _latent_factor(nlp: Nlp, split: LatentSplit, z: np.ndarray) -> tuple[object, np.ndarray, float, sps.csc_matrix]:
    """(SuperLU of K[:, order], order, log det(Z^T H_uu Z), the constraint Jacobian) at ``z``
    (scaled): what the log-determinant needs and no more (no residual Jacobian)."""
    d = nlp.derivatives
    a = d.jacobian_g(z).tocsc()
    u = split.latent
    if nlp.n_g and np.any(np.diff(submatrix(a, slice(None), u).tocsr().indptr) == 0):
        raise ValueError("a constraint involves parameters only: the latent KKT matrix is singular")
    kkt = latent_kkt_matrix(d.gauss_newton(z), a, u)
    order = _column_order(kkt)
    lu = splu(submatrix(kkt, slice(None), order), permc_spec="NATURAL")
    a_d = submatrix(a, slice(0, nlp.n_determining), nlp.dependent)
    log_det = _log_abs_det(lu) - 2.0 * _log_abs_det(splu(a_d)) - _side_log_det(
        submatrix(a, slice(nlp.n_determining, nlp.n_g), u))
    return lu, order, log_det, a


def _log_abs_det(lu) -> float:
    """log |det| of a SuperLU-factorised matrix (L has a unit diagonal)."""
    return float(np.sum(np.log(np.abs(lu.U.diagonal()))))


def _side_log_det(a_side: sps.spmatrix) -> float:
    """log det(A_S A_S^T) of the side constraints' rows (0 without side constraints)."""
    if a_side.shape[0] == 0:
        return 0.0
    return _log_abs_det(splu((a_side @ a_side.T).tocsc()))


def half_log_det(nlp: Nlp, z: np.ndarray, split: LatentSplit | None = None) -> float:
    """1/2 log det(Z^T H_uu Z) at ``z`` (scaled): the term the marginal likelihood adds to Phi."""
    return 0.5 * _latent_factor(nlp, split or LatentSplit.of(nlp), np.asarray(z, float))[2]


@dataclass(frozen=True)
class LatentSolve:
    """What :func:`solve_latent` ends with: the iterate's factorised KKT, whether it converged,
    the iterations and the predicted chi-square decrease of one more step."""

    kkt: LatentKkt
    converged: bool
    iterations: int
    decrement: float
    lam: np.ndarray
    du: np.ndarray


def solve_latent(nlp: Nlp, split: LatentSplit, z0: np.ndarray, max_iter: int = MAX_INNER,
                 feasibility_tol: float = INNER_FEASIBILITY_TOL,
                 decrement_tol: float = convergence.DECREMENT_TOL) -> LatentSolve:
    """Minimise Phi over the latent columns with theta held at ``z0[split.theta]``: sparse
    Gauss-Newton steps from K with an l1-merit line search. Converged when the constraints are met
    to ``feasibility_tol`` and the predicted chi-square decrease is at most ``decrement_tol``."""
    z, nu = np.asarray(z0, float).copy(), 0.0
    no_bounds = (np.zeros(0, np.int64), np.zeros(0), np.zeros(0))
    for iteration in range(max_iter + 1):
        kkt = LatentKkt(nlp, split, z)
        du, lam, predicted = kkt.inner_step()
        violation = float(np.abs(kkt.c).max()) if kkt.c.size else 0.0
        LOG.debug("inner iteration %d: chi-square %.10g, violation %.2g, predicted decrease %.3g", iteration,
                  float(kkt.r @ kkt.r), violation, predicted)
        if violation <= feasibility_tol and predicted <= decrement_tol:
            return LatentSolve(kkt, True, iteration, predicted, lam, du)
        if iteration == max_iter:
            break
        dz = np.zeros(nlp.n_z)
        dz[split.latent] = du
        grad = np.asarray(kkt.jr.T @ kkt.r).ravel()
        grad[split.theta] = 0.0

        def correct(c_trial: np.ndarray, kkt=kkt) -> np.ndarray:
            out = np.zeros(nlp.n_z)
            out[split.latent] = kkt.solve(np.zeros(kkt.n_u), -c_trial)[0]
            return out

        z_new, nu, _ = line_search(nlp, z, kkt.r, kkt.c, grad, kkt.jr, dz, nu, no_bounds, correct)
        if z_new is None:
            break
        z = z_new
    return LatentSolve(kkt, False, iteration, predicted, lam, du)


@dataclass(frozen=True)
class MarginalRun:
    """What :func:`maximise_marginal` ends with.

    Attributes
    ----------
    z : array
        The marginal-likelihood estimate (scaled): theta at the maximum, u at its inner optimum.
    lam_g : array
        Constraint multipliers at z.
    objective : float
        Phi at z (half the chi-square of the unknown-dependent rows).
    half_log_det : float
        1/2 log det(Z^T H_uu Z) at z.
    converged : bool
    status : str
    outer_iterations, inner_iterations : int
    shift_sigma : float
        Mahalanobis length of theta's move from the joint MAP (in parameter sigmas).
    gradient_s, inner_s : float
        Seconds spent on the log-determinant's gradient and on the inner solves.
    """

    z: np.ndarray
    lam_g: np.ndarray
    objective: float
    half_log_det: float
    converged: bool
    status: str
    outer_iterations: int
    inner_iterations: int
    shift_sigma: float
    gradient_s: float
    inner_s: float


def _log_det_gradient(nlp: Nlp, split: LatentSplit, kkt: LatentKkt, tangent: np.ndarray,
                      sigma: np.ndarray) -> np.ndarray:
    """d/dtheta_k of 1/2 log det(Z^T H_uu Z) at ``kkt.z`` along the inner optimum's tangent
    (du*/dtheta_k, e_k), by forward differences of step FD_FRACTION sigma_k (one factorisation per
    parameter; the truncation error moves the estimate by about FD_FRACTION / 2 times the
    log-determinant's curvature in sigma units, well under the stopping tolerance). With a spare
    core (:func:`casrecon.parallel.spare_core`) a forked child differences every other parameter
    (the same numbers: each difference is its own factorisation)."""

    def differences(ks: np.ndarray) -> np.ndarray:
        out = np.zeros(ks.size)
        for i, k in enumerate(ks):
            h = FD_FRACTION * sigma[k]
            d = np.zeros(nlp.n_z)
            d[split.latent] = tangent[:, k]
            d[split.theta[k]] = 1.0
            out[i] = (half_log_det(nlp, kkt.z + h * d, split) - 0.5 * kkt.log_det) / h
        return out

    ks = np.arange(split.theta.size)
    gradient = np.zeros(ks.size)
    if ks.size > 1 and spare_core():
        child = Forked(lambda: differences(ks[1::2]))
        gradient[0::2] = differences(ks[0::2])
        gradient[1::2] = child.result()
    else:
        gradient[:] = differences(ks)
    return gradient


@dataclass(frozen=True)
class LogDetCurvature:
    """The curvature the marginal estimator leaves out, at one point (scaled units).

    Attributes
    ----------
    profile_hessian : (p, p) array
        P, the profile's Gauss-Newton Hessian (its inverse is the reported parameter covariance).
    log_det_hessian : (p, p) array
        L, the Hessian of 1/2 log det(Z^T H_uu Z) along the inner optimum, by forward differences
        of :func:`_log_det_gradient` (symmetrised).
    tangent : (n_u, p) array
        du*/dtheta, the inner optimum's tangent.
    """

    profile_hessian: np.ndarray
    log_det_hessian: np.ndarray
    tangent: np.ndarray


@single_threaded_blas()
def log_det_curvature(nlp: Nlp, z: np.ndarray, step_sigma: float = 0.1) -> LogDetCurvature:
    """P and L at ``z`` (scaled; the marginal estimate), L from gradients at steps of
    ``step_sigma`` parameter sigmas along each parameter's tangent: p + 1 gradients of p
    factorisations each (about a minute on a whole ees-drop-3 gust fit). A diagnostic of what
    leaving L out of the parameter covariance costs; not part of a fit."""
    split = LatentSplit.of(nlp)

    def at(point: np.ndarray) -> tuple[LatentKkt, np.ndarray, np.ndarray]:
        kkt = LatentKkt(nlp, split, point)
        du, lam, _ = kkt.inner_step()
        _, p, tangent = kkt.profile(du, lam)
        return kkt, p, tangent

    kkt, p, tangent = at(np.asarray(z, float))
    sigma = np.sqrt(np.diag(np.linalg.inv(p)))
    g0 = _log_det_gradient(nlp, split, kkt, tangent, sigma)
    curvature = np.zeros_like(p)
    for k in range(split.theta.size):
        h = step_sigma * sigma[k]
        direction = np.zeros(nlp.n_z)
        direction[split.latent] = tangent[:, k]
        direction[split.theta[k]] = 1.0
        kkt_k, _, tangent_k = at(kkt.z + h * direction)
        curvature[:, k] = (_log_det_gradient(nlp, split, kkt_k, tangent_k, sigma) - g0) / h
    return LogDetCurvature(p, 0.5 * (curvature + curvature.T), tangent)


def outer_stop(length: float, stalled: int, inner_converged: bool) -> str | None:
    """The status that ends the outer iteration, or None to go on: at an inner optimum, a Newton
    step of ``length`` (sigma) under STEP_TOL, or under STALL_STEP_TOL after ``stalled`` (at least
    STALLED_STEPS) accepted steps that each lowered F by less than STALL_FRACTION of their
    prediction."""
    if not inner_converged:
        return None
    if length <= STEP_TOL:
        return f"Converged (marginal likelihood; Newton step {length:.2g} sigma)"
    if stalled >= STALLED_STEPS and length <= STALL_STEP_TOL:
        return (f"Converged (marginal likelihood; F stationary: the last {stalled} Newton steps lowered it by less "
                f"than {STALL_FRACTION:g} of their prediction; the remaining step, {length:.2g} sigma, is within "
                "the gradient's accuracy)")
    return None


@single_threaded_blas()
def maximise_marginal(nlp: Nlp, z_map: np.ndarray, bounds: tuple[np.ndarray, np.ndarray] | None = None
                      ) -> MarginalRun:
    """Maximise the Laplace marginal likelihood of the parameters from the joint MAP estimate ``z_map``
    (scaled), see the module docstring; ``bounds`` (scaled lower, upper over z) clip theta.

    Returns the last iterate whether or not it converged (``converged`` and ``status`` say why)."""
    split = LatentSplit.of(nlp)
    lo, hi = (np.full(nlp.n_z, -np.inf), np.full(nlp.n_z, np.inf)) if bounds is None else (
        np.broadcast_to(np.asarray(b, float), (nlp.n_z,)) for b in bounds)
    theta = split.theta
    t0 = time.perf_counter()
    inner = solve_latent(nlp, split, z_map)
    inner_s, gradient_s, n_inner = time.perf_counter() - t0, 0.0, inner.iterations
    status, converged = "outer iteration limit reached", False
    outer, stalled, predicted = 0, 0, 0.0
    f_previous = None
    for outer in range(MAX_OUTER + 1):
        kkt = inner.kkt
        g_env, p, tangent = kkt.profile(inner.du, inner.lam)
        cov = np.linalg.inv(p)
        sigma = np.sqrt(np.diag(cov))
        t1 = time.perf_counter()
        grad = g_env + _log_det_gradient(nlp, split, kkt, tangent, sigma)
        gradient_s += time.perf_counter() - t1
        step = -cov @ grad
        length = float(np.sqrt(step @ p @ step))
        f0 = 0.5 * float(kkt.r @ kkt.r) + 0.5 * kkt.log_det
        LOG.info("marginal likelihood: outer iteration %d, F %.10g, Newton step %.3g sigma", outer, f0, length)
        if f_previous is not None:
            stalled = stalled + 1 if f_previous - f0 < STALL_FRACTION * predicted else 0
        stop = outer_stop(length, stalled, inner.converged)
        if stop is not None:
            status, converged = stop, True
            break
        if outer == MAX_OUTER:
            break
        alpha, accepted = 1.0, None
        while alpha >= MIN_OUTER_STEP:
            trial = kkt.z.copy()
            trial[theta] = np.clip(kkt.z[theta] + alpha * step, lo[theta], hi[theta])
            moved = trial[theta] - kkt.z[theta]
            trial[split.latent] += inner.du + tangent @ moved
            t1 = time.perf_counter()
            candidate = solve_latent(nlp, split, trial)
            inner_s += time.perf_counter() - t1
            n_inner += candidate.iterations
            ck = candidate.kkt
            f1 = 0.5 * float(ck.r @ ck.r) + 0.5 * ck.log_det
            LOG.debug("marginal likelihood: step length %g: F %.10g (%d inner iterations%s)", alpha, f1,
                      candidate.iterations, "" if candidate.converged else ", not converged")
            # an unconverged inner solve gives an upper bound of F: if even that passes Armijo, so does F
            if f1 <= f0 + 1e-4 * float(grad @ moved):
                accepted = candidate
                break
            alpha *= 0.5
        if accepted is None:
            status = "outer line search failed (no step down to 1/64 lowers the marginal objective)"
            break
        f_previous, predicted = f0, 0.5 * length**2 * alpha * (2.0 - alpha)  # the quadratic model at alpha
        inner = accepted
    kkt = inner.kkt  # every exit leaves p as the profile Hessian at this iterate
    diff = kkt.z[theta] - z_map[theta]
    return MarginalRun(kkt.z, inner.lam.copy(), 0.5 * float(kkt.r @ kkt.r), 0.5 * kkt.log_det, converged, status,
                       outer, n_inner, float(np.sqrt(diff @ p @ diff)), gradient_s, inner_s)


def marginal_solution(nlp: Nlp, sol: SolveResult, bounds: tuple[np.ndarray, np.ndarray] | None = None
                      ) -> SolveResult:
    """The joint MAP solution ``sol`` of ``nlp`` moved to the marginal-likelihood estimate
    (:func:`maximise_marginal`), its record in ``marginal``; FitError when that does not converge."""
    t0 = time.perf_counter()
    run = maximise_marginal(nlp, sol.z, bounds)
    seconds = time.perf_counter() - t0
    if not run.converged:
        raise FitError(f"the marginal-likelihood estimate did not converge: {run.status} after {run.outer_iterations} "
                       "Newton steps from the joint MAP estimate; no result written")
    LOG.info("marginal likelihood: %s after %d Newton steps (%d inner iterations, %.1f s); the parameters moved "
             "%.2f sigma from the joint MAP", run.status, run.outer_iterations, run.inner_iterations, seconds,
             run.shift_sigma)
    return dataclasses.replace(sol, z=run.z, lam_g=run.lam_g, objective=run.objective,
                               status=f"{sol.status}; {run.status}", solve_s=sol.solve_s + seconds,
                               method=f"{sol.method}, then marginal likelihood", reduced=None, decrement=None,
                               marginal=run)
