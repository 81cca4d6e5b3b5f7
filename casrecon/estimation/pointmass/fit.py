"""GPS-only fit of a point mass (3-DOF): the same collocation, Ipopt and KKT covariance as the
6-DOF fit, for a body that carried only a GPS (a skydiver, a capsule without IMU).

Unknowns: node states (antenna NED position and velocity); the drag area CdA (m^2), constant or a
cubic B-spline in time (coefficients c >= 0, so CdA(t) >= 0, CdA(t) = B(t) c) with a smoothness
prior on the second differences of c; optionally horizontal lift areas (same spline); the wind
bias (north, east) against the atmosphere used. Mass is given
(``[vehicle] mass_kg``): only CdA / m is observable, so CdA scales with the mass assumed.

Mesh: one node per GPS epoch (uniform, the receiver's period) through the segment; each good fix
is compared with the node state at its own epoch, whitened by the receiver's reported accuracies
(north and east by hAcc, down by vAcc, each velocity component by sAcc or ``[gps] velocity_sigma_mps``).
A component the file does not give (NMEA: vertical velocity) has zero weight and is not counted.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.interpolate import BSpline

from casrecon.estimation.engine.blocks import BlockSet, Term
from casrecon.estimation.engine.checks import (
    FitError,
    check_converged,
    check_determined,
    covariance_or_fail,
)
from casrecon.estimation.engine.convergence import fit_stage, iteration_logging, nested_label
from casrecon.estimation.engine.covariance import Covariance
from casrecon.estimation.engine.nlp import Nlp, assemble_nlp
from casrecon.estimation.engine.solve import SolveResult, solve
from casrecon.estimation.error_models import pointmass_gps_sigma as gps_sigma
from casrecon.estimation.error_models.profile_sigma import MAX_REFITS
from casrecon.estimation.kinds.disturbance import gauss_markov_terms
from casrecon.estimation.kinds.drag import CDA_SCALE, SCALE, drag_interval_kind, drag_prior_terms
from casrecon.estimation.kinds.priors import prior_terms
from casrecon.estimation.pointmass.innovations import filter_innovations, measurement_rows
from casrecon.estimation.pointmass.segment import SegmentError, final_drop_before, find_segment, unsteady_note
from casrecon.estimation.sixdof.layout import DropLayout
from casrecon.estimation.sixdof.parameters import ParameterSet, ParameterSpec
from casrecon.estimation.sixdof.transcription import Mesh
from casrecon.estimation.validation.data_checks import check_point_mass_data
from casrecon.io.errors import InputError
from casrecon.io.flysight import GpsTrack, iso_utc
from casrecon.io.gps_files import read_gps_track
from casrecon.io.gps_rules import fixes_ned
from casrecon.io.pointmass_problem import ModelErrorConfig, PointMassConfig
from casrecon.io.sounding import read_sounding
from casrecon.physics.atmosphere import Atmosphere
from casrecon.physics.pointmass import PointMassModel


@dataclass
class PointMassData:
    """The segment's fixes on the node grid: y (K, 6) NED antenna position/velocity, inverse sigma
    (K, 6; 0 where the node has no good fix), node UTC times and the notes."""

    t_unix: np.ndarray
    y: np.ndarray
    inv_sigma: np.ndarray
    notes: tuple[str, ...]
    track: GpsTrack


@dataclass
class PointMassResult:
    """A GPS-only fit (SI units)."""

    config: PointMassConfig
    model_name: str                   # "constant" or "spline"
    t_unix: np.ndarray
    states: np.ndarray                # (K, 6)
    state_sigma: np.ndarray           # (K, 6) absolute 1-sigma
    cda: np.ndarray                   # (K,) m^2
    cda_sigma: np.ndarray
    params: ParameterSet
    values: np.ndarray
    sigma: np.ndarray
    normalized_residuals: np.ndarray  # (K, 6), NaN where no fix
    chi2: dict[str, float]
    n_measurements: dict[str, int]
    reduced_chi2: float
    solver: SolveResult
    timings: dict[str, float]
    nlp: Nlp
    z: np.ndarray                     # scaled decision vector at the solution
    covariance: Covariance
    track: GpsTrack                   # the whole track as read
    y: np.ndarray                     # (K, 6) fixes on the nodes (0 where none)
    inv_sigma: np.ndarray             # (K, 6) inverse 1-sigma of those fixes, 0 where none
    areas: np.ndarray                 # (K, n_areas) CdA and (with lift or an area process) AN, AE, m^2
    area_sigma: np.ndarray            # (K, n_areas) absolute 1-sigma, m^2
    whitened_residuals: np.ndarray | None = None  # (K, 6) innovations under the GPS error model, NaN where no fix
    area_process: np.ndarray | None = None  # (K, 3) fitted area process of CdA, AN, AE, m^2 ([model_error])
    area_process_sigma: np.ndarray | None = None  # (K, 3) its absolute 1-sigma, m^2
    notes: tuple[str, ...] = ()

    def residual_stats(self) -> dict[str, dict[str, float]]:
        """Per component: RMS of the normalised residuals and their lag-1 autocorrelation (near 0
        for white residuals; near 1 when the model leaves structure)."""
        names = ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")
        out = {}
        for i, n in enumerate(names):
            r = self.normalized_residuals[:, i]
            r = r[np.isfinite(r)]
            if r.size == 0:  # a component the GPS file does not give
                out[n] = {"rms": float("nan"), "lag1_autocorrelation": float("nan")}
                continue
            ac = float(np.corrcoef(r[:-1], r[1:])[0, 1]) if r.size > 3 else float("nan")
            out[n] = {"rms": float(np.sqrt(np.mean(r * r))), "lag1_autocorrelation": ac}
        return out


def atmosphere_of(cfg: PointMassConfig) -> Atmosphere:
    """The configured sounding, or the ICAO standard atmosphere (no wind) for ``"standard"``."""
    if cfg.sounding is None:
        return Atmosphere.standard()
    return Atmosphere.from_sounding(read_sounding(cfg.sounding), gradient_ref_alt_msl_m=cfg.site.ground_alt_msl_m,
                                    humidity=cfg.humidity)


def prepare_data(cfg: PointMassConfig) -> PointMassData:
    """Read the track, find the segment, check the data (:mod:`casrecon.estimation.validation.data_checks`: a failure is
    a located :class:`~casrecon.io.errors.InputError`) and put the good fixes on a uniform node grid."""
    track = read_gps_track(cfg.gps_file, cfg.gps_date)
    if not np.isfinite(track.vel_d_mps).any() and (cfg.segment.start_unix_s is None or cfg.segment.end_unix_s is None):
        raise InputError(cfg.path, f"the GPS file {track.path} gives no vertical velocity, from which the segment "
                         "is found; give [segment] start_utc and end_utc", field="segment.start_utc")
    try:
        seg = find_segment(track, cfg.quality, cfg.segment)
    except SegmentError as err:
        raise FitError(str(err)) from None
    if cfg.segment.end_unix_s is not None:
        drop = final_drop_before(track, seg.good, seg.start_unix_s, seg.end_unix_s, cfg.segment)
        if drop is not None:
            raise InputError(cfg.path, f"the segment ends at {iso_utc(seg.end_unix_s)}, "
                             f"{seg.end_unix_s - drop.onset_unix_s:.1f} s after the fall's final drop (canopy opening "
                             f"or impact) began at {iso_utc(drop.onset_unix_s)} (GPS vertical speed "
                             f"{drop.onset_speed_mps:.1f} m/s, down to {drop.slow_speed_mps:.1f} m/s by "
                             f"{iso_utc(drop.slow_unix_s)}); expected end_utc at or before "
                             f"{iso_utc(drop.onset_unix_s - cfg.segment.end_margin_s)} (end_margin_s before it), "
                             "or no end_utc to find the end from the data", field="segment.end_utc")
    unsteady = unsteady_note(track, seg.good, seg.start_unix_s, seg.end_unix_s)
    if unsteady:
        seg = dataclasses.replace(seg, notes=seg.notes + (unsteady,))
    check_point_mass_data(cfg, track, cfg.quality, (seg.start_unix_s, seg.end_unix_s))
    t = track.time_unix_s
    period = float(np.median(np.diff(t)))
    # nodes on the fix epochs: an explicit start_utc between two fixes starts at the next fix, and a
    # fix at the end itself is kept (the division can fall a hair short of a whole number)
    start = float(t[min(int(np.searchsorted(t, seg.start_unix_s - 1e-3)), t.size - 1)])
    nodes = start + period * np.arange(max(int(np.floor((seg.end_unix_s - start) / period + 1e-3)), 0) + 1)
    idx = np.clip(np.searchsorted(t, nodes - period / 2), 0, t.size - 1)
    on_node = (np.abs(t[idx] - nodes) < period / 4) & seg.good[idx]
    pos, vel, sig = fixes_ned(track, cfg.site, idx, cfg.velocity_sigma_mps)
    sig = sig * cfg.gps_errors.scale  # the error's size the fit assumes
    y = np.nan_to_num(np.column_stack([pos, vel]))  # a missing component (NaN) has sigma inf: weight 0
    inv = np.where(on_node[:, None], 1.0 / sig, 0.0)
    if on_node.sum() < 3:
        raise FitError(f"{track.path}: only {int(on_node.sum())} good fixes in the segment "
                       f"{iso_utc(seg.start_unix_s)} to {iso_utc(seg.end_unix_s)}")
    notes = track.notes + seg.notes + (f"{int(on_node.sum())} fixes on {nodes.size} nodes every {period:.3f} s",)
    return PointMassData(nodes, np.where(on_node[:, None], y, 0.0), inv, notes, track)


def drag_basis(cfg: PointMassConfig, model: str, t: np.ndarray, span: tuple[float, float] | None = None) -> np.ndarray:
    """(len(t), n_coef) basis of CdA(t): a column of ones, or a clamped cubic B-spline basis whose
    knots (every ``knot_spacing_s`` or a little more) cover ``span`` = (first, last node time), s;
    default (t[0], t[-1]). Times outside ``span`` are clamped to it."""
    if model == "constant":
        return np.ones((t.size, 1))
    a, b = span if span is not None else (t[0], t[-1])
    n_inner = max(int(np.floor((b - a) / cfg.drag.knot_spacing_s)), 1)
    inner = np.linspace(a, b, n_inner + 1)
    knots = np.r_[[a] * 3, inner, [b] * 3]
    return BSpline.design_matrix(np.clip(t, a, b), knots, 3).toarray()


def interval_bases(cfg: PointMassConfig, model: str, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bases of CdA(t) at the nodes ``t`` (K,) and at the K - 1 interval midpoints, s: one spline,
    one knot vector over the nodes' span for both."""
    span = (float(t[0]), float(t[-1]))
    return drag_basis(cfg, model, t, span), drag_basis(cfg, model, 0.5 * (t[:-1] + t[1:]), span)


