"""IMU-driven (kinematic) reconstruction of any rigid body: the measured specific force and body
rates drive the states through preintegration (:mod:`casrecon.physics.preintegration`), the IMU
noise is the process noise, and fixes and barometer samples observe the states. No vehicle or aero
model is needed (docs/design.md: Kinematic reconstruction).

Unknowns: the IMU's position, velocity and attitude at every node, the IMU error parameters
(biases and scale factors with priors), optionally the clock offset of the fixes, the barometer
bias and the parameters of sample kinds (:mod:`.samples`, after the others), and with a GPS error
model the correlated part of each fix's error. Nodes sit on the fixes
(plus the window's ends, and more where fixes are further apart than ``max_node_spacing_s``).
A unit-norm constraint per node fixes each quaternion's scale; everything else is least squares,
solved by Levenberg-Marquardt on the unit quaternions (:mod:`.solve`: Gauss-Newton steps
with their geodesic acceleration and a line search, damping as the fallback; not Ipopt, whose
steps on the scale-free quaternions wander and fail at the optimum), first from the guess with the
IMU noise inflated 30, 10 and 3 times (:data:`START_INFLATIONS`, each from the last), then with
the stated noise to the Gauss-Newton decrement test of the other fits; should that still not
converge, Ipopt finishes from its last iterate and its verdict decides. The
covariance is the z-block of the inverse KKT matrix, computed without it
(:mod:`.covariance`).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np
from scipy.interpolate import interp1d
from scipy.spatial.transform import Rotation

from casrecon.estimation.engine.blocks import BlockSet, Term, unit_norm_term
from casrecon.estimation.engine.checks import FitError
from casrecon.estimation.engine.convergence import iteration_logging
from casrecon.estimation.engine.covariance import SingularCovariance
from casrecon.estimation.engine.nlp import Nlp, assemble_nlp
from casrecon.estimation.engine.solve import SolveResult, solve
from casrecon.estimation.kinds.disturbance import gauss_markov_terms
from casrecon.estimation.kinds.priors import prior_terms
from casrecon.estimation.kinds.samples import SampleKind, check_kinds
from casrecon.estimation.kinematic.covariance import GaugeCovariance
from casrecon.estimation.kinematic.data import KinematicData, KinematicOptions, local_line
from casrecon.estimation.kinematic.imu_record import check_piece_rotation
from casrecon.estimation.kinematic.samples import CLOCK, sample_parameters, sample_terms
from casrecon.estimation.kinematic.solve import LmResult, levenberg_marquardt
from casrecon.estimation.kinematic.terms import (
    KINEMATIC_SCALE,
    N_STATE,
    baro_kind,
    fix_kind,
    interval_kind,
)
from casrecon.estimation.sixdof.parameters import ParameterSet, ParameterSpec
from casrecon.physics.preintegration import IMU_PARAMETERS, Preintegrated, preintegrate

#: IMU noise inflations of the start solves, each from the last one's result, and their iteration limit.
START_INFLATIONS = (30.0, 10.0, 3.0)
#: Re-preintegration at the estimate when an IMU parameter moved more than this many prior sigmas
#: from the linearisation point, and how many times the final solve may do so.
RELINEARISE_SIGMAS = 1.0
RELINEARISATIONS = 3
START_MAX_ITER = 40
#: Span (s) over which the guess's heading is aligned, and the window of its tilt corrections.
HEADING_SPAN_S = 10.0
LEVEL_WINDOW_S = 1.0
#: Nodes closer than this to the previous one are merged into it, s.
MIN_NODE_SPACING_S = 1e-3
#: A clock offset estimated further than this from the guess the fixes were placed with (s) becomes
#: the new guess, and the fit is repeated with the nodes on the fixes' times under it: the fix
#: model carries a node's state over the difference with the IMU values at the node, which over
#: 0.1 s of a capsule's 2 to 3 Hz oscillation is far from the truth (in the truth study it pulled
#: the offset to three quarters of its value, 4 to 6 sigma, and the heights 1.5 m off).
CLOCK_REPLACE_S = 2e-3
#: Repetitions of the fit for :data:`CLOCK_REPLACE_S` at most.
CLOCK_REPLACEMENTS = 3
BARO_BIAS = "baro_bias_pa"
BARO_SCALE = "baro_height_scale"


@dataclass
class KinematicResult:
    """A kinematic reconstruction (SI; IMU position, velocity and IMU-to-NED attitude).

    Attributes
    ----------
    node_time_s : (K,) array
        IMU clock, s.
    states : (K, 10) array
        p (m, NED), v (m/s), q (IMU to NED).
    state_sigma : (K, 9) array
        1-sigma of p, v and of the attitude error as a NED rotation vector (rad).
    params : ParameterSet
    values, sigma : arrays
        Parameter estimates and 1-sigma (SI); ``parameter_covariance`` their covariance (SI).
    chi2 : dict
        Per residual group.
    n_measurements : dict
    reduced_chi2 : float
    """

    node_time_s: np.ndarray
    states: np.ndarray
    state_sigma: np.ndarray
    params: ParameterSet
    values: np.ndarray
    sigma: np.ndarray
    chi2: dict[str, float]
    n_measurements: dict[str, int]
    reduced_chi2: float
    nlp: Nlp
    z: np.ndarray
    covariance: object
    solver: LmResult | SolveResult
    preintegrated: Preintegrated
    data: KinematicData
    options: KinematicOptions
    timings: dict[str, float]
    notes: tuple[str, ...] = ()
    parameter_covariance: np.ndarray | None = None

    @property
    def state_columns(self) -> np.ndarray:
        """(K, 10) columns of z holding each node's scaled state (p, v, q; times KINEMATIC_SCALE is SI)."""
        return N_STATE * np.arange(self.node_time_s.size)[:, None] + np.arange(N_STATE)[None, :]

    @property
    def parameter_columns(self) -> np.ndarray:
        """Columns of z holding the parameters, in the order of ``params`` (times ``params.scales`` is SI)."""
        return N_STATE * self.node_time_s.size + np.arange(self.params.n)

    def parameter(self, name: str) -> tuple[float, float]:
        """(value, 1-sigma) of a parameter, SI."""
        i = self.params.index(name)
        return float(self.values[i]), float(self.sigma[i])

    def group_reduced_chi2(self) -> dict[str, float]:
        """Chi-square over measurement count per residual group."""
        return {g: self.chi2[g] / max(self.n_measurements.get(g, 1), 1) for g in self.chi2}


