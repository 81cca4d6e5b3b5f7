"""What a Gauss-Markov disturbance does between the nodes: the kernels against Monte Carlo draws of
the process, and the IMU compression with correlated errors against dense generalised least
squares (masked samples included)."""

from __future__ import annotations

import numpy as np
import pytest

from casrecon.estimation.sixdof.subgrid import interval_kernels, subgrid_integral_sigma
from casrecon.estimation.sixdof.transcription import D_OFFSETS, R_OFFSETS, Mesh, channel_bases, compress_imu

H_S, SAMPLES, TAU_S = 0.026, 13, 0.5


@pytest.fixture(scope="module")
def draws():
    """4000 draws of a unit-variance Gauss-Markov process (tau 0.5 s: the departures are larger
    than for the gusts' 3 s) on a fine grid over one interval, exactly discretised."""
    rng = np.random.default_rng(5)
    fine = 64
    t = np.linspace(0.0, H_S, SAMPLES * fine + 1)
    phi = np.exp(-np.diff(t) / TAU_S)
    x = np.empty((4000, t.size))
    x[:, 0] = rng.normal(size=4000)
    for i, p in enumerate(phi):
        x[:, i + 1] = p * x[:, i] + np.sqrt(1 - p * p) * rng.normal(size=4000)
    tau = t / H_S
    quadratic = (np.outer(x[:, 0], 2 * (tau - 0.5) * (tau - 1)) + np.outer(x[:, t.size // 2], -4 * tau * (tau - 1))
                 + np.outer(x[:, -1], 2 * tau * (tau - 0.5)))
    e = x - quadratic
    running = np.concatenate([np.zeros((4000, 1)), np.cumsum(0.5 * (e[:, 1:] + e[:, :-1]) * np.diff(t), axis=1)], 1)
    j = running - np.outer(running[:, -1], 3 * tau**2 - 2 * tau**3)
    return e[:, ::fine][:, :SAMPLES], j[:, ::fine][:, :SAMPLES], running[:, -1]


def test_kernels_match_draws_of_the_process(draws):
    e, j, _ = draws
    accel, gyro = interval_kernels(H_S, SAMPLES, np.array([TAU_S]))
    assert accel.shape == gyro.shape == (1, SAMPLES, SAMPLES)
    # zero at the node, largest near the quarter points; 4000 draws: variances within 8 %
    assert accel[0, 0, 0] == 0 and gyro[0, 0, 0] == 0
    assert np.diag(accel[0])[1:] == pytest.approx(np.var(e, axis=0)[1:], rel=0.08)
    assert np.diag(gyro[0])[1:] == pytest.approx(np.var(j, axis=0)[1:], rel=0.08)
    # and the correlation between two samples of the interval
    assert accel[0, 2, 9] == pytest.approx(np.mean(e[:, 2] * e[:, 9]), abs=0.1 * accel[0, 3, 3])


def test_integral_sigma_matches_draws_and_scales_with_sigma(draws):
    _, _, integral = draws
    one = subgrid_integral_sigma(np.array([1.0]), np.array([TAU_S]), H_S)
    assert one[0] == pytest.approx(np.std(integral), rel=0.05)
    two = subgrid_integral_sigma(np.array([2.0, 0.5]), np.array([TAU_S, TAU_S]), H_S)
    assert two == pytest.approx([2 * one[0], 0.5 * one[0]], rel=1e-12)


def test_compression_with_correlated_errors_is_generalised_least_squares():
    """For any basis coefficients c, the compressed rows' squared norm plus the constant equals the
    dense GLS chi-square (y - B c)^T C^-1 (y - B c) over the unmasked samples of each interval."""
    rng = np.random.default_rng(2)
    n_int, k = 4, SAMPLES
    mesh = Mesh(np.arange(n_int + 1) * H_S, H_S, k)
    y = rng.normal(size=(n_int * k, 6))
    valid = np.ones((n_int * k, 6), bool)
    valid[k + 3, 1] = valid[2 * k + 7, 4] = False  # two masked samples
    sigma = np.array([0.05, 0.05, 0.05, 0.002, 0.002, 0.002])
    accel, gyro = interval_kernels(H_S, k, np.array([TAU_S]))
    extra = np.empty((n_int, 6, k, k))
    extra[:, :3] = 0.3 * sigma[0] ** 2 / accel[0].max() * accel[0]
    extra[:, 3:] = 0.3 * sigma[3] ** 2 / gyro[0].max() * gyro[0]
    blocks = compress_imu(mesh, y, valid, sigma, extra)
    bases = channel_bases(k)
    total_want, total_got = 0.0, float(blocks.const_chi2.sum())
    for c in range(6):
        nb = bases[c].shape[1]
        for i in range(n_int):
            coef = rng.normal(size=nb)
            ok = valid[i * k:(i + 1) * k, c]
            r = (y[i * k:(i + 1) * k, c] - bases[c] @ coef)[ok]
            cov = (extra[i, c] + sigma[c] ** 2 * np.eye(k))[np.ix_(ok, ok)]
            total_want += float(r @ np.linalg.solve(cov, r))
            rr = blocks.R[R_OFFSETS[c]:R_OFFSETS[c + 1], i].reshape(nb, nb, order="F")
            row = blocks.d[D_OFFSETS[c]:D_OFFSETS[c + 1], i] - rr @ coef
            total_got += float(row @ row)
    assert total_got == pytest.approx(total_want, rel=1e-10)
    assert list(blocks.n_used) == [n_int * k, n_int * k - 1, n_int * k, n_int * k, n_int * k - 1, n_int * k]
