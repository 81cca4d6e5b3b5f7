"""Gauss-Newton steps in the full space: the solver of fits with an atmosphere-profile grid, and the
start of fits with latent process values before Ipopt takes over.

**Atmosphere-profile fits** (:func:`solve_kkt_gauss_newton`). Each profile coefficient is a free
direction of the constraints' null space, so :mod:`.gauss_newton`'s dense reduced system has
hundreds of columns (541 on ees-drop-1 on the default 10 m grid: 1.2 to 1.5 s to form, against
0.2 s for the whole plain fit's), and Ipopt took 8 to 10 iterations with a null-space convergence
test on top. The same constrained Gauss-Newton step (the same linearised problem, so in exact
arithmetic the same iterates as the null-space solver) is solved here in the full space, through
the KKT matrix factorised in time order (:mod:`.time_ordered_kkt`, about 0.15 s on ees-drop-1),
with the same line search and a primal active set for the clock offset's bound (a held bound's
row dropped, one more solve). It stops when the constraints are met and a full step's predicted
chi-square decrease, read off the step itself, is below :data:`.convergence.DECREMENT_TOL` (1e-3,
the test that stopped Ipopt on these fits): the profile's weakly determined edge coefficients
converge only linearly under Gauss-Newton, and the null-space solver's 1e-6 would cost several
more iterations for changes far below a sigma. An iterate whose decrement is converged but whose
constraint violation is not (yet below PROJECTION_VIOLATION) is projected onto the constraints
with the same factor, the decrement tested again there (:func:`feasible_projection`), instead of
taking another step. Where the last steps settle into one slowly shrinking mode, the step is
extrapolated along it (:class:`SlowMode`). An unconverged run hands its iterate to Ipopt.

**Latent process values** (:func:`warm_start`).
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
from dataclasses import dataclass

import numpy as np
import scipy.sparse as sps

from casrecon.estimation.engine import convergence
from casrecon.estimation.engine.bordered_kkt import BorderedKkt
from casrecon.estimation.engine.covariance import fisher_and_jacobian, kkt_matrix
from casrecon.estimation.engine.gauss_newton import (
    GaussNewtonFailure,
    GaussNewtonRun,
    bounded_columns,
    hold_bounds,
    line_search,
)
from casrecon.estimation.engine.nlp import Nlp
from casrecon.estimation.engine.time_ordered_kkt import OrderedPattern, TimeOrderedKkt
from casrecon.parallel import single_threaded_blas

LOG = logging.getLogger(__name__)

#: After a step whose largest change of a (scaled) unknown is at most this, the next KKT matrix is
#: first solved with the factor before (a chord step: iterative refinement against the new matrix,
#: :class:`.time_ordered_kkt.TimeOrderedKkt`); after larger steps the matrices differ too much for
#: that to converge (ees-drop-1's profile fit: after steps of 7 to 8 the refinement diverges, after
#: 0.3 it needs 29 steps, after 0.1 or less 5 to 8, against 3 with the matrix's own factor).
CHORD_STEP = 0.2
#: Largest constraint violation (scaled units) from which an iterate whose step is converged but for
#: the violation is projected onto the constraints (:func:`feasible_projection`) instead of taking
#: another step. A step's constraint curvature leaves a violation of about 1e-4 |dz|^2, and
#: Gauss-Newton shrinks its steps in the weakly determined profile directions only linearly (they
#: about halve at each iteration on ees-drop-3-model-error), so the violation, not the decrement,
#: often decided the last iteration. (Newton steps, the exact Lagrangian Hessian, were tried for that tail: they
#: converge quadratically, but each costs 0.5 s more than a Gauss-Newton step for the exact block
#: Hessians alone, more than the iterations they save: ees-drop-1's profile fit 5.2 -> 6.3 s.)
PROJECTION_VIOLATION = 1e-6
#: The steps are taken to be in one slow mode (:class:`SlowMode`) when each of the last three has a
#: cosine of at least SLOW_MODE_COSINE with the one before, their two ratios of lengths differ by at
#: most SLOW_MODE_RATE_CHANGE of the last, and that rate is at most SLOW_MODE_MAX_RATE (the
#: extrapolation 1 / (1 - rate) at most 10).
SLOW_MODE_COSINE = 0.99
SLOW_MODE_RATE_CHANGE = 0.1
SLOW_MODE_MAX_RATE = 0.9
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


class KktFactors:
    """The Gauss-Newton KKT matrices of one NLP at successive iterates, factorised in time order
    (:mod:`.time_ordered_kkt`; where each source value lands is worked out at the first iterate:
    the patterns of J^T J and of the constraint Jacobian do not change)."""

    def __init__(self, nlp: Nlp) -> None:
        if nlp.stages is None:
            raise GaussNewtonFailure("the NLP has no nodes to order its KKT matrix by")
        self.nlp = nlp
        self._pattern: OrderedPattern | None = None
        self._last: TimeOrderedKkt | None = None

    def at(self, z: np.ndarray, chord: bool = False) -> TimeOrderedKkt:
        """The Gauss-Newton KKT matrix at ``z`` (evaluated), factorised; RuntimeError if singular.
        ``chord``: solve it with the factor of the matrix before as long as the refinement
        converges fast (:class:`.time_ordered_kkt.TimeOrderedKkt`), factorising it only if not."""
        nlp, d = self.nlp, self.nlp.derivatives
        h_values, g_values = d.hessian_values(z, 1.0, None, "gauss-newton"), d.jacobian_g_values(z)
        if self._pattern is None:
            h = d.jtj_target.matrix(np.arange(1.0, h_values.size + 1))
            a = d.jac_target.matrix(np.arange(h_values.size + 1.0, h_values.size + g_values.size + 1))
            self._pattern = OrderedPattern(kkt_matrix(h + sps.triu(h, 1).T, a), nlp.n_z, nlp.stages,
                                           nlp.parameter_columns)
        self._last = TimeOrderedKkt(self._pattern, np.concatenate([h_values, g_values]),
                                    self._last if chord else None)
        return self._last


def bounded_step(factor: TimeOrderedKkt, rhs: np.ndarray, z: np.ndarray,
                 bounded: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """K^-1 ``rhs`` (the step [dz; lambda]) with z + dz kept within the bounds of the ``bounded``
    columns by a primal active set (:func:`.gauss_newton.hold_bounds`): a held bound's row is
    dropped, and its residual rhs - K x there is the force holding it."""
    cols, lo, hi = bounded

    def solve_held(idx: np.ndarray, held: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        sol, force = factor.solve_fixed(rhs, cols[idx], held - z[cols[idx]])
        return sol, z[cols] + sol[cols], force

    return hold_bounds(solve_held, lo, hi, "the bounded full-space step did not settle")


def feasibility_step(factor: TimeOrderedKkt, c: np.ndarray, z: np.ndarray,
                     bounded: tuple[np.ndarray, np.ndarray, np.ndarray]) -> np.ndarray:
    """dz_p, the least-curvature step with A dz_p = -c (``c`` the constraints at ``z``), from the
    step's own factor (one solve, the bounds of the ``bounded`` columns held)."""
    return bounded_step(factor, np.concatenate([np.zeros(z.size), -c]), z, bounded)[:z.size]


