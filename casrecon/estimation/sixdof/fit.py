"""The per-drop fit as one call: data, mesh, NLP, initial guess, Ipopt, covariance, bands.

``fit_drop(scenario)`` returns a :class:`FitResult` or raises
:class:`~casrecon.estimation.engine.checks.FitError` with the reason (no convergence, singular KKT
matrix, unusable data); it never writes files. :class:`FitSettings` holds the solver settings of
a drop, resolved once from its ``[estimation]`` table, for the per-drop and the joint fit alike.
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from casrecon.estimation.engine.checks import (
    FitError,
    covariance_or_fail,
)
from casrecon.estimation.engine.convergence import fit_stage, iteration_logging, nested_label
from casrecon.estimation.engine.covariance import Covariance
from casrecon.estimation.engine.kkt_covariance import KktCovariance
from casrecon.estimation.engine.laplace import marginal_solution
from casrecon.estimation.engine.nlp import Nlp
from casrecon.estimation.engine.solve import SolveResult
from casrecon.estimation.error_models.error_model_sigma import estimate_error_sizes, gps_estimated
from casrecon.estimation.error_models.plausibility import implausible, judged_again, not_refitted_text
from casrecon.estimation.error_models.profile_sigma import MAX_REFITS, ProfileSigmaEstimate, profile_refit, refit_text
from casrecon.estimation.error_models.size_uncertainty import with_size_uncertainty
from casrecon.estimation.kinds.base import MeasurementKind
from casrecon.estimation.kinds.sample_terms import SampleTerms
from casrecon.estimation.kinds.samples import SampleKind, check_kinds
from casrecon.estimation.sixdof.bands import MAX_BAND_NODES, columns_of, trajectory_with_bands
from casrecon.estimation.sixdof.continuation import clock_bounds, held_clock_text, solve_fit, transferred
from casrecon.estimation.sixdof.drop import MEASUREMENT_KINDS, FitNlp, build_nlp, load_measurements, parameter_set
from casrecon.estimation.sixdof.fitdata import FitData, FitDataError, load_fit_data
from casrecon.estimation.sixdof.initial_guess import initial_guess
from casrecon.estimation.sixdof.layout import DropLayout
from casrecon.estimation.sixdof.parameters import ParameterSet
from casrecon.estimation.sixdof.settings import FitSettings
from casrecon.estimation.sixdof.transcription import Mesh, make_mesh
from casrecon.io.errors import InputError
from casrecon.io.estimation_config import INTERVAL_S
from casrecon.io.problem import ProblemConfig
from casrecon.physics.dynamics import DISTURBANCE_NAMES
from casrecon.scenario import Scenario


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
    table_sigma: np.ndarray | None     # absolute 1-sigma (None only inside fit_drop: see with_bands)
    chi2: dict[str, float]
    n_measurements: dict[str, int]
    dof: int
    reduced_chi2: float
    solver: SolveResult
    timings: dict[str, float]
    condition: float
    covariance: Covariance | KktCovariance  # of the whole NLP (joint fits: shared by every drop)
    nlp: Nlp                           # the NLP solved (joint fits: the joint NLP)
    part: DropLayout                   # where this drop sits in ``nlp``
    measurements: dict                 # each measurement kind's data, by kind name
    z: np.ndarray                      # scaled decision vector at the solution
    residuals: np.ndarray              # whitened residual vector of ``nlp`` at ``z``
    notes: tuple[str, ...] = ()
    fit_nlp: FitNlp | None = None      # the NLP with its drops (joint fits: shared by every drop)
    gross_errors: tuple[str, ...] = ()  # error-model estimates beyond the plausibility limits (verdict findings)
    uncertainty: str = "model"  # "widened": sigmas and bands from the time-block sandwich (see
    #                             casrecon/analysis/widened_uncertainty.py)

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

    def group(self, name: str) -> str:
        """This drop's name of the residual group ``name`` in ``nlp`` (prefixed in a joint fit)."""
        prefixed = f"{self.part.name}/{name}"
        return prefixed if prefixed in self.nlp.groups else name


