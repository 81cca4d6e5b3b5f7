"""Estimator Monte Carlo under model error: the same synthetic drops fitted with and without the
error models (atmosphere-profile corrections, correlated GPS errors), parameter NEES and the
pooled coverage of the 3-sigma bands of the time history (issue 18's acceptance study).

Each case draws a truth from the fit's priors (:func:`~casrecon.analysis.estimator_mc.draw_truth`),
makes synthetic data with the problem's ``[truth]`` error processes (a profile error between the
sounding and the air flown through, coloured GPS errors), fits it as the problem says (its
``[atmosphere]`` profile and ``[sensors.gps]`` error-model keys) and again with those models off,
and records for each fit the parameter errors, NEES and, per group of columns, how many node
values of the truth lie inside the reported 3-sigma band.
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np

from casrecon.analysis.estimator_mc import chi2_interval, draw_truth, parameter_errors
from casrecon.parallel import parallel_map
from casrecon.physics.sensor_errors import GpsErrorModel
from casrecon.scenario import Scenario

#: Groups of time-history columns whose band coverage is pooled, with the truth's source for each
#: column: ("state", index) or ("output", name), and the unit factor from SI to the column's unit.
BAND_GROUPS = {
    "position": (("pos_n_m", ("state", 0), 1.0), ("pos_e_m", ("state", 1), 1.0), ("pos_d_m", ("state", 2), 1.0)),
    "velocity": (("vel_n_mps", ("state", 3), 1.0), ("vel_e_mps", ("state", 4), 1.0),
                 ("vel_d_mps", ("state", 5), 1.0)),
    "euler": (("roll_deg", ("output", "roll"), np.degrees(1.0)), ("pitch_deg", ("output", "pitch"), np.degrees(1.0)),
              ("yaw_deg", ("output", "yaw"), np.degrees(1.0))),
    "rates": (("p_dps", ("state", 10), np.degrees(1.0)), ("q_dps", ("state", 11), np.degrees(1.0)),
              ("r_dps", ("state", 12), np.degrees(1.0))),
    "qbar": (("qbar_pa", ("output", "qbar"), 1.0),),
    "alpha_t": (("alpha_t_deg", ("output", "alpha_t"), np.degrees(1.0)),),
}
#: Columns that are angles (differences wrapped to +-180 deg).
ANGLES = ("roll_deg", "yaw_deg")
#: Every coverage group: the column groups, and "attitude", the 3-D attitude error region (see
#: :func:`attitude_coverage`); the Euler-angle bands are linearised and fail near +-90 deg pitch.
COVERAGE_GROUPS = (*BAND_GROUPS, "attitude")
#: Chi-square (3 degrees of freedom) whose region holds 99.73 %, the content of a 1-D 3-sigma band.
ATTITUDE_NEES_3SIGMA = 14.1563


def without_error_models(scenario: Scenario) -> Scenario:
    """The scenario with the fit's atmosphere-profile and GPS error models off."""
    cfg = scenario.config
    atm = dataclasses.replace(cfg.atmosphere, profile_wind_sigma_mps=0.0, profile_density_sigma=0.0)
    gps = dataclasses.replace(cfg.gps, error_model=GpsErrorModel.white())
    return Scenario.from_config(dataclasses.replace(cfg, atmosphere=atm, gps=gps))


def attitude_nees(q_fit: np.ndarray, q_true: np.ndarray, cov_q: np.ndarray) -> np.ndarray:
    """NEES of the attitude error at each node.

    Parameters
    ----------
    q_fit, q_true : ndarray, shape (K, 4)
        Fitted and true attitude quaternions (scalar first, body to NED), unit norm.
    cov_q : ndarray, shape (K, 4, 4)
        Covariance of the fitted quaternion.

    Returns
    -------
    ndarray, shape (K,)
        dtheta^T C^-1 dtheta with dtheta = 2 vec(q_fit* q_true), the small rotation (body axes,
        rad) from the fit to the truth, and C = 4 Xi^T cov_q Xi its covariance, Xi(q_fit) the
        4 x 3 matrix with vec(q_fit* p) = Xi^T p.
    """
    q0, q1, q2, q3 = q_fit.T
    xi = np.stack([np.stack([-q1, -q2, -q3], -1), np.stack([q0, -q3, q2], -1),
                   np.stack([q3, q0, -q1], -1), np.stack([-q2, q1, q0], -1)], axis=1)  # (K, 4, 3)
    cov = 4 * np.einsum("kai,kab,kbj->kij", xi, cov_q, xi)
    sign = np.sign(np.einsum("ka,ka->k", q_fit, q_true))
    error = 2 * np.einsum("kai,ka->ki", xi, q_true) * sign[:, None]
    return np.einsum("ki,ki->k", error, np.linalg.solve(cov, error[:, :, None])[:, :, 0])