def feasible_projection(nlp: Nlp, z: np.ndarray, grad: np.ndarray, jr: sps.spmatrix, dz: np.ndarray,
                        dz_p: np.ndarray, decrement_tol: float = convergence.DECREMENT_TOL,
                        ) -> tuple[np.ndarray, float, float] | None:
    """The iterate ``z`` moved onto the constraints when only its constraint violation stands between
    it and convergence (see :data:`PROJECTION_VIOLATION`): (projected iterate, its violation, the
    Gauss-Newton decrement there), or None when the projected point is not converged (its decrement
    above ``decrement_tol``, chi-square, or its violation above FEASIBILITY_TOL).

    The Gauss-Newton step ``dz`` at ``z`` (gradient ``grad``, residual Jacobian ``jr``) is split
    into its feasibility part ``dz_p`` (:func:`feasibility_step`) and the rest dz_o = dz - dz_p,
    which has A dz_o = 0 and is the Gauss-Newton step from z + dz_p of the same linearised problem.
    Its predicted chi-square decrease there, -(2 (g + J^T J dz_p)^T dz_o + |J dz_o|^2), is the
    decrement the convergence test reads, and the constraints are evaluated at z + dz_p (a step of
    the violation's size leaves a violation of about its square). The full step's own predicted
    decrease mixes the two parts: on ees-drop-1's profile fit it was 3.4e-4 at a violation of
    1.2e-8, and 0.007 after the projection, so the projection does not stop that fit early; on
    ees-drop-3-model-error it saves one to two iterations of each of its four solves."""
    dz_o = dz - dz_p
    jdp, jdo = jr @ dz_p, jr @ dz_o
    predicted = -(2.0 * float(grad @ dz_o) + 2.0 * float(jdp @ jdo) + float(jdo @ jdo))
    if predicted > decrement_tol:
        return None
    z_p = z + dz_p
    _, c_p = nlp.derivatives.values_only(z_p)
    violation = float(np.abs(c_p).max()) if c_p.size else 0.0
    if violation > convergence.FEASIBILITY_TOL:
        return None
    LOG.debug("full-space Gauss-Newton: projected onto the constraints (violation %.2g), decrement there %.3g",
              violation, predicted)
    return z_p, violation, predicted


