"""Solve a fit NLP, with timings: the null-space Gauss-Newton solver where it applies, else Ipopt.

``method="auto"`` (default) uses :mod:`.gauss_newton` for NLPs without latent process values,
with the Gauss-Newton Hessian and few free directions (:func:`.gauss_newton.applies`), the same
iteration solved in the full space (:func:`.kkt_gauss_newton.solve_kkt_gauss_newton`) for those
with many (an atmosphere-profile grid), and hands the last iterate to Ipopt if it stops
unconverged; NLPs with latent process values start Ipopt
from a few full-space Gauss-Newton steps (:func:`.kkt_gauss_newton.warm_start`).
``method="ipopt"`` always uses Ipopt from the given start.

Ipopt's objective, constraints, gradient, constraint Jacobian and Hessian all come from
:class:`BlockDerivatives` through CasADi callbacks: one evaluation of the mapped (compiled) block
functions per point Ipopt visits, shared by the five; no symbolic graph of the whole problem is built.

Hessian choices
    ``"gauss-newton"`` (default): sigma triu(J^T J), the constraint curvature left out. Residuals
    are sensor noise, so the multipliers are small and this constrained Gauss-Newton method
    converges nearly as fast as Newton's method at a fraction of the cost. ``"exact"``: the exact
    Hessian of the Lagrangian assembled from per-block exact Hessians. An Ipopt run with the
    Gauss-Newton Hessian that has not converged after :data:`GAUSS_NEWTON_IPOPT_ITER` iterations
    continues with the exact one (:func:`ipopt_then_exact`).

Stopping: Ipopt's own test (``tol``), or the statistical test of
:mod:`casrecon.estimation.engine.convergence` (a full Gauss-Newton step would lower chi-square by less
than 1e-3; for fits with latent process values from the KKT system), made at Ipopt's iterates and
once more on an unconverged return; ``SolveResult.status`` says which test stopped the fit.
"""

from __future__ import annotations

import dataclasses
import logging
import os
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.estimation.engine import convergence, gauss_newton, kkt_gauss_newton
from casrecon.estimation.engine.buffers import BufferCallback
from casrecon.estimation.engine.nlp import Nlp


@dataclass(frozen=True)
class SolveResult:
    """What Ipopt returned, with timings (s).

    ``solve_s`` is the whole solve; of it, ``evaluation_s`` went to the block functions
    (objective, constraints and their derivatives, the Hessian), ``stop_test_s`` to the
    Gauss-Newton decrement test (Ipopt) and ``linear_algebra_s`` to the Gauss-Newton solver's
    reduced systems; the rest is Ipopt's own work, mostly its KKT factorisations. ``method`` says
    which solver produced ``z``: "gauss-newton", "ipopt", or "gauss-newton, then ipopt" (with
    ", then marginal likelihood" when the marginal-likelihood estimator moved it from there).
    """

    z: np.ndarray
    lam_g: np.ndarray
    objective: float
    converged: bool
    status: str
    iterations: int
    build_s: float
    solve_s: float
    hessian: str
    linear_solver: str
    decrement: float | None = None
    evaluation_s: float = 0.0
    stop_test_s: float = 0.0
    reduced: object | None = None   # the convergence test's ReducedSystem when it was formed at ``z`` itself
    method: str = "ipopt"
    linear_algebra_s: float = 0.0
    marginal: object | None = None  # laplace.MarginalRun when the marginal-likelihood estimator moved z
    profile_placements: int = 0     # times the atmosphere-profile windows were placed again (continuation)
    clocks_held: tuple[tuple[str, float], ...] = ()  # (drop, clock offset s) held at its limit (continuation)