def attitude_coverage(result, trajectory, release_imu_s: float) -> tuple[int, int]:
    """(nodes whose true attitude lies in the fit's 99.73 % attitude region, nodes): the
    :func:`attitude_nees` at most :data:`ATTITUDE_NEES_3SIGMA`. Unlike the roll, pitch and yaw bands,
    this region stays right at any attitude, +-90 deg pitch included."""
    part = result.part
    t = result.node_time_s - release_imu_s
    q_true = np.column_stack([np.interp(t, trajectory.time_s, trajectory.states[:, 6 + i]) for i in range(4)])
    q_true /= np.linalg.norm(q_true, axis=1, keepdims=True)
    q_fit = result.states[:, 6:10] / np.linalg.norm(result.states[:, 6:10], axis=1, keepdims=True)
    scale = part.state_scale[6:10]
    blocks = result.covariance.blocks(list(part.node_cols.reshape(-1, part.n_states)[:, 6:10]))
    cov_q = np.array(blocks) * np.outer(scale, scale)
    nees = attitude_nees(q_fit, q_true, cov_q)
    return int(np.sum(nees <= ATTITUDE_NEES_3SIGMA)), int(nees.size)


def band_coverage(result, trajectory, release_imu_s: float) -> dict[str, tuple[int, int]]:
    """Per group of :data:`COVERAGE_GROUPS`: (node values whose truth lies within 3 sigma, node values).

    Parameters
    ----------
    result : casrecon.estimation.sixdof.fit.FitResult
    trajectory : casrecon.simulation.simulate.Trajectory
        The truth (flight time since the true release).
    release_imu_s : float
        The true release time on the IMU clock, s.
    """
    t = result.node_time_s - release_imu_s
    out = {}
    for group, columns in BAND_GROUPS.items():
        inside = total = 0
        for column, (source, key), factor in columns:
            series = trajectory.states[:, key] if source == "state" else trajectory.output(key)
            truth = np.interp(t, trajectory.time_s, series) * factor
            value, sigma = result.column(column)
            diff = value - truth
            if column in ANGLES:
                diff = (diff + 180.0) % 360.0 - 180.0
            ok = np.isfinite(diff) & np.isfinite(sigma)
            inside += int(np.sum(np.abs(diff[ok]) <= 3.0 * sigma[ok]))
            total += int(ok.sum())
        out[group] = (inside, total)
    out["attitude"] = attitude_coverage(result, trajectory, release_imu_s)
    return out


