"""Quaternion, DCM and Euler conventions (docs/design.md: Frames and angles; scalar-first q, body to NED, ZYX)."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from casrecon.physics.rotations import (
    best_rotation,
    dcm_body_to_ned,
    dcm_body_to_ned_array,
    euler_deg_to_quat,
    euler_from_quat,
    quat_derivative,
    quat_from_dcm,
    quat_from_euler,
    quat_multiply,
    quat_to_euler_deg,
)

RNG = np.random.default_rng(20231003)


def dcm(q) -> np.ndarray:
    return np.asarray(dcm_body_to_ned(ca.DM(np.asarray(q, float))), float)


def quat(phi, theta, psi) -> np.ndarray:
    return np.asarray(quat_from_euler(phi, theta, psi), float).ravel()


def skew(w) -> np.ndarray:
    return np.array([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])


def random_angles(n: int) -> np.ndarray:
    """n random (roll, pitch, yaw) in rad with |pitch| < 89 deg (away from gimbal lock)."""
    return np.column_stack([RNG.uniform(-np.pi, np.pi, n), np.radians(RNG.uniform(-89, 89, n)),
                            RNG.uniform(-np.pi, np.pi, n)])


def test_euler_quaternion_round_trip():
    # 500 random attitudes; the round trip is pure trigonometry, so only rounding remains
    # (amplified near |pitch| = 89 deg by 1/cos(theta) ~ 57: 1e-9 rad is ample headroom).
    for phi, theta, psi in random_angles(500):
        q = quat(phi, theta, psi)
        assert np.linalg.norm(q) == pytest.approx(1.0, abs=1e-14)
        back = np.asarray(euler_from_quat(ca.DM(q)), float).ravel()
        assert back == pytest.approx([phi, theta, psi], abs=1e-9)
        # a non-unit quaternion describes the same attitude
        assert np.asarray(euler_from_quat(ca.DM(2.5 * q)), float).ravel() == pytest.approx(back, abs=1e-12)


def test_degree_helpers_round_trip():
    e = [-99.71, -76.81, -102.38]  # drop 1's release attitude (Table 3)
    assert quat_to_euler_deg(euler_deg_to_quat(e)) == pytest.approx(e, abs=1e-9)


def test_dcm_orthonormal_proper_even_for_unnormalised_quaternions():
    for _ in range(200):
        q = RNG.normal(size=4) * RNG.uniform(0.3, 3.0)
        c = dcm(q)
        assert c @ c.T == pytest.approx(np.eye(3), abs=1e-13)
        assert np.linalg.det(c) == pytest.approx(1.0, abs=1e-13)


def test_dcm_matches_zyx_euler_product():
    # C_nb = Rz(psi) Ry(theta) Rx(phi) with the passive-to-active convention of body-to-NED
    for phi, theta, psi in random_angles(50):
        cz, sz, cy, sy = np.cos(psi), np.sin(psi), np.cos(theta), np.sin(theta)
        cx, sx = np.cos(phi), np.sin(phi)
        rz = np.array([[cz, -sz, 0], [sz, cz, 0], [0, 0, 1]])
        ry = np.array([[cy, 0, sy], [0, 1, 0], [-sy, 0, cy]])
        rx = np.array([[1, 0, 0], [0, cx, -sx], [0, sx, cx]])
        assert dcm(quat(phi, theta, psi)) == pytest.approx(rz @ ry @ rx, abs=1e-13)


def test_yaw_90_maps_body_x_to_east():
    c = dcm(quat(0.0, 0.0, np.pi / 2))
    assert c @ [1, 0, 0] == pytest.approx([0, 1, 0], abs=1e-15)   # nose points east
    assert c @ [0, 1, 0] == pytest.approx([-1, 0, 0], abs=1e-15)  # right wing points south


def test_pitch_minus_90_is_nose_down():
    c = dcm(quat(0.0, -np.pi / 2, 0.0))
    assert c @ [1, 0, 0] == pytest.approx([0, 0, 1], abs=1e-15)   # body x along NED down
    assert quat_to_euler_deg(euler_deg_to_quat([0, -90, 0]))[1] == pytest.approx(-90.0, abs=1e-6)


def test_pitch_up_and_roll_right():
    # +30 deg pitch raises the nose: body x gets a negative (up) down-component -sin 30 = -0.5
    assert dcm(quat(0.0, np.radians(30), 0.0)) @ [1, 0, 0] == pytest.approx([np.cos(np.radians(30)), 0, -0.5])
    # +90 deg roll puts the right wing (body y) down
    assert dcm(quat(np.pi / 2, 0.0, 0.0)) @ [0, 1, 0] == pytest.approx([0, 0, 1], abs=1e-15)


def test_quaternion_product_composes_rotations():
    for _ in range(50):
        p, q = RNG.normal(size=4), RNG.normal(size=4)
        p, q = p / np.linalg.norm(p), q / np.linalg.norm(q)
        pq = np.asarray(quat_multiply(ca.DM(p), ca.DM(q)), float).ravel()
        assert dcm(pq) == pytest.approx(dcm(p) @ dcm(q), abs=1e-13)


def exact_attitude(q0: np.ndarray, w: np.ndarray, t: float) -> np.ndarray:
    """q(t) = q0 (x) (cos(|w| t / 2), sin(|w| t / 2) w / |w|) for a constant body rate w."""
    n = np.linalg.norm(w)
    dq = np.concatenate([[np.cos(n * t / 2)], np.sin(n * t / 2) * w / n])
    return np.asarray(quat_multiply(ca.DM(q0), ca.DM(dq)), float).ravel()


def test_quaternion_kinematics_against_finite_difference():
    # Central difference with h = 1e-5 s: truncation |q'''| h^2 / 6 ~ |w|^3 h^2 / 48 < 1e-10 for
    # |w| < 3 rad/s, rounding ~ 1e-16 / h = 1e-11, so 1e-9 tolerates both with margin.
    h = 1e-5
    for phi, theta, psi in random_angles(20):
        q0 = quat(phi, theta, psi)
        w = RNG.uniform(-1.5, 1.5, 3)
        fd = (exact_attitude(q0, w, h) - exact_attitude(q0, w, -h)) / (2 * h)
        model = np.asarray(quat_derivative(ca.DM(q0), ca.DM(w)), float).ravel()
        assert model == pytest.approx(fd, abs=1e-9)


def test_body_rate_is_in_body_axes():
    # dC_nb/dt = C_nb [w x] for body rate w: checks the q (x) (0, w) ordering against the DCM.
    # Same central-difference error budget as above, on entries of size <= 1.
    h = 1e-5
    q0 = quat(0.3, -1.2, 2.0)
    w = np.array([0.4, -0.7, 1.1])
    fd = (dcm(exact_attitude(q0, w, h)) - dcm(exact_attitude(q0, w, -h))) / (2 * h)
    assert fd == pytest.approx(dcm(q0) @ skew(w), abs=1e-9)
    # and a yaw rate (body z) of a level body turns the nose from north toward east
    q1 = exact_attitude(quat(0, 0, 0), np.array([0, 0, 0.1]), 1.0)
    assert (dcm(q1) @ [1, 0, 0])[1] == pytest.approx(np.sin(0.1), abs=1e-14)


def test_vectorised_dcm_equals_the_casadi_one_also_for_unnormalised_quaternions():
    from casrecon.physics.rotations import dcm_body_to_ned, dcm_body_to_ned_array

    quats = np.random.default_rng(3).normal(size=(6, 4)) * 1.7  # norms far from 1
    many = dcm_body_to_ned_array(quats)
    for q, c in zip(quats, many):
        assert c == pytest.approx(np.asarray(dcm_body_to_ned(q), float), abs=1e-14)


def test_quaternion_from_dcm_equals_scipy_in_every_branch():
    """Shepperd's method against scipy for random rotations and for 180 deg turns about each axis
    (where the scalar part vanishes and another component is the pivot)."""
    rotations = [Rotation.random(random_state=k) for k in range(100)]
    rotations += [Rotation.from_rotvec(np.pi * axis) for axis in np.eye(3)]
    rotations += [Rotation.from_rotvec(np.radians(179.9) * np.array([0.6, -0.64, 0.48]))]
    for r in rotations:
        q = quat_from_dcm(r.as_matrix())
        ref = np.roll(r.as_quat(), 1)
        assert np.allclose(q, ref if ref[0] >= 0 else -ref, atol=1e-12)
        assert np.allclose(dcm_body_to_ned_array(q[None])[0], r.as_matrix(), atol=1e-12)


def test_best_rotation_solves_wahba_as_scipy_does():
    rng = np.random.default_rng(3)
    for k in range(20):
        truth = Rotation.random(random_state=k)
        source = rng.normal(size=(40, 3))
        target = truth.apply(source) + 0.2 * rng.normal(size=(40, 3))
        expected, _ = Rotation.align_vectors(target, source)
        c = best_rotation(target, source)
        assert np.allclose(c, expected.as_matrix(), atol=1e-12)
        assert np.isclose(np.linalg.det(c), 1.0)