def node_times(data: KinematicData, max_spacing_s: float) -> np.ndarray:
    """Nodes on the fixes inside the window, the window's ends, and fill nodes so that no interval
    is longer than ``max_spacing_s``."""
    t0, t1 = data.window
    fixes = data.fix_time_s[(data.fix_time_s > t0) & (data.fix_time_s < t1)]
    nodes = np.unique(np.r_[t0, fixes, t1])
    keep = np.r_[True, np.diff(nodes) > MIN_NODE_SPACING_S]
    keep[-1] = True
    nodes = nodes[keep]
    if nodes.size > 2 and nodes[-1] - nodes[-2] <= MIN_NODE_SPACING_S:
        nodes = np.delete(nodes, -2)
    filled = [nodes[:1]]
    for a, b in zip(nodes[:-1], nodes[1:]):
        n = int(np.ceil((b - a) / max_spacing_s - 1e-9))
        filled.append(np.linspace(a, b, n + 1)[1:])
    return np.concatenate(filled)


def _parameters(options: KinematicOptions, has_baro: bool, extra=()) -> tuple[ParameterSet, np.ndarray]:
    sig = options.imu_prior_sigmas
    estimated = np.flatnonzero(sig > 0)
    units = ["rad/s"] * 3 + ["m/s^2"] * 3 + ["-"] * 6 + ["rad"] * 12
    specs = [ParameterSpec(IMU_PARAMETERS[i], "imu", sig[i], sig[i], units[i]) for i in estimated]
    if options.clock_sigma_s > 0:
        specs.append(ParameterSpec(CLOCK, "clock", options.clock_sigma_s, options.clock_sigma_s, "s"))
    if has_baro:
        s = options.baro_bias_sigma_pa
        specs.append(ParameterSpec(BARO_BIAS, "baro", s, s, "Pa"))
        s = options.baro_height_scale_sigma
        specs.append(ParameterSpec(BARO_SCALE, "baro", s, s, "-"))
    return ParameterSet(tuple(specs) + tuple(extra)), estimated