#: Ipopt stops "at an acceptable level" after ACCEPTABLE_ITER successive iterates whose scaled
#: optimality error is below ACCEPTABLE_TOL. On long fine meshes the last digits of the dual
#: infeasibility are round-off, and without this Ipopt can wander for hundreds of iterations after it
#: has converged. A dual infeasibility d moves a scaled variable of standard deviation s by about
#: s^2 d, so 1e-4 is far below every reported sigma.
ACCEPTABLE_TOL = 1e-4
ACCEPTABLE_ITER = 8
#: Iterations the Gauss-Newton solver gets before it hands its iterate to Ipopt (it converges in
#: 3 to 10 on the shipped drops).
GAUSS_NEWTON_MAX_ITER = 50
#: Ipopt iterations with the Gauss-Newton Hessian before :func:`ipopt_then_exact` switches to the
#: exact one: the profile fits of the model-error study converge in 11 to 64 with Gauss-Newton; one
#: drop cycled for 200 between objectives 14434 and 14444, which the exact Hessian ends in 12.
GAUSS_NEWTON_IPOPT_ITER = 80
#: Solver choices of :func:`solve`.
METHODS = ("auto", "ipopt")

LOG = logging.getLogger(__name__)


class _Evaluation(BufferCallback):
    """A CasADi function backed by :class:`BlockDerivatives`: ``f``, ``g``, ``grad_f``, ``jac_g`` or
    ``hess_lag`` at z (all from the one cached evaluation at that z), written straight into
    CasADi's memory (:class:`~casrecon.estimation.engine.buffers.BufferCallback`)."""

    NAMES = {"f": (["x"], ["f"]), "g": (["x"], ["g"]),
             "grad_f": (["x", "p"], ["f", "grad_f_x"]), "jac_g": (["x", "p"], ["g", "jac_g_x"]),
             "hess_lag": (["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"])}

    def __init__(self, which: str, nlp: Nlp, interruption: convergence.Interruption, hessian: str) -> None:
        ca.Callback.__init__(self)
        self.which, self.nlp, self.interruption, self.hessian = which, nlp, interruption, hessian
        self.n_z, self.n_g = nlp.n_z, nlp.n_g
        d = nlp.derivatives
        f_sp, g_sp = ca.Sparsity.dense(1, 1), ca.Sparsity.dense(self.n_g, 1)
        self.out_sp = {"f": [f_sp], "g": [g_sp], "grad_f": [f_sp, ca.Sparsity.dense(self.n_z, 1)],
                       "jac_g": [g_sp, d.jac_target.sparsity], "hess_lag": [d.hess_target(hessian).sparsity]}[which]
        self.construct(f"nlp_{which}", {})

    def get_n_in(self):
        return len(self.NAMES[self.which][0])

    def get_n_out(self):
        return len(self.NAMES[self.which][1])

    def get_name_in(self, i):
        return self.NAMES[self.which][0][i]

    def get_name_out(self, i):
        return self.NAMES[self.which][1][i]

    def get_sparsity_in(self, i):
        return [ca.Sparsity.dense(self.n_z, 1), ca.Sparsity(0, 1), ca.Sparsity.dense(1, 1),
                ca.Sparsity.dense(self.n_g, 1)][i]

    def get_sparsity_out(self, i):
        return self.out_sp[i]

    def fill(self, inputs, outputs):
        try:
            self.interruption.check()
            self.write(inputs, outputs)
        except BaseException as err:
            raised = self.interruption.keep(err)
            if raised is err:
                raise
            raise raised from None

    def write(self, inputs, outputs):
        z = inputs[0].copy()
        d = self.nlp.derivatives
        if self.which == "hess_lag":
            outputs[0][:] = d.hessian_values(z, float(inputs[2][0]), inputs[3].copy(), self.hessian)
            return
        if self.which in ("f", "grad_f"):
            r = d.residuals(z)
            outputs[0][0] = 0.5 * float(r @ r)
        if self.which == "g":
            outputs[0][:] = d.constraints(z)
        if self.which == "grad_f":
            outputs[1][:] = d.gradient(z)
        if self.which == "jac_g":
            outputs[0][:] = d.constraints(z)
            outputs[1][:] = d.jacobian_g_values(z)