def drop_statistics(fit_nlp: FitNlp, part: DropLayout, r: np.ndarray) -> tuple[dict, dict, int]:
    """chi-square and measurement count per residual group of one drop (group names without the
    drop prefix; IMU counts samples, and includes its compression constant), and the drop's dof:
    its measurements minus the free directions of the columns it sees (its nodes, latent values
    and parameters, shared ones included) less its constraints. For a per-drop fit this is the
    fit's dof; in a joint fit the drops' dofs add up to less than the joint dof."""
    nlp, prefix = fit_nlp.nlp, f"{part.name}/"
    mine = [g for g in nlp.groups if g.startswith(prefix)] if len(fit_nlp.parts) > 1 else list(nlp.groups)
    chi2 = {g.removeprefix(prefix): v for g, v in nlp.group_chi2(r, mine).items()}
    counts = {g.removeprefix(prefix): nlp.n_measurements[g] for g in mine}
    n_cols = part.n_state_vars + part.n_u_values + part.params.n + part.n_extra
    n_constraints = part.n_states * part.mesh.n_intervals + 1
    return chi2, counts, sum(counts.values()) - (n_cols - n_constraints)


def drop_result(scenario: Scenario, data: FitData, fit_nlp: FitNlp, index: int, sol: SolveResult,
                cov: Covariance | KktCovariance, r: np.ndarray, timings: dict[str, float],
                bands: bool = True) -> FitResult:
    """The :class:`FitResult` of drop ``index`` of a solved NLP (the whole NLP for a per-drop fit);
    ``bands=False`` leaves its ``table_sigma`` None (for :func:`with_bands` to add, if it stands)."""
    nlp, part = fit_nlp.nlp, fit_nlp.parts[index]
    cov_theta = cov.covariance_of(part.theta_cols, part.params.scales)
    sigma = np.sqrt(np.diag(cov_theta))
    table, table_sigma = trajectory_with_bands(scenario.model, part, sol.z, cov if bands else None)
    chi2, counts, dof = drop_statistics(fit_nlp, part, r)
    result = FitResult(
        scenario=scenario, data=data, params=part.params, values=part.values(sol.z), sigma=sigma,
        correlation=cov_theta / np.outer(sigma, sigma), node_time_s=part.mesh.t_nodes,
        flight_time_s=part.mesh.t_nodes - data.release_imu_s, states=part.states(sol.z),
        columns=columns_of(part), table=table, table_sigma=table_sigma, chi2=chi2,
        n_measurements=counts, dof=dof, reduced_chi2=sum(chi2.values()) / max(dof, 1), solver=sol, timings=timings,
        condition=cov.condition, covariance=cov, nlp=nlp, part=part, z=sol.z, residuals=r,
        measurements=dict(fit_nlp.contexts[index].measurements),
        notes=data.notes + weak_constraint_notes(part) + error_model_notes(scenario, part) + _placement_notes(sol),
        fit_nlp=fit_nlp, gross_errors=tuple(held_clock_text(part, clock_s)
                                            for name, clock_s in sol.clocks_held if name == part.name))
    return result


def with_bands(result: FitResult) -> FitResult:
    """``result`` with its trajectory bands (``table_sigma``) when it was made without them (a profile
    fit that a refit with the sigmas from the data may replace: the bands cost 0.3 s on ees-drop-1's
    profile fit and only the fit that stands needs them); their time is added to its ``covariance_s``
    and ``total_s``."""
    if result.table_sigma is not None:
        return result
    t0 = time.perf_counter()
    with fit_stage("trajectory bands"):
        _, table_sigma = trajectory_with_bands(result.scenario.model, result.part, result.z, result.covariance)
    spent = time.perf_counter() - t0
    timings = dict(result.timings)
    for key in ("covariance_s", "total_s"):
        timings[key] = timings.get(key, 0.0) + spent
    return dataclasses.replace(result, table_sigma=table_sigma, timings=timings)


