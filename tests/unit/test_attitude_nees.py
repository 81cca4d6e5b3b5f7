"""The attitude-error NEES of the model-error Monte Carlo: a known small rotation under a known
isotropic covariance, at ordinary attitudes and at 90 deg pitch (where Euler-angle bands fail)."""

from __future__ import annotations

import numpy as np
import pytest

from casrecon.analysis.model_error_mc import ATTITUDE_NEES_3SIGMA, attitude_nees
from casrecon.physics.rotations import euler_deg_to_quat, quat_multiply


def xi(q):
    return np.array([[-q[1], -q[2], -q[3]], [q[0], -q[3], q[2]], [q[3], q[0], -q[1]], [-q[2], q[1], q[0]]])


@pytest.mark.parametrize("euler_deg", [(10.0, 20.0, 30.0), (-129.4, -89.9, 71.5), (0.0, 90.0, 0.0)])
def test_attitude_nees_of_a_known_rotation(euler_deg):
    q = euler_deg_to_quat(euler_deg)
    sigma = np.radians(0.3)
    axis = np.array([0.3, -0.5, 0.8]) / np.linalg.norm([0.3, -0.5, 0.8])
    angle = np.radians(0.6)
    dq = np.r_[np.cos(angle / 2), np.sin(angle / 2) * axis]
    q_true = np.asarray(quat_multiply(q, dq)).ravel()
    cov_q = sigma**2 / 4 * xi(q) @ xi(q).T  # dtheta covariance sigma^2 I
    nees = attitude_nees(q[None], q_true[None], cov_q[None])
    assert nees[0] == pytest.approx((angle / sigma) ** 2, rel=1e-4)
    # the quaternion's sign does not matter
    assert attitude_nees(q[None], -q_true[None], cov_q[None])[0] == pytest.approx(nees[0])
    assert ATTITUDE_NEES_3SIGMA == pytest.approx(14.156, abs=1e-3)