def fit_summary(scenario: Scenario, truth: dict[str, float], trajectory, release_imu_s: float,
                method: str | None = None, information: str | None = None, forced_widening: bool = False) -> dict:
    """Fit ``scenario`` (by ``method``, "map" or "marginal", its covariance from ``information``,
    "observed" or "expected"; defaults its ``[estimation]``'s) and summarise what it publishes against
    the truth (or the failure): the published parameters' errors, sigmas and correlations and the
    model's (the fit's own, before any widening), NEES, band coverage, verdict; with
    ``forced_widening``, for a fit published with its own sigmas also what the widened ones would
    have been (``forced_widening``: sigma, nees, coverage; 1 to 6 s more), for studies of the
    publication rule."""
    from casrecon.analysis.accel_bias_floor import NOTE_START as BIAS_NOTE
    from casrecon.analysis.fit_products import result_adequacy
    from casrecon.analysis.widened_uncertainty import published_result, widened_result, widening_refused
    from casrecon.estimation.sixdof.fit import FitError, fit_drop

    t0 = time.perf_counter()
    try:
        r = fit_drop(scenario, method=method, information=information)
    except FitError as err:
        return {"failed": str(err), "seconds": time.perf_counter() - t0}
    verdict = result_adequacy(r)
    model = r
    r, widening = published_result(r, verdict.trusted)  # what the fit publishes (widened if the data say so)
    e, nees = parameter_errors(r, truth)
    out = {"names": list(r.params.names), "error": e.tolist(), "sigma": r.sigma.tolist(), "nees": nees,
           "correlation": r.correlation.tolist(), "model_sigma": model.sigma.tolist(),
           "model_correlation": model.correlation.tolist(),
           "reduced_chi2": r.reduced_chi2, "iterations": r.solver.iterations, "seconds": time.perf_counter() - t0,
           "coverage": band_coverage(r, trajectory, release_imu_s), **verdict_summary(verdict),
           "widened": widening is not None,
           "bias_floored": any(n.startswith(BIAS_NOTE) for n in r.notes)}
    if forced_widening and widening is None and widening_refused(model) is None:  # what widening would publish
        forced, _ = widened_result(model, reason="a study's comparison")
        _, forced_nees = parameter_errors(forced, truth)
        out["forced_widening"] = {"sigma": forced.sigma.tolist(), "nees": forced_nees,
                                  "coverage": band_coverage(forced, trajectory, release_imu_s)}
    return out


def verdict_summary(adequacy) -> dict:
    """What a Monte Carlo keeps of a fit's verdict: trusted, conservative (trusted with residuals
    smaller than their sigmas) and the reasons it failed, if it did."""
    return {"trusted": bool(adequacy.trusted), "conservative": bool(adequacy.trusted and adequacy.cautions),
            "reasons": list(adequacy.reasons)}


#: The two fits of a case: as the problem says, and with the error models off.
VARIANTS = ("with_models", "without_models")


@dataclass(frozen=True)
class World:
    """Which of a problem's ``[truth]`` error processes a study's data carry (all, by default).

    Attributes
    ----------
    exact_air : bool
        The air flown is the sounding (no profile error); the fit's profile model stays on.
    white_gps : bool
        The GPS errors are white, and the fit is told so (its GPS error model white too).
    matched_gps : bool
        The GPS errors are drawn from the fit's own GPS error model (its correlation times and its
        white share of each variance, ``1 - *_correlated_fraction``), so that the adequacy verdict's
        GPS tests are made under a true model.
    default_gps_model : bool
        The data's GPS errors as the problem's ``[truth]`` says, but the fit's GPS error model is
        casrecon's default (:class:`~casrecon.physics.sensor_errors.GpsErrorModel`), whatever the
        problem says: what a user who does not characterise the receiver gets.
    """

    exact_air: bool = False
    white_gps: bool = False
    matched_gps: bool = False
    default_gps_model: bool = False

    def describe(self) -> str:
        """The study line's clause for this world ("" for the problem's own)."""
        return "".join(text for on, text in ((self.exact_air, ", air flown = sounding"),
                                             (self.white_gps, ", white GPS errors"),
                                             (self.matched_gps, ", GPS errors drawn from the fit's model"),
                                             (self.default_gps_model, ", the fit's GPS error model the default"))
                       if on)


def in_world(scenario: Scenario, world: World = World()) -> Scenario:
    """The scenario with its ``[truth]`` error processes as ``world`` says."""
    if world.white_gps + world.matched_gps + world.default_gps_model > 1:
        raise ValueError("white_gps, matched_gps and default_gps_model are different GPS worlds: choose one")
    cfg = scenario.config
    errors = cfg.truth.errors
    if world.exact_air:
        errors = dataclasses.replace(errors, profile_wind_sigma_mps=0.0, profile_density_sigma=0.0)
    gps = cfg.gps
    if world.white_gps:
        errors = dataclasses.replace(errors, gps_position_time_s=0.0, gps_velocity_time_s=0.0)
        gps = dataclasses.replace(gps, error_model=GpsErrorModel.white())
    if world.matched_gps:
        model = gps.error_model
        if model.position_fraction != model.velocity_fraction:
            raise ValueError(f"matched_gps needs one correlated fraction for position and velocity (the simulator "
                             f"draws one white share), got {model.position_fraction} and {model.velocity_fraction}")
        errors = dataclasses.replace(errors, gps_position_time_s=model.position_time_s,
                                     gps_velocity_time_s=model.velocity_time_s,
                                     gps_white_fraction=1.0 - model.position_fraction)
    if world.default_gps_model:
        gps = dataclasses.replace(gps, error_model=GpsErrorModel())
    return Scenario.from_config(dataclasses.replace(cfg, truth=dataclasses.replace(cfg.truth, errors=errors), gps=gps))


