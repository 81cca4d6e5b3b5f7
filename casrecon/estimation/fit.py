"""The per-drop fit as one call: data, mesh, NLP, initial guess, Ipopt, covariance, bands.

``fit_drop(scenario)`` returns a :class:`FitResult` or raises :class:`FitError` with the reason
(no convergence, singular KKT matrix, unusable data); it never writes files.
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np

from casrecon.estimation.bands import MAX_BAND_NODES, columns_of, trajectory_with_bands
from casrecon.estimation.covariance import Covariance, SingularCovariance, compute_covariance
from casrecon.estimation.fitdata import FitData, FitDataError, load_fit_data
from casrecon.estimation.initial_guess import initial_guess
from casrecon.estimation.parameters import ParameterSet, parameter_set
from casrecon.estimation.problem import DropPart, FitNlp, build_nlp
from casrecon.estimation.solve import SolveResult, solve
from casrecon.estimation.transcription import Mesh, make_mesh
from casrecon.physics.dynamics import DISTURBANCE_NAMES
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
    covariance: Covariance             # of the whole NLP (joint fits: shared by every drop)
    nlp: FitNlp                        # the NLP solved (joint fits: the joint NLP)
    part: DropPart                     # where this drop sits in ``nlp``
    z: np.ndarray                      # scaled decision vector at the solution
    residuals: np.ndarray              # whitened residual vector of ``nlp`` at ``z``
    notes: tuple[str, ...] = ()

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
        columns=columns_of(part), table=table, table_sigma=table_sigma, chi2=chi2,
        n_measurements=counts, dof=dof, reduced_chi2=cov.reduced_chi2, solver=sol, timings=timings,
        condition=cov.condition, covariance=cov, nlp=nlp, part=part, z=sol.z, residuals=r,
        notes=data.notes + _weak_constraint_notes(part))
    return result


def _weak_constraint_notes(part: DropPart) -> tuple[str, ...]:
    if not part.n_u:
        return ()
    names = ", ".join(DISTURBANCE_NAMES[i] for i in part.active)
    return (f"weak constraint: {names} estimated at every node with a Gauss-Markov prior; covariance from a sparse LU "
            f"of the KKT matrix, 3-sigma bands computed at {min(MAX_BAND_NODES, part.mesh.t_nodes.size)} nodes "
            "and interpolated between them",)


def prepare_drop(scenario: Scenario) -> tuple[FitData, Mesh]:
    """Read a drop's data and lay its mesh, turning data problems into FitError."""
    try:
        data = load_fit_data(scenario.config)
        return data, make_mesh(data.imu_time_s, scenario.config.estimation.mesh_samples(scenario.config.imu.rate_hz))
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
    x0 = initial_guess(data, mesh, cfg.vehicle, scenario.atmosphere, cfg.site.ground_alt_msl_m)
    t1 = time.perf_counter()

    def build(guesses: dict[str, float]) -> FitNlp:
        return build_nlp(scenario.model, data, mesh, params, cfg, hessian or est.resolved_hessian(), guesses[cfg.name])

    def start(nlp: FitNlp) -> np.ndarray:
        return nlp.pack(x0, np.zeros(params.n))

    nlp, sol, build_s = solve_fit(build, start, {cfg.name: est.clock_offset_guess_s},
                                  dict(linear_solver=linear_solver or est.linear_solver, max_iter=est.max_iter,
                                       tol=est.tol, print_level=print_level))
    t3 = time.perf_counter()
    r = residual_vector(nlp, sol.z)
    cov = covariance_or_fail(nlp, sol.z, r)
    timings = {"build_s": build_s, "initial_guess_s": t1 - t0, "solve_s": sol.solve_s}
    result = drop_result(scenario, data, nlp.parts[0], nlp, sol, cov, r, timings)
    t4 = time.perf_counter()
    timings.update(covariance_s=t4 - t3, total_s=t4 - t0)
    return result


def max_clock_shifts(nlp: FitNlp) -> int:
    """How many times a clock-offset guess may move by one mesh interval: enough to cross 3 sigma
    of its prior (beyond that :func:`_check_clock_plausible` stops the fit anyway), plus one."""
    shifts = [1]
    for part in nlp.parts:
        if "clock_offset_s" in part.params.names:
            spec = part.params.specs[part.params.index("clock_offset_s")]
            shifts.append(int(np.ceil(3 * (spec.prior_sigma or spec.scale) / part.mesh.h)) + 1)
    return max(shifts)