def _dm(arrays) -> list:
    """Block data as CasADi matrices (one column per block)."""
    return [ca.DM(np.asarray(a, float)) for a in arrays]


def carried_states(previous: KinematicResult, nodes: np.ndarray) -> np.ndarray:
    """(K, 10) states of ``previous`` at the times ``nodes``: positions and velocities interpolated
    linearly, quaternions component-wise between sign-aligned neighbours, renormalised."""
    q = previous.states[:, 6:10].copy()
    flips = np.cumsum(np.r_[0, np.sum(q[1:] * q[:-1], axis=1) < 0]) % 2
    q[flips == 1] *= -1.0
    states = np.column_stack([previous.states[:, :6], q])
    out = np.column_stack([np.interp(nodes, previous.node_time_s, states[:, i]) for i in range(10)])
    out[:, 6:10] /= np.linalg.norm(out[:, 6:10], axis=1, keepdims=True)
    return out


def initial_guess(data: KinematicData, nodes: np.ndarray, pre: Preintegrated, options: KinematicOptions,
                  gyro: np.ndarray, accel: np.ndarray) -> np.ndarray:
    """(K, 10) node states: positions and velocities interpolated from the fixes (velocity from the
    positions where the receiver gives none; the barometer's altitude where it gives no height),
    attitudes from the chained preintegrated rotations, turned by the rotation that best maps the
    rotated specific force onto the fixes' acceleration minus gravity over the first
    :data:`HEADING_SPAN_S` (Wahba's problem) and re-levelled window by window (:func:`levelled`)."""
    y = data.fix_y
    span = max(1.0, 4.0 * float(np.median(np.diff(data.fix_time_s)))) if data.fix_time_s.size > 1 else 1.0
    pos = np.zeros((nodes.size, 3))
    vel = np.zeros((nodes.size, 3))
    for i in range(3):
        ok = np.isfinite(y[:, i]) & np.isfinite(data.fix_sigma[:, i])
        if ok.sum() >= 2:
            pos[:, i] = np.interp(nodes, data.fix_time_s[ok], y[ok, i])
        elif i == 2 and data.baro_time_s is not None and data.atmosphere is not None:
            levels = data.atmosphere.levels
            alt = np.interp(-data.baro_pressure_pa, -levels["pressure_pa"], levels["altitude_msl_m"])
            pos[:, 2] = options.ground_alt_msl_m - np.interp(nodes, data.baro_time_s, alt)
        ok_v = np.isfinite(y[:, 3 + i]) & np.isfinite(data.fix_sigma[:, 3 + i])
        if ok_v.sum() >= 2:
            vel[:, i] = np.interp(nodes, data.fix_time_s[ok_v], y[ok_v, 3 + i])
        else:
            vel[:, i] = _smooth_derivative(nodes, pos[:, i], span)
    # attitude: chain the preintegrated rotations from identity
    rel = [Rotation.identity()]
    for q in pre.delta[:, :4]:
        rel.append(rel[-1] * Rotation.from_quat([q[1], q[2], q[3], q[0]]))
    rel = Rotation.concatenate(rel)
    f_nodes = interp1d(data.imu_time_s, accel, axis=0, assume_sorted=True, bounds_error=False,
                       fill_value=(accel[0], accel[-1]))(nodes)
    accel_ned = np.column_stack([_smooth_derivative(nodes, vel[:, i], span) for i in range(3)])
    g = np.array([0.0, 0.0, 9.80665 if options.gravity != "off" else 0.0])
    target = accel_ned - g
    first = nodes <= nodes[0] + HEADING_SPAN_S
    r0, _ = Rotation.align_vectors(target[first], rel[first].apply(f_nodes[first]))
    q = levelled(nodes, rel, f_nodes, target, r0).as_quat()
    return np.column_stack([pos, vel, q[:, 3], q[:, :3]])


