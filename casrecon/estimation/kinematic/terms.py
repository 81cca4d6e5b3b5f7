"""The residual blocks of a kinematic fit (docs/design.md: Kinematic reconstruction).

Node state x = (p (3) m, v (3) m/s, q (4)) of the IMU (position and velocity of the IMU, q rotating
IMU axes into NED), scaled by :data:`KINEMATIC_SCALE`.

Interval (nodes k, k+1, length T; the IMU parameters theta)::

    c       = J_theta (theta - theta_lin)                      first-order change of the preintegration
    q_pred  = Exp(-Omega T) (x) q_k (x) dq (x) Exp(c_phi)       (Omega only when the gyros sense it)
    r_phi   = 2 vec(conj(q_pred) (x) q_k+1)                    rotation error, rad (sign of the scalar part)
    a_grav  = g(h) - 2 Omega x v_k                             gravity (+ Coriolis)
    r_v     = C(q_k)^T (v_k+1 - v_k - a_grav T) - dv - c_v
    r_p     = C(q_k)^T (p_k+1 - p_k - v_k T - a_grav T^2 / 2) - dp - c_p
    residual = W (r_phi, r_v, r_p)                             W Sigma W^T = I, Sigma from the IMU noise

Fix near node k (antenna lever l in IMU axes; measured rate w and specific force f at the node; the
fix happened d = t_fix - t_k + clock_guess - clock later on the IMU clock than the node, t_fix
its time with the guessed clock offset applied)::

    p_ant = p_k + C l,   v_ant = v_k + C (w x l),   a = C (f + w x (w x l)) + g,   j = C (w x f + df/dt)
    (w, f, df/dt corrected by the IMU error parameters as in the preintegration)
    y_pred = (p_ant + v_ant d + a d^2 / 2 + j d^3 / 6,  v_ant + a d + j d^2 / 2)

Barometer sample at fraction tau of an interval: the cubic Hermite altitude through (p_d, v_d) of
the two nodes, its height above the ground scaled by (1 + k), the atmosphere's pressure there plus
a constant bias.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind
from casrecon.estimation.sixdof.transcription import hermite
from casrecon.physics.earth import EARTH_RATE, normal_gravity
from casrecon.physics.preintegration import N_IMU_PARAMETERS, imu_gains, quat_conj, quat_exp
from casrecon.physics.rotations import dcm_body_to_ned, quat_multiply

#: Scale of each node state entry (m, m/s, -): Ipopt sees state / scale.
#: The nine whitened residuals of a preintegrated interval, in order: rotation (NED axes), velocity
#: and position (IMU body axes at the interval's start); whitening mixes each with the ones before it.
INTERVAL_RESIDUALS = ("rot_n", "rot_e", "rot_d", "vel_x", "vel_y", "vel_z", "pos_x", "pos_y", "pos_z")
KINEMATIC_SCALE = np.array([100.0, 100.0, 100.0, 10.0, 10.0, 10.0, 1.0, 1.0, 1.0, 1.0])
N_STATE = KINEMATIC_SCALE.size


def gravity_ned(options, alt_msl_m):
    """Gravity vector in NED (m/s^2) at ``alt_msl_m`` (CasADi)."""
    if options.gravity == "off":
        return ca.DM.zeros(3)
    h = options.ground_alt_msl_m if options.gravity == "constant" else alt_msl_m
    return ca.vertcat(0, 0, normal_gravity(options.latitude_rad, h))


def earth_rate(options) -> ca.DM:
    lat = options.latitude_rad
    return ca.DM([EARTH_RATE * np.cos(lat), 0.0, -EARTH_RATE * np.sin(lat)])


def unscale_state(xs):
    return xs * ca.DM(KINEMATIC_SCALE)


def interval_kind(options, imu_scales: np.ndarray, estimated: np.ndarray) -> BlockKind:
    """Block of one interval: local (x_k, x_k+1, estimated IMU parameters, scaled); data T (s),
    delta (10), J_theta (9 x 12, column-major), W (9 x 9, column-major), theta_lin (12)."""
    xk_s, xk1_s = ca.SX.sym("xk", N_STATE), ca.SX.sym("xk1", N_STATE)
    th_s = ca.SX.sym("theta", estimated.size)
    dur, delta = ca.SX.sym("T"), ca.SX.sym("delta", 10)
    jac, white, lin = ca.SX.sym("J", 9 * N_IMU_PARAMETERS), ca.SX.sym("W", 81), ca.SX.sym("lin", N_IMU_PARAMETERS)
    xk, xk1 = unscale_state(xk_s), unscale_state(xk1_s)
    theta = ca.SX(N_IMU_PARAMETERS, 1)
    for j, i in enumerate(estimated):
        theta[int(i)] = th_s[j] * imu_scales[j]
    corr = ca.reshape(jac, 9, N_IMU_PARAMETERS) @ (theta - lin)
    qk, qk1 = xk[6:10], xk1[6:10]
    q_pred = quat_multiply(quat_multiply(qk, delta[0:4]), quat_exp(corr[0:3]))
    omega = earth_rate(options)
    if options.gyro_senses_earth_rate:
        q_pred = quat_multiply(quat_exp(-omega * dur), q_pred)
    q_err = quat_multiply(quat_conj(q_pred), qk1) / (ca.norm_2(qk) * ca.norm_2(qk1))
    r_phi = 2 * ca.sign(q_err[0]) * q_err[1:4]
    pk, vk, pk1, vk1 = xk[0:3], xk[3:6], xk1[0:3], xk1[3:6]
    alt = options.ground_alt_msl_m - 0.5 * (pk[2] + pk1[2])
    accel = gravity_ned(options, alt)
    if options.earth_rotation:
        accel = accel - 2 * ca.cross(omega, vk)
    c_t = dcm_body_to_ned(qk).T
    r_v = c_t @ (vk1 - vk - accel * dur) - delta[4:7] - corr[3:6]
    r_p = c_t @ (pk1 - pk - vk * dur - accel * dur * dur / 2) - delta[7:10] - corr[6:9]
    r = ca.reshape(white, 9, 9) @ ca.vertcat(r_phi, r_v, r_p)
    return BlockKind("kinematic_interval", ca.vertcat(xk_s, xk1_s, th_s), [dur, delta, jac, white, lin], r, None)


def fix_kind(options, with_clock: bool, clock_scale: float, n_errors: int, active: np.ndarray,
             imu_scales: np.ndarray, estimated: np.ndarray) -> BlockKind:
    """Block of one fix: local (x_k, estimated IMU parameters (scaled), [clock], [correlated error
    values]); data y (6), 1 / sigma of the white part (6; 0 where missing), the measured w (3), f
    (3) and df/dt (3, per second) at the node (a local line through the IMU samples), the fix time
    minus the node time (s), [error amplitudes]. The rate and specific force that carry the state
    to the fix's time are corrected by the IMU parameters, as in the preintegration, and the
    change of C f over that time is kept to second order (module docstring)."""
    x_s = ca.SX.sym("x", N_STATE)
    th_s = ca.SX.sym("theta", estimated.size)
    clock = ca.SX.sym("clock", 1 if with_clock else 0)
    errors = ca.SX.sym("e", n_errors)
    y, inv, w_raw, f_raw = ca.SX.sym("y", 6), ca.SX.sym("inv", 6), ca.SX.sym("w", 3), ca.SX.sym("f", 3)
    f_slope_raw = ca.SX.sym("f_slope", 3)
    shift = ca.SX.sym("shift")
    amp = ca.SX.sym("amp", n_errors)
    theta = ca.SX(N_IMU_PARAMETERS, 1)
    for j, i in enumerate(estimated):
        theta[int(i)] = th_s[j] * imu_scales[j]
    gyro_gain, accel_gain = imu_gains(theta)
    w, f = gyro_gain @ w_raw - theta[0:3], accel_gain @ f_raw - theta[3:6]
    x = unscale_state(x_s)
    c = dcm_body_to_ned(x[6:10])
    lever = ca.DM(options.gps_lever_m)
    p_ant = x[0:3] + c @ lever
    v_ant = x[3:6] + c @ ca.cross(w, lever)
    data = [y, inv, w_raw, f_raw, f_slope_raw, shift]
    d = shift + (options.clock_guess_s - clock[0] * clock_scale if with_clock else 0.0)
    # the antenna's acceleration: the IMU's plus the lever's centripetal part (its angular
    # acceleration part is left out: it needs the rate's derivative)
    accel = c @ (f + ca.cross(w, ca.cross(w, lever))) + gravity_ned(options, options.ground_alt_msl_m - x[2])
    # and its rate of change, the turning of the specific force and its own change (a capsule's
    # oscillation turns C f by tens of m/s^3: over a 0.1 s clock offset 0.1 m/s of velocity)
    jerk = c @ (ca.cross(w, f) + accel_gain @ f_slope_raw)
    p_ant = p_ant + v_ant * d + accel * (d * d / 2) + jerk * (d * d * d / 6)
    v_ant = v_ant + accel * d + jerk * (d * d / 2)
    pred = ca.vertcat(p_ant, v_ant)
    if n_errors:
        sel = ca.DM.zeros(6, n_errors)
        for j, i in enumerate(active):
            sel[int(i), j] = 1.0
        pred = pred + sel @ (amp * errors)
        data.append(amp)
    r = (y - pred) * inv
    return BlockKind("kinematic_fix", ca.vertcat(x_s, th_s, clock, errors), data, r, None)


def baro_kind(atmosphere, options, bias_scale: float, height_scale_scale: float) -> BlockKind:
    """Block of one barometer sample: local (x_k, x_k+1, bias, height scale); data tau, T (s),
    pressure (Pa), 1 / noise. The atmosphere's pressure is read at the ground altitude plus the
    height above the ground times (1 + k): k stands for the temperature of the day differing from
    the profile's (about 3.5 % per 10 K), which no constant pressure bias absorbs over kilometres."""
    xk_s, xk1_s = ca.SX.sym("xk", N_STATE), ca.SX.sym("xk1", N_STATE)
    bias, k = ca.SX.sym("bias"), ca.SX.sym("k")
    tau, dur, y, inv = ca.SX.sym("tau"), ca.SX.sym("T"), ca.SX.sym("p"), ca.SX.sym("inv")
    xk, xk1 = unscale_state(xk_s), unscale_state(xk1_s)
    down = hermite(tau, dur, xk[2], xk[5], xk1[2], xk1[5])
    pressure = atmosphere.at(options.ground_alt_msl_m - down * (1 + k * height_scale_scale)).pressure
    r = (y - pressure - bias * bias_scale) * inv
    return BlockKind("kinematic_baro", ca.vertcat(xk_s, xk1_s, bias, k), [tau, dur, y, inv], r, None)