def with_marginal_estimate(result: FitResult) -> FitResult:
    """A per-drop joint-MAP fit moved to the parameters' marginal-likelihood estimate (the same NLP,
    no refit; see :func:`~casrecon.estimation.engine.laplace.marginal_solution`), covariance and
    bands recomputed there. Raises FitError when the marginal estimate does not converge."""
    if result.fit_nlp is None or len(result.fit_nlp.parts) != 1:
        raise ValueError("with_marginal_estimate takes a per-drop fit result")
    t0 = time.perf_counter()
    nlp = result.nlp
    sol = marginal_solution(nlp, result.solver, clock_bounds(result.fit_nlp.parts, nlp.n_z))
    r = nlp.residual_vector(sol.z)
    # the curvature the MAP fit's covariance was asked for (a fallback there is tried again here)
    information = "expected" if result.covariance.information == "expected" else "observed"
    cov = covariance_or_fail(nlp, sol.z, r, information=information, lam_g=sol.lam_g)
    timings = dict(result.timings, marginal_s=time.perf_counter() - t0)
    return drop_result(result.scenario, result.data, result.fit_nlp, 0, sol, cov, r, timings)


def error_model_notes(scenario: Scenario, part: DropLayout) -> tuple[str, ...]:
    """One note per error model of the fit: the atmosphere-profile corrections and the GPS errors."""
    notes = []
    grid = part.profile
    if grid is not None:
        atm = scenario.config.atmosphere
        sizes = []
        if atm.profile_wind_sigma_mps > 0:
            sizes.append(f"wind {atm.profile_wind_sigma_mps:g} m/s per component")
        if atm.profile_density_sigma > 0:
            sizes.append(f"density {100 * atm.profile_density_sigma:g} %")
        what = ", ".join(sizes)
        notes.append(f"atmosphere-profile corrections ({what}, 1-sigma, {grid.length_m:g} m correlation length) "
                     f"estimated on {grid.n_levels} levels every {grid.step_m:g} m from "
                     f"{grid.base_msl_m:.0f} m MSL")
    errors = scenario.config.gps.error_model
    if errors.enabled:
        notes.append(errors.describe() + ", estimated at every fix")
    return tuple(notes)


def _placement_notes(sol: SolveResult) -> tuple[str, ...]:
    """A note when the atmosphere-profile windows had to be placed again by the fitted altitudes."""
    if not sol.profile_placements:
        return ()
    return (f"atmosphere-profile windows placed again by the fitted altitudes {sol.profile_placements} time(s): "
            "the GPS altitudes differ from the fitted ones by more than the windows' tolerance",)


#: Collocation interval (s) at or below which gust bands passed the whole-drop calibration study
#: (README, issue 13), the default with disturbance states; a gust fit on a coarser mesh gets a note
#: saying so.
GUST_MESH_S = INTERVAL_S


def weak_constraint_notes(part: DropLayout) -> tuple[str, ...]:
    """The report's notes on a fit's disturbance states (none without them): what is estimated and
    how its covariance is formed, and, for gust states on a mesh coarser than GUST_MESH_S, that
    their bands are too narrow there."""
    if not part.n_u:
        return ()
    names = ", ".join(DISTURBANCE_NAMES[i] for i in part.active)
    notes = [f"weak constraint: {names} estimated at every node and interval midpoint with a Gauss-Markov prior, "
             "and what they do between those points to first order (docs/design.md); covariance from a sparse "
             f"LU of the KKT matrix, 3-sigma bands computed at {min(MAX_BAND_NODES, part.mesh.t_nodes.size)} nodes "
             "and interpolated between them"]
    gusts = any(DISTURBANCE_NAMES[i].startswith("gust") for i in part.active)
    if gusts and part.mesh.h > GUST_MESH_S * 1.05:
        notes.append(f"gust states on a {1000 * part.mesh.h:.3g} ms mesh: what a gust does between the nodes is "
                     "modelled to first order (a departure from the quadratic through the node and midpoint values, "
                     "linearised on the initial guess), and the whole-drop calibration study passed on 25 ms; on a "
                     "coarser mesh that approximation is untested and the gust bands may be too narrow: leave "
                     f"[estimation] interval_s unset (it is then {GUST_MESH_S:g} s) or set it no coarser")
    return tuple(notes)


#: Largest relative difference between the declared IMU rate and the one measured in the file.
RATE_TOLERANCE = 0.02