def make_solver(nlp: Nlp, linear_solver: str = "mumps", max_iter: int = 200, tol: float = 1e-6,
                print_level: int = 0, bounds: tuple[np.ndarray, np.ndarray] | None = None,
                hessian: str | None = None) -> tuple[ca.Function, list]:
    """Build the Ipopt solver of ``nlp`` (``hessian``: "gauss-newton" or "exact", default the
    NLP's); also returns the callbacks, which must outlive it (the last is the
    :class:`~casrecon.estimation.engine.convergence.DecrementStop`)."""
    interruption = convergence.Interruption()  # shared: Ctrl-C in one callback stops them all
    hessian = hessian or nlp.derivatives.hessian
    callbacks = [_Evaluation(which, nlp, interruption, hessian) for which in ("grad_f", "jac_g", "hess_lag", "f", "g")]
    opts = {"ipopt.linear_solver": linear_solver, "ipopt.max_iter": max_iter, "ipopt.tol": tol,
            "ipopt.print_level": print_level, "print_time": False, "ipopt.sb": "yes",
            # f and g are callbacks without derivatives: every derivative comes from the blocks
            "calc_lam_p": False, "no_nlp_grad": True,
            "ipopt.mu_strategy": "adaptive", "ipopt.acceptable_tol": ACCEPTABLE_TOL,
            "ipopt.acceptable_iter": ACCEPTABLE_ITER, "grad_f": callbacks[0], "jac_g": callbacks[1],
            "hess_lag": callbacks[2]}
    # every iterate's chi-square is logged, and the decrement test made
    stop = convergence.DecrementStop(nlp, bounds, interruption)
    opts["iteration_callback"] = stop
    callbacks.append(stop)
    if linear_solver == "spral":
        os.environ.setdefault("OMP_CANCELLATION", "TRUE")
        os.environ.setdefault("OMP_PROC_BIND", "TRUE")
    z = ca.MX.sym("z", nlp.n_z)
    solver = ca.nlpsol("casrecon_fit", "ipopt", {"x": z, "f": callbacks[3](z), "g": callbacks[4](z)}, opts)
    return solver, callbacks


def solve(nlp: Nlp, z0: np.ndarray, linear_solver: str = "mumps", max_iter: int = 200, tol: float = 1e-6,
          print_level: int = 0, bounds: tuple[np.ndarray, np.ndarray] | None = None,
          method: str = "auto", decrement_tol: float | None = None) -> SolveResult:
    """Solve from ``z0`` (scaled); ``bounds`` = (lbx, ubx), scaled; ``method`` in METHODS (see the
    module docstring). ``linear_solver``, ``tol`` and ``print_level`` are Ipopt's. ``decrement_tol``
    (chi-square): the Gauss-Newton decrement at which the Gauss-Newton solvers stop; None: each
    one's own (:data:`.gauss_newton.DECREMENT_TOL`, :data:`.convergence.DECREMENT_TOL`). Ipopt keeps
    its own test."""
    if method not in METHODS:
        raise ValueError(f"solver method {method!r}: expected one of {', '.join(METHODS)}")
    if method == "auto" and nlp.latent:
        z_warm, steps, seconds = kkt_gauss_newton.warm_start(nlp, z0, bounds)
        sol = solve_ipopt(nlp, z_warm, linear_solver, max_iter, tol, print_level, bounds)
        return dataclasses.replace(sol, iterations=steps + sol.iterations, solve_s=seconds + sol.solve_s,
                                   method=f"gauss-newton ({steps} steps), then ipopt")
    if method == "auto" and gauss_newton.applies(nlp):
        return _gauss_newton_then_ipopt(gauss_newton.solve_gauss_newton, "gauss-newton", "superlu (null space)", nlp,
                                        z0, linear_solver, max_iter, tol, print_level, bounds, decrement_tol)
    if method == "auto" and full_space_applies(nlp):
        return _gauss_newton_then_ipopt(kkt_gauss_newton.solve_kkt_gauss_newton, "gauss-newton (full space)",
                                        "superlu (time-ordered KKT)", nlp, z0, linear_solver, max_iter, tol,
                                        print_level, bounds, decrement_tol)
    return ipopt_then_exact(nlp, z0, linear_solver, max_iter, tol, print_level, bounds)


