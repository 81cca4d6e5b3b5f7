"""IMU and GPS measurement models (docs/design.md: Sensors), hand cases with lever arms and axes."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from casrecon.physics.rotations import euler_deg_to_quat
from casrecon.physics.sensors import gps_antenna_ned, imu_angular_rate, imu_specific_force
from casrecon.physics.vehicle import Vehicle

# IMU x -> body y, IMU y -> body -x, IMU z -> body z (v_body = R v_imu)
R_IMU = ((0.0, -1.0, 0.0), (1.0, 0.0, 0.0), (0.0, 0.0, 1.0))


def vehicle(**kw) -> Vehicle:
    base = dict(name="v", mass_kg=50.0, inertia_kgm2=np.diag([3.0, 2.0, 2.0]), cm_m=(-0.25, 0.0, 0.0),
                mrp_m=(0.0, 0.0, 0.0), ref_area_m2=1.0, ref_length_m=1.0)
    base.update(kw)
    return Vehicle(**base)


def f_imu(veh, force=(0, 0, 0), w=(0, 0, 0), wdot=(0, 0, 0)) -> np.ndarray:
    return np.asarray(imu_specific_force(veh, ca.DM(force), ca.DM(w), ca.DM(wdot)), float).ravel()


def test_centripetal_term():
    # IMU 0.5 m ahead of the CM (CM at x = -0.25, IMU at x = +0.25), spin about z at 2 rad/s:
    # w x (w x r) = -w^2 a x_hat = -4 * 0.5 = -2.0 m/s^2 along x
    veh = vehicle(imu_position_m=(0.25, 0.0, 0.0))
    assert f_imu(veh, w=(0, 0, 2.0)) == pytest.approx([-2.0, 0.0, 0.0], abs=1e-14)
    # spin about the x axis itself: the lever arm is on the axis, nothing sensed
    assert f_imu(veh, w=(5.0, 0, 0)) == pytest.approx([0.0, 0.0, 0.0], abs=1e-14)


def test_tangential_term():
    # angular acceleration 3 rad/s^2 about z, r = (0.5, 0, 0): dw/dt x r = (0, 3 * 0.5, 0) = (0, 1.5, 0)
    veh = vehicle(imu_position_m=(0.25, 0.0, 0.0))
    assert f_imu(veh, wdot=(0, 0, 3.0)) == pytest.approx([0.0, 1.5, 0.0], abs=1e-14)
    # about y: (0, 3, 0) x (0.5, 0, 0) = (0, 0, -1.5)
    assert f_imu(veh, wdot=(0, 3.0, 0)) == pytest.approx([0.0, 0.0, -1.5], abs=1e-14)


def test_force_term_and_sum():
    # F = (-100, 20, 0) N on 50 kg -> (-2, 0.4, 0); plus centripetal (-2, 0, 0) and tangential (0, 1.5, 0)
    veh = vehicle(imu_position_m=(0.25, 0.0, 0.0))
    got = f_imu(veh, force=(-100.0, 20.0, 0.0), w=(0, 0, 2.0), wdot=(0, 0, 3.0))
    assert got == pytest.approx([-4.0, 1.9, 0.0], abs=1e-14)


def test_imu_axes_rotation_applied():
    # the same (-2, 0, 0) body specific force seen by a rotated IMU: f_imu = R^T f_body.
    # body -x is IMU +y, so the IMU reads (0, 2, 0); a body z rate is IMU z.
    veh = vehicle(imu_position_m=(0.25, 0.0, 0.0), imu_to_body=R_IMU)
    assert f_imu(veh, w=(0, 0, 2.0)) == pytest.approx([0.0, 2.0, 0.0], abs=1e-14)
    gyro = np.asarray(imu_angular_rate(veh, ca.DM([0.1, 0.2, 0.3])), float).ravel()
    # body (0.1, 0.2, 0.3): IMU x = body y = 0.2, IMU y = -body x = -0.1, IMU z = 0.3
    assert gyro == pytest.approx([0.2, -0.1, 0.3], abs=1e-15)


def test_gps_antenna_lever_arm():
    # CM at (10, 20, -100) NED, nose east (yaw 90), antenna 1 m ahead of the CM in body x,
    # body yaw rate 0.5 rad/s, CM velocity (1, 2, 30).
    veh = vehicle(gps_position_m=(0.75, 0.0, 0.0))        # r = 0.75 - (-0.25) = 1.0 m along x
    q = euler_deg_to_quat([0.0, 0.0, 90.0])
    p, v = gps_antenna_ned(veh, ca.DM([10.0, 20.0, -100.0]), ca.DM([1.0, 2.0, 30.0]), ca.DM(q),
                           ca.DM([0.0, 0.0, 0.5]))
    # position: body x is east -> (10, 21, -100)
    assert np.asarray(p, float).ravel() == pytest.approx([10.0, 21.0, -100.0], abs=1e-12)
    # w x r = (0, 0, 0.5) x (1, 0, 0) = (0, 0.5, 0) body; body y is south -> (-0.5, 0, 0) NED
    assert np.asarray(v, float).ravel() == pytest.approx([0.5, 2.0, 30.0], abs=1e-12)


def test_native_axes_rotation_of_mounts():
    # Zephyr-style native axes: body x = native Z, body y = native X, body z = native Y.
    r = ((0.0, 0.0, 1.0), (1.0, 0.0, 0.0), (0.0, 1.0, 0.0))
    veh = Vehicle.from_native(r, inertia_kgm2=Vehicle.inertia_from_moments(1.0, 2.0, 3.0, ixz=0.1),
                              cm_m=(0.0, 0.0, 0.154), mrp_m=(0, 0, 0), imu_position_m=(0.05, 0.0, 0.12),
                              imu_to_native=np.eye(3), gps_position_m=(0.0, 0.0, -0.6), name="z",
                              mass_kg=1.0, ref_area_m2=1.0, ref_length_m=1.0)
    assert veh.cm_m == pytest.approx((0.154, 0.0, 0.0))
    assert veh.imu_position_m == pytest.approx((0.12, 0.05, 0.0))
    # native Izz (3) is the body roll inertia; native I_xz product becomes body I_xy (x-body = Z, y-body = X)
    inertia = np.asarray(veh.inertia_kgm2)
    assert np.diag(inertia) == pytest.approx([3.0, 1.0, 2.0])
    assert inertia[0, 1] == pytest.approx(-0.1) and inertia[0, 2] == pytest.approx(0.0)
    # a native-axes IMU reads a body roll rate on its Z axis
    gyro = np.asarray(imu_angular_rate(veh, ca.DM([1.0, 0.0, 0.0])), float).ravel()
    assert gyro == pytest.approx([0.0, 0.0, 1.0])
