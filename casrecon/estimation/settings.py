"""Solver settings of a fit, resolved once per drop from its ``[estimation]`` table and used by
the per-drop and the joint fit alike (a joint fit takes the first drop's, and says when the drops
disagree)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from casrecon.io.problem import EstimationConfig


@dataclass(frozen=True)
class FitSettings:
    """How the NLP is solved.

    Parameters
    ----------
    hessian : {"gauss-newton", "exact"}
        Hessian given to Ipopt ("auto" already resolved).
    linear_solver : {"mumps", "spral"}
        Ipopt's linear solver.
    solver : {"auto", "ipopt"}
        See :func:`~casrecon.estimation.engine.solve.solve` (``method``).
    method : {"map", "marginal"}
        Estimator: joint MAP, or the parameters' Laplace marginal likelihood (see
        :mod:`~casrecon.estimation.engine.laplace`).
    max_iter : int
        Ipopt iteration limit.
    tol : float
        Ipopt tolerance (scaled optimality error).
    print_level : int
        Ipopt print level (0: silent).
    """

    hessian: str = "gauss-newton"
    linear_solver: str = "mumps"
    solver: str = "auto"
    method: str = "map"
    max_iter: int = 200
    tol: float = 1e-6
    print_level: int = 0

    @classmethod
    def from_estimation(cls, est: EstimationConfig, **overrides) -> FitSettings:
        """The settings of an ``[estimation]`` table; keyword overrides that are None are ignored."""
        base = cls(est.resolved_hessian(), est.linear_solver, est.solver, est.method, est.max_iter, est.tol)
        return dataclasses.replace(base, **{k: v for k, v in overrides.items() if v is not None})