def full_space_applies(nlp: Nlp) -> bool:
    """Whether :func:`.kkt_gauss_newton.solve_kkt_gauss_newton` is the default for ``nlp``: no latent
    process values, the Gauss-Newton Hessian, too many free directions for the null-space solver
    (an atmosphere-profile grid), and nodes to order the KKT matrix by."""
    return (not nlp.latent and nlp.derivatives.hessian == "gauss-newton" and nlp.stages is not None
            and not gauss_newton.applies(nlp))


def _gauss_newton_then_ipopt(run_gauss_newton, method: str, linear_solver_name: str, nlp: Nlp, z0: np.ndarray,
                             linear_solver: str, max_iter: int, tol: float, print_level: int,
                             bounds: tuple[np.ndarray, np.ndarray] | None,
                             decrement_tol: float | None = None) -> SolveResult:
    """``run_gauss_newton(nlp, z0, max_iter, bounds[, decrement_tol])`` (a
    :class:`.gauss_newton.GaussNewtonRun`; ``decrement_tol`` passed when not None), and Ipopt from its
    last iterate when it stops unconverged (or from ``z0`` when it cannot start)."""
    t0 = time.perf_counter()
    stop = {} if decrement_tol is None else {"decrement_tol": decrement_tol}
    try:
        run = run_gauss_newton(nlp, z0, min(max_iter, GAUSS_NEWTON_MAX_ITER), bounds, **stop)
    except gauss_newton.GaussNewtonFailure as err:
        LOG.info("Gauss-Newton could not start (%s); solving with Ipopt", err)
        return ipopt_then_exact(nlp, z0, linear_solver, max_iter, tol, print_level, bounds)
    seconds = time.perf_counter() - t0
    if run.converged:
        r = nlp.derivatives.residuals(run.z)
        return SolveResult(z=run.z, lam_g=run.multipliers, objective=0.5 * float(r @ r), converged=True,
                           status=run.status, iterations=run.iterations, build_s=0.0, solve_s=seconds,
                           hessian="gauss-newton", linear_solver=linear_solver_name, decrement=run.decrement,
                           evaluation_s=run.evaluation_s, reduced=run.system, method=method,
                           linear_algebra_s=run.linear_algebra_s)
    LOG.info("%s after %d iterations; Ipopt continues from its last iterate", run.status, run.iterations)
    sol = ipopt_then_exact(nlp, run.z, linear_solver, max_iter, tol, print_level, bounds)
    return dataclasses.replace(sol, status=f"{sol.status} (after {run.status})", iterations=run.iterations +
                               sol.iterations, solve_s=seconds + sol.solve_s, evaluation_s=run.evaluation_s +
                               sol.evaluation_s, method=f"{method}, then ipopt",
                               linear_algebra_s=run.linear_algebra_s)


def ipopt_then_exact(nlp: Nlp, z0: np.ndarray, linear_solver: str, max_iter: int, tol: float, print_level: int,
                     bounds: tuple[np.ndarray, np.ndarray] | None) -> SolveResult:
    """Ipopt with the NLP's Hessian; when that is Gauss-Newton and Ipopt has not converged (within
    :data:`GAUSS_NEWTON_IPOPT_ITER` iterations, or stopped otherwise), Ipopt again from its last iterate with the exact
    Hessian, the two within ``max_iter`` iterations together. Gauss-Newton is the safer start far from the optimum, the
    exact Hessian the faster finish where Gauss-Newton converges only linearly."""
    if nlp.derivatives.hessian != "gauss-newton":
        return solve_ipopt(nlp, z0, linear_solver, max_iter, tol, print_level, bounds)
    sol = solve_ipopt(nlp, z0, linear_solver, min(max_iter, GAUSS_NEWTON_IPOPT_ITER), tol, print_level, bounds)
    if sol.converged or sol.iterations >= max_iter:
        return sol
    LOG.info("%s after %d iterations with the Gauss-Newton Hessian; Ipopt continues with the exact Hessian",
             sol.status, sol.iterations)
    end = solve_ipopt(nlp, sol.z, linear_solver, max_iter - sol.iterations, tol, print_level, bounds, hessian="exact")
    return dataclasses.replace(end, status=f"{end.status} (after {sol.status})", iterations=sol.iterations +
                               end.iterations, build_s=sol.build_s + end.build_s, solve_s=sol.solve_s + end.solve_s,
                               evaluation_s=sol.evaluation_s + end.evaluation_s,
                               stop_test_s=sol.stop_test_s + end.stop_test_s,
                               hessian="gauss-newton, then exact", method="ipopt, then ipopt (exact Hessian)")


