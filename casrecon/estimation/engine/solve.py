"""Solve a fit NLP with Ipopt, giving it the block-assembled derivatives, with timings.

Ipopt's gradient, constraint Jacobian and Hessian come from :class:`BlockDerivatives` through
CasADi callbacks (one evaluation of the mapped block functions per iterate, shared by the three);
the objective and constraints are CasADi expressions of the mapped value functions.

Hessian choices
    ``"gauss-newton"`` (default): sigma triu(J^T J), the constraint curvature left out. Residuals
    are sensor noise, so the multipliers are small and this constrained Gauss-Newton method
    converges nearly as fast as Newton's method at a fraction of the cost; J^T J is also the Fisher
    information the covariance uses. ``"exact"``: the exact Hessian of the Lagrangian assembled
    from per-block exact Hessians.

Stopping: Ipopt's own test (``tol``), or, for strong-constraint fits, the statistical test of
:mod:`casrecon.estimation.engine.convergence` (a full Gauss-Newton step would lower chi-square by less
than 1e-3), made at Ipopt's iterates and once more on an unconverged return; ``SolveResult.status``
says which test stopped the fit.
"""

from __future__ import annotations

import os
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.estimation.engine import convergence
from casrecon.estimation.engine.nlp import Nlp


@dataclass(frozen=True)
class SolveResult:
    """What Ipopt returned, with timings (s)."""

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


#: Ipopt stops "at an acceptable level" after ACCEPTABLE_ITER successive iterates whose scaled
#: optimality error is below ACCEPTABLE_TOL. On long fine meshes the last digits of the dual
#: infeasibility are round-off, and without this Ipopt can wander for hundreds of iterations after it
#: has converged. A dual infeasibility d moves a scaled variable of standard deviation s by about
#: s^2 d, so 1e-4 is far below every reported sigma.
ACCEPTABLE_TOL = 1e-4
ACCEPTABLE_ITER = 8


class _Derivative(ca.Callback):
    """A CasADi function backed by :class:`BlockDerivatives` (``grad_f``, ``jac_g`` or ``hess_lag``)."""

    NAMES = {"grad_f": (["x", "p"], ["f", "grad_f_x"]), "jac_g": (["x", "p"], ["g", "jac_g_x"]),
             "hess_lag": (["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"])}

    def __init__(self, which: str, nlp: Nlp, value_fn: ca.Function | None,
                 interruption: convergence.Interruption) -> None:
        ca.Callback.__init__(self)
        self.which, self.nlp, self.value_fn, self.interruption = which, nlp, value_fn, interruption
        self.n_z, self.n_g = nlp.z.numel(), nlp.constraints.numel()
        d = nlp.derivatives
        self.out_sp = {"grad_f": [ca.Sparsity.dense(1, 1), ca.Sparsity.dense(self.n_z, 1)],
                       "jac_g": [ca.Sparsity.dense(self.n_g, 1), d.jac_target.sparsity],
                       "hess_lag": [d.hess_target.sparsity]}[which]
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

    def eval(self, args):
        try:
            self.interruption.check()
            z = np.asarray(args[0]).ravel()
            d = self.nlp.derivatives
            if self.which == "grad_f":
                return [self.value_fn(z), d.gradient(z)]
            if self.which == "jac_g":
                return [self.value_fn(z), d.jacobian_g(z)]
            return [d.hessian_lagrangian(z, float(args[2]), np.asarray(args[3]).ravel())]
        except BaseException as err:
            raised = self.interruption.keep(err)
            if raised is err:
                raise
            raise raised from None


