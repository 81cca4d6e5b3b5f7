"""The per-drop fit as one call: data, mesh, NLP, initial guess, Ipopt, covariance, bands.

``fit_drop(scenario)`` returns a :class:`FitResult` or raises :class:`FitError` with the reason
(no convergence, singular KKT matrix, unusable data); it never writes files.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field, replace

import numpy as np

from casrecon.estimation.bands import COLUMNS, trajectory_with_bands
from casrecon.estimation.covariance import Covariance, SingularCovariance, compute_covariance
from casrecon.estimation.fitdata import FitData, FitDataError, load_fit_data
from casrecon.estimation.initial_guess import initial_guess
from casrecon.estimation.parameters import ParameterSet, parameter_set
from casrecon.estimation.problem import FitNlp, build_nlp
from casrecon.estimation.solve import SolveResult, solve
from casrecon.estimation.transcription import make_mesh
from casrecon.scenario import Scenario


class FitError(RuntimeError):
    """The fit did not produce a trustworthy result; the message says why."""


@dataclass
class FitResult:
    """Everything a per-drop fit produced (SI units unless a column name says otherwise)."""

    scenario: Scenario
    data: FitData
    params: ParameterSet
    values: np.ndarray                 # parameter estimates
    sigma: np.ndarray                  # absolute 1-sigma
    correlation: np.ndarray
    node_time_s: np.ndarray            # IMU clock
    flight_time_s: np.ndarray          # since release
    states: np.ndarray                 # (K, 13)
    columns: tuple[str, ...]
    table: np.ndarray                  # (K, len(columns)) values
    table_sigma: np.ndarray            # absolute 1-sigma
    chi2: dict[str, float]
    n_measurements: dict[str, int]
    dof: int
    reduced_chi2: float
    solver: SolveResult
    timings: dict[str, float]
    condition: float
    notes: tuple[str, ...] = ()
    extra: dict = field(default_factory=dict)

    @property
    def converged(self) -> bool:
        return self.solver.converged

    def parameter(self, name: str) -> tuple[float, float]:
        """(value, absolute 1-sigma) of one parameter."""
        i = self.params.index(name)
        return float(self.values[i]), float(self.sigma[i])

    def column(self, name: str) -> tuple[np.ndarray, np.ndarray]:
        """(values, 1-sigma) of one time-history column."""
        i = self.columns.index(name)
        return self.table[:, i], self.table_sigma[:, i]


def _chi2(nlp: FitNlp, z: np.ndarray, residual_fn) -> tuple[dict[str, float], dict[str, int]]:
    r = np.asarray(residual_fn(z)).ravel()
    chi2 = {g: float(r[s] @ r[s]) for g, s in nlp.groups.items()}
    blocks = nlp.imu_blocks
    chi2["imu"] += float(blocks.const_chi2.sum())
    counts = {g: s.stop - s.start for g, s in nlp.groups.items()}
    counts["imu"] = int(blocks.n_used.sum())
    return chi2, counts


def fit_drop(scenario: Scenario, *, linear_solver: str | None = None, hessian: str | None = None,
             print_level: int = 0) -> FitResult:
    """Reconstruct one drop (DESIGN section 1). Raises FitError when the result is not usable."""
    import casadi as ca

    cfg = scenario.config
    est = cfg.estimation
    hessian = hessian or est.hessian
    linear_solver = linear_solver or est.linear_solver
    t0 = time.perf_counter()
    try:
        data = load_fit_data(cfg)
        mesh = make_mesh(data.imu_time_s, est.samples_per_interval)
    except (FitDataError, ValueError) as err:
        raise FitError(str(err)) from None
    params = parameter_set(cfg)
    nlp = build_nlp(scenario.model, data, mesh, params, cfg, hessian)
    t1 = time.perf_counter()
    x0 = initial_guess(data, mesh, cfg.vehicle, scenario.atmosphere, cfg.site.ground_alt_msl_m)
    z0 = nlp.pack(x0, np.zeros(params.n))
    t2 = time.perf_counter()
    sol = solve(nlp, z0, linear_solver, est.max_iter, est.tol, print_level)
    if not sol.converged:
        raise FitError(f"Ipopt did not converge: {sol.status} after {sol.iterations} iterations "
                       f"(objective {sol.objective:.6g}); no result written")
    t3 = time.perf_counter()
    residual_fn = ca.Function("residuals", [nlp.z], [nlp.residuals])
    chi2, counts = _chi2(nlp, sol.z, residual_fn)
    n_free = nlp.z.numel() - nlp.constraints.numel()
    dof = sum(counts.values()) - n_free
    try:
        cov = compute_covariance(nlp, sol.z, sum(chi2.values()), dof)
    except SingularCovariance as err:
        raise FitError(str(err)) from None
    states, values = nlp.unpack(sol.z)
    part = nlp.parts[0]
    cov_theta = cov.covariance_of(part.theta_cols, params.scales)
    sigma = np.sqrt(np.diag(cov_theta))
    table, table_sigma = trajectory_with_bands(scenario.model, part, sol.z, cov)
    t4 = time.perf_counter()
    timings = {"data_s": t1 - t0 - 0.0, "build_s": (t1 - t0) + sol.build_s, "initial_guess_s": t2 - t1,
               "solve_s": sol.solve_s, "covariance_s": t4 - t3, "total_s": t4 - t0}
    result = FitResult(
        scenario=scenario, data=data, params=params, values=values, sigma=sigma,
        correlation=cov_theta / np.outer(sigma, sigma), node_time_s=mesh.t_nodes,
        flight_time_s=mesh.t_nodes - data.release_imu_s, states=states,
        columns=tuple(c for c, _ in COLUMNS), table=table, table_sigma=table_sigma, chi2=chi2,
        n_measurements=counts, dof=dof, reduced_chi2=cov.reduced_chi2, solver=sol, timings=timings,
        condition=cov.condition, notes=data.notes)
    result.extra["covariance"] = cov
    result.extra["nlp"] = nlp
    result.extra["z"] = sol.z
    return replace(result)
