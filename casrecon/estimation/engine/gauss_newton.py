"""A constrained Gauss-Newton solver in the null space of the constraints (fits without latent states).

For min 1/2 |r(z)|^2 s.t. c(z) = 0 with few free directions (the collocation defects fix the node
states given the initial state and the parameters: 31 free directions against 20,000 unknowns on
ees-drop-1), each iteration solves the linearised problem

    min 1/2 |r + J dz|^2   s.t.   c + A dz = 0   (and the bounds on z + dz)

exactly: dz = P + Z w, with P a particular step (A P = -c, from the sparse LU of the defects'
Jacobian in the dependent columns) and Z the null-space basis of :mod:`.covariance`, so only the
small dense reduced system (Z^T H Z) w = -Z^T (g + H P) is solved (H = J^T J; columns in no
constraint, e.g. latent GPS errors, eliminated by the same Schur complement as the covariance). No
KKT matrix of the whole problem is ever factorised, and the last iteration's reduced system is
the covariance's.

Globalisation: a backtracking line search on the l1 merit function f + nu |c|_1 (f = chi2/2), with
the penalty nu raised as in Nocedal & Wright (2006, eq. 18.36) so that every step is a descent
direction, and a second-order correction of the constraints when a full step is rejected (the
Maratos effect). Bounds (the clock offset's one-interval box) are held by a small active set on
the reduced coordinates.

Stopping: the statistical test of :mod:`.convergence`, tightened: the constraints within
FEASIBILITY_TOL and a full step's predicted chi-square decrease (the Gauss-Newton decrement)
below this module's DECREMENT_TOL (1e-6 against Ipopt's 1e-3).
"""

from __future__ import annotations

import logging
import time
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps

from casrecon.estimation.engine import convergence
from casrecon.estimation.engine.covariance import ReducedSystem, SingularCovariance, reduced_hessian_from_jacobian
from casrecon.estimation.engine.nlp import Nlp
from casrecon.parallel import single_threaded_blas

LOG = logging.getLogger(__name__)

#: Largest number of reduced coordinates (null-space columns) for which this solver is used by
#: default: the reduced system costs O(n_z n_w^2) per iteration, which beyond this is more than
#: Ipopt's sparse KKT factorisation (an atmosphere-profile grid adds hundreds of columns).
MAX_REDUCED = 160
#: Gauss-Newton decrement (chi-square) at which the iteration stops, the constraints being met: 1e-6,
#: i.e. within 0.001 sigma of the optimum, tighter than the 1e-3 with which Ipopt is stopped
#: (:data:`.convergence.DECREMENT_TOL`), so that fits of one problem from different starts agree
#: to 0.001 sigma. It costs nothing measurable: by the iterate that first meets the constraints'
#: 1e-8 the decrement is usually far below it (9e-9 on ees-drop-1).
DECREMENT_TOL = 1e-6
#: Armijo constant of the line search.
ARMIJO = 1e-4
#: Smallest step length tried before the line search gives up.
MIN_STEP = 1e-6
#: Fraction of the model's decrease the penalty update reserves for the constraint violation.
PENALTY_RHO = 0.1


class GaussNewtonFailure(RuntimeError):
    """The Gauss-Newton iteration cannot continue (the message says why); the caller may hand the
    last iterate to Ipopt."""


def applies(nlp: Nlp) -> bool:
    """Whether :func:`solve_gauss_newton` is the default for ``nlp``: no latent process values, the
    Gauss-Newton Hessian, and at most MAX_REDUCED free directions outside the eliminated columns."""
    if nlp.latent or nlp.derivatives.hessian != "gauss-newton":
        return False
    return nlp.n_free - np.asarray(nlp.eliminated).size <= MAX_REDUCED


@dataclass(frozen=True)
class Step:
    """A linearised step: ``dz`` (scaled), the model's predicted chi-square decrease ``predicted``,
    and the reduced system it was solved with."""

    dz: np.ndarray
    predicted: float
    system: ReducedSystem