def make_solver(nlp: Nlp, linear_solver: str = "mumps", max_iter: int = 200, tol: float = 1e-6,
                print_level: int = 0, bounds: tuple[np.ndarray, np.ndarray] | None = None) -> tuple[ca.Function, list]:
    """Build the Ipopt solver of ``nlp``; also returns the callbacks, which must outlive it (the
    last is the :class:`~casrecon.estimation.engine.convergence.DecrementStop`, or None)."""
    f = 0.5 * ca.sumsqr(nlp.residuals)
    f_fn = ca.Function("f", [nlp.z], [f])
    g_fn = ca.Function("g", [nlp.z], [nlp.constraints])
    interruption = convergence.Interruption()  # shared: Ctrl-C in one callback stops them all
    callbacks = [_Derivative("grad_f", nlp, f_fn, interruption), _Derivative("jac_g", nlp, g_fn, interruption),
                 _Derivative("hess_lag", nlp, None, interruption)]
    opts = {"ipopt.linear_solver": linear_solver, "ipopt.max_iter": max_iter, "ipopt.tol": tol,
            "ipopt.print_level": print_level, "print_time": False, "ipopt.sb": "yes",
            "ipopt.mu_strategy": "adaptive", "ipopt.acceptable_tol": ACCEPTABLE_TOL,
            "ipopt.acceptable_iter": ACCEPTABLE_ITER, "grad_f": callbacks[0], "jac_g": callbacks[1],
            "hess_lag": callbacks[2]}
    stop = convergence.DecrementStop(nlp, bounds, interruption) if convergence.applies(nlp) else None
    if stop is not None:
        opts["iteration_callback"] = stop
    callbacks.append(stop)
    if linear_solver == "spral":
        os.environ.setdefault("OMP_CANCELLATION", "TRUE")
        os.environ.setdefault("OMP_PROC_BIND", "TRUE")
    solver = ca.nlpsol("casrecon_fit", "ipopt", {"x": nlp.z, "f": f, "g": nlp.constraints}, opts)
    return solver, callbacks


def solve(nlp: Nlp, z0: np.ndarray, linear_solver: str = "mumps", max_iter: int = 200, tol: float = 1e-6,
          print_level: int = 0, bounds: tuple[np.ndarray, np.ndarray] | None = None) -> SolveResult:
    """Build the solver and run Ipopt from ``z0`` (scaled); ``bounds`` = (lbx, ubx), scaled."""
    t0 = time.perf_counter()
    solver, callbacks = make_solver(nlp, linear_solver, max_iter, tol, print_level, bounds)
    t1 = time.perf_counter()
    n_g = nlp.constraints.numel()
    lbx, ubx = bounds if bounds is not None else (-np.inf, np.inf)
    sol = solver(x0=z0, lbg=np.zeros(n_g), ubg=np.zeros(n_g), lbx=lbx, ubx=ubx)
    # Ctrl-C or SIGTERM during the solve stopped Ipopt: stop the caller too
    callbacks[0].interruption.after_solve(str(solver.stats()["return_status"]))
    z = np.asarray(sol["x"]).ravel()
    converged, status, decrement = _judge(nlp, solver.stats(), callbacks[-1], z, np.asarray(sol["g"]).ravel(), bounds)
    t2 = time.perf_counter()
    return SolveResult(z=z, lam_g=np.asarray(sol["lam_g"]).ravel(), objective=float(sol["f"]), converged=converged,
                       status=status, iterations=int(solver.stats()["iter_count"]), build_s=t1 - t0, solve_s=t2 - t1,
                       hessian=nlp.derivatives.hessian, linear_solver=linear_solver, decrement=decrement)


def _judge(nlp: Nlp, stats: dict, stop, z: np.ndarray, g: np.ndarray, bounds) -> tuple[bool, str, float | None]:
    """(converged, status, Gauss-Newton decrement): Ipopt's verdict, or the decrement test's when
    it stopped Ipopt or when Ipopt ended unconverged at a feasible iterate."""
    status = str(stats["return_status"])
    if stop is not None and stop.stopped_at is not None:
        return True, f"Converged (Gauss-Newton decrement {stop.stopped_at:.2g} chi2)", stop.stopped_at
    if stats["success"] or stop is None:
        return bool(stats["success"]), status, None
    delta = convergence.decrement_if_feasible(nlp, z, g, bounds)
    if delta is None:
        return False, status, None
    if delta <= convergence.DECREMENT_TOL:
        return True, f"Converged (Gauss-Newton decrement {delta:.2g} chi2; Ipopt: {status})", delta
    return False, f"{status}; Gauss-Newton decrement {delta:.3g} chi2", delta
