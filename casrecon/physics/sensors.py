"""IMU and GPS measurement models (docs/design.md: Sensors); CasADi expressions (and
:func:`lever_acceleration`, one of them evaluated on numpy arrays), SI units.

Biases, scale factors and noise are the estimator's and the simulator's business; these functions
give the noise-free quantity each sensor senses.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.physics.numpy_call import numpy_rows
from casrecon.physics.rotations import dcm_body_to_ned
from casrecon.physics.vehicle import Vehicle


def imu_specific_force(vehicle: Vehicle, force_body, omega_body, omega_dot_body):
    """Specific force sensed at the IMU, in IMU axes, m/s^2.

    f = F_b / m + dw/dt x r + w x (w x r), with r the IMU position minus the centre of mass in
    body axes and F_b every non-gravitational force (here the aerodynamic force), then rotated from
    body to IMU axes.
    """
    f_body = lever_specific_force(vehicle, omega_body, omega_dot_body, force_body / vehicle.mass_kg)
    return ca.DM(np.asarray(vehicle.imu_to_body)).T @ f_body


def lever_specific_force(vehicle: Vehicle, omega_body, omega_dot_body, cm_specific_force_body=0):
    """Specific force at the IMU, body axes, m/s^2: the centre of mass's
    ``cm_specific_force_body`` (m/s^2; 0 gives what the IMU senses beyond it) plus
    dw/dt x r + w x (w x r), r the IMU position minus the centre of mass in body axes; summed in
    that order (the simulator's bytes)."""
    r = ca.DM(vehicle.lever(vehicle.imu_position_m))
    return cm_specific_force_body + ca.cross(omega_dot_body, r) + ca.cross(
        omega_body, ca.cross(omega_body, r))


def lever_acceleration(vehicle: Vehicle, omega: np.ndarray, omega_dot: np.ndarray) -> np.ndarray:
    """:func:`lever_specific_force` (body axes, m/s^2) evaluated at each of the (n, 3) body rates
    (rad/s) and angular accelerations (rad/s^2): (n, 3)."""
    w, w_dot = ca.SX.sym("w", 3), ca.SX.sym("w_dot", 3)
    return numpy_rows(ca.Function("lever", [w, w_dot], [lever_specific_force(vehicle, w, w_dot)]), omega, omega_dot)


def imu_angular_rate(vehicle: Vehicle, omega_body):
    """Angular rate sensed by the gyros, in IMU axes, rad/s."""
    return ca.DM(np.asarray(vehicle.imu_to_body)).T @ omega_body


def gps_antenna_ned(vehicle: Vehicle, pos_cm_ned, vel_cm_ned, quat, omega_body):
    """Antenna position (m) and velocity (m/s) in NED from the centre-of-mass state.

    p_ant = p_cm + C_nb r and v_ant = v_cm + C_nb (w x r), r the antenna lever arm in body axes.
    """
    r = ca.DM(vehicle.lever(vehicle.gps_position_m))
    c_nb = dcm_body_to_ned(quat)
    return pos_cm_ned + c_nb @ r, vel_cm_ned + c_nb @ ca.cross(omega_body, r)
