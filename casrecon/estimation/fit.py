"""The per-drop fit as one call: data, mesh, NLP, initial guess, Ipopt, covariance, bands.

``fit_drop(scenario)`` returns a :class:`FitResult` or raises :class:`FitError` with the reason
(no convergence, singular KKT matrix, unusable data); it never writes files.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, field

import numpy as np

from casrecon.estimation.bands import COLUMNS, trajectory_with_bands
from casrecon.estimation.covariance import Covariance, SingularCovariance, compute_covariance
from casrecon.estimation.fitdata import FitData, FitDataError, load_fit_data
from casrecon.estimation.initial_guess import initial_guess
from casrecon.estimation.parameters import ParameterSet, parameter_set
from casrecon.estimation.problem import DropPart, FitNlp, build_nlp
from casrecon.estimation.solve import SolveResult, solve
from casrecon.estimation.transcription import Mesh, make_mesh
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


def _chi2(nlp: FitNlp, part: DropPart, r: np.ndarray) -> tuple[dict[str, float], dict[str, int]]:
    """chi-square and measurement count per residual group of one drop (IMU includes the constant
    part of its QR compression, and counts samples, not compressed rows)."""
    chi2, counts = {}, {}
    for g, s in part.groups.items():
        key = g.split("/")[-1]
        chi2[key] = float(r[s] @ r[s])
        counts[key] = s.stop - s.start
    if part.imu_blocks is not None:
        chi2["imu"] += float(part.imu_blocks.const_chi2.sum())
        counts["imu"] = int(part.imu_blocks.n_used.sum())
    return chi2, counts


def residual_vector(nlp: FitNlp, z: np.ndarray) -> np.ndarray:
    import casadi as ca

    return np.asarray(ca.Function("residuals", [nlp.z], [nlp.residuals])(z)).ravel()


def drop_result(scenario: Scenario, data: FitData, part: DropPart, nlp: FitNlp, sol: SolveResult,
                cov: Covariance, r: np.ndarray, timings: dict[str, float]) -> FitResult:
    """The :class:`FitResult` of one drop of a solved NLP (the whole NLP for a per-drop fit)."""
    cov_theta = cov.covariance_of(part.theta_cols, part.params.scales)
    sigma = np.sqrt(np.diag(cov_theta))
    table, table_sigma = trajectory_with_bands(scenario.model, part, sol.z, cov)
    chi2, counts = _chi2(nlp, part, r)
    dof = sum(counts.values()) - (nlp.z.numel() - nlp.constraints.numel())
    result = FitResult(
        scenario=scenario, data=data, params=part.params, values=part.values(sol.z), sigma=sigma,
        correlation=cov_theta / np.outer(sigma, sigma), node_time_s=part.mesh.t_nodes,
        flight_time_s=part.mesh.t_nodes - data.release_imu_s, states=part.states(sol.z),
        columns=tuple(c for c, _ in COLUMNS), table=table, table_sigma=table_sigma, chi2=chi2,
        n_measurements=counts, dof=dof, reduced_chi2=cov.reduced_chi2, solver=sol, timings=timings,
        condition=cov.condition, notes=data.notes)
    result.extra.update(covariance=cov, nlp=nlp, part=part, z=sol.z)
    return result


def prepare_drop(scenario: Scenario) -> tuple[FitData, Mesh]:
    """Read a drop's data and lay its mesh, turning data problems into FitError."""
    try:
        data = load_fit_data(scenario.config)
        return data, make_mesh(data.imu_time_s, scenario.config.estimation.samples_per_interval)
    except (FitDataError, ValueError) as err:
        raise FitError(str(err)) from None


def fit_drop(scenario: Scenario, *, linear_solver: str | None = None, hessian: str | None = None,
             print_level: int = 0) -> FitResult:
    """Reconstruct one drop (DESIGN section 1). Raises FitError when the result is not usable."""
    cfg = scenario.config
    est = cfg.estimation
    t0 = time.perf_counter()
    data, mesh = prepare_drop(scenario)
    params = parameter_set(cfg)
    nlp = build_nlp(scenario.model, data, mesh, params, cfg, hessian or est.hessian)
    t1 = time.perf_counter()
    x0 = initial_guess(data, mesh, cfg.vehicle, scenario.atmosphere, cfg.site.ground_alt_msl_m)
    z0 = nlp.pack(x0, np.zeros(params.n))
    t2 = time.perf_counter()
    sol = solve(nlp, z0, linear_solver or est.linear_solver, est.max_iter, est.tol, print_level)
    check_converged(sol)
    t3 = time.perf_counter()
    r = residual_vector(nlp, sol.z)
    cov = covariance_or_fail(nlp, sol.z, r)
    timings = {"build_s": (t1 - t0) + sol.build_s, "initial_guess_s": t2 - t1, "solve_s": sol.solve_s}
    result = drop_result(scenario, data, nlp.parts[0], nlp, sol, cov, r, timings)
    t4 = time.perf_counter()
    timings.update(covariance_s=t4 - t3, total_s=t4 - t0)
    return result


def check_converged(sol: SolveResult) -> None:
    if not sol.converged:
        raise FitError(f"Ipopt did not converge: {sol.status} after {sol.iterations} iterations "
                       f"(objective {sol.objective:.6g}); no result written")


def covariance_or_fail(nlp: FitNlp, z: np.ndarray, r: np.ndarray) -> Covariance:
    """KKT covariance; FitError when singular. chi2 includes the IMU compression constants."""
    imu = [p for p in nlp.parts if p.imu_blocks is not None]
    chi2 = float(r @ r) + sum(float(p.imu_blocks.const_chi2.sum()) for p in imu)
    n_meas = r.size + sum(int(p.imu_blocks.n_used.sum()) - p.groups_size("imu") for p in imu)
    dof = n_meas - (nlp.z.numel() - nlp.constraints.numel())
    try:
        return compute_covariance(nlp, z, chi2, dof)
    except SingularCovariance as err:
        raise FitError(str(err)) from None