def prepare_drop(scenario: Scenario) -> tuple[FitData, Mesh]:
    """Read and check a drop's data and lay its mesh, turning data problems into FitError (bad input files and
    the pre-solve data check's refusals stay :class:`~casrecon.io.errors.InputError`).

    The samples per interval come from the IMU rate measured in the file (median sample spacing);
    a declared ``[sensors.imu] rate_hz`` more than RATE_TOLERANCE away from it is an error (a
    400 Hz log declared as 500 Hz would otherwise get intervals 25 % longer than asked for).
    """
    cfg = scenario.config
    try:
        data = load_fit_data(cfg, scenario.sounding)
        measured_hz = 1.0 / float(np.median(np.diff(data.imu_time_s)))
        if abs(measured_hz - cfg.imu.rate_hz) > RATE_TOLERANCE * cfg.imu.rate_hz:
            raise FitError(f"{cfg.imu.file}: the IMU samples are {measured_hz:.2f} Hz apart (median spacing) but "
                           f"{cfg.path} declares [sensors.imu] rate_hz = {cfg.imu.rate_hz:g}; correct rate_hz")
        return data, make_mesh(data.imu_time_s, cfg.estimation.mesh_samples(measured_hz))
    except InputError:
        raise  # bad input (a file, or the pre-solve data check): exit 2, not a failed fit
    except (FitDataError, ValueError) as err:
        raise FitError(str(err)) from None


def fit_drop(scenario: Scenario, *, linear_solver: str | None = None, hessian: str | None = None,
             print_level: int = 0, solver: str | None = None, method: str | None = None,
             information: str | None = None, sample_kinds: Sequence[SampleKind] = ()) -> FitResult:
    """Reconstruct one drop (see docs/design.md). Raises FitError when the result is not usable.

    ``linear_solver``, ``hessian``, ``solver``, ``method`` ("map" or "marginal") and
    ``information`` ("auto", "observed" or "expected") override the problem's ``[estimation]`` settings.
    With the atmosphere-profile model and ``[atmosphere] profile_sigma_from_data`` (the default), a
    MAP fit without disturbance states is made again with the profile sigmas the data say when they
    differ from the configured ones (:mod:`casrecon.estimation.error_models.profile_sigma`; the notes say so).
    ``sample_kinds`` (:class:`~casrecon.estimation.kinds.samples.SampleKind`, centre of mass and body
    axes) are fitted after the problem's own measurement kinds, their parameters after its own.
    """
    cfg = scenario.config
    kinds = drop_kinds(cfg, sample_kinds)
    settings = FitSettings.from_estimation(cfg.estimation, linear_solver=linear_solver, hessian=hessian,
                                           print_level=print_level, solver=solver, method=method,
                                           information=information)
    t0 = time.perf_counter()
    data, mesh = prepare_drop(scenario)
    params = parameter_set(cfg, kinds)
    measurements = load_measurements(cfg, data, kinds)  # read once, not at every clock shift
    t_data = time.perf_counter()
    x0 = initial_guess(data, mesh, cfg.vehicle, scenario.atmosphere, cfg.site.ground_alt_msl_m)
    t1 = time.perf_counter()

    def fitted(sc: Scenario, start, guess_clock_s: float, prior_sigma: np.ndarray | None = None,
               notes: tuple[str, ...] = (), label: str = "fit", solved: FitSettings = settings) -> FitResult:
        sc = sc.with_fresh_functions()  # its compiled functions named as in any other fit of the drop

        def build(guesses: dict[str, float], altitudes: dict[str, np.ndarray]) -> FitNlp:
            with fit_stage("building the NLP"):
                return build_nlp(sc.model, data, mesh, params, sc.config, settings.hessian, guesses[cfg.name],
                                 measurements, altitudes.get(cfg.name), profile_prior_sigma=prior_sigma, kinds=kinds)

        t2 = time.perf_counter()
        with iteration_logging(label=nested_label(label)):
            fit_nlp, sol, build_s = solve_fit(build, start, {cfg.name: guess_clock_s}, solved)
            t3 = time.perf_counter()
            with fit_stage("covariance"):
                r = fit_nlp.nlp.residual_vector(sol.z)
                cov = covariance_or_fail(fit_nlp.nlp, sol.z, r, sol.reduced,
                                         information=solved.information_for(fit_nlp.parts), lam_g=sol.lam_g)
        timings = {"data_s": t_data - t0, "initial_guess_s": t1 - t_data, "build_s": build_s, "solve_s": sol.solve_s,
                   "solve_evaluation_s": sol.evaluation_s, "solve_stop_test_s": sol.stop_test_s,
                   "solve_linear_algebra_s": sol.linear_algebra_s}
        result = drop_result(sc, data, fit_nlp, 0, sol, cov, r, timings, bands=False)  # with_bands: the one that stands
        t4 = time.perf_counter()
        timings.update(covariance_s=t4 - t3, total_s=t4 - t0, fit_s=t4 - t2)
        return dataclasses.replace(result, notes=result.notes + notes) if notes else result

    refits = settings.method != "marginal" and bool(sizes_named(cfg))
    result = fitted(scenario, lambda fit_nlp: fit_nlp.pack(x0, np.zeros(params.n)), cfg.estimation.clock_offset_guess_s,
                    label=f"fit 1 of up to {MAX_REFITS + 1}" if refits else "fit",
                    solved=dataclasses.replace(settings, decrement_tol=SIZING_DECREMENT, information="expected")
                    if refits else settings)

    def finished(fit: FitResult) -> FitResult:  # fit 1, solved to the full tolerance from where it stopped
        return fitted(fit.scenario, lambda fit_nlp: transferred(fit.fit_nlp, fit_nlp, fit.z),
                      fit.fit_nlp.parts[0].guess_clock_s, label="fit 1, finished")

    if not sizes_estimated(result) or result.part.n_u or settings.method == "marginal":
        return with_bands(finished(result) if refits else result)
    return with_bands(with_profile_sigma_from_data(result, cfg, t0, fitted, finished))