@dataclass
class GaussNewtonRun:
    """What :func:`solve_gauss_newton` ends with: the last iterate and how it got there (s)."""

    z: np.ndarray
    converged: bool
    status: str
    iterations: int
    decrement: float | None
    evaluation_s: float
    linear_algebra_s: float
    system: ReducedSystem | None     # formed at ``z`` itself
    multipliers: np.ndarray


def bounded_columns(bounds, n_z: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(columns, lower, upper) of the finite bounds among ``bounds`` = (lbx, ubx) (None: none)."""
    if bounds is None:
        return np.zeros(0, np.int64), np.zeros(0), np.zeros(0)
    lo, hi = (np.broadcast_to(np.asarray(b, float), (n_z,)) for b in bounds)
    cols = np.flatnonzero(np.isfinite(lo) | np.isfinite(hi))
    return cols, lo[cols], hi[cols]


def reduced_step(system: ReducedSystem, grad: np.ndarray, jr: sps.spmatrix, c: np.ndarray, z: np.ndarray,
                 bounded: tuple[np.ndarray, np.ndarray, np.ndarray]) -> Step:
    """The constrained Gauss-Newton step at ``z`` (see the module docstring): ``grad`` = J^T r, ``jr``
    = J (the residuals' Jacobian), ``c`` the constraint values, ``bounded`` = (columns, lower,
    upper) of the bounds."""
    split, basis = system.split, system.basis
    p = split.particular(c)
    b = grad + jr.T @ (jr @ p)
    elim = system.elimination
    dz_e = np.zeros_like(p)
    if elim is not None:  # dz_E = -H_EE^-1 b_E - M w: the first part here, the second through basis rows
        dz_e[elim.cols] = -elim.lu.solve(b[elim.cols])
    rhs = basis.T @ b
    cols, lo, hi = bounded
    w = _bounded_reduced_solve(system.hessian, rhs, basis[cols], z[cols] + p[cols], lo, hi)
    dz = p + dz_e + basis @ w
    jdz = jr @ dz
    predicted = -(2.0 * float(grad @ dz) + float(jdz @ jdz))
    return Step(dz, predicted, system)


def _bounded_reduced_solve(s: np.ndarray, rhs: np.ndarray, rows: np.ndarray, start: np.ndarray,
                           lo: np.ndarray, hi: np.ndarray) -> np.ndarray:
    """w minimising 1/2 w^T S w + rhs^T w with lo <= start + rows w <= hi (a primal active set over
    the few bounded columns, :func:`hold_bounds`; bounds are met within round-off)."""
    chol = _damped_cholesky(s)

    def solve_s(v):
        return np.linalg.solve(chol.T, np.linalg.solve(chol, v))

    def solve_held(idx: np.ndarray, held: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        if not idx.size:
            w, mu = -solve_s(rhs), np.zeros(0)
        else:
            c = rows[idx]
            s_inv_ct = solve_s(c.T)
            s_inv_rhs = solve_s(rhs)
            # KKT: S w + C^T mu = -rhs, C w = target
            mu = np.linalg.solve(c @ s_inv_ct, -c @ s_inv_rhs - (held - start[idx]))
            w = -s_inv_rhs - s_inv_ct @ mu
        return w, start + rows @ w, mu

    return hold_bounds(solve_held, lo, hi, "the bounded reduced step did not settle")


def hold_bounds(solve_held: Callable[[np.ndarray, np.ndarray], tuple[np.ndarray, np.ndarray, np.ndarray]],
                lo: np.ndarray, hi: np.ndarray, unsettled: str) -> np.ndarray:
    """A primal active set over a few bounded values: ``solve_held(idx, held)`` solves with the
    bounded values ``idx`` held at ``held`` and returns (solution, every bounded value, each held
    bound's force, positive where it pushes a lower bound inwards, negative an upper one). A held
    bound whose force pulls the value inwards is released; else the most violated free bound is
    held, until none is violated (within 1e-12). Raises GaussNewtonFailure(``unsettled``) when that
    takes more than twice as many rounds as there are bounds."""
    active: dict[int, float] = {}  # index among the bounded values -> the bound held
    for _ in range(2 * lo.size + 1):
        idx = np.array(sorted(active), np.int64)
        held = np.array([active[i] for i in idx])
        solution, value, force = solve_held(idx, held)
        signs = np.where(held == lo[idx], 1.0, -1.0)
        leaving = idx[signs * force > 1e-12]
        if leaving.size:
            del active[int(leaving[0])]
            continue
        violated = [i for i in np.flatnonzero((value < lo - 1e-12) | (value > hi + 1e-12)) if i not in active]
        if not violated:
            return solution
        i = int(violated[np.argmax(np.maximum(lo[violated] - value[violated], value[violated] - hi[violated]))])
        active[i] = lo[i] if value[i] < lo[i] else hi[i]
    raise GaussNewtonFailure(unsettled)


def _damped_cholesky(s: np.ndarray) -> np.ndarray:
    """Cholesky factor of S, or of S + mu max(diag S) I with the smallest mu in 1e-12, 1e-10, ...,
    1e-4 that makes it positive definite (a Levenberg-Marquardt step in the directions the
    linearisation cannot see, e.g. a damping while every rate of the start is zero)."""
    scale = max(float(np.max(np.diag(s))), 1e-300)
    for mu in (0.0, 1e-12, 1e-10, 1e-8, 1e-6, 1e-4):
        try:
            return np.linalg.cholesky(s + mu * scale * np.eye(s.shape[0]))
        except np.linalg.LinAlgError:
            continue
    raise GaussNewtonFailure("the reduced Gauss-Newton Hessian is not positive definite")


def _merit(r: np.ndarray, c: np.ndarray, nu: float) -> float:
    return 0.5 * float(r @ r) + nu * float(np.abs(c).sum())


@single_threaded_blas()
def solve_gauss_newton(nlp: Nlp, z0: np.ndarray, max_iter: int = 100,
                       bounds: tuple[np.ndarray, np.ndarray] | None = None,
                       decrement_tol: float = DECREMENT_TOL) -> GaussNewtonRun:
    """Run the constrained Gauss-Newton iteration from ``z0`` (scaled; clipped into ``bounds``) until
    the constraints are met and the Gauss-Newton decrement is at most ``decrement_tol`` (chi-square).

    Returns the last iterate whether or not it converged (``converged``/``status`` say); raises
    :class:`GaussNewtonFailure` only when not even a first step can be formed.
    """
    d = nlp.derivatives
    bounded = bounded_columns(bounds, nlp.n_z)
    z = np.asarray(z0, float).copy()
    z[bounded[0]] = np.clip(z[bounded[0]], bounded[1], bounded[2])
    const_chi2 = float(sum(nlp.const_chi2.values()))
    level, label = convergence.iteration_log_settings()
    nu, eval_s, algebra_s = 0.0, 0.0, 0.0
    status, system, step = "iteration limit reached", None, None
    for iteration in range(max_iter + 1):
        t0 = time.perf_counter()
        d.evaluate(z)
        r, c, grad = d.residuals(z), d.constraints(z), d.gradient(z)
        t1 = time.perf_counter()
        violation = float(np.abs(c).max()) if c.size else 0.0
        convergence.log_iteration(level, label, iteration, float(r @ r) + const_chi2, violation)
        try:
            jr = d.jacobian_r(z)
            system = reduced_hessian_from_jacobian(nlp, jr, d.jacobian_g(z))
            step = reduced_step(system, grad, jr, c, z, bounded)
        except (SingularCovariance, GaussNewtonFailure, RuntimeError) as err:
            eval_s += t1 - t0
            algebra_s += time.perf_counter() - t1
            if step is None:
                raise GaussNewtonFailure(str(err)) from None
            return _run(z, False, f"Gauss-Newton stopped: {err}", iteration, None, eval_s, algebra_s, None, nlp)
        t2 = time.perf_counter()
        eval_s += t1 - t0
        algebra_s += t2 - t1
        if violation <= convergence.FEASIBILITY_TOL and step.predicted <= decrement_tol:
            return _run(z, True, f"Converged (Gauss-Newton decrement {max(step.predicted, 0.0):.2g} chi2)", iteration,
                        step.predicted, eval_s, algebra_s, system, nlp)
        if iteration == max_iter:
            break
        z_new, nu, trial_eval_s = line_search(nlp, z, r, c, grad, jr, step.dz, nu, bounded,
                                              step.system.split.particular)
        eval_s += trial_eval_s
        if z_new is None:
            status = "line search failed (no step length down to 1e-6 lowers the merit function)"
            return _run(z, False, f"Gauss-Newton stopped: {status}", iteration, step.predicted, eval_s,
                        algebra_s, system, nlp)
        z = z_new
    return _run(z, False, f"Gauss-Newton stopped: {status} ({max_iter})", max_iter,
                None if step is None else step.predicted, eval_s, algebra_s, None, nlp)


def line_search(nlp: Nlp, z: np.ndarray, r: np.ndarray, c: np.ndarray, grad: np.ndarray, jr: sps.spmatrix,
                dz: np.ndarray, nu: float, bounded: tuple[np.ndarray, np.ndarray, np.ndarray],
                correct: Callable[[np.ndarray], np.ndarray] | None = None) -> tuple[np.ndarray | None, float, float]:
    """Armijo backtracking on the l1 merit 1/2 |r|^2 + nu |c|_1 along the Gauss-Newton step ``dz``
    from ``z`` (residuals ``r``, constraints ``c``, gradient ``grad`` = J^T r, Jacobian ``jr``), the
    penalty ``nu`` raised first (Nocedal & Wright eq. 18.36), trial points clipped into ``bounded``
    and evaluated without derivatives. When the full step is rejected, one second-order correction
    ``correct(c_trial)`` (a step that zeroes the linearised constraints) is tried.

    Returns (accepted iterate or None, updated penalty, evaluation seconds).
    """
    d = nlp.derivatives
    c1 = float(np.abs(c).sum())
    jdz = jr @ dz
    model = float(grad @ dz) + 0.5 * float(jdz @ jdz)
    if c1 > 0.0 and model > 0.0:
        nu = max(nu, model / ((1.0 - PENALTY_RHO) * c1))
    slope = float(grad @ dz) - nu * c1
    phi0 = _merit(r, c, nu)
    cols, lo, hi = bounded
    seconds, alpha = 0.0, 1.0
    while alpha >= MIN_STEP:
        trial = z + alpha * dz
        trial[cols] = np.clip(trial[cols], lo, hi)
        t0 = time.perf_counter()
        r_t, c_t = d.values_only(trial)
        seconds += time.perf_counter() - t0
        if np.all(np.isfinite(r_t)) and np.all(np.isfinite(c_t)):
            if _merit(r_t, c_t, nu) <= phi0 + ARMIJO * alpha * slope:
                LOG.debug("Gauss-Newton step length %g (penalty %.3g)", alpha, nu)
                return trial, nu, seconds
            if alpha == 1.0 and c_t.size and correct is not None:  # second-order correction
                corrected = trial + correct(c_t)
                corrected[cols] = np.clip(corrected[cols], lo, hi)
                t0 = time.perf_counter()
                r_s, c_s = d.values_only(corrected)
                seconds += time.perf_counter() - t0
                if np.all(np.isfinite(r_s)) and _merit(r_s, c_s, nu) <= phi0 + ARMIJO * slope:
                    LOG.debug("Gauss-Newton full step with a second-order correction (penalty %.3g)", nu)
                    return corrected, nu, seconds
        alpha *= 0.5
    return None, nu, seconds


def _run(z, converged, status, iterations, decrement, eval_s, algebra_s, system, nlp) -> GaussNewtonRun:
    """The run's record, with the constraint multipliers at ``z`` from the transposed LU (A^T lam = -g
    on the dependent columns, least squares on the side rows); zeros without a system."""
    lam = np.zeros(nlp.n_g)
    if system is not None and system.split is not None and nlp.n_g:
        split, grad = system.split, nlp.derivatives.gradient(z)
        n_det = split.dep.size
        lam[:n_det] = -split.lu.solve(grad[split.dep], trans="T")
        if nlp.n_g > n_det:
            rest = -grad[split.indep] - split.a_indep.T @ lam[:n_det]
            lam[n_det:] = np.linalg.lstsq(split.a_side.T, rest, rcond=None)[0]
    return GaussNewtonRun(z, converged, status, iterations, decrement, eval_s, algebra_s, system, lam)