def levelled(nodes: np.ndarray, rel: Rotation, f_body: np.ndarray, target: np.ndarray, r0: Rotation,
             window_s: float = LEVEL_WINDOW_S) -> Rotation:
    """Body-to-NED attitudes at the nodes from the chained gyro rotations ``rel`` (node to first
    node), started at ``r0`` and tilted window by window: in each window of ``window_s`` the
    smallest rotation that turns the mean NED specific force C f onto the mean of ``target``
    (acceleration minus gravity) is applied from there on. Keeps the tilt right however far the
    gyros drift over a long record; the heading stays the first window's."""
    out = []
    corr = r0
    start = 0
    while start < nodes.size:
        stop = max(int(np.searchsorted(nodes, nodes[start] + window_s)), start + 2)
        r = corr * rel[start:stop]
        u, v = r.apply(f_body[start:stop]).mean(axis=0), target[start:stop].mean(axis=0)
        axis = np.cross(u, v)
        norm = np.linalg.norm(axis)
        if norm > 1e-12:
            corr = Rotation.from_rotvec(axis / norm * np.arctan2(norm, u @ v)) * corr
        out.append(corr * rel[start:stop])
        start = stop
    return Rotation.concatenate(out)[:nodes.size]


def _smooth_derivative(t: np.ndarray, x: np.ndarray, span_s: float = 1.0) -> np.ndarray:
    """Derivative of x(t) by a local line fitted over +-span_s / 2 around each point."""
    out = np.zeros_like(x)
    for i, ti in enumerate(t):
        sel = np.abs(t - ti) <= span_s / 2
        if sel.sum() >= 2:
            out[i] = np.polyfit(t[sel] - ti, x[sel], 1)[0]
    return out


def fit_kinematic(data: KinematicData, options: KinematicOptions, print_level: int = 0,
                  sample_kinds: Sequence[SampleKind] = ()) -> KinematicResult:
    """Reconstruct position, velocity and attitude with 3-sigma bands from the IMU record driving
    the states and the fixes (and barometer, and ``sample_kinds``: :mod:`.samples`, lever arms from
    the IMU in IMU axes) observing them; with a clock offset estimated, the nodes end on the fixes'
    times under the estimated offset (:data:`CLOCK_REPLACE_S`).

    Raises
    ------
    InputError
        An IMU record whose rate is too low for the body's rotation (more than 1 rad between samples).
    FitError
        No convergence, or a singular KKT matrix.
    """
    t_start = time.perf_counter()
    kinds = check_kinds(sample_kinds, ("imu", "gps", "gps_error", "gps_error_start", "baro", "quaternion_norm",
                                       *_parameters(options, data.baro_time_s is not None)[0].names))
    result = _fit_placed(data, options, print_level, kinds=kinds)
    for placement in range(1, CLOCK_REPLACEMENTS + 1):
        if CLOCK not in result.params.names:
            break
        clock = float(result.values[result.params.index(CLOCK)])
        if abs(clock - options.clock_guess_s) <= CLOCK_REPLACE_S:
            break
        earlier = result.timings["earlier_iterations"] + result.solver.iterations
        data = replace(data, fix_time_s=data.fix_time_s + options.clock_guess_s - clock)
        options = replace(options, clock_guess_s=clock)
        result = _fit_placed(data, options, print_level, previous=result, kinds=kinds)
        result.timings["earlier_iterations"] += earlier
        result.notes = result.notes + (f"fixes placed again at the estimated clock offset {clock:+.4f} s "
                                       f"(placement {placement + 1})",)
    result.timings["total_s"] = time.perf_counter() - t_start
    return result