def solve_fit(build, start, guesses: dict[str, float], solve_kw: dict):
    """Build and solve, keeping every GPS fix on its collocation interval.

    Each drop's clock offset is bounded to one mesh interval around its guess. When a solution ends
    on such a bound, the guess moves there, the fixes are reassigned to intervals and the fit is
    redone from that solution (at most :func:`max_clock_shifts` times).

    Returns (nlp, SolveResult, build seconds).
    """
    z, build_s, attempt, limit = None, 0.0, 0, 1
    while attempt <= limit:
        t = time.perf_counter()
        nlp = build(guesses)
        build_s += time.perf_counter() - t
        limit = max_clock_shifts(nlp)
        z0 = start(nlp) if z is None else z.copy()
        for part in nlp.parts:
            if "clock_offset_s" in part.params.names:
                i = part.params.index("clock_offset_s")
                z0[part.theta_cols[i]] = part.guess_clock_s / part.params.scales[i]
        if attempt == 0:
            check_determined(nlp, z0)
        bounds = clock_bounds(nlp)
        sol = solve(nlp, z0, bounds=bounds, **solve_kw)
        build_s += sol.build_s
        check_converged(sol, nlp)
        moved = clocks_at_bound(sol, nlp, bounds)
        if not moved:
            return nlp, sol, build_s
        _check_clock_plausible(nlp, moved)
        guesses.update(moved)
        z = sol.z
        attempt += 1
    raise FitError(f"the IMU-to-GPS clock offset kept reaching its bound after {limit} shifts "
                   f"({', '.join(f'{k} {v:+.3f} s' for k, v in moved.items())}); give [estimation] "
                   "clock_offset_guess_s")


def check_determined(nlp: FitNlp, z: np.ndarray) -> None:
    """FitError before solving when a parameter has no effect on any residual or constraint and no
    prior (its column of the KKT matrix is zero, so the matrix is singular whatever the data)."""
    jg = nlp.derivatives.jacobian_g(z)
    in_g = np.zeros(nlp.z.numel(), bool)
    g_cols = np.asarray(jg.sparsity().get_triplet()[1])
    in_g[g_cols[np.asarray(jg.nonzeros()) != 0.0]] = True
    jtj = nlp.derivatives.gauss_newton(z)
    diag = np.zeros(nlp.z.numel())
    sp = jtj.sparsity()
    rows, cols = sp.get_triplet()
    values = np.asarray(jtj.nonzeros())
    on_diag = np.asarray(rows) == np.asarray(cols)
    diag[np.asarray(rows)[on_diag]] = values[on_diag]
    names = nlp.parameter_columns()
    dead = [name for col, name in names.items() if diag[col] == 0.0 and not in_g[col]]
    if dead:
        raise FitError(f"KKT matrix singular: {', '.join(dead)} affect(s) no residual or constraint and carry "
                       "no prior, so nothing determines them; fix them or switch their prior on")


def clock_bounds(nlp: FitNlp) -> tuple[np.ndarray, np.ndarray]:
    """Scaled bounds: each drop's clock offset within one mesh interval of its guess (so every GPS
    fix stays on its collocation interval); everything else free."""
    n = nlp.z.numel()
    lbx, ubx = np.full(n, -np.inf), np.full(n, np.inf)
    for part in nlp.parts:
        if "clock_offset_s" in part.params.names:
            i = part.params.index("clock_offset_s")
            guess = part.guess_clock_s
            col, scale = part.theta_cols[i], part.params.scales[i]
            lbx[col], ubx[col] = (guess - part.mesh.h) / scale, (guess + part.mesh.h) / scale
    return lbx, ubx


def _check_clock_plausible(nlp: FitNlp, moved: dict[str, float]) -> None:
    """FitError when a clock offset runs beyond 3 sigma of its prior: the data are then being bent
    to a model that does not fit them (or the clock guess is far off)."""
    for part in nlp.parts:
        if part.name in moved and "clock_offset_s" in part.params.names:
            spec = part.params.specs[part.params.index("clock_offset_s")]
            limit = 3 * (spec.prior_sigma or spec.scale)
            if abs(moved[part.name]) > limit:
                raise FitError(f"{part.name}: the IMU-to-GPS clock offset runs to {moved[part.name]:+.3f} s, beyond 3 "
                               f"sigma of its prior ({limit:.3f} s); the model probably does not fit the data (or "
                               "give [estimation] clock_offset_guess_s, or hold the clock with estimate_clock = false)")


def clocks_at_bound(sol: SolveResult, nlp: FitNlp, bounds) -> dict[str, float]:
    """{drop: clock offset (s)} of the drops whose clock offset ended on its bound."""
    moved = {}
    for part in nlp.parts:
        if "clock_offset_s" not in part.params.names:
            continue
        i = part.params.index("clock_offset_s")
        col = part.theta_cols[i]
        width = bounds[1][col] - bounds[0][col]
        if min(sol.z[col] - bounds[0][col], bounds[1][col] - sol.z[col]) < 1e-4 * width:
            moved[part.name] = float(sol.z[col] * part.params.scales[i])
    return moved


def check_converged(sol: SolveResult, nlp: FitNlp | None = None) -> None:
    """FitError when Ipopt failed; says whether the KKT matrix at its last iterate is singular."""
    if sol.converged:
        return
    why = ""
    if nlp is not None:
        try:
            compute_covariance(nlp, sol.z, 1.0, 1)
        except SingularCovariance as err:
            why = f"; at the last iterate the {err}"
        except Exception:  # noqa: BLE001 - a diagnosis attempt must not hide the real failure
            pass
    raise FitError(f"Ipopt did not converge: {sol.status} after {sol.iterations} iterations "
                   f"(objective {sol.objective:.6g}){why}; no result written")


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