AREA_NAMES = ("CdA", "AN", "AE")


def _parameters(n_coef: int, n_areas: int, cfg: PointMassConfig) -> ParameterSet:
    wind = cfg.wind_3sigma_mps / 3
    specs = [ParameterSpec(f"{a}_{i:02d}" if n_coef > 1 else a, "drag", CDA_SCALE, None, "m^2")
             for a in AREA_NAMES[:n_areas] for i in range(n_coef)]
    specs += [ParameterSpec("wind_bias_n", "atmosphere", wind, wind, "m/s"),
              ParameterSpec("wind_bias_e", "atmosphere", wind, wind, "m/s")]
    return ParameterSet(tuple(specs))


def _initial_states(data: PointMassData) -> np.ndarray:
    """(K, 6) NED position and velocity on the nodes: each component interpolated through its fixes; a
    velocity no fix gives from the derivative of its position; a position no fix gives 0."""
    t = data.t_unix - data.t_unix[0]
    out = np.zeros((t.size, 6))
    for i in range(6):
        ok = data.inv_sigma[:, i] > 0
        if ok.any():
            out[:, i] = np.interp(t, t[ok], data.y[ok, i])
        elif i >= 3:
            out[:, i] = np.gradient(out[:, i - 3], t)
    return out


def _initial_cda(data: PointMassData, cfg: PointMassConfig, atm: Atmosphere, states: np.ndarray) -> float:
    """CdA from the drag needed to explain the vertical acceleration at each good fix (median), on the
    initial states (:func:`_initial_states`: the fixes' values where they have them)."""
    ok = data.inv_sigma[:, 0] > 0
    t, vd = data.t_unix[ok], states[ok, 5]
    accel = np.gradient(vd, t)
    alt = cfg.site.ground_alt_msl_m - states[ok, 2]
    rho = np.interp(alt, atm.levels["altitude_msl_m"], atm.levels["density_kgm3"])
    speed2 = np.sum(states[ok, 3:6] ** 2, axis=1)
    cda = 2 * cfg.mass_kg * (9.80665 - accel) / (rho * np.maximum(speed2, 25.0))
    return float(np.clip(np.median(cda[speed2 > 400]) if np.any(speed2 > 400) else np.median(cda), 0.01, 5.0))