def _fit_placed(data: KinematicData, options: KinematicOptions, print_level: int,
                previous: KinematicResult | None = None, kinds: tuple[SampleKind, ...] = ()) -> KinematicResult:
    """:func:`fit_kinematic` with the fixes where ``data`` and ``options.clock_guess_s`` put them;
    from ``previous`` (its states interpolated to the new nodes, its parameters), without the
    inflated-noise starts, when given."""
    t_start = time.perf_counter()
    nodes = node_times(data, options.max_node_spacing_s)
    gyro, accel = data.bridged()
    gyro_sigma, accel_sigma = data.noise_sigmas(options)
    pre = preintegrate(data.imu_time_s, gyro, accel, nodes, gyro_sigma, accel_sigma)
    check_piece_rotation(data, gyro)
    has_baro = data.baro_time_s is not None and data.baro_time_s.size > 0
    params, estimated = _parameters(options, has_baro, sample_parameters(kinds))
    k, n_int = nodes.size, nodes.size - 1
    theta_cols = N_STATE * k + np.arange(params.n)
    imu_cols = theta_cols[:estimated.size]
    n_z = N_STATE * k + params.n
    state_cols = N_STATE * np.arange(k)[:, None] + np.arange(N_STATE)[None, :]

    interval = interval_kind(options, params.scales[:estimated.size], estimated)
    cols = np.column_stack([state_cols[:-1], state_cols[1:], np.tile(imu_cols, (n_int, 1))])
    fix_terms, n_z, e_cols = _fix_terms(data, options, nodes, params, estimated, theta_cols, state_cols, gyro, accel,
                                              n_z)
    other_terms = fix_terms + ([_baro_term(data, options, nodes, params, theta_cols, state_cols)] if has_baro else [])
    other_terms += sample_terms(kinds, data, options, nodes, params, theta_cols, state_cols)
    other_terms += prior_terms(params, theta_cols) + [unit_norm_term(state_cols[:, 6:10], "quaternion_norm")]

    def assemble(inflation: float, pre: Preintegrated) -> Nlp:
        interval_data = [pre.duration_s[None, :], pre.delta.T,
                         pre.jac_theta.transpose(0, 2, 1).reshape(n_int, -1).T,
                         pre.whitening.transpose(0, 2, 1).reshape(n_int, -1).T / inflation,
                         np.tile(pre.theta_lin[:, None], (1, n_int))]
        terms = [Term("imu", (BlockSet(interval, cols, _dm(interval_data)),), n_measurements=9 * n_int)]
        return assemble_nlp(terms + other_terms, n_z, dependent=np.zeros(0, np.int64),
                            parameter_names=dict(zip(theta_cols.tolist(), params.names)), latent=True,
                            eliminated=e_cols)

    x0 = initial_guess(data, nodes, pre, options, gyro, accel) if previous is None else carried_states(previous, nodes)
    z0 = np.zeros(n_z)
    z0[state_cols.ravel()] = (x0 / KINEMATIC_SCALE).ravel()
    if previous is not None:
        z0[theta_cols] = previous.values / params.scales
    elif CLOCK in params.names:
        z0[theta_cols[params.index(CLOCK)]] = options.clock_guess_s / params.specs[params.index(CLOCK)].scale
    # continuation: the IMU noise inflated first, so the fixes place the trajectory and the attitude
    # before the IMU's full weight binds them (the guess's attitude can be far off)
    t_guess = time.perf_counter()
    prior = params.scales[:estimated.size]
    earlier_iterations = 0   # of the starts and of the solves before a relinearisation
    if previous is not None:
        pre = _relinearised(pre, z0[imu_cols] * prior, estimated, prior, data, gyro, accel, nodes, options)
    for inflation in START_INFLATIONS if previous is None else ():
        start = levenberg_marquardt(assemble(inflation, pre), z0, state_cols[:, 6:10], START_MAX_ITER,
                                    label=f"kinematic start (IMU noise x {inflation:g})")
        z0, earlier_iterations = start.z, earlier_iterations + start.iterations
        pre = _relinearised(pre, z0[imu_cols] * prior, estimated, prior, data, gyro, accel, nodes, options)
    nlp = assemble(1.0, pre)
    t_built = time.perf_counter()
    for attempt in range(RELINEARISATIONS + 1):
        sol = levenberg_marquardt(nlp, z0, state_cols[:, 6:10], options.max_iter)
        if attempt == RELINEARISATIONS:
            break  # the solution belongs to this linearisation; it is reported with it
        moved = _relinearised(pre, sol.z[imu_cols] * prior, estimated, prior, data, gyro, accel, nodes, options)
        if moved is pre:
            break
        pre, z0, earlier_iterations = moved, sol.z, earlier_iterations + sol.iterations
        nlp = assemble(1.0, pre)
    if not sol.converged:
        sol = _ipopt_finish(nlp, sol, options, print_level)
    t_solved = time.perf_counter()
    r = nlp.residual_vector(sol.z)
    try:
        cov = GaugeCovariance(nlp, sol.z, state_cols[:, 6:10], nlp.chi2(r), nlp.dof())
        cov.check_parameters(theta_cols)
    except SingularCovariance as err:
        raise FitError(str(err)) from None
    result = _result(data, options, nodes, pre, params, estimated, nlp, sol, cov, r, state_cols, theta_cols)
    result.timings.update(build_s=t_guess - t_start, start_solve_s=t_built - t_guess, solve_s=t_solved - t_built,
                          earlier_iterations=earlier_iterations,
                          covariance_s=time.perf_counter() - t_solved, total_s=time.perf_counter() - t_start)
    return result


