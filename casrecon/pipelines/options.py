"""The options of a fit run, parsed and validated once: what ``casrecon fit`` / ``casrecon joint`` take
on the command line and :func:`casrecon.fit` / :func:`casrecon.fit_joint` take as keywords."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from casrecon.io.errors import InputError

#: Allowed values of the solver overrides (None keeps the problem's ``[estimation]`` setting).
LINEAR_SOLVERS = ("mumps", "spral")
HESSIANS = ("gauss-newton", "exact")
SOLVERS = ("auto", "ipopt")
METHODS = ("map", "marginal")


@dataclass(frozen=True)
class FitOptions:
    """Options of one fit run.

    Attributes
    ----------
    linear_solver : {"mumps", "spral"} or None
        Ipopt's linear solver; None: the problem's ``[estimation] linear_solver``.
    hessian : {"gauss-newton", "exact"} or None
        Ipopt's Hessian; None: ``[estimation] hessian``.
    solver : {"auto", "ipopt"} or None
        "auto": the null-space Gauss-Newton solver where it applies, else Ipopt; None:
        ``[estimation] solver``.
    method : {"map", "marginal"} or None
        Joint MAP, or the parameters at the maximum of their Laplace marginal likelihood; None:
        ``[estimation] method``.
    print_level : int
        Ipopt's print level (0 silent, 5 every iteration).
    kinematic_check : bool
        Also reconstruct the drop from its IMU without the aero model and compare the aero
        coefficients (``implied_aero.csv``, ``kinematic_check.csv``/``.json``; 6-DOF problems).
    concurrent : bool
        Compute the fit's products on a second core in forked processes (the same numbers; for a
        command, not inside worker processes).

    The four solver overrides and ``kinematic_check`` apply to 6-DOF problems only: a point-mass or
    kinematic problem given one is an InputError rather than a silently ignored option.
    """

    linear_solver: str | None = None
    hessian: str | None = None
    solver: str | None = None
    method: str | None = None
    print_level: int = 0
    kinematic_check: bool = False
    concurrent: bool = False

    def __post_init__(self) -> None:
        for name, allowed in (("linear_solver", LINEAR_SOLVERS), ("hessian", HESSIANS), ("solver", SOLVERS),
                              ("method", METHODS)):
            value = getattr(self, name)
            if value is not None and value not in allowed:
                raise ValueError(f"{name} must be one of {', '.join(allowed)} or None, got {value!r}")

    @property
    def solver_overrides(self) -> dict[str, str | int | None]:
        """The keyword arguments of the 6-DOF estimators (``fit_drop``, the joint ``fit_joint``)."""
        return {"linear_solver": self.linear_solver, "hessian": self.hessian, "solver": self.solver,
                "method": self.method, "print_level": self.print_level}

    def require_six_dof_options_unset(self, problem: Path, kind: str) -> None:
        """InputError naming ``problem`` when an option that only a 6-DOF fit has is set for a
        problem of another ``kind``."""
        given = [name for name in ("linear_solver", "hessian", "solver", "method") if getattr(self, name) is not None]
        given += ["kinematic_check"] if self.kinematic_check else []
        if given:
            raise InputError(problem, f"{', '.join(given)} applies to 6-DOF problems only, and this is a "
                                      f"{kind} problem", field="problem.kind")


#: The options of a plain run: every setting from the problem's own tables.
DEFAULT_OPTIONS = FitOptions()