@dataclass
class PointMassNlp:
    """A point-mass problem ready for Ipopt: its data, layout, NLP, starting point (scaled) and
    lower bounds (the drag-area coefficients >= 0), and the drag basis at the nodes."""

    data: PointMassData
    layout: DropLayout
    nlp: Nlp
    z0: np.ndarray
    lower: np.ndarray
    basis: np.ndarray


def build_point_mass(cfg: PointMassConfig, model_name: str | None = None) -> PointMassNlp:
    """Read the data and build the NLP of the constant or spline drag model, checked at the start
    point (:func:`~casrecon.estimation.engine.checks.check_determined` evaluates its derivatives)."""
    model_name = model_name or cfg.drag.model
    data = prepare_data(cfg)
    atm = atmosphere_of(cfg)
    model = PointMassModel(atm, cfg.site, cfg.mass_kg, cfg.dynamics)
    t_rel = data.t_unix - data.t_unix[0]
    h = float(t_rel[1] - t_rel[0])
    basis, b_mid = interval_bases(cfg, model_name, t_rel)
    n_coef, n_areas = basis.shape[1], 3 if (cfg.drag.lift and model_name == "spline") else 1
    params = _parameters(n_coef, n_areas, cfg)
    k = t_rel.size
    mesh = Mesh(t_rel, h, 1)
    part = DropLayout(cfg.name, mesh, params, 0, 6 * k + np.arange(params.n), state_scale=SCALE)
    n_int = k - 1
    errors = cfg.gps_errors
    active = errors.active
    e_cols, a_cols = latent_columns(cfg, k, params.n)
    process = cfg.model_error
    cols = np.column_stack([6 * np.arange(n_int)[:, None] + np.arange(12)[None, :],
                            np.tile(part.theta_cols, (n_int, 1)), e_cols[:-1], e_cols[1:], a_cols[:-1], a_cols[1:]])
    last = np.zeros((n_int, 6))
    last[-1] = 1.0
    white = data.inv_sigma / np.sqrt(1.0 - errors.fraction)
    block_data = [ca.DM(basis[:-1].T), ca.DM(b_mid.T), ca.DM(basis[1:].T), ca.DM(data.y[:-1].T),
                  ca.DM(white[:-1].T), ca.DM(data.y[1:].T), ca.DM((white[1:] * last).T)]
    if active.size:
        with np.errstate(divide="ignore"):
            amp = np.where(data.inv_sigma > 0, np.sqrt(errors.fraction) / data.inv_sigma, 0.0)[:, active]
        block_data += [ca.DM(amp[:-1].T), ca.DM(amp[1:].T)]
    kind = drag_interval_kind(model, h, n_coef, n_areas, params.scales[-1], tuple(active.tolist()),
                              process.sigmas if process.enabled else ())
    terms = [Term("gps", (BlockSet(kind, cols, block_data),)),
             *drag_prior_terms(n_coef, n_areas, part.theta_cols[:n_coef * n_areas], cfg),
             *prior_terms(params, part.theta_cols)]
    if active.size:
        phi = np.tile(errors.transition(np.array([h])), (k - 1, 1))
        terms += gauss_markov_terms(e_cols, phi, "gps_error_start", "gps_error")
    if process.enabled:
        terms += gauss_markov_terms(a_cols, np.full((k - 1, 3), process.transition(h)), "area_process_start",
                                    "area_process")
    nlp = assemble_nlp(terms, 6 * k + params.n + e_cols.size + a_cols.size, dependent=part.dependent_cols,
                       parameter_names=dict(zip(part.theta_cols.tolist(), params.names)), eliminated=e_cols.ravel(),
                       latent=process.enabled)
    pos_vel = _initial_states(data)
    cda0 = _initial_cda(data, cfg, atm, pos_vel)
    z0 = np.concatenate([(pos_vel / SCALE).ravel(), np.full(n_coef, cda0 / CDA_SCALE),
                         np.zeros(n_coef * (n_areas - 1) + 2 + e_cols.size + a_cols.size)])
    check_determined(nlp, z0)
    lbx = np.full(z0.size, -np.inf)
    lbx[part.theta_cols[:n_coef]] = 0.0  # B-spline coefficients >= 0 keep CdA(t) >= 0 everywhere
    return PointMassNlp(data, part, nlp, z0, lbx, basis)


