"""Aerodynamic coefficient histories of a fit with 3-sigma bands (the DAVINCI paper's Figs. 12-15).

At every node three sets of :data:`~casrecon.analysis.aero_columns.COEFFICIENTS` are computed:

- **reconstructed**, from the measurements: in a strong-constraint fit the fitted accelerations are
  the database's by construction, so the force and moment that acted are taken from the IMU instead.
  The bias-corrected accelerometers and gyros are smoothed by a Savitzky-Golay filter (cubic, 0.1 s),
  which also gives the angular acceleration; the specific force is moved from the IMU to the centre
  of mass, F = m (f - dw/dt x r - w x (w x r)); the moment about the centre of mass is
  I dw/dt + w x I w, moved to the MRP, M_MRP = M_cm - (r_MRP - r_cm) x F; both are divided by
  qbar S (and d) with qbar and the crossflow direction of the reconstructed trajectory. The
  difference from the database is what the fitted model misses (in a weak-constraint fit, the
  model-error force and moment among it).
- **best_fit**: the database with the fitted dispersions along the reconstructed trajectory (air
  velocity with the fitted wind and, in a weak-constraint fit, the estimated gusts); totals with
  damping, about the MRP.
- **nominal**: the same with every dispersion 0 (no band).

3-sigma bands by the delta method, as :mod:`casrecon.estimation.sixdof.bands` does for the trajectory: the
Jacobian of each coefficient with respect to the node's state, the parameters (IMU biases, wind,
density, dispersions) and the node's disturbances, times their covariance block (never a dense
covariance of the whole decision vector). The reconstructed band adds the measurement noise passed
through the filter (exact: the filter is linear in the samples, so its variance is sigma^2 times the
sum of its squared weights). The two parts are added as independent: each node's 51 samples are a
small share of those that determine the biases and the dynamic pressure. A node whose filter window
holds a saturated sample has no reconstructed value (NaN).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.analysis import aero_columns as cols
from casrecon.estimation.kinds.imu import SENSOR_NAMES, imu_sigma
from casrecon.estimation.numerics.savgol import savgol_coeffs
from casrecon.estimation.sixdof.bands import MAX_BAND_NODES, node_cell_inputs, node_parameters
from casrecon.estimation.sixdof.layout import NS, BlockLocals
from casrecon.estimation.sixdof.transcription import STATE_SCALE, disturbance_selection
from casrecon.physics.aero import DISPERSION_NAMES, aero_force_moment, flow_angles
from casrecon.physics.dynamics import DISTURBANCE_NAMES, FlightModel
from casrecon.physics.numpy_call import numpy_call

#: Savitzky-Golay filter of the IMU samples: window (s) and polynomial order.
SMOOTHING_WINDOW_S = 0.1
SMOOTHING_ORDER = 3
#: Fewest samples of a cubic window; below, the quartic through 5 samples (:func:`filter_shape`).
MIN_SMOOTHING_SAMPLES = 7
N_COEF = len(cols.COEFFICIENTS)


def coefficient_vector(force, moment_mrp, qbar, ref_area_m2: float, ref_length_m: float, crossflow_dir):
    """The :data:`~casrecon.analysis.aero_columns.COEFFICIENTS` (8, dimensionless) of a body-axis
    force (N) and moment about the MRP (N m) at dynamic pressure ``qbar`` (Pa), with the crossflow
    direction e_c (3-vector, body axes) for the crossflow-plane resultants."""
    qs = qbar * ref_area_m2
    c_a, c_y, c_n = -force[0] / qs, force[1] / qs, -force[2] / qs
    c_l, c_m, c_yaw = (moment_mrp[i] / (qs * ref_length_m) for i in range(3))
    ey, ez = crossflow_dir[1], crossflow_dir[2]
    return ca.vertcat(c_a, c_y, c_n, c_l, c_m, c_yaw, c_n * ez - c_y * ey, c_m * ez - c_yaw * ey)


def _flow(model: FlightModel, x, p, d):
    """(qbar Pa, crossflow direction, equations-of-motion terms) at state x, parameters p, disturbance d."""
    t = model.terms(x, p, d)
    fl = flow_angles(t["v_air_body"])
    return 0.5 * t["air"].density * fl.speed ** 2, fl, t


def database_coefficients(model: FlightModel, x, p, d=None):
    """Coefficients (8) of the aero database alone (no model-error force or moment) at state ``x``
    (13, SI), model parameters ``p`` (dispersions and atmosphere corrections) and disturbance ``d``
    (9; its gust moves the air): total force and moment about the MRP from
    :func:`~casrecon.physics.aero.aero_force_moment`, divided by qbar S (and d)."""
    veh = model.vehicle
    qbar, fl, t = _flow(model, x, p, d)
    force, moment = aero_force_moment(model.aero, t["v_air_body"], x[10:13], t["air"].density,
                                      t["air"].sound_speed, p[:len(DISPERSION_NAMES)], veh.ref_area_m2,
                                      veh.ref_length_m, ca.DM.zeros(3))
    return coefficient_vector(force, moment, qbar, veh.ref_area_m2, veh.ref_length_m, fl.crossflow_dir)


def imu_force_moment(vehicle, f_body, w_body, wdot_body):
    """Aerodynamic force (N) and moment about the MRP (N m), body axes, from the IMU's corrected
    specific force ``f_body`` (m/s^2), rate ``w_body`` (rad/s) and angular acceleration ``wdot_body``
    (rad/s^2), all already turned into body axes (CasADi).

    F = m (f - dw/dt x r - w x (w x r)) (r the IMU position from the centre of mass), M_cm = I dw/dt +
    w x I w, M_MRP = M_cm - (r_MRP - r_cm) x F."""
    r = ca.DM(vehicle.lever(vehicle.imu_position_m))
    force = vehicle.mass_kg * (f_body - ca.cross(wdot_body, r) - ca.cross(w_body, ca.cross(w_body, r)))
    inertia = ca.DM(np.asarray(vehicle.inertia_kgm2))
    moment_cm = inertia @ wdot_body + ca.cross(w_body, inertia @ w_body)
    return force, moment_cm - ca.cross(ca.DM(vehicle.lever(vehicle.mrp_m)), force)


def reconstructed_coefficients(model: FlightModel, x, p, d, bias, f_imu, w_imu, wdot_imu):
    """Coefficients (8) from IMU quantities: specific force ``f_imu`` (m/s^2), rate ``w_imu`` (rad/s)
    and angular acceleration ``wdot_imu`` (rad/s^2), IMU axes, before removing ``bias`` (6:
    accelerometer m/s^2, gyro rad/s); qbar and the crossflow direction from ``x``, ``p``, ``d``;
    force and moment by :func:`imu_force_moment`."""
    veh = model.vehicle
    r_ib = ca.DM(np.asarray(veh.imu_to_body))
    force, moment_mrp = imu_force_moment(veh, r_ib @ (f_imu - bias[0:3]), r_ib @ (w_imu - bias[3:6]),
                                         r_ib @ wdot_imu)
    qbar, fl, _ = _flow(model, x, p, d)
    return coefficient_vector(force, moment_mrp, qbar, veh.ref_area_m2, veh.ref_length_m, fl.crossflow_dir)


def coefficient_functions(model: FlightModel) -> tuple[ca.Function, ca.Function]:
    """``database(x, p, d) -> c`` and ``reconstructed(x, p, d, bias6, f, w, wdot) -> c`` as CasADi
    Functions (SI inputs, see :func:`database_coefficients` and :func:`reconstructed_coefficients`)."""
    x, p, d = ca.SX.sym("x", NS), ca.SX.sym("p", model.n_params), ca.SX.sym("d", len(DISTURBANCE_NAMES))
    b, f, w, wd = (ca.SX.sym(n, k) for n, k in (("b", 6), ("f", 3), ("w", 3), ("wd", 3)))
    db = ca.Function("database_coefficients", [x, p, d], [database_coefficients(model, x, p, d)])
    rec = ca.Function("reconstructed_coefficients", [x, p, d, b, f, w, wd],
                      [reconstructed_coefficients(model, x, p, d, b, f, w, wd)])
    return db, rec


def _node_function(result) -> ca.Function:
    """(z_node, z_theta, z_u, s9) -> (y, J) for one node, scaled decision variables.

    y = [best-fit (8); reconstructed (8); nominal (8); alpha_T deg; qbar Pa]; J = [d(best-fit;
    reconstructed)/d(z_node; z_theta; z_u) | d(best-fit; reconstructed)/d s9], s9 the smoothed IMU
    specific force, rate and angular acceleration (IMU axes, before bias removal)."""
    model, part = result.scenario.model, result.part
    loc = BlockLocals(part)
    zx, zt, zu = ca.SX.sym("zx", NS), ca.SX.sym("zt", part.params.n), ca.SX.sym("zu", part.n_u)
    zg, base = ca.SX.sym("zg", part.n_profile_local), ca.SX.sym("base")
    s = ca.SX.sym("s", 9)
    x, theta = zx * ca.DM(STATE_SCALE), zt * ca.DM(part.params.scales)
    d = disturbance_selection(part.active) @ (zu * ca.DM(part.u_scale)) if part.n_u else ca.DM.zeros(9)
    p = node_parameters(part, x, theta, zg, base)
    n_disp = len(DISPERSION_NAMES)
    p_nominal = ca.vertcat(ca.DM.zeros(n_disp), p[n_disp:])
    best = database_coefficients(model, x, p, d)
    rec = reconstructed_coefficients(model, x, p, d, loc.select(theta, SENSOR_NAMES), s[0:3], s[3:6], s[6:9])
    qbar, fl, _ = _flow(model, x, p, d)
    y = ca.vertcat(best, rec, database_coefficients(model, x, p_nominal, d), fl.alpha_t * 180 / np.pi, qbar)
    banded = ca.vertcat(best, rec)
    jac = ca.horzcat(ca.jacobian(banded, ca.vertcat(zx, zt, zu, zg)), ca.jacobian(banded, s))
    return ca.Function("aero_coefficients_node", [zx, zt, zu, zg, base, s], [ca.densify(y), ca.densify(jac)])


def filter_shape(window_s: float, dt_s: float) -> tuple[int, int]:
    """(samples, polynomial order) of the Savitzky-Golay filter for a ``window_s`` window at sample
    spacing ``dt_s``: the window rounded to an odd number of samples, cubic; where that holds fewer
    than :data:`MIN_SMOOTHING_SAMPLES` (an IMU below about 60 Hz), the quartic through 5 samples
    instead (no smoothing of the values; the fourth-order central derivative), because a cubic
    over a longer window would flatten the vehicle's oscillation (at 13 Hz a 0.38 s window)."""
    width = int(round(window_s / dt_s)) // 2 * 2 + 1
    if width < MIN_SMOOTHING_SAMPLES:
        return 5, 4
    return width, SMOOTHING_ORDER


