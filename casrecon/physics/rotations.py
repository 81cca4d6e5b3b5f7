"""Quaternion, direction-cosine and Euler-angle helpers (docs/design.md: Frames and angles).

Quaternions are scalar first, q = (q0, q1, q2, q3), and rotate body vectors into NED:
``v_ned = C_nb(q) @ v_body``. Euler angles are yaw-pitch-roll (ZYX): ``q = qz(psi) qy(theta) qx(phi)``.
All functions accept CasADi SX/MX/DM or numpy inputs and return CasADi expressions.
"""

from __future__ import annotations

import casadi as ca
import numpy as np


def quat_multiply(p, q):
    """Hamilton product ``p (x) q`` of two scalar-first quaternions."""
    p0, p1, p2, p3 = p[0], p[1], p[2], p[3]
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    return ca.vertcat(
        p0 * q0 - p1 * q1 - p2 * q2 - p3 * q3,
        p0 * q1 + p1 * q0 + p2 * q3 - p3 * q2,
        p0 * q2 - p1 * q3 + p2 * q0 + p3 * q1,
        p0 * q3 + p1 * q2 - p2 * q1 + p3 * q0,
    )


def dcm_body_to_ned(q):
    """Direction cosine matrix C_nb (body to NED) of a quaternion.

    The homogeneous form divided by |q|^2 is used, so a quaternion that has drifted from unit
    norm (as collocation allows between constraints) still yields an exact rotation matrix.
    """
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3
    c = ca.vertcat(
        ca.horzcat(q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3, 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)),
        ca.horzcat(2 * (q1 * q2 + q0 * q3), q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3, 2 * (q2 * q3 - q0 * q1)),
        ca.horzcat(2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3),
    )
    return c / n2


def dcm_body_to_ned_array(quats: np.ndarray) -> np.ndarray:
    """Numeric, vectorised :func:`dcm_body_to_ned`: the (n, 3, 3) C_nb of quaternions (n, 4)."""
    q = np.asarray(quats, float)
    q0, q1, q2, q3 = q[:, 0], q[:, 1], q[:, 2], q[:, 3]
    c = np.stack([
        np.stack([q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3, 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)], -1),
        np.stack([2 * (q1 * q2 + q0 * q3), q0 * q0 - q1 * q1 + q2 * q2 - q3 * q3, 2 * (q2 * q3 - q0 * q1)], -1),
        np.stack([2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3], -1),
    ], -2)
    return c / np.sum(q * q, axis=1)[:, None, None]


def quat_from_dcm(c: np.ndarray) -> np.ndarray:
    """Unit quaternion (4,), scalar first with q0 >= 0, of a rotation matrix C_nb (3, 3)
    (Shepperd's method: the largest of the four squared components is computed first, so no
    division by a small number)."""
    c = np.asarray(c, float)
    trace = np.trace(c)
    squares = np.array([1 + trace, 1 + 2 * c[0, 0] - trace, 1 + 2 * c[1, 1] - trace, 1 + 2 * c[2, 2] - trace])
    k = int(np.argmax(squares))
    q = np.empty(4)
    q[k] = 0.5 * np.sqrt(squares[k])
    s = 0.25 / q[k]
    if k == 0:
        q[1:] = s * np.array([c[2, 1] - c[1, 2], c[0, 2] - c[2, 0], c[1, 0] - c[0, 1]])
    elif k == 1:
        q[[0, 2, 3]] = s * np.array([c[2, 1] - c[1, 2], c[0, 1] + c[1, 0], c[0, 2] + c[2, 0]])
    elif k == 2:
        q[[0, 1, 3]] = s * np.array([c[0, 2] - c[2, 0], c[0, 1] + c[1, 0], c[1, 2] + c[2, 1]])
    else:
        q[[0, 1, 2]] = s * np.array([c[1, 0] - c[0, 1], c[0, 2] + c[2, 0], c[1, 2] + c[2, 1]])
    q /= np.linalg.norm(q)
    return q if q[0] >= 0 else -q


def best_rotation(target: np.ndarray, source: np.ndarray) -> np.ndarray:
    """The rotation matrix C (3, 3) minimising sum |target_i - C source_i|^2 over rows of (n, 3)
    vectors (Wahba's problem; the SVD solution with the determinant forced to +1, as
    ``scipy.spatial.transform.Rotation.align_vectors`` computes it with unit weights)."""
    u, _, vt = np.linalg.svd(np.asarray(target, float).T @ np.asarray(source, float))
    d = np.sign(np.linalg.det(u @ vt)) or 1.0
    return u @ np.diag([1.0, 1.0, d]) @ vt


def quat_derivative(q, omega_body):
    """Kinematics ``dq/dt = q (x) (0, w) / 2`` with w the body angular rate (rad/s)."""
    return 0.5 * quat_multiply(q, ca.vertcat(0, omega_body))


def quat_from_euler(phi, theta, psi):
    """Quaternion of ZYX Euler angles (roll phi, pitch theta, yaw psi), radians."""
    cr, sr = ca.cos(phi / 2), ca.sin(phi / 2)
    cp, sp = ca.cos(theta / 2), ca.sin(theta / 2)
    cy, sy = ca.cos(psi / 2), ca.sin(psi / 2)
    return ca.vertcat(
        cy * cp * cr + sy * sp * sr,
        cy * cp * sr - sy * sp * cr,
        cy * sp * cr + sy * cp * sr,
        sy * cp * cr - cy * sp * sr,
    )


def euler_from_quat(q):
    """ZYX Euler angles (phi, theta, psi) in radians of a quaternion (any norm).

    Roll and yaw are ill-defined at theta = +-90 deg (gimbal lock); the pitch argument is clipped
    to [-1, 1] so rounding never produces NaN.
    """
    q0, q1, q2, q3 = q[0], q[1], q[2], q[3]
    n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3
    phi = ca.atan2(2 * (q0 * q1 + q2 * q3), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3)
    s = ca.fmin(ca.fmax(2 * (q0 * q2 - q3 * q1) / n2, -1), 1)
    theta = ca.asin(s)
    psi = ca.atan2(2 * (q0 * q3 + q1 * q2), q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3)
    return ca.vertcat(phi, theta, psi)


def euler_deg_to_quat(euler_deg) -> np.ndarray:
    """Numeric convenience: quaternion (numpy, unit norm) of (roll, pitch, yaw) in degrees."""
    phi, theta, psi = np.radians(np.asarray(euler_deg, dtype=float))
    return np.asarray(quat_from_euler(phi, theta, psi), dtype=float).ravel()


def quat_to_euler_deg(q) -> np.ndarray:
    """Numeric convenience: (roll, pitch, yaw) in degrees of one quaternion (numpy)."""
    return np.degrees(np.asarray(euler_from_quat(ca.DM(np.asarray(q, float))), dtype=float).ravel())