def fit_point_mass(cfg: PointMassConfig, model_name: str | None = None, print_level: int = 0) -> PointMassResult:
    """Fit the track of a point-mass problem with the constant or the spline drag model; its
    iteration lines are labelled ``constant-CdA fit`` or ``spline-CdA fit``. With a GPS error model
    and ``[gps] error_model_from_data``, the fit is made again with the GPS error model the
    data say until it stops changing (at most MAX_REFITS refits;
    :mod:`casrecon.estimation.error_models.pointmass_gps_sigma`); the notes say what each estimate found."""
    t0 = time.perf_counter()
    name = f"{model_name or cfg.drag.model}-CdA"
    refits = cfg.gps_error_model_from_data and cfg.gps_errors.enabled
    label = f"{name} fit 1 of up to {MAX_REFITS + 1}" if refits else f"{name} fit"
    result = _fitted(cfg, model_name, print_level, label)
    if not gps_sigma.estimated(result):
        return result
    configured = cfg.gps_errors
    times = (configured.position_time_s, configured.velocity_time_s)
    history: tuple[str, ...] = ()
    estimate_s = 0.0
    for refit in range(MAX_REFITS + 1):
        t1 = time.perf_counter()
        try:
            with iteration_logging(label=nested_label(label)), fit_stage("estimating the GPS error sizes"):
                estimate = gps_sigma.estimate_gps_model(result, times, search=refit == 0)
        except (np.linalg.LinAlgError, ValueError) as err:
            note = (f"GPS error model not estimated from the data ({err}): fitted with the "
                    f"{'configured' if refit == 0 else 'last estimated'} one")
            return _noted(result, history + (note,), estimate_s, t0)
        estimate_s += time.perf_counter() - t1
        if not estimate.refit:
            return _noted(result, history + (estimate.text() + "; no refit",), estimate_s, t0)
        if refit == MAX_REFITS:
            break
        try:
            label = f"{name} refit {refit + 2} of up to {MAX_REFITS + 1} (GPS error sizes)"
            again = _fitted(dataclasses.replace(result.config, gps_errors=estimate.estimated), model_name, print_level,
                            label)
        except FitError as err:  # the fit before stands, and says why it was not replaced
            return _noted(result, history + (f"{estimate.text()}; the refit with it failed: {err}",), estimate_s, t0)
        history += (f"{estimate.text()}; refitted (the fit before took {result.timings['total_s']:.1f} s)",)
        result = again
    return _noted(result, history + (f"GPS error model: still changing after {MAX_REFITS} refits; the last fit "
                                     "stands",), estimate_s, t0)