def smoothed_imu(time_s: np.ndarray, accel: np.ndarray, gyro: np.ndarray, valid: np.ndarray,
                 node_time_s: np.ndarray, sigma: np.ndarray, window_s: float = SMOOTHING_WINDOW_S):
    """Savitzky-Golay values at the nodes of the IMU specific force, rate and angular acceleration.

    Parameters
    ----------
    time_s : (N,) array
        Sample times, s (uniform).
    accel, gyro : (N, 3) arrays
        Specific force (m/s^2) and rate (rad/s), IMU axes, as measured.
    valid : (N,) bool array
        False where any channel of a sample is saturated.
    node_time_s : (K,) array
        Times (s) to evaluate at (the filter's window centred on the nearest sample, its
        polynomial evaluated at the time itself).
    sigma : (6,) array
        White-noise 1-sigma per sample of the six channels (m/s^2, rad/s).
    window_s : float
        Filter window, s (:func:`filter_shape`).

    Returns
    -------
    s : (K, 9) array
        Smoothed specific force (m/s^2), rate (rad/s) and angular acceleration (rad/s^2); NaN rows
        where the window holds a saturated sample or there are too few samples.
    cov : (K, 9, 9) array
        Covariance of ``s`` from the white noise (exact for the linear filter).
    """
    n, k = time_s.size, node_time_s.size
    dt = float(np.median(np.diff(time_s))) if n > 1 else 1.0
    width, order = filter_shape(window_s, dt)
    s, cov = np.full((k, 9), np.nan), np.zeros((k, 9, 9))
    if n < width:
        return s, cov
    idx = np.clip(np.searchsorted(time_s, node_time_s - 0.5 * dt), 0, n - 1)
    start = np.clip(idx - width // 2, 0, n - width)
    # the polynomial evaluated at the node's own time (between samples at a low IMU rate)
    pos = np.round(np.clip((node_time_s - time_s[start]) / dt, 0.0, width - 1.0), 6)
    windows = start[:, None] + np.arange(width)[None, :]
    y = np.column_stack([accel, gyro])[windows]                      # (K, width, 6)
    for p in np.unique(pos):
        rows = pos == p
        c0 = savgol_coeffs(width, order, pos=float(p), use="dot")
        c1 = savgol_coeffs(width, order, deriv=1, delta=dt, pos=float(p), use="dot")
        s[rows, 0:6] = np.einsum("w,kwc->kc", c0, y[rows])
        s[rows, 6:9] = np.einsum("w,kwc->kc", c1, y[rows, :, 3:6])
        block = np.zeros((9, 9))
        block[range(6), range(6)] = sigma[:6] ** 2 * (c0 @ c0)
        for j in range(3):
            g = sigma[3 + j] ** 2
            block[6 + j, 6 + j] = g * (c1 @ c1)
            block[3 + j, 6 + j] = block[6 + j, 3 + j] = g * (c0 @ c1)
        cov[rows] = block
    s[~valid[windows].all(axis=1)] = np.nan
    return s, cov


def aero_coefficients(result) -> dict[str, np.ndarray]:
    """The columns of ``aero_coefficients.csv`` (:func:`~casrecon.analysis.aero_columns.all_columns`)
    of a converged per-drop fit (or one drop of a joint fit).

    Parameters
    ----------
    result : casrecon.estimation.sixdof.fit.FitResult

    Returns
    -------
    dict of str to (K,) array
        Times (s), alpha_T (deg), qbar (Pa), and per coefficient the reconstructed value and 3-sigma,
        the best-fit value and 3-sigma, and the nominal value (dimensionless). With disturbance states
        the state and parameter part of the sigmas is computed at up to MAX_BAND_NODES nodes and
        interpolated, as for the trajectory bands.
    """
    part, data, z = result.part, result.data, result.z
    k = part.mesh.t_nodes.size
    valid = data.accel_valid.all(axis=1) & data.gyro_valid.all(axis=1)
    s, cov_s = smoothed_imu(data.imu_time_s, data.accel_imu, data.gyro_imu, valid, part.mesh.t_nodes,
                            imu_sigma(result.scenario.config))
    fn = _node_function(result).map(k, "thread", 2)
    zx = z[part.node_cols].reshape(k, NS).T
    zt = np.repeat(z[part.theta_cols, None], k, axis=1)
    zu = z[part.u_cols].T
    cell_cols, zg, base = node_cell_inputs(part, z, np.arange(k))
    y, jac = numpy_call(fn, zx, zt, zu, zg, base, np.nan_to_num(s).T)
    y = y.T                                                           # (K, 26)
    n_v = NS + part.params.n + part.n_u + part.n_profile_local
    jac = jac.reshape(2 * N_COEF, k, n_v + 9).transpose(1, 0, 2)   # (K, 16, n_v + 9)
    nodes = np.arange(k) if not part.n_u else np.unique(np.linspace(0, k - 1, min(k, MAX_BAND_NODES)).astype(int))
    index_sets = [np.r_[part.node_offset + np.arange(NS * i, NS * i + NS), part.theta_cols, part.u_cols[i],
                        cell_cols[i]] for i in nodes]
    var_z = result.covariance.output_variances(index_sets, np.ascontiguousarray(jac[nodes, :, :n_v]))
    if nodes.size < k:
        t = part.mesh.t_nodes
        var_z = np.column_stack([np.interp(t, t[nodes], var_z[:, c]) for c in range(2 * N_COEF)])
    j_s = jac[:, N_COEF:, n_v:]                                       # reconstructed w.r.t. s
    var_noise = np.einsum("kij,kjl,kil->ki", j_s, cov_s, j_s)
    three = 3 * np.sqrt(np.maximum(var_z + np.c_[np.zeros((k, N_COEF)), var_noise], 0.0))
    recon = np.where(np.isnan(s[:, :1]), np.nan, y[:, N_COEF:2 * N_COEF])
    three[:, N_COEF:] = np.where(np.isnan(s[:, :1]), np.nan, three[:, N_COEF:])
    out = {cols.TIME_IMU: part.mesh.t_nodes, cols.FLIGHT_TIME: part.mesh.t_nodes - data.release_imu_s,
           cols.ALPHA_T: y[:, 3 * N_COEF], cols.QBAR: y[:, 3 * N_COEF + 1]}
    for i, c in enumerate(cols.COEFFICIENTS):
        out[cols.column(c, cols.RECONSTRUCTED)] = recon[:, i]
        out[cols.sigma_column(c, cols.RECONSTRUCTED)] = three[:, N_COEF + i]
        out[cols.column(c, cols.BEST_FIT)] = y[:, i]
        out[cols.sigma_column(c, cols.BEST_FIT)] = three[:, i]
        out[cols.column(c, cols.NOMINAL)] = y[:, 2 * N_COEF + i]
    return {name: out[name] for name in cols.all_columns()}