#: The Gauss-Newton decrement (chi-square) at which the first fit of the default path stops: the
#: error models' sizes are estimated on it, and a refit with them follows (or, when the sizes
#: agree, the same fit is finished to the solvers' own tolerance from there). Within sqrt(0.1) =
#: 0.3 sigma of its optimum, the fit's quadratic model moves the log evidence by about 0.05 nats,
#: far below the 3 nats that decide anything (:data:`~.profile_sigma.ZERO_EVIDENCE_NATS`); the
#: Gauss-Newton tail it saves (the profile's weakly determined coefficients converge linearly) was
#: 6 of 12 iterations, 4 of 27 s, on benchmarks/default_cost.py's case. Its covariance is formed on
#: the Gauss-Newton curvature: the estimate made on it fell back to that curvature on every case
#: looked at (docs/design/error-models.md), and a first fit that stands is solved and its
#: covariance formed again.
SIZING_DECREMENT = 0.1


def sizes_named(cfg: ProblemConfig) -> str:
    """What error-model sizes a fit of ``cfg`` may estimate from the data and refit with, as the log
    names its refits (``"profile sizes"``, ``"GPS error sizes"``, both, or ``""``: none; a fit with
    disturbance states estimates none)."""
    atm, gps, disturbance = cfg.atmosphere, cfg.gps, cfg.estimation.disturbance
    if disturbance is not None and len(disturbance.active):
        return ""
    profile = atm.profile_sigma_from_data and bool(atm.profile_wind_sigma_mps or atm.profile_density_sigma)
    errors = bool(gps.error_model_from_data and gps.error_model.enabled)
    return " and ".join(name for name, on in (("profile", profile), ("GPS error", errors)) if on) + (
        " sizes" if profile or errors else "")


def drop_kinds(cfg: ProblemConfig, sample_kinds: Sequence[SampleKind] = ()) -> tuple[MeasurementKind, ...]:
    """The measurement kinds of a per-drop fit: :data:`~casrecon.estimation.sixdof.drop.MEASUREMENT_KINDS`,
    then each sample kind's adapter (:class:`~casrecon.estimation.kinds.sample_terms.SampleTerms`);
    ValueError when a sample kind's name or parameter names are taken."""
    if not sample_kinds:
        return MEASUREMENT_KINDS
    taken = (tuple(k.name for k in MEASUREMENT_KINDS) + parameter_set(cfg).names
             + ("gps_error", "gps_error_start", "unit_norm", "disturbance", "profile"))
    return MEASUREMENT_KINDS + tuple(SampleTerms(k) for k in check_kinds(sample_kinds, taken))