def _noted(result: PointMassResult, notes: tuple[str, ...], estimate_s: float, t0: float) -> PointMassResult:
    """``result`` with the GPS error model estimate's ``notes`` and its timings (``error_model_s``:
    the estimates; ``total_s`` from ``t0``, the fits before included)."""
    timings = dict(result.timings, error_model_s=estimate_s, total_s=time.perf_counter() - t0)
    return dataclasses.replace(result, notes=result.notes + notes, timings=timings)


def _fitted(cfg: PointMassConfig, model_name: str | None, print_level: int, label: str | None = None
            ) -> PointMassResult:
    """One fit with the configured GPS error model (see :func:`fit_point_mass`); its log lines labelled
    ``label`` (default ``"<model>-CdA fit"``: casrecon fit runs two, spline and constant CdA)."""
    model_name = model_name or cfg.drag.model
    t0 = time.perf_counter()
    with iteration_logging(label=nested_label(label or f"{model_name}-CdA fit")):
        with fit_stage("reading the track, building the NLP", announce=False):  # a refused input: one line
            built = build_point_mass(cfg, model_name)
        data, part, nlp, z0, lbx, basis = built.data, built.layout, built.nlp, built.z0, built.lower, built.basis
        t1 = time.perf_counter()
        with fit_stage("solving"):
            sol = solve(nlp, z0, cfg.linear_solver, cfg.max_iter, cfg.tol, print_level, (lbx, np.full(z0.size, np.inf)))
        check_converged(sol, nlp)
        t2 = time.perf_counter()
        with fit_stage("covariance"):
            r = nlp.residual_vector(sol.z)
            cov = covariance_or_fail(nlp, sol.z, r)
        with fit_stage("drag-area and state sigmas"):
            result = _result(cfg, model_name, data, part, nlp, sol, cov, r, basis)
    result.timings.update(build_s=t1 - t0 + sol.build_s, solve_s=sol.solve_s, covariance_s=time.perf_counter() - t2,
                          total_s=time.perf_counter() - t0)
    return result


