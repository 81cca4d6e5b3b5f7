"""IMU preintegration (casrecon.physics.preintegration) against a finely integrated smooth motion,
finite differences and a Monte Carlo of the noise."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from casrecon.physics.preintegration import N_IMU_PARAMETERS, cut_pieces, preintegrate


def rate(t):
    return np.column_stack([0.8 * np.sin(2 * np.pi * 1.2 * t), 0.5 * np.cos(2 * np.pi * 0.7 * t), 0.3 + 0 * t])


def force(t):
    return np.column_stack([2 * np.cos(3 * t), -9.0 + np.sin(2 * t), 1.0 + 0 * t])


def fine_truth(t0, t1, n=1500):
    """(rotation, dv, dp) by the midpoint rule on n steps of the continuous signals."""
    h = (t1 - t0) / n
    rot, v, p = Rotation.identity(), np.zeros(3), np.zeros(3)
    for i in range(n):
        tm = t0 + (i + 0.5) * h
        acc = (rot * Rotation.from_rotvec(rate(np.array([tm]))[0] * h / 2)).apply(force(np.array([tm]))[0])
        p, v = p + v * h + acc * h * h / 2, v + acc * h
        rot = rot * Rotation.from_rotvec(rate(np.array([tm]))[0] * h)
    return rot, v, p


def errors(rate_hz):
    t = np.arange(0.0, 2.0, 1.0 / rate_hz)
    nodes = np.array([0.05, 0.25, 0.45, 0.85, 1.6])
    pre = preintegrate(t, rate(t), force(t), nodes, np.full((t.size, 3), 1e-3), np.full((t.size, 3), 1e-2))
    out = []
    for k in range(nodes.size - 1):
        rot, v, p = fine_truth(nodes[k], nodes[k + 1])
        q = pre.delta[k, :4]
        est = Rotation.from_quat([q[1], q[2], q[3], q[0]])
        out.append(((rot.inv() * est).magnitude(), np.abs(pre.delta[k, 4:7] - v).max(),
                    np.abs(pre.delta[k, 7:] - p).max()))
    return np.array(out).max(axis=0)


def test_preintegration_converges_at_fourth_order():
    """Rotation, velocity and position changes against a fine integration: at 100 Hz within 1e-6,
    and the error falls by more than (100 / 25)^3 from 25 Hz (third order or better)."""
    coarse, fine = errors(25.0), errors(100.0)
    assert np.all(fine < 1e-6), fine
    assert np.all(coarse / fine > 64), (coarse, fine)


def test_pieces_tile_the_intervals():
    t = np.arange(0.0, 1.0, 0.077)
    nodes = np.array([0.01, 0.2, 0.21, 0.6, 0.9])
    interval, sample, start, stop = cut_pieces(t, nodes)
    for k in range(nodes.size - 1):
        sel = interval == k
        assert np.isclose((stop - start)[sel].sum(), nodes[k + 1] - nodes[k])
        assert start[sel][0] == pytest.approx(nodes[k]) and stop[sel][-1] == pytest.approx(nodes[k + 1])
    # every piece lies inside its sample's cell
    assert np.all(np.abs((start + stop) / 2 - t[sample]) <= 0.077 / 2 + 1e-12)


def test_parameter_jacobian_matches_finite_differences():
    t = np.arange(0.0, 1.0, 0.01)
    nodes = np.array([0.0, 0.3, 0.9])
    sig = np.full((t.size, 3), 1e-3)
    theta = np.r_[0.01, -0.02, 0.005, 0.05, -0.1, 0.02, 0.01, -0.01, 0.02, 0.003, 0.004, -0.005,
                  0.002 * np.arange(1, 13) * (-1) ** np.arange(12)]
    pre = preintegrate(t, rate(t), force(t), nodes, sig, sig, theta)
    step = 1e-6
    for j in range(N_IMU_PARAMETERS):
        d = np.zeros(N_IMU_PARAMETERS)
        d[j] = step
        hi = preintegrate(t, rate(t), force(t), nodes, sig, sig, theta + d)
        lo = preintegrate(t, rate(t), force(t), nodes, sig, sig, theta - d)
        for k in range(2):
            dv = (hi.delta[k, 4:] - lo.delta[k, 4:]) / (2 * step)
            q0 = pre.delta[k, :4]
            r0 = Rotation.from_quat([q0[1], q0[2], q0[3], q0[0]])
            rh = Rotation.from_quat(np.r_[hi.delta[k, 1:4], hi.delta[k, 0]])
            rl = Rotation.from_quat(np.r_[lo.delta[k, 1:4], lo.delta[k, 0]])
            dphi = ((r0.inv() * rh).as_rotvec() - (r0.inv() * rl).as_rotvec()) / (2 * step)
            np.testing.assert_allclose(pre.jac_theta[k, :, j], np.r_[dphi, dv], atol=1e-6, rtol=1e-5)


def test_noise_covariance_matches_monte_carlo():
    """The 9 x 9 covariance of (rotation, dv, dp) against 400 noisy records whose noise is white
    per sample at the stated sigma (the estimator's continuous model): variances within 20 %
    (the sampling error of a variance from 400 draws is 7 %). The records are laid end to end, 10 s
    apart, and preintegrated in one call."""
    rate_hz, n_rec = 100.0, 400
    t = np.arange(0.0, 1.0, 1.0 / rate_hz)
    s_g, s_a = 2e-3, 5e-2
    rng = np.random.default_rng(0)
    t_all = np.concatenate([t + 10.0 * j for j in range(n_rec)])
    w = np.tile(rate(t), (n_rec, 1)) + rng.normal(0, s_g, (t_all.size, 3))
    f = np.tile(force(t), (n_rec, 1)) + rng.normal(0, s_a, (t_all.size, 3))
    nodes = np.concatenate([[0.1 + 10.0 * j, 0.6 + 10.0 * j] for j in range(n_rec)])
    sig_g, sig_a = np.full((t_all.size, 3), s_g), np.full((t_all.size, 3), s_a)
    noisy = preintegrate(t_all, w, f, nodes, sig_g, sig_a)
    clean = preintegrate(t, rate(t), force(t), nodes[:2], sig_g[:t.size], sig_a[:t.size])
    q0 = clean.delta[0, :4]
    r0 = Rotation.from_quat([q0[1], q0[2], q0[3], q0[0]])
    d = noisy.delta[::2]                                   # the records' own intervals (the others span the gaps)
    rot = (r0.inv() * Rotation.from_quat(np.column_stack([d[:, 1:4], d[:, 0]]))).as_rotvec()
    samples = np.column_stack([rot, d[:, 4:] - clean.delta[0, 4:]])
    var_mc = np.var(samples, axis=0)
    np.testing.assert_allclose(var_mc, np.diag(clean.covariance[0]), rtol=0.2)