@dataclass(frozen=True)
class SlowMode:
    """The last three steps taken (scaled), to see whether the iteration has settled into one slow mode.

    Near the optimum Gauss-Newton's error shrinks by e_k+1 = M e_k, M = I - H_GN^-1 H (H the exact
    reduced Hessian); where one eigenvalue rho of M dominates, each step is the one before times rho,
    in the same direction, and the steps still to come sum to rho / (1 - rho) times the last. On
    ees-drop-3-model-error's profile fit the steps from the fifth on were parallel to 3 digits (cosine
    1.000) and shrank by 0.461, 0.450, 0.456, 0.457, 0.457: four more iterations to the decrement test.
    :meth:`rate` gives rho when the last two steps and the new one are parallel and shrink at one
    rate (SLOW_MODE_COSINE, SLOW_MODE_RATE_CHANGE, at most SLOW_MODE_MAX_RATE); the solver then takes
    the new step's part on the constraints' null space 1 / (1 - rho) times (Aitken's extrapolation
    of a linearly converging sequence), through the same line search (the plain step if it is
    rejected), and starts counting again. Where the steps turn (ees-drop-1's profile fit, cosines
    -0.4 to 0.9) it never applies.

    Where two modes alternate, M^2 = rho2 on them (eigenvalues +-sqrt(rho2) or a rotation), every
    step is parallel to the one two before and shorter by rho2, while neighbours turn:
    :meth:`paired_rate` gives rho2 when the new step and the one two before, and the last and the
    one three before, are parallel and shrink at one rate (the same limits), and the steps still to
    come from the new one dz_k on sum to (dz_k + rho2 dz_k-1) / (1 - rho2) (:meth:`extrapolated`;
    with dz_k-1 = dz_k / rho this is Aitken's 1 / (1 - rho)). Found on the refit of a
    ``sounding-pair`` drop (seed 240): from the fourth step on each was at cosine 0.99 to 1.000 with
    the one two before and -0.7 with the one before, shrinking by 0.70 to 0.75 every two steps, 25
    iterations to the decrement test."""

    steps: tuple[np.ndarray, ...] = ()

    @property
    def last(self) -> np.ndarray | None:
        """The last step taken (None before one)."""
        return self.steps[-1] if self.steps else None

    def rate(self, dz: np.ndarray) -> float | None:
        """rho for the new step ``dz``, or None when the steps are not in one slow mode."""
        if len(self.steps) < 2 or self.steps[-1].size != dz.size:
            return None
        return _one_rate((self.steps[-2], self.steps[-1]), (self.steps[-1], dz))

    def paired_rate(self, dz: np.ndarray) -> float | None:
        """rho2 for the new step ``dz`` where it and the last three alternate between two modes that
        shrink at one rate every two steps (see the class docstring), or None."""
        if len(self.steps) < 3 or self.steps[-1].size != dz.size:
            return None
        return _one_rate((self.steps[-3], self.steps[-1]), (self.steps[-2], dz))

    def applies(self, dz: np.ndarray) -> bool:
        """Whether :meth:`extrapolated` extrapolates the new step ``dz`` (one slow mode or two
        alternating ones)."""
        return self.rate(dz) is not None or self.paired_rate(dz) is not None

    def extrapolated(self, dz: np.ndarray, dz_null: np.ndarray) -> tuple[np.ndarray, str] | None:
        """(the new step ``dz`` with its null-space part ``dz_null`` replaced by the sum of the steps
        still to come, what was extrapolated) where the steps are in one slow mode (:meth:`rate`) or
        two alternating ones (:meth:`paired_rate`), else None."""
        rate = self.rate(dz)
        if rate is not None:
            return dz + rate / (1.0 - rate) * dz_null, f"one slow mode, rate {rate:.3f}"
        paired = self.paired_rate(dz)
        if paired is not None:
            return (dz + paired / (1.0 - paired) * (dz_null + self.steps[-1]),
                    f"two alternating modes, rate {paired:.3f} every two steps")
        return None

    def after(self, step: np.ndarray, restart: bool) -> SlowMode:
        """The record after taking ``step``; ``restart``: the count starts again (an extrapolated
        step, or one the line search shortened or corrected: not a step of the iteration's own map)."""
        if restart:
            return SlowMode()
        # the steps kept all have the last one's size: a step of another size (a rebuilt NLP) starts afresh
        kept = self.steps[-2:] if self.last is not None and self.last.size == step.size else ()
        return SlowMode((*kept, step))