def latent_columns(cfg: PointMassConfig, k: int, n_params: int) -> tuple[np.ndarray, np.ndarray]:
    """z columns (K, n_active) of the correlated GPS errors and (K, 3 or 0) of the area process,
    for K nodes and ``n_params`` parameters (they follow the node states and parameters)."""
    n_e = cfg.gps_errors.active.size
    first_e = 6 * k + n_params
    n_a = 3 if cfg.model_error.enabled else 0
    return (first_e + np.arange(k * n_e).reshape(k, n_e),
            first_e + k * n_e + np.arange(k * n_a).reshape(k, n_a))


def innovations(cfg: PointMassConfig, data: PointMassData, part: DropLayout, nlp: Nlp, z: np.ndarray) -> np.ndarray:
    """(K, 6) Kalman-filter innovations of the fixes under the fitted model with its area
    process (:mod:`casrecon.estimation.pointmass.innovations`), NaN where a node has no fix."""
    k = data.t_unix.size
    d = nlp.derivatives
    jr, jg = d.jacobian_r(z), d.jacobian_g(z)
    x_cols = 6 * np.arange(k)[:, None] + np.arange(6)[None, :]
    e_cols, a_cols = latent_columns(cfg, k, part.params.n)
    h = float(data.t_unix[1] - data.t_unix[0])
    return filter_innovations(jr, jg, nlp.residual_vector(z), z, x_cols=x_cols, a_cols=a_cols, e_cols=e_cols,
                              phi_a=cfg.model_error.transition(h), phi_e=cfg.gps_errors.transition(np.array([h]))[0],
                              defect_rows=6 * np.arange(k - 1)[:, None] + np.arange(6)[None, :],
                              fix_rows=measurement_rows(jr, nlp.groups["gps"], x_cols))


