"""Reconstructed time history with marginal 3-sigma bands (delta method through the null-space
covariance): position, altitude, velocity, Euler angles, body rates, flow angles, qbar, Mach."""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.covariance import Covariance
from casrecon.estimation.problem import NS, DropPart, _Unscale
from casrecon.estimation.transcription import STATE_SCALE
from casrecon.physics.dynamics import OUTPUT_NAMES, FlightModel

#: (column, unit factor) of each reported quantity; angles and rates in degrees.
COLUMNS = (("pos_n_m", 1.0), ("pos_e_m", 1.0), ("pos_d_m", 1.0), ("h_agl_m", 1.0),
           ("vel_n_mps", 1.0), ("vel_e_mps", 1.0), ("vel_d_mps", 1.0),
           ("roll_deg", 180 / np.pi), ("pitch_deg", 180 / np.pi), ("yaw_deg", 180 / np.pi),
           ("p_dps", 180 / np.pi), ("q_dps", 180 / np.pi), ("r_dps", 180 / np.pi),
           ("alpha_deg", 180 / np.pi), ("beta_deg", 180 / np.pi), ("alpha_t_deg", 180 / np.pi),
           ("qbar_pa", 1.0), ("mach", 1.0))


def _output_function(model: FlightModel, params) -> ca.Function:
    """(z_node (13), z_theta) -> (y, dy/d[z_node; z_theta]) for the COLUMNS, scaled inputs."""
    un = _Unscale(model, params)
    zx, zt = ca.SX.sym("zx", NS), ca.SX.sym("zt", params.n)
    x, theta = zx * ca.DM(STATE_SCALE), zt * ca.DM(params.scales)
    out = model.outputs(x, un.model_params(theta))
    idx = OUTPUT_NAMES.index
    y = ca.vertcat(x[0:3], out[idx("h_agl")], x[3:6], out[idx("roll"):idx("yaw") + 1], x[10:13],
                   out[idx("alpha")], out[idx("beta")], out[idx("alpha_t")], out[idx("qbar")], out[idx("mach")])
    y = y * ca.DM([f for _, f in COLUMNS])
    v = ca.vertcat(zx, zt)
    return ca.Function("outputs_with_jacobian", [zx, zt], [y, ca.jacobian(y, v)])


def trajectory_with_bands(model: FlightModel, part: DropPart, z: np.ndarray, cov: Covariance):
    """One drop's node values of COLUMNS and their absolute 1-sigma, arrays (K, len(COLUMNS))."""
    k = part.mesh.t_nodes.size
    fn = _output_function(model, part.params).map(k, "thread", 2)
    zx = z[part.node_cols].reshape(k, NS).T
    zt = np.repeat(z[part.theta_cols, None], k, axis=1)
    y, jac = fn(zx, zt)
    y = np.asarray(y).T
    ny, nv = len(COLUMNS), NS + part.params.n
    jac = np.asarray(jac).reshape(ny, k, nv).transpose(1, 0, 2)  # (k, ny, nv)
    theta_rows = cov.rows(part.theta_cols)
    sigma = np.zeros((k, ny))
    for i in range(k):
        rows = np.vstack([cov.rows(part.node_offset + np.arange(NS * i, NS * i + NS)), theta_rows])
        gs = jac[i] @ rows
        sigma[i] = np.sqrt(np.maximum(np.einsum("ij,jk,ik->i", gs, cov.cov_w, gs), 0.0))
    return y, sigma
