"""A kinematic reconstruction against a known truth: the centre-of-mass position and velocity,
body attitude and IMU parameters the fit reports, their errors against a simulated flight, and
the share of node values whose truth lies inside the reported 3-sigma band (the truth test of
docs/design.md: Kinematic reconstruction).
"""

from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from casrecon.physics.vehicle import Vehicle

#: Groups of compared quantities and their columns in :func:`node_errors`.
GROUPS = {"position": slice(0, 3), "velocity": slice(3, 6), "attitude": slice(6, 9)}


def _rotations(q_scalar_first: np.ndarray) -> Rotation:
    q = np.asarray(q_scalar_first, float)
    return Rotation.from_quat(np.column_stack([q[:, 1:], q[:, 0]]))


def body_states(result, vehicle: Vehicle) -> tuple[np.ndarray, Rotation]:
    """Centre-of-mass position and velocity (K, 6; m, m/s, NED) and body-to-NED attitude at the
    nodes, from the IMU's states, the IMU mount and the measured rates (bias-corrected)."""
    r_ib = np.asarray(vehicle.imu_to_body, float)
    c_ni = _rotations(result.states[:, 6:10])
    c_nb = c_ni * Rotation.from_matrix(r_ib.T)
    lever = np.asarray(vehicle.lever(vehicle.imu_position_m), float)
    data = result.data
    gyro = np.column_stack([np.interp(result.node_time_s, data.imu_time_s, data.gyro_radps[:, i]) for i in range(3)])
    names = list(result.params.names)
    bias = np.array([result.values[names.index(f"gyro_bias_{a}")] if f"gyro_bias_{a}" in names else 0.0
                     for a in "xyz"])
    omega_body = (gyro - bias) @ r_ib.T
    pos = result.states[:, 0:3] - c_nb.apply(np.tile(lever, (len(c_nb), 1)))
    vel = result.states[:, 3:6] - c_nb.apply(np.cross(omega_body, lever))
    return np.column_stack([pos, vel]), c_nb


def node_errors(result, vehicle: Vehicle, trajectory, release_imu_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(errors, sigmas), each (K, 9): position (m), velocity (m/s) and attitude (NED rotation
    vector from the truth to the estimate, rad) at the nodes, with the reported 1-sigma. The lever
    arm's effect on the bands is neglected (the IMU's position and velocity sigmas are used)."""
    t = result.node_time_s - release_imu_s
    truth = np.column_stack([np.interp(t, trajectory.time_s, trajectory.states[:, i]) for i in range(10)])
    est, c_nb = body_states(result, vehicle)
    q_true = truth[:, 6:10] / np.linalg.norm(truth[:, 6:10], axis=1, keepdims=True)
    att = (c_nb * _rotations(q_true).inv()).as_rotvec()
    err = np.column_stack([est - truth[:, :6], att])
    return err, result.state_sigma


def coverage(errors: np.ndarray, sigmas: np.ndarray, k: float = 3.0) -> dict[str, tuple[int, int]]:
    """Per group of :data:`GROUPS`: (values inside k sigma, values)."""
    out = {}
    for name, cols in GROUPS.items():
        e, s = errors[:, cols], sigmas[:, cols]
        ok = np.isfinite(e) & np.isfinite(s)
        out[name] = (int(np.sum(np.abs(e[ok]) <= k * s[ok])), int(ok.sum()))
    return out