def sizes_estimated(result: FitResult) -> bool:
    """Whether the fit has error-model sizes to estimate from the data: the profile model with
    ``[atmosphere] profile_sigma_from_data``, or a GPS error model with ``[sensors.gps]
    error_model_from_data``."""
    profile = result.scenario.config.atmosphere.profile_sigma_from_data and result.part.profile is not None
    return bool(profile or gps_estimated(result))


def with_profile_sigma_from_data(result: FitResult, cfg: ProblemConfig, t0: float,
                                 fitted: Callable[..., FitResult],
                                 finished: Callable[[FitResult], FitResult] = lambda fit: fit) -> FitResult:
    """The profile fit ``result`` made again with the profile sigmas the data say, until the estimate
    made on a fit agrees with the sigmas it was made with (at most MAX_REFITS refits; see
    :mod:`casrecon.estimation.error_models.profile_sigma`). An estimate beyond the plausibility limits
    (:mod:`casrecon.estimation.error_models.plausibility`) is not refitted with: the fit it was made
    on stands, its ``gross_errors`` say why (a not-trusted verdict); once, where its GPS error model
    differs from the fit's and is within the limits or only a few times beyond them
    (:func:`~casrecon.estimation.error_models.plausibility.judged_again`), the fit is first made
    again with that model alone and the estimate searched and judged again on it
    (:func:`with_gps_estimate_only`; where the GPS model itself was beyond the limits and the
    refit's estimate is beyond them too, or the refit fails, the fit before stands with its
    findings); ``cfg`` is the problem's configuration, ``t0`` the
    ``perf_counter`` at which the fit began, and ``fitted(scenario, start, guess_clock_s, prior,
    notes)`` makes one fit. The result's timings ``first_fit_s`` is the time of the fits before
    the last, ``estimate_s`` that of the size estimates, ``refits`` their number and
    ``all_build_s``, ``all_solve_s``, ``all_covariance_s`` the parts of every fit made. A refit
    that fails leaves the fit before it, whose notes say why. ``finished(fit)`` is the first fit
    solved to the full tolerance, where it stands (it was stopped at :data:`SIZING_DECREMENT`)."""
    earlier_s, intended, history, deferred, judged = 0.0, None, (), False, None
    what = sizes_named(cfg) or "error-model sizes"
    chain = {"estimate_s": 0.0, "refits": 0.0} | {f"all_{p}": result.timings.get(p, 0.0) for p in CHAIN_PARTS}

    def timed(fit: FitResult) -> FitResult:
        fit.timings.update(chain, total_s=time.perf_counter() - t0)
        return fit

    def standing(fit: FitResult, k: int) -> FitResult:  # the fit that stands, the first one finished
        if k:
            return fit
        done = finished(fit)
        if done is not fit:
            for p in CHAIN_PARTS:
                chain[f"all_{p}"] += done.timings.get(p, 0.0)
            done.timings.update(first_fit_s=fit.timings["fit_s"])
        return done

    for k in range(MAX_REFITS):
        try:
            errors = cfg.gps.error_model
            t_estimate = time.perf_counter()
            with iteration_logging(label=nested_label(f"{'fit' if k == 0 else 'refit'} {k + 1} of up to "
                                                      f"{MAX_REFITS + 1}")), fit_stage(f"estimating the {what}"):
                estimate = estimate_error_sizes(result, cfg.atmosphere.profile_length_m,
                                                profile=cfg.atmosphere.profile_sigma_from_data,
                                                configured_times_s=(errors.position_time_s, errors.velocity_time_s),
                                                search=intended is None, configured_model=errors)
            chain["estimate_s"] += time.perf_counter() - t_estimate
        except (np.linalg.LinAlgError, ValueError) as err:
            result = standing(result, k)
            return timed(dataclasses.replace(result, notes=result.notes + (
                f"error-model sizes not estimated from the data ({err}): fitted with the "
                f"{'configured' if intended is None else 'last estimated'} ones",)))
        if not estimate.differs_from(estimate.fitted if intended is None else intended):
            result = standing(result, k)
            result = dataclasses.replace(result, notes=result.notes + (estimate.text() + "; no refit",))
            return timed(with_size_uncertainty(result, estimate))
        findings = implausible(estimate, cfg.atmosphere.profile_length_m)
        gps_only = with_gps_estimate_only(estimate)
        gps_beyond = bool(implausible(gps_only, cfg.atmosphere.profile_length_m))
        defer = (bool(findings) and not deferred and estimate.gps is not None and estimate.gps.refit
                 and (not gps_beyond or judged_again(gps_only)))
        if findings and judged is not None:  # the refit did not clear the GPS finding: the fit before stands
            first, first_k, first_estimate, first_findings = judged
            first = standing(first, first_k)
            return timed(dataclasses.replace(first, notes=first.notes + (
                f"{not_refitted_text(first_estimate, first_findings)}; judged again on a refit with its GPS model, "
                f"whose estimate was beyond the limits too ({'; '.join(findings)})",),
                gross_errors=first.gross_errors + first_findings))
        if findings and not defer:  # a gross error in the inputs, not a model to refit with: this fit stands
            result = standing(result, k)
            return timed(dataclasses.replace(result, notes=result.notes + (not_refitted_text(estimate, findings),),
                                             gross_errors=result.gross_errors + findings))
        made = estimate
        if defer:  # judged again once the GPS errors are the data's: see with_gps_estimate_only
            made, deferred = gps_only, True
            if gps_beyond:  # a GPS finding itself: kept, to stand if the refit does not clear it
                judged = (result, k, estimate, findings)
        else:
            judged = None
        # from this fit's configuration: the problem's with the error models the refits before set
        refit_cfg, prior = profile_refit(result.scenario.config, made)
        before = result.fit_nlp
        earlier_s += result.timings["fit_s"]
        history += ((f"{estimate.text()}; beyond the plausibility limits ({'; '.join(findings)}): refitted "
                     f"{refit_text(made, prior)} first, its estimate to be judged (the fit before took "
                     f"{result.timings['fit_s']:.1f} s)") if defer else
                    f"{estimate.text()}; refitted {refit_text(estimate, prior)} (the fit before took "
                    f"{result.timings['fit_s']:.1f} s)",)
        try:
            again = fitted(dataclasses.replace(result.scenario, config=refit_cfg),
                           lambda fit_nlp, before=before, z=result.z: transferred(before, fit_nlp, z),
                           before.parts[0].guess_clock_s, prior, history,
                           label=f"refit {k + 2} of up to {MAX_REFITS + 1} ({what})")
        except FitError as err:  # the fit before stands, and says why it was not replaced
            result = standing(result, k)
            return timed(dataclasses.replace(result, notes=result.notes + (
                f"{estimate.text()}; the refit {refit_text(made, prior)} failed: {err}",),
                gross_errors=result.gross_errors + (findings if defer else ())))
        chain["refits"] += 1
        for p in CHAIN_PARTS:
            chain[f"all_{p}"] += again.timings.get(p, 0.0)
        again.timings.update(first_fit_s=earlier_s)
        if not sizes_estimated(again):  # without the profile model or GPS errors: nothing left to estimate
            return timed(again)
        result, intended = again, None if defer else estimate.estimated
    return timed(dataclasses.replace(result, notes=result.notes + (
        f"error-model sizes: still changing after {MAX_REFITS} refits; the last fit stands",)))


def with_gps_estimate_only(estimate: ProfileSigmaEstimate) -> ProfileSigmaEstimate:
    """``estimate`` with its profile sizes and length those the fit had: a refit with it changes only
    the GPS error model. Made when an estimate is beyond the plausibility limits while its GPS
    model also differs from the fit's: the first fit's quadratic model is then far from the data's
    GPS errors, and its profile estimate extrapolates. Measured (error family ``none``, seed 216:
    white GPS errors, the air the sounding): the first fit, at the default 99 %-correlated GPS
    model, asked for density 1.65 % over 30 km with GPS position white errors 9.6 times the fit's,
    and taking it for a gross error left ``CA_mult`` 7.7 sigma off; the search is made again on the
    refit, whose findings, if any, stand (the sounding of another day, the IMU clock 1 s off:
    tests/integration/test_gross_errors.py)."""
    return dataclasses.replace(estimate, estimated=dict(estimate.fitted), length_m=estimate.fitted_length_m)


#: The parts of a fit's time summed over the fits of the default path (``all_<part>`` timings).
CHAIN_PARTS = ("build_s", "solve_s", "covariance_s")