def run_case(problem: str, seed: int, index: int, variants: tuple[str, ...] = VARIANTS,
             method: str | None = None, information: str | None = None, world: World = World()) -> dict:
    """Case ``index``: draw a truth, simulate with the problem's error processes (those
    :func:`in_world` leaves on), fit (by ``method`` and ``information``, defaults the problem's)
    with and without the error models (those of ``variants``)."""
    from casrecon.simulation.synthetic import synthetic_scenario, truth_parameters_by_name

    rng = np.random.default_rng([seed, index])
    scenario = in_world(draw_truth(Scenario.load(problem), rng), world)
    out = {"index": index}
    with tempfile.TemporaryDirectory() as tmp:
        sc, data = synthetic_scenario(scenario, Path(tmp), seed=int(rng.integers(2**31)))
        truth = truth_parameters_by_name(sc)
        release = float(data.truth["release_imu_time_s"])
        if "with_models" in variants:
            out["with_models"] = fit_summary(sc, truth, data.trajectory, release, method, information)
        if "without_models" in variants:
            out["without_models"] = fit_summary(without_error_models(sc), truth, data.trajectory, release, method,
                                              information)
    return out


@dataclass(frozen=True)
class ModelErrorStudy:
    """Every case of :func:`model_error_montecarlo` and the pooled statistics of one variant."""

    cases: list[dict]

    def variant(self, name: str) -> dict:
        """Pooled figures of ``"with_models"`` or ``"without_models"``: converged cases, NEES sum and
        its 95 % interval, per-parameter mean and RMS z, coverage per band group, trusted verdicts."""
        fits = [c[name] for c in self.cases if name in c]
        ok = [f for f in fits if "nees" in f]
        n_params = len(ok[0]["names"]) if ok else 0
        coverage = {}
        for group in COVERAGE_GROUPS:
            inside = sum(f["coverage"][group][0] for f in ok)
            total = sum(f["coverage"][group][1] for f in ok)
            coverage[group] = inside / total if total else float("nan")
        z = np.array([np.asarray(f["error"]) / np.asarray(f["sigma"]) for f in ok]) if ok else np.zeros((0, 0))
        return {"converged": len(ok), "cases": len(fits), "nees_sum": float(sum(f["nees"] for f in ok)),
                "interval": chi2_interval(n_params * len(ok)), "names": ok[0]["names"] if ok else [],
                "mean_z": z.mean(axis=0).tolist() if ok else [],
                "rms_z": np.sqrt((z**2).mean(axis=0)).tolist() if ok else [], "coverage": coverage,
                "trusted": sum(f["trusted"] for f in ok), "conservative": sum(f.get("conservative", False) for f in ok),
                "reasons": [reason for f in ok for reason in f.get("reasons", [])],
                "seconds": [f["seconds"] for f in fits]}


def model_error_montecarlo(problem: Path, n_cases: int, seed: int = 0, workers: int = 2,
                           scheduler: str | None = None, variants: tuple[str, ...] = VARIANTS,
                           method: str | None = None, information: str | None = None,
                           world: World = World()) -> ModelErrorStudy:
    """Run ``n_cases`` cases of :func:`run_case` (reproducible from (seed, index)), fitting the
    ``variants`` of :data:`VARIANTS` by ``method`` ("map", "marginal") with the covariance from
    ``information`` ("auto", "observed", "expected"; defaults the problem's), in the world
    ``world`` (:class:`World`)."""
    unknown = set(variants) - set(VARIANTS)
    if unknown:
        raise ValueError(f"unknown variants {sorted(unknown)}; expected some of {VARIANTS}")
    cases = parallel_map(partial(run_case, str(Path(problem).resolve()), seed, variants=tuple(variants),
                                 method=method, information=information, world=world),
                         range(n_cases), workers=workers,
                         scheduler=scheduler, progress="model-error montecarlo")
    return ModelErrorStudy(cases)