def _relinearised(pre: Preintegrated, theta_estimated: np.ndarray, estimated: np.ndarray, prior: np.ndarray,
                  data: KinematicData, gyro, accel, nodes, options) -> Preintegrated:
    """The preintegration taken again at the estimated IMU parameters when any has moved more than
    :data:`RELINEARISE_SIGMAS` prior sigmas from where it was linearised (the first-order
    correction J (theta - theta_lin) then errs by more than the noise on a fast-turning record);
    ``pre`` itself otherwise."""
    if np.all(np.abs(theta_estimated - pre.theta_lin[estimated]) <= RELINEARISE_SIGMAS * prior):
        return pre
    theta = np.zeros_like(pre.theta_lin)
    theta[estimated] = theta_estimated
    gyro_sigma, accel_sigma = data.noise_sigmas(options)
    return preintegrate(data.imu_time_s, gyro, accel, nodes, gyro_sigma, accel_sigma, theta)


def _ipopt_finish(nlp: Nlp, lm: LmResult, options: KinematicOptions, print_level: int):
    """Ipopt from Levenberg-Marquardt's last iterate, for a strongly nonlinear record (a spinning
    body) where the damped steps crawl; its verdict decides. FitError when it fails too."""
    with iteration_logging(label="kinematic fit (Ipopt)"):
        sol = solve(nlp, lm.z, options.linear_solver, options.max_iter, options.tol, print_level)
    if not sol.converged:
        raise FitError(f"the kinematic fit did not converge: Levenberg-Marquardt {lm.status}, then Ipopt "
                       f"{sol.status} after {sol.iterations} iterations; no result written")
    return sol


def _fix_terms(data, options, nodes, params, estimated, theta_cols, state_cols, gyro, accel, n_z):
    """The fix term (and the correlated-error terms) and the new size of z."""
    t = data.fix_time_s
    inside = (t >= nodes[0] - 1e-9) & (t <= nodes[-1] + 1e-9)
    t, y, sigma = t[inside], data.fix_y[inside], data.fix_sigma[inside]
    if t.size == 0:
        raise FitError("no position or velocity fix inside the reconstructed window")
    node = np.clip(np.searchsorted(nodes, t - 1e-6), 0, nodes.size - 1)
    nearer = (node > 0) & (np.abs(nodes[node - 1] - t) < np.abs(nodes[node] - t))
    node = np.where(nearer, node - 1, node)
    errors = options.gps_errors
    active = errors.active
    white_inv = np.where(np.isfinite(sigma), 1.0 / (sigma * np.sqrt(1.0 - errors.fraction)), 0.0)
    with_clock = CLOCK in params.names
    cols = [state_cols[node], np.tile(theta_cols[:estimated.size], (t.size, 1))]
    if with_clock:
        cols.append(np.full((t.size, 1), theta_cols[params.index(CLOCK)]))
    w_node, _ = local_line(nodes[node], data.imu_time_s, gyro)
    f_node, f_slope = local_line(nodes[node], data.imu_time_s, accel)
    block_data = [np.where(np.isfinite(y), y, 0.0).T, white_inv.T, w_node.T, f_node.T, f_slope.T,
                  (t - nodes[node])[None, :]]
    e_cols = np.zeros(0, np.int64)
    terms = []
    if active.size:
        e_cols = n_z + np.arange(t.size * active.size)
        n_z += e_cols.size
        cols.append(e_cols.reshape(t.size, active.size))
        amp = np.where(np.isfinite(sigma), sigma * np.sqrt(errors.fraction), 0.0)[:, active]
        block_data.append(amp.T)
    clock_scale = params.specs[params.index(CLOCK)].scale if with_clock else 1.0
    kind = fix_kind(options, with_clock, clock_scale, active.size, active, params.scales[:estimated.size], estimated)
    n_meas = int(np.isfinite(sigma).sum())
    terms.append(Term("gps", (BlockSet(kind, np.column_stack(cols), _dm(block_data)),), n_measurements=n_meas))
    if active.size:
        phi = errors.transition(np.diff(t))
        terms += gauss_markov_terms(e_cols.reshape(t.size, active.size), phi, "gps_error_start", "gps_error")
    return terms, n_z, e_cols


