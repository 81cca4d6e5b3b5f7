"""IMU preintegration: what the measured specific force and body rates say about the change of
attitude, velocity and position between two instants, with its sensitivity to the IMU's error
parameters and its noise covariance (docs/design.md: Kinematic reconstruction).

The IMU's own frame is the reference: the attitude q rotates IMU axes into NED and the position
and velocity are those of the IMU. Between two nodes the measured signals are taken as a sequence
of *pieces*: the IMU samples' cells (each sample governs the time from the midpoint with its
predecessor to the midpoint with its successor) cut at the nodes. The corrected rate is
w_c = (I + S_g + M_g) w - b_g and the specific force f_c = (I + S_a + M_a) f - b_a (biases b,
diagonal scale-factor errors S and off-diagonal misalignments M, IMU axes), with w and f from the
local quadratic through the sample and its two neighbours (:func:`piece_table`): on each piece the
rate is the line with the quadratic's mean and its slope at the piece's middle, and the specific
force is sampled from the quadratic at the piece's start, middle and end. Per piece (scalar-first
quaternions, body-to-NED like :mod:`.rotations`; w_c and
f_c corrected as below)::

    phi(s) = a s + b s^2 / 2 + (a x b) s^3 / 12     rotation vector after s (Bortz, rate a + b s)
    dq'    = dq (x) Exp(phi(tau) + nu_g)
    dv'    = dv + tau / 6 (g_0 + 4 g_m + g_1) + C_m nu_a          (Simpson; g = C(q(s)) f_c(s))
    dp'    = dp + dv tau + tau^2 / 6 (g_0 + 2 g_m) + C_m (nu_a tau / 2 + nu_p)

starting from dq = 1, dv = dp = 0 at the first node; gravity, Earth rotation and the states enter
in the estimator's residual, not here. The IMU noise is white in continuous time, its density from
the per-sample 1-sigma: the integrated noises nu_g, nu_a of a piece have variance
sigma^2 dt_sample tau on each axis, and the position gets, besides nu_a tau / 2, the independent
part nu_p of the doubly integrated noise (variance sigma_a^2 dt_sample tau^3 / 12), so the 9 x 9
covariance is regular however few pieces an interval holds, and pieces of different intervals are
independent.

Exp is the quaternion exponential by its Taylor series to the sixth power (error below 1e-7 for
rotations up to 1 rad per piece; :data:`MAX_PIECE_ROTATION_RAD` is checked by the caller).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.physics.rotations import dcm_body_to_ned, quat_multiply

#: IMU error parameters, in this order (SI: rad/s, m/s^2, fractions).
#: Misalignment m_ij: the i axis senses m_ij times the rate (force) along the j axis.
MISALIGNMENT_PAIRS = ("xy", "xz", "yx", "yz", "zx", "zy")
IMU_PARAMETERS = ("gyro_bias_x", "gyro_bias_y", "gyro_bias_z", "accel_bias_x", "accel_bias_y", "accel_bias_z",
                  "gyro_scale_x", "gyro_scale_y", "gyro_scale_z", "accel_scale_x", "accel_scale_y", "accel_scale_z",
                  *(f"gyro_misalignment_{p}" for p in MISALIGNMENT_PAIRS),
                  *(f"accel_misalignment_{p}" for p in MISALIGNMENT_PAIRS))
N_IMU_PARAMETERS = len(IMU_PARAMETERS)
#: Integrated noises of a piece: rotation (rad), velocity (m/s) and the part of the position noise
#: (m) independent of the velocity noise.
N_NOISE = 9
#: Rotation of one piece beyond which the series exponential loses accuracy, rad.
MAX_PIECE_ROTATION_RAD = 1.0


def quat_exp(phi):
    """Unit quaternion of the rotation vector ``phi`` (rad), CasADi: Taylor series of cos(|phi|/2)
    and sin(|phi|/2) / |phi| (smooth at zero)."""
    x2 = ca.sumsqr(phi)
    c = 1 - x2 / 8 + x2**2 / 384 - x2**3 / 46080
    s = 0.5 - x2 / 48 + x2**2 / 3840 - x2**3 / 645120
    return ca.vertcat(c, s * phi)


def quat_conj(q):
    """Conjugate (inverse of a unit quaternion)."""
    return ca.vertcat(q[0], -q[1], -q[2], -q[3])


#: Columns of a piece: tau (s), mid-piece rate w_m (rad/s), rate slope (rad/s^2), specific force at
#: the piece's start, middle and end (m/s^2); all IMU axes.
PIECE_COLUMNS = 16


def _rotation_vector(a, b, s):
    """Rotation vector after time ``s`` of a rate a + b t (Bortz's equation to third order in s)."""
    return a * s + b * (s * s / 2) + ca.cross(a, b) * (s * s * s / 12)


def _gain(scale, misalignment):
    """I + diag(scale) + the off-diagonal misalignment (order of MISALIGNMENT_PAIRS)."""
    rows = []
    for i, axis in enumerate("xyz"):
        row = []
        for j, other in enumerate("xyz"):
            row.append(1 + scale[i] if i == j else misalignment[MISALIGNMENT_PAIRS.index(axis + other)])
        rows.append(ca.horzcat(*row))
    return ca.vertcat(*rows)


def imu_gains(theta):
    """(gyro gain, accelerometer gain), the 3 x 3 matrices I + S + M of the IMU error parameters
    ``theta`` (:data:`IMU_PARAMETERS` order): the corrected rate is gyro gain @ w - b_g, the
    corrected specific force accelerometer gain @ f - b_a (IMU axes)."""
    return _gain(theta[6:9], theta[12:18]), _gain(theta[9:12], theta[18:24])


def _step() -> ca.Function:
    d, piece = ca.SX.sym("d", 10), ca.SX.sym("piece", PIECE_COLUMNS)
    theta, nu = ca.SX.sym("theta", N_IMU_PARAMETERS), ca.SX.sym("nu", N_NOISE)
    tau = piece[0]
    gyro_gain, accel_gain = imu_gains(theta)
    w_m, slope = gyro_gain @ piece[1:4] - theta[0:3], gyro_gain @ piece[4:7]
    f = [accel_gain @ piece[7 + 3 * i:10 + 3 * i] - theta[3:6] for i in range(3)]
    a = w_m - slope * (tau / 2)
    dq, dv, dp = d[0:4], d[4:7], d[7:10]
    q_mid = quat_multiply(dq, quat_exp(_rotation_vector(a, slope, tau / 2) + nu[0:3] / 2))
    q_end = quat_multiply(dq, quat_exp(_rotation_vector(a, slope, tau) + nu[0:3]))
    g0, g_mid, g1 = dcm_body_to_ned(dq) @ f[0], dcm_body_to_ned(q_mid) @ f[1], dcm_body_to_ned(q_end) @ f[2]
    noise = dcm_body_to_ned(q_mid) @ nu[3:6]
    dv_inc = tau / 6 * (g0 + 4 * g_mid + g1) + noise  # Simpson
    dp_inc = dv * tau + tau * tau / 6 * (g0 + 2 * g_mid) + noise * (tau / 2) + dcm_body_to_ned(q_mid) @ nu[6:9]
    out = ca.vertcat(q_end / ca.norm_2(q_end), dv + dv_inc, dp + dp_inc)
    return ca.Function("preintegration_step", [d, piece, theta, nu], [out])


@functools.lru_cache(maxsize=16)
def preintegration_function(n_pieces: int) -> ca.Function:
    """``(pieces (16, n_pieces), theta (24)) -> (delta (10), d delta / d theta (10, 24),
    d delta / d nu (10, 9 n_pieces))``: the preintegrated (dq, dv, dp) of one interval whose pieces
    are the columns of :data:`PIECE_COLUMNS` (padding pieces have tau = 0), and its Jacobians at
    zero noise; nu stacks each piece's (nu_g, nu_a, nu_p)."""
    pieces, theta = ca.MX.sym("pieces", PIECE_COLUMNS, n_pieces), ca.MX.sym("theta", N_IMU_PARAMETERS)
    nu = ca.MX.sym("nu", N_NOISE, n_pieces)
    run = _step().mapaccum("preintegration", n_pieces)
    d0 = ca.DM([1, 0, 0, 0, 0, 0, 0, 0, 0, 0])
    delta = run(d0, pieces, ca.repmat(theta, 1, n_pieces), nu)[:, -1]
    jac_theta = ca.jacobian(delta, theta)
    jac_nu = ca.jacobian(delta, ca.vec(nu))
    zero = ca.DM.zeros(N_NOISE, n_pieces)
    outs = [ca.substitute(e, nu, zero) for e in (delta, jac_theta, jac_nu)]
    return ca.Function("preintegrate", [pieces, theta], outs)


def tangent_rows(delta_q: np.ndarray) -> np.ndarray:
    """(3, 4) matrix M with d phi = M d q for q = delta_q (x) Exp(d phi) near ``delta_q`` (unit):
    d phi = 2 vec(conj(delta_q) (x) d q)."""
    w, x, y, z = delta_q
    # rows of the left-multiplication matrix of conj(delta_q), vector part
    left = np.array([[w, x, y, z], [-x, w, z, -y], [-y, -z, w, x], [-z, y, -x, w]])
    return 2.0 * left[1:]


@dataclass(frozen=True)
class Preintegrated:
    """Every interval's preintegration at the linearisation point ``theta_lin``.

    Attributes
    ----------
    duration_s : (n,) array
        Interval lengths, s.
    delta : (n, 10) array
        (dq (4), dv (3) m/s, dp (3) m), IMU axes of the interval's first node.
    jac_theta : (n, 9, 24) array
        d (dphi, dv, dp) / d theta, dphi the rotation in the tangent space of dq (rad).
    covariance : (n, 9, 9) array
        Covariance of (dphi, dv, dp) from the IMU noise.
    theta_lin : (24,) array
        Where the Jacobians were taken (SI).
    """

    duration_s: np.ndarray
    delta: np.ndarray
    jac_theta: np.ndarray
    covariance: np.ndarray
    theta_lin: np.ndarray

    @property
    def whitening(self) -> np.ndarray:
        """(n, 9, 9) W with W Sigma W^T = I (the inverse Cholesky factor of each covariance)."""
        chol = np.linalg.cholesky(self.covariance)
        return np.linalg.inv(chol)


def local_quadratics(time_s: np.ndarray, values: np.ndarray, sample: np.ndarray):
    """The quadratic through samples ``sample - 1, sample, sample + 1`` of ``values`` (a line at the
    ends of the record) in Newton form about t1 = time_s[sample]: y(t) = y1 + slope (t - t1) +
    curvature (t - t1)^2. Returns (t1 (P,), y1 (P, m), slope (P, m), curvature (P, m))."""
    n = time_s.size
    lo, hi = np.clip(sample - 1, 0, n - 1), np.clip(sample + 1, 0, n - 1)
    t0, t1, t2 = time_s[lo], time_s[sample], time_s[hi]
    y0, y1, y2 = values[lo], values[sample], values[hi]
    gap01 = np.where(t1 > t0, t1 - t0, 1.0)[:, None]
    gap12 = np.where(t2 > t1, t2 - t1, 1.0)[:, None]
    d01 = np.where((t1 > t0)[:, None], (y1 - y0) / gap01, 0.0)
    d12 = np.where((t2 > t1)[:, None], (y2 - y1) / gap12, 0.0)
    inner = ((lo < sample) & (hi > sample))[:, None]
    curvature = np.where(inner, (d12 - d01) / np.where(inner[:, 0], t2 - t0, 1.0)[:, None], 0.0)
    slope = np.where(inner, d01 + curvature * (t1 - t0)[:, None], np.where((hi > sample)[:, None], d12, d01))
    return t1, y1, slope, curvature


def piece_table(time_s: np.ndarray, gyro: np.ndarray, accel: np.ndarray, start_s: np.ndarray,
                stop_s: np.ndarray, sample: np.ndarray) -> np.ndarray:
    """(P, :data:`PIECE_COLUMNS`) rows [tau, mean rate over the piece, rate slope at its middle,
    specific force at its start, middle and end] from the local quadratics of the samples."""
    t1, w1, w_slope, w_curv = local_quadratics(time_s, gyro, sample)
    _, f1, f_slope, f_curv = local_quadratics(time_s, accel, sample)
    a, b = (start_s - t1)[:, None], (stop_s - t1)[:, None]
    mid = (a + b) / 2
    w_mean = w1 + w_slope * mid + w_curv * (a * a + a * b + b * b) / 3
    cols = [(stop_s - start_s)[:, None], w_mean, w_slope + 2 * w_curv * mid]
    cols += [f1 + f_slope * x + f_curv * x * x for x in (a, mid, b)]
    return np.hstack(cols)


def cut_pieces(sample_time_s: np.ndarray, node_time_s: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray,
                                                                            np.ndarray]:
    """The pieces of every interval: the samples' cells cut at the nodes.

    Returns
    -------
    interval, sample : (P,) int arrays
        The interval and the sample of each piece (pieces of an interval are consecutive, in time order).
    start_s, stop_s : (P,) arrays
    """
    t = sample_time_s
    edges = np.r_[t[0] - (t[1] - t[0]) / 2, (t[1:] + t[:-1]) / 2, t[-1] + (t[-1] - t[-2]) / 2]
    cuts = np.union1d(edges, node_time_s)
    cuts = cuts[(cuts >= node_time_s[0]) & (cuts <= node_time_s[-1])]
    start, stop = cuts[:-1], cuts[1:]
    keep = stop - start > 1e-12
    start, stop = start[keep], stop[keep]
    mid = (start + stop) / 2
    sample = np.clip(np.searchsorted(edges, mid) - 1, 0, t.size - 1)
    interval = np.clip(np.searchsorted(node_time_s, mid) - 1, 0, node_time_s.size - 2)
    return interval, sample, start, stop


def preintegrate(sample_time_s: np.ndarray, gyro_radps: np.ndarray, accel_mps2: np.ndarray,
                 node_time_s: np.ndarray, gyro_sigma_radps: np.ndarray, accel_sigma_mps2: np.ndarray,
                 theta_lin: np.ndarray | None = None) -> Preintegrated:
    """Preintegrate the IMU record between consecutive nodes.

    Parameters
    ----------
    sample_time_s : (N,) array
        IMU sample times, s (N >= 2), covering the nodes up to half a sample.
    gyro_radps, accel_mps2 : (N, 3) arrays
        Measured rates (rad/s) and specific force (m/s^2), IMU axes.
    node_time_s : (K,) array
        Node times, s, strictly increasing.
    gyro_sigma_radps, accel_sigma_mps2 : (N, 3) arrays
        White noise 1-sigma of each sample and axis (large where a sample is saturated).
    theta_lin : (24,) array, optional
        IMU error parameters (SI) at which to linearise; zero by default.

    Returns
    -------
    Preintegrated
    """
    theta_lin = np.zeros(N_IMU_PARAMETERS) if theta_lin is None else np.asarray(theta_lin, float)
    interval, sample, start, stop = cut_pieces(sample_time_s, node_time_s)
    n_int = node_time_s.size - 1
    table = piece_table(sample_time_s, gyro_radps, accel_mps2, start, stop, sample)
    tau = stop - start
    counts = np.bincount(interval, minlength=n_int)
    n_max = int(counts.max())
    slot = np.arange(interval.size) - np.r_[0, np.cumsum(counts)][interval]
    pieces = np.zeros((n_int, n_max, PIECE_COLUMNS))
    pieces[interval, slot] = table
    dt = np.gradient(sample_time_s)[sample]
    var = np.zeros((n_int, n_max, N_NOISE))
    accel_var = accel_sigma_mps2[sample] ** 2 * (dt * tau)[:, None]
    var[interval, slot] = np.column_stack([gyro_sigma_radps[sample] ** 2 * (dt * tau)[:, None], accel_var,
                                           accel_var * (tau * tau / 12)[:, None]])
    fn = preintegration_function(n_max).map(n_int, "thread", 2)
    delta, j_theta, j_nu = fn(pieces.transpose(2, 0, 1).reshape(PIECE_COLUMNS, n_int * n_max), theta_lin)
    delta = np.asarray(delta).T
    j_theta = np.asarray(j_theta).reshape(10, n_int, N_IMU_PARAMETERS).transpose(1, 0, 2)
    j_nu = np.asarray(j_nu).reshape(10, n_int, N_NOISE * n_max).transpose(1, 0, 2)
    tangent = np.zeros((n_int, 9, 10))
    tangent[:, :3, :4] = np.array([tangent_rows(q) for q in delta[:, :4]])
    tangent[:, 3:, 4:] = np.eye(6)
    j9_theta = tangent @ j_theta
    j9_nu = tangent @ j_nu
    cov = np.einsum("kin,kn,kjn->kij", j9_nu, var.reshape(n_int, -1), j9_nu)
    return Preintegrated(np.diff(node_time_s), delta, j9_theta, 0.5 * (cov + cov.transpose(0, 2, 1)), theta_lin)
