"""Initial guess for the fit: interpolate GPS, integrate the gyros, align with the flow.

1. Attitude change: the gyro rates (body axes) are integrated from the first node with the same
   quaternion kinematics as the model (RK4 per IMU sample, CasADi ``mapaccum``), giving
   C_nb(t) = R0 dC(t) with R0 unknown.
2. R0: in descent the specific force points against the air-relative velocity, so R0 is the
   rotation that best maps dC(t) f(t) onto -|f| v_air(t) / |v_air| (Wahba's problem, solved by
   SVD: :func:`~casrecon.physics.rotations.best_rotation`) over the window, with v_air the GPS
   velocity minus the balloon wind.
3. Position and velocity: GPS antenna fixes interpolated to the nodes, moved to the centre of mass
   with the lever arm at the guessed attitude. Rates: the gyro at the nodes (saturated samples
   bridged by interpolation). Parameters: zero.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.sixdof.fitdata import FitData
from casrecon.estimation.sixdof.transcription import Mesh
from casrecon.io.gps_rules import interpolate_fixes
from casrecon.physics.atmosphere import Atmosphere
from casrecon.physics.numpy_call import numpy_call
from casrecon.physics.rotations import (
    best_rotation,
    dcm_body_to_ned_array,
    quat_derivative,
    quat_from_dcm,
    quat_multiply,
)
from casrecon.physics.vehicle import Vehicle


def _integrate_gyro(t: np.ndarray, gyro_body: np.ndarray) -> np.ndarray:
    """Quaternions (N, 4) from identity at t[0] by RK4 on dq/dt = q (x) (0, w) / 2."""
    q, w0, w1, h = ca.SX.sym("q", 4), ca.SX.sym("w0", 3), ca.SX.sym("w1", 3), ca.SX.sym("h")
    wm = 0.5 * (w0 + w1)
    k1 = quat_derivative(q, w0)
    k2 = quat_derivative(q + h / 2 * k1, wm)
    k3 = quat_derivative(q + h / 2 * k2, wm)
    k4 = quat_derivative(q + h * k3, w1)
    qn = q + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    step = ca.Function("gyro_step", [q, w0, w1, h], [qn / ca.norm_2(qn)])
    n = t.size - 1
    run = step.mapaccum("gyro_run", n)
    qs = np.asarray(run([1, 0, 0, 0], gyro_body[:-1].T, gyro_body[1:].T, np.diff(t)[None, :]))
    return np.vstack([[1.0, 0, 0, 0], qs.T])


def _rotate_all(q0: np.ndarray, dq: np.ndarray) -> np.ndarray:
    """q0 (x) dq[i] for every row of ``dq`` (N, 4): the model's own :func:`quat_multiply`, mapped."""
    p, q = ca.SX.sym("p", 4), ca.SX.sym("q", 4)
    product = ca.Function("quat_product", [p, q], [quat_multiply(p, q)]).map(dq.shape[0])
    return numpy_call(product, np.repeat(q0[:, None], dq.shape[0], axis=1), dq.T)[0].T


def _bridge(t: np.ndarray, values: np.ndarray, valid: np.ndarray) -> np.ndarray:
    out = values.copy()
    for c in range(values.shape[1]):
        ok = valid[:, c]
        if (~ok).any() and ok.sum() >= 2:
            out[~ok, c] = np.interp(t[~ok], t[ok], values[ok, c])
    return out


def initial_guess(data: FitData, mesh: Mesh, vehicle: Vehicle, atmosphere: Atmosphere,
                  ground_alt_msl_m: float) -> np.ndarray:
    """Node states (K, 13), SI units, for the Ipopt start."""
    t = data.imu_time_s
    gyro = _bridge(t, data.gyro_body, data.gyro_valid)
    dq = _integrate_gyro(t, gyro)
    pos, vel = interpolate_fixes(t, data.gps_time_s, data.gps_pos_ned, data.gps_vel_ned)  # fills missing components
    lv = atmosphere.levels
    alt = ground_alt_msl_m - pos[:, 2]
    wind = np.column_stack([np.interp(alt, lv["altitude_msl_m"], lv["wind_north_mps"]),
                            np.interp(alt, lv["altitude_msl_m"], lv["wind_east_mps"]), np.zeros(t.size)])
    v_air = vel - wind
    f = _bridge(t, data.accel_body, data.accel_valid)
    fmag = np.linalg.norm(f, axis=1)
    use = (fmag > 3.0) & (np.linalg.norm(v_air, axis=1) > 5.0)
    if use.sum() < 10:
        use = fmag > 0
    f_start = np.einsum("nij,nj->ni", dcm_body_to_ned_array(dq), f)
    target = -v_air / np.linalg.norm(v_air, axis=1, keepdims=True) * fmag[:, None]
    q0 = quat_from_dcm(best_rotation(target[use], f_start[use]))
    quats = _rotate_all(q0, dq)
    idx = np.searchsorted(t, mesh.t_nodes - 1e-9)
    idx = np.clip(idx, 0, t.size - 1)
    lever = vehicle.lever(vehicle.gps_position_m)
    states = np.zeros((mesh.t_nodes.size, 13))
    c_nb = dcm_body_to_ned_array(quats[idx])
    states[:, 0:3] = pos[idx] - c_nb @ lever
    states[:, 3:6] = vel[idx]
    states[:, 6:10] = quats[idx]
    states[:, 10:13] = gyro[idx]
    return states
