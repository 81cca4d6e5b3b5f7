"""Solver settings of a fit, resolved once per drop from its ``[estimation]`` table and used by
the per-drop and the joint fit alike (a joint fit takes the first drop's, and says when the drops
disagree)."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

from casrecon.io.estimation_config import EstimationConfig


@dataclass(frozen=True)
class FitSettings:
    """How the NLP is solved: an ``[estimation]`` table with its "auto" Hessian resolved
    (:meth:`from_estimation`; its defaults are :class:`~casrecon.io.estimation_config.EstimationConfig`'s,
    written there only) and the run's overrides.

    Parameters
    ----------
    hessian : {"gauss-newton", "exact"}
        Hessian given to Ipopt ("auto" already resolved).
    information : {"auto", "observed", "expected"}
        Curvature the covariance inverts (see
        :func:`~casrecon.estimation.engine.covariance.compute_covariance`); "auto" is resolved
        per NLP by :meth:`information_for`.
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
    decrement_tol : float or None
        Gauss-Newton decrement (chi-square) at which the Gauss-Newton solvers stop; None: their own
        (see :func:`~casrecon.estimation.engine.solve.solve`). Looser only for a fit made to
        estimate the error models' sizes from (:data:`~casrecon.estimation.sixdof.fit.SIZING_DECREMENT`).
    """

    hessian: str
    information: str
    linear_solver: str
    solver: str
    method: str
    max_iter: int
    tol: float
    print_level: int = 0
    decrement_tol: float | None = None

    @classmethod
    def from_estimation(cls, est: EstimationConfig, **overrides) -> FitSettings:
        """The settings of an ``[estimation]`` table; keyword overrides that are None are ignored."""
        base = cls(est.resolved_hessian(), est.information, est.linear_solver, est.solver, est.method, est.max_iter,
                   est.tol)
        return dataclasses.replace(base, **{k: v for k, v in overrides.items() if v is not None})

    def information_for(self, parts) -> str:
        """The covariance's curvature for an NLP of these drop ``parts``
        (:class:`~casrecon.estimation.sixdof.layout.DropLayout`): ``information`` unless "auto", which
        is "observed" when a drop has atmosphere-profile or GPS-error unknowns (the fits for data
        the plain model does not fit, where the two curvatures part) and "expected" otherwise."""
        if self.information != "auto":
            return self.information
        with_errors = any(p.profile is not None or p.eliminated_cols.size for p in parts)
        return "observed" if with_errors else "expected"