def _areas_with_process(cfg: PointMassConfig, part: DropLayout, cov, basis: np.ndarray, values: np.ndarray,
                        z: np.ndarray, n_areas: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(areas, their 1-sigma, the process's part of them, its 1-sigma), each (K, 3) m^2, of a fit
    with area processes: the drag area is its spline times exp(sigma a), each lift area its spline
    (none for a lift area the spline model lacks) plus sigma a; the process's part is the area
    less its spline. Variances to first order in the spline coefficients and the node's process
    values together."""
    k, n_coef = basis.shape
    sigma = np.asarray(cfg.model_error.sigmas, float)
    _, a_cols = latent_columns(cfg, k, part.params.n)
    n_c = n_coef * n_areas
    a = z[a_cols] * sigma  # (K, 3): the drag area's log change, the lift areas' additions (m^2)
    spline = np.zeros((k, 3))
    for j in range(n_areas):
        spline[:, j] = basis @ values[j * n_coef:(j + 1) * n_coef]
    factor = np.exp(a[:, 0])
    areas = spline + a
    areas[:, 0] = spline[:, 0] * factor
    blocks = cov.blocks([np.concatenate([part.theta_cols[:n_c], a_cols[i]]) for i in range(k)])
    area_var, process_var = np.empty((k, 3)), np.empty((k, 3))
    for i, c in enumerate(blocks):
        for j in range(3):
            w_total, w_process = np.zeros(n_c + 3), np.zeros(n_c + 3)
            if j < n_areas:
                w_total[j * n_coef:(j + 1) * n_coef] = basis[i] * CDA_SCALE * (factor[i] if j == 0 else 1.0)
                if j == 0:
                    w_process[:n_coef] = basis[i] * CDA_SCALE * (factor[i] - 1.0)
            w_total[n_c + j] = w_process[n_c + j] = sigma[j] * (spline[i, 0] * factor[i] if j == 0 else 1.0)
            area_var[i, j], process_var[i, j] = w_total @ c @ w_total, w_process @ c @ w_process
    return areas, np.sqrt(area_var), areas - spline, np.sqrt(process_var)


def fit_with_comparison(cfg: PointMassConfig, print_level: int = 0) -> tuple[PointMassResult, PointMassResult]:
    """(the configured fit, the constant-drag comparison) of ``casrecon fit``: the comparison is the
    constant-CdA fit of the same fixes without the area process (which would take up what a constant
    drag area leaves), or the configured fit itself when it is that one."""
    main = fit_point_mass(cfg, print_level=print_level)
    if cfg.drag.model == "constant" and not cfg.model_error.enabled:
        return main, main
    # with the main fit's GPS error model (the one the data say, when estimated), as it is
    comparison = dataclasses.replace(main.config, model_error=ModelErrorConfig(), gps_error_model_from_data=False)
    return main, fit_point_mass(comparison, "constant")


def _result(cfg, model_name, data, part, nlp, sol, cov: Covariance, r, basis) -> PointMassResult:
    states = part.states(sol.z)
    values = part.values(sol.z)
    n_coef = basis.shape[1]
    k = states.shape[0]
    state_sigma = np.sqrt(np.array([np.diag(c) for c in cov.blocks([6 * i + np.arange(6) for i in range(k)])])) * SCALE
    cov_p = cov.covariance_of(part.theta_cols, part.params.scales)
    sigma = np.sqrt(np.diag(cov_p))
    n_areas = (len(values) - 2) // n_coef
    process = process_sigma = None
    if cfg.model_error.enabled:
        areas, area_sigma, process, process_sigma = _areas_with_process(cfg, part, cov, basis, values, sol.z, n_areas)
    else:
        areas, area_sigma = [], []
        for a in range(n_areas):
            sl = slice(a * n_coef, (a + 1) * n_coef)
            areas.append(basis @ values[sl])
            area_sigma.append(np.sqrt(np.einsum("ij,jk,ik->i", basis, cov_p[sl, sl], basis)))
        areas, area_sigma = np.column_stack(areas), np.column_stack(area_sigma)
    cda, cda_sigma = areas[:, 0], area_sigma[:, 0]
    with np.errstate(divide="ignore", invalid="ignore"):
        norm = np.where(data.inv_sigma > 0, (data.y - states) * data.inv_sigma, np.nan)
    errors = cfg.gps_errors
    whitened = innovations(cfg, data, part, nlp, sol.z) if cfg.model_error.enabled else errors.whiten(norm, data.t_unix)
    chi2 = nlp.group_chi2(r)
    counts = dict(nlp.n_measurements)
    counts["gps"] = int((data.inv_sigma > 0).sum())
    dof = sum(counts.values()) - (nlp.n_z - nlp.n_g)
    return PointMassResult(cfg, model_name, data.t_unix, states, state_sigma, cda, cda_sigma, part.params, values,
                           sigma, norm, chi2, counts, sum(chi2.values()) / max(dof, 1), sol, {}, nlp=nlp,
                           z=sol.z, covariance=cov, track=data.track, y=data.y, inv_sigma=data.inv_sigma,
                           areas=areas, area_sigma=area_sigma, whitened_residuals=whitened,
                           area_process=process, area_process_sigma=process_sigma,
                           notes=data.notes + ((errors.describe(),) if errors.enabled else ())
                          + ((cfg.model_error.describe(),) if cfg.model_error.enabled else ()))