def _one_rate(first: tuple[np.ndarray, np.ndarray], second: tuple[np.ndarray, np.ndarray]) -> float | None:
    """The ratio |b| / |a| of the pair ``second`` (a, b) where each pair's b is parallel to its a
    (cosine at least SLOW_MODE_COSINE), both ratios are at most SLOW_MODE_MAX_RATE and they differ
    by at most SLOW_MODE_RATE_CHANGE of the second; else None."""
    rates = []
    for a, b in (first, second):
        na, nb = float(np.linalg.norm(a)), float(np.linalg.norm(b))
        if na == 0.0 or nb == 0.0 or float(a @ b) / (na * nb) < SLOW_MODE_COSINE:
            return None
        rates.append(nb / na)
    if max(rates) > SLOW_MODE_MAX_RATE or abs(rates[1] - rates[0]) > SLOW_MODE_RATE_CHANGE * rates[1]:
        return None
    return rates[1]


@single_threaded_blas()
def solve_kkt_gauss_newton(nlp: Nlp, z0: np.ndarray, max_iter: int = 100,
                           bounds: tuple[np.ndarray, np.ndarray] | None = None,
                           decrement_tol: float = convergence.DECREMENT_TOL) -> GaussNewtonRun:
    """The constrained Gauss-Newton iteration of :mod:`.gauss_newton` with each step solved in the full
    space (see the module docstring), from ``z0`` (scaled; clipped into ``bounds``), until the
    constraints are met and a full step's predicted chi-square decrease is at most ``decrement_tol``.

    Returns the last iterate whether or not it converged (``converged``/``status`` say; ``system``
    is None: the covariance forms its own); raises :class:`GaussNewtonFailure` only when not even a
    first step can be formed.
    """
    d = nlp.derivatives
    bounded = bounded_columns(bounds, nlp.n_z)
    factors = KktFactors(nlp)
    z = np.asarray(z0, float).copy()
    z[bounded[0]] = np.clip(z[bounded[0]], bounded[1], bounded[2])
    const_chi2 = float(sum(nlp.const_chi2.values()))
    level, label = convergence.iteration_log_settings()
    nu, eval_s, algebra_s, lam, predicted, step_size = 0.0, 0.0, 0.0, np.zeros(nlp.n_g), None, np.inf
    slow_mode = SlowMode()
    status = "iteration limit reached"
    for iteration in range(max_iter + 1):
        t0 = time.perf_counter()
        d.evaluate(z)
        r, c, grad = d.residuals(z), d.constraints(z), d.gradient(z)
        jr = d.jacobian_r(z)
        t1 = time.perf_counter()
        eval_s += t1 - t0
        violation = float(np.abs(c).max()) if c.size else 0.0
        convergence.log_iteration(level, label, iteration, float(r @ r) + const_chi2, violation)
        try:
            factor = factors.at(z, chord=step_size <= CHORD_STEP)
            sol = bounded_step(factor, np.concatenate([-grad, -c]), z, bounded)
        except (RuntimeError, np.linalg.LinAlgError) as err:
            algebra_s += time.perf_counter() - t1
            if iteration == 0:
                raise GaussNewtonFailure(str(err)) from None
            return GaussNewtonRun(z, False, f"Gauss-Newton stopped: {err}", iteration, predicted, eval_s, algebra_s,
                                  None, lam)
        dz, lam = sol[:nlp.n_z], sol[nlp.n_z:]
        jdz = jr @ dz
        predicted = -(2.0 * float(grad @ dz) + float(jdz @ jdz))
        algebra_s += time.perf_counter() - t1
        LOG.debug("full-space Gauss-Newton step: predicted chi-square decrease %.3g, largest |dz| %.3g%s", predicted,
                  float(np.abs(dz).max()), " (the factor before)" if factor.stale else
                  "" if factor.refined else " (pivoting factorisation)")
        dz_p = None  # the step's feasibility part, solved for when needed (once)
        if convergence.FEASIBILITY_TOL < violation <= PROJECTION_VIOLATION:
            t2 = time.perf_counter()
            dz_p = feasibility_step(factor, c, z, bounded)
            projected = feasible_projection(nlp, z, grad, jr, dz, dz_p, decrement_tol)
            algebra_s += time.perf_counter() - t2
            if projected is not None:
                z, violation, predicted = projected
        if violation <= convergence.FEASIBILITY_TOL and predicted <= decrement_tol:
            return GaussNewtonRun(z, True, f"Converged (Gauss-Newton decrement {max(predicted, 0.0):.2g} chi2)",
                                  iteration, predicted, eval_s, algebra_s, None, lam)
        if iteration == max_iter:
            break

        def correct(c_trial: np.ndarray, factor=factor) -> np.ndarray:
            return factor.solve(np.concatenate([np.zeros(nlp.n_z), -c_trial]))[:nlp.n_z]

        slow = slow_mode.applies(dz)
        z_new = None
        if slow:  # the step summed over the iterations to come (see SlowMode)
            if dz_p is None:
                t2 = time.perf_counter()
                dz_p = feasibility_step(factor, c, z, bounded)
                algebra_s += time.perf_counter() - t2
            step, what = slow_mode.extrapolated(dz, dz - dz_p)
            z_new, nu, trial_eval_s = line_search(nlp, z, r, c, grad, jr, step, nu, bounded, correct)
            eval_s += trial_eval_s
            LOG.debug("full-space Gauss-Newton: the step extrapolated (%s)%s", what,
                      "" if z_new is not None else ": rejected by the line search")
        if z_new is None:
            z_new, nu, trial_eval_s = line_search(nlp, z, r, c, grad, jr, dz, nu, bounded, correct)
            eval_s += trial_eval_s
        if z_new is None:
            status = "line search failed (no step length down to 1e-6 lowers the merit function)"
            return GaussNewtonRun(z, False, f"Gauss-Newton stopped: {status}", iteration, predicted, eval_s,
                                  algebra_s, None, lam)
        taken = z_new - z
        full = not slow and np.allclose(taken, dz, rtol=1e-6, atol=1e-12 * float(np.abs(dz).max()))
        slow_mode = slow_mode.after(taken, restart=not full)
        step_size, z = float(np.abs(taken).max()), z_new
    return GaussNewtonRun(z, False, f"Gauss-Newton stopped: {status} ({max_iter})", max_iter, predicted, eval_s,
                          algebra_s, None, lam)
