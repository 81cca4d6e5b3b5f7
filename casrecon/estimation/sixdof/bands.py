"""Reconstructed time history with marginal 3-sigma bands (delta method through the null-space
covariance): position, altitude, velocity, Euler angles, body rates, flow angles, qbar, Mach,
airspeed (the model's: the speed relative to the air, wind and gusts included) and speed |v|
(relative to the ground)."""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.sixdof.layout import NS, BlockLocals, DropLayout
from casrecon.estimation.sixdof.transcription import STATE_SCALE, disturbance_selection
from casrecon.physics.dynamics import OUTPUT_NAMES, FlightModel
from casrecon.physics.numpy_call import numpy_call

#: (column, unit factor) of each reported quantity; angles and rates in degrees.
COLUMNS = (("pos_n_m", 1.0), ("pos_e_m", 1.0), ("pos_d_m", 1.0), ("h_agl_m", 1.0),
           ("vel_n_mps", 1.0), ("vel_e_mps", 1.0), ("vel_d_mps", 1.0),
           ("roll_deg", 180 / np.pi), ("pitch_deg", 180 / np.pi), ("yaw_deg", 180 / np.pi),
           ("p_dps", 180 / np.pi), ("q_dps", 180 / np.pi), ("r_dps", 180 / np.pi),
           ("alpha_deg", 180 / np.pi), ("beta_deg", 180 / np.pi), ("alpha_t_deg", 180 / np.pi),
           ("qbar_pa", 1.0), ("mach", 1.0), ("airspeed_mps", 1.0), ("speed_mps", 1.0))
#: Added under the square root of the speed |v| (m^2/s^2) so that its derivative stays finite at
#: rest (a drop released from a hover): changes the speed by at most 1e-6 m/s.
SPEED_FLOOR_M2PS2 = 1e-12


#: Column names and unit factors of the disturbance entries (DISTURBANCE_NAMES order).
DISTURBANCE_COLUMNS = (("gust_n_mps", 1.0), ("gust_e_mps", 1.0), ("gust_d_mps", 1.0),
                       ("force_error_x_n", 1.0), ("force_error_y_n", 1.0), ("force_error_z_n", 1.0),
                       ("moment_error_x_nm", 1.0), ("moment_error_y_nm", 1.0), ("moment_error_z_nm", 1.0))
#: With disturbance states the bands are computed at most at this many nodes and interpolated.
MAX_BAND_NODES = 50


def columns_of(part: DropLayout) -> tuple[str, ...]:
    """Names of the reconstructed columns of one drop: COLUMNS, then its estimated disturbances."""
    return tuple(c for c, _ in COLUMNS) + tuple(DISTURBANCE_COLUMNS[i][0] for i in part.active)


def node_parameters(part: DropLayout, x, theta, z_cell, cell_base_msl_m):
    """The FlightModel parameters at a node of state ``x`` (SI): the estimates ``theta`` (SI) plus,
    with a profile, the corrections from its cell's window (scaled spline coefficients ``z_cell``,
    the lowest at ``cell_base_msl_m``)."""
    p = BlockLocals(part).model_params(theta)
    grid = part.profile
    if grid is None:
        return p
    return grid.add_to_parameters(p, grid.correction(z_cell, part.ground_alt_msl_m - x[2], cell_base_msl_m))