def _baro_term(data, options, nodes, params, theta_cols, state_cols) -> Term:
    t = data.baro_time_s
    inside = (t >= nodes[0]) & (t <= nodes[-1])
    t, p = t[inside], data.baro_pressure_pa[inside]
    k = np.clip(np.searchsorted(nodes, t, side="right") - 1, 0, nodes.size - 2)
    dur = nodes[k + 1] - nodes[k]
    tau = (t - nodes[k]) / dur
    bias_col = theta_cols[params.index(BARO_BIAS)]
    kind = baro_kind(data.atmosphere, options, params.specs[params.index(BARO_BIAS)].scale,
                     params.specs[params.index(BARO_SCALE)].scale)
    cols = np.column_stack([state_cols[k], state_cols[k + 1], np.full(t.size, bias_col),
                            np.full(t.size, theta_cols[params.index(BARO_SCALE)])])
    block_data = [tau[None, :], dur[None, :], p[None, :], np.full((1, t.size), 1.0 / data.baro_noise_pa)]
    return Term("baro", (BlockSet(kind, cols, _dm(block_data)),))


def _result(data, options, nodes, pre, params, estimated, nlp, sol, cov, r, state_cols, theta_cols) -> KinematicResult:
    states = sol.z[state_cols] * KINEMATIC_SCALE
    q = states[:, 6:10] / np.linalg.norm(states[:, 6:10], axis=1, keepdims=True)
    states[:, 6:10] = q
    blocks = cov.blocks([c for c in state_cols])
    sigma = np.zeros((nodes.size, 9))
    for i, (b, qi) in enumerate(zip(blocks, q)):
        b = b * np.outer(KINEMATIC_SCALE, KINEMATIC_SCALE)
        sigma[i, :6] = np.sqrt(np.clip(np.diag(b)[:6], 0, None))
        # NED rotation vector d(theta) = 2 vec(dq (x) conj(q)) for q' = Exp(d theta) (x) q
        w, x, y, z = qi
        right_conj = np.array([[-x, w, -z, y], [-y, z, w, -x], [-z, -y, x, w]])
        m = 2.0 * right_conj
        sigma[i, 6:] = np.sqrt(np.clip(np.diag(m @ b[6:, 6:] @ m.T), 0, None))
    cov_p = cov.covariance_of(theta_cols, params.scales)
    values = sol.z[theta_cols] * params.scales
    chi2 = nlp.group_chi2(r)
    counts = dict(nlp.n_measurements)
    dof = sum(counts.values()) - (nlp.n_z - nlp.n_g)
    notes = data.notes + (f"{nodes.size} nodes, {nodes.size - 1} preintegrated intervals over "
                          f"{nodes[-1] - nodes[0]:.1f} s",)
    return KinematicResult(nodes, states, sigma, params, values, np.sqrt(np.diag(cov_p)), chi2, counts,
                           sum(chi2.values()) / max(dof, 1), nlp, sol.z, cov, sol, pre, data, options, {}, notes,
                           parameter_covariance=cov_p)