def solve_ipopt(nlp: Nlp, z0: np.ndarray, linear_solver: str = "mumps", max_iter: int = 200, tol: float = 1e-6,
                print_level: int = 0, bounds: tuple[np.ndarray, np.ndarray] | None = None,
                hessian: str | None = None) -> SolveResult:
    """Build the Ipopt solver and run it from ``z0`` (scaled); ``bounds`` = (lbx, ubx), scaled;
    ``hessian`` the Hessian Ipopt is given ("gauss-newton" or "exact", default the NLP's)."""
    t0 = time.perf_counter()
    hessian = hessian or nlp.derivatives.hessian
    solver, callbacks = make_solver(nlp, linear_solver, max_iter, tol, print_level, bounds, hessian)
    t1 = time.perf_counter()
    n_g = nlp.n_g
    lbx, ubx = bounds if bounds is not None else (-np.inf, np.inf)
    sol = solver(x0=z0, lbg=np.zeros(n_g), ubg=np.zeros(n_g), lbx=lbx, ubx=ubx)
    # Ctrl-C or SIGTERM during the solve stopped Ipopt: stop the caller too
    callbacks[0].interruption.after_solve(str(solver.stats()["return_status"]))
    z = np.asarray(sol["x"]).ravel()
    stop = callbacks[-1]
    converged, status, decrement = _judge(nlp, solver.stats(), stop, z, np.asarray(sol["g"]).ravel(), bounds)
    t2 = time.perf_counter()
    stats = solver.stats()
    evaluation_s = sum(float(stats.get(f"t_wall_nlp_{k}", 0.0)) for k in ("f", "g", "grad_f", "jac_g", "hess_l"))
    return SolveResult(z=z, lam_g=np.asarray(sol["lam_g"]).ravel(), objective=float(sol["f"]), converged=converged,
                       status=status, iterations=int(solver.stats()["iter_count"]), build_s=t1 - t0, solve_s=t2 - t1,
                       hessian=hessian, linear_solver=linear_solver, decrement=decrement,
                       evaluation_s=evaluation_s, stop_test_s=float(stats.get("t_wall_callback_fun", 0.0)),
                       reduced=stop.cache.system if stop.cache.at(z) else None)


def _judge(nlp: Nlp, stats: dict, stop, z: np.ndarray, g: np.ndarray, bounds) -> tuple[bool, str, float | None]:
    """(converged, status, Gauss-Newton decrement): Ipopt's verdict, or the decrement test's when
    it stopped Ipopt or when Ipopt ended unconverged at a feasible iterate."""
    status = str(stats["return_status"])
    if stop.stopped_at is not None:
        return True, f"Converged (Gauss-Newton decrement {stop.stopped_at:.2g} chi2)", stop.stopped_at
    if stats["success"]:
        return bool(stats["success"]), status, None
    if not nlp.latent and (g.size == 0 or np.abs(g).max() <= convergence.FEASIBILITY_TOL):
        stop.cache.get(nlp, z)  # the verdict on a fresh system, never a stale one
    delta = convergence.decrement_if_feasible(nlp, z, g, bounds, stop.cache)
    if delta is None:
        return False, status, None
    if delta <= convergence.DECREMENT_TOL:
        return True, f"Converged (Gauss-Newton decrement {delta:.2g} chi2; Ipopt: {status})", delta
    return False, f"{status}; Gauss-Newton decrement {delta:.3g} chi2", delta