def node_cell_inputs(part: DropLayout, z: np.ndarray, nodes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(z columns (len(nodes), n_profile_local), their values (n_profile_local, len(nodes)), the
    windows' lowest altitudes (1, len(nodes))) of the profile cells of ``nodes`` (empty without a
    profile)."""
    nodes = np.asarray(nodes, np.int64)
    if part.profile is None:
        return np.zeros((nodes.size, 0), np.int64), np.zeros((0, nodes.size)), np.zeros((1, nodes.size))
    cells = part.node_cells[nodes]
    cols = part.profile_cell_columns(cells)
    return cols, z[cols].T, part.profile.window_base_msl_m(cells)[None, :]


def node_parameter_values(part: DropLayout, z: np.ndarray) -> np.ndarray:
    """The FlightModel parameters (n_params, K) at every node of a fit at ``z`` (scaled): the
    estimates plus the profile corrections at each node's altitude."""
    k = part.n_nodes
    zx, zt = ca.SX.sym("zx", NS), ca.SX.sym("zt", part.params.n)
    zg, base = ca.SX.sym("zg", part.n_profile_local), ca.SX.sym("base")
    x, theta = zx * ca.DM(STATE_SCALE), zt * ca.DM(part.params.scales)
    fn = ca.Function("node_parameters", [zx, zt, zg, base], [node_parameters(part, x, theta, zg, base)])
    _, zg_v, base_v = node_cell_inputs(part, z, np.arange(k))
    return np.asarray(fn.map(k)(z[part.node_cols].reshape(k, NS).T, np.repeat(z[part.theta_cols, None], k, axis=1),
                                zg_v, base_v))


def _output_function(model: FlightModel, part: DropLayout) -> ca.Function:
    """(z_node (13), z_theta, z_u, z_cell, cell base) -> (y, dy/d[z_node; z_theta; z_u; z_cell]) for the
    columns, scaled inputs."""
    params, active = part.params, part.active
    zx, zt, zu = ca.SX.sym("zx", NS), ca.SX.sym("zt", params.n), ca.SX.sym("zu", len(active))
    zg, base = ca.SX.sym("zg", part.n_profile_local), ca.SX.sym("base")
    x, theta = zx * ca.DM(STATE_SCALE), zt * ca.DM(params.scales)
    u = zu * ca.DM(part.u_scale)
    out = model.outputs_d(x, node_parameters(part, x, theta, zg, base), disturbance_selection(active) @ u)
    idx = OUTPUT_NAMES.index
    y = ca.vertcat(x[0:3], out[idx("h_agl")], x[3:6], out[idx("roll"):idx("yaw") + 1], x[10:13],
                   out[idx("alpha")], out[idx("beta")], out[idx("alpha_t")], out[idx("qbar")], out[idx("mach")],
                   out[idx("airspeed")], ca.sqrt(ca.sumsqr(x[3:6]) + SPEED_FLOOR_M2PS2), u)
    y = y * ca.DM([f for _, f in COLUMNS] + [DISTURBANCE_COLUMNS[i][1] for i in active])
    v = ca.vertcat(zx, zt, zu, zg)
    return ca.Function("outputs_with_jacobian", [zx, zt, zu, zg, base],
                       [ca.densify(y), ca.densify(ca.jacobian(y, v))])  # dense: evaluated by numpy_call


def trajectory_with_bands(model: FlightModel, part: DropLayout, z: np.ndarray, cov):
    """One drop's node values of its columns (:func:`columns_of`) and their absolute 1-sigma,
    arrays (K, n_columns); the sigmas None when ``cov`` is None. With disturbance states the
    sigmas are computed at up to MAX_BAND_NODES evenly spaced nodes and linearly interpolated in
    time between them."""
    k = part.mesh.t_nodes.size
    fn = _output_function(model, part).map(k, "thread", 2)
    zx = z[part.node_cols].reshape(k, NS).T
    zt = np.repeat(z[part.theta_cols, None], k, axis=1)
    zu = z[part.u_cols].T
    cell_cols, zg, base = node_cell_inputs(part, z, np.arange(k))
    y, jac = numpy_call(fn, zx, zt, zu, zg, base)
    y = y.T
    if cov is None:
        return y, None
    ny, nv = y.shape[1], NS + part.params.n + part.n_u + part.n_profile_local
    jac = jac.reshape(ny, k, nv).transpose(1, 0, 2)  # (k, ny, nv)
    nodes = np.arange(k) if not part.n_u else np.unique(np.linspace(0, k - 1, min(k, MAX_BAND_NODES)).astype(int))
    index_sets = [np.r_[part.node_offset + np.arange(NS * i, NS * i + NS), part.theta_cols, part.u_cols[i],
                        cell_cols[i]] for i in nodes]
    sigma = np.sqrt(np.maximum(cov.output_variances(index_sets, jac[nodes]), 0.0))
    if nodes.size < k:
        t = part.mesh.t_nodes
        sigma = np.column_stack([np.interp(t, t[nodes], sigma[:, c]) for c in range(ny)])
    return y, sigma
