"""Hermite-Simpson collocation on a uniform mesh of the IMU clock, and how the data enter it.

Mesh
    Nodes every ``samples_per_interval`` IMU samples (25 at 500 Hz: h = 50 ms), the first node on
    the first IMU sample of the fit window. The state between nodes is the cubic Hermite polynomial
    through (x_k, f_k) and (x_k+1, f_k+1), f = rhs(x); the compressed Hermite-Simpson defect is
    x_k+1 - x_k - h/6 (f_k + 4 f_m + f_k+1) with x_m = (x_k + x_k+1)/2 + h/8 (f_k - f_k+1).

IMU samples (every one, at its own time)
    The model's IMU output (specific force and rate in IMU axes) is evaluated on the collocation
    polynomial at tau = 0, 1/3, 2/3, 1 of each interval and interpolated by the cubic through those
    four values to every sample time: m(t_i) = L_i m4. The rate output is exactly cubic (the Hermite
    polynomial of the state), the specific force to O(h^4). For one channel of one interval the
    samples' squared whitened residuals are sum_i w_i (y_i - L_i m4)^2 = |Q^T W y - R m4|^2 + c,
    with W L = Q R (thin QR over the unmasked samples, W = 1 / sigma) and c = |(I - Q Q^T) W y|^2
    independent of the unknowns. The NLP carries the 4 rows Q^T W y - R m4 per channel and
    interval; c is added back for the chi-square. This is an exact rewriting of the per-sample sum,
    not a decimation: masked (saturated) samples simply have w_i = 0.

GPS fixes
    Each fix is compared with the antenna position and velocity on the collocation polynomial at
    its own time, t_fix - clock_offset on the IMU clock (so the clock offset is estimable).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.physics.dynamics import FlightModel
from casrecon.physics.sensors import gps_antenna_ned, imu_angular_rate, imu_specific_force

#: Collocation-polynomial points at which the IMU model is evaluated, fractions of an interval.
IMU_TAU = (0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0)
#: Scale of each state (m, m/s, -, rad/s): Ipopt sees state / scale.
STATE_SCALE = np.array([100.0, 100.0, 100.0, 10.0, 10.0, 10.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0, 1.0])


@dataclass(frozen=True)
class Mesh:
    """Uniform mesh on the IMU clock: ``t_nodes`` (s), step ``h`` (s), samples per interval."""

    t_nodes: np.ndarray
    h: float
    samples_per_interval: int

    @property
    def n_intervals(self) -> int:
        return self.t_nodes.size - 1


def make_mesh(imu_time_s: np.ndarray, samples_per_interval: int) -> Mesh:
    """Mesh whose nodes sit on every ``samples_per_interval``-th IMU sample."""
    n_int = (imu_time_s.size - 1) // samples_per_interval
    if n_int < 2:
        raise ValueError("the fit window holds fewer than two collocation intervals")
    dt = float(np.median(np.diff(imu_time_s)))
    t_nodes = imu_time_s[0] + dt * samples_per_interval * np.arange(n_int + 1)
    return Mesh(t_nodes, dt * samples_per_interval, samples_per_interval)


def hermite(tau, h, xk, fk, xk1, fk1):
    """Cubic Hermite state at fraction ``tau`` of an interval of length ``h``."""
    t2, t3 = tau * tau, tau * tau * tau
    return ((2 * t3 - 3 * t2 + 1) * xk + (t3 - 2 * t2 + tau) * h * fk
            + (-2 * t3 + 3 * t2) * xk1 + (t3 - t2) * h * fk1)


def lagrange_matrix(tau_samples: np.ndarray, nodes=IMU_TAU) -> np.ndarray:
    """L[i, j] = l_j(tau_i): cubic Lagrange basis of ``nodes`` evaluated at the sample fractions."""
    nodes = np.asarray(nodes)
    out = np.ones((tau_samples.size, nodes.size))
    for j, tj in enumerate(nodes):
        for m, tm in enumerate(nodes):
            if m != j:
                out[:, j] *= (tau_samples - tm) / (tj - tm)
    return out


def imu_model_function(model: FlightModel) -> ca.Function:
    """``imu(x, p) -> (xdot, [specific force (3); rate (3)])``: the state derivative and the
    noise- and bias-free IMU output in IMU axes, from one evaluation of the equations of motion."""
    x = ca.SX.sym("x", model.n_states)
    p = ca.SX.sym("p", model.n_params)
    t = model.terms(x, p)
    y = ca.vertcat(imu_specific_force(model.vehicle, t["force_body"], x[10:13], t["omega_dot"]),
                   imu_angular_rate(model.vehicle, x[10:13]))
    return ca.Function("imu_model", [x, p], [t["xdot"], y])


def interval_function(model: FlightModel, h: float) -> ca.Function:
    """``interval(xk, xk1, p, bias6, d24, R96) -> (defect13 scaled, r24, m4)`` for one interval.

    ``d`` holds Q^T W y for the 6 IMU channels (4 rows each), ``R`` the 6 4x4 R factors (column
    major, stacked); ``bias6`` the accelerometer and gyro biases (IMU axes); ``m4`` (6 x 4) the
    predicted IMU output with biases at the points ``IMU_TAU``.
    """
    xk, xk1 = ca.SX.sym("xk", 13), ca.SX.sym("xk1", 13)
    p, b = ca.SX.sym("p", model.n_params), ca.SX.sym("b", 6)
    d, rr = ca.SX.sym("d", 24), ca.SX.sym("R", 96)
    imu = imu_model_function(model)
    (fk, yk), (fk1, yk1) = imu(xk, p), imu(xk1, p)
    xm = 0.5 * (xk + xk1) + h / 8 * (fk - fk1)
    defect = (xk1 - xk - h / 6 * (fk + 4 * model.rhs(xm, p) + fk1)) / ca.DM(STATE_SCALE)
    inner = [imu(hermite(tau, h, xk, fk, xk1, fk1), p)[1] for tau in IMU_TAU[1:-1]]
    m4 = ca.horzcat(yk, *inner, yk1) + ca.repmat(b, 1, len(IMU_TAU))  # 6 x 4
    res = [d[4 * c:4 * c + 4] - ca.reshape(rr[16 * c:16 * c + 16], 4, 4) @ m4[c, :].T for c in range(6)]
    return ca.Function("interval", [xk, xk1, p, b, d, rr], [defect, ca.vertcat(*res), m4],
                       ["xk", "xk1", "p", "bias", "d", "R"], ["defect", "r_imu", "m4"])


def gps_function(model: FlightModel, h: float) -> ca.Function:
    """``gps(xk, xk1, p, tau, y6, inv_sigma6) -> r6``: whitened antenna position/velocity residual."""
    xk, xk1 = ca.SX.sym("xk", 13), ca.SX.sym("xk1", 13)
    p, tau = ca.SX.sym("p", model.n_params), ca.SX.sym("tau")
    y, w = ca.SX.sym("y", 6), ca.SX.sym("w", 6)
    x = hermite(tau, h, xk, model.rhs(xk, p), xk1, model.rhs(xk1, p))
    pos, vel = gps_antenna_ned(model.vehicle, x[0:3], x[3:6], x[6:10], x[10:13])
    return ca.Function("gps", [xk, xk1, p, tau, y, w], [(y - ca.vertcat(pos, vel)) * w])


@dataclass(frozen=True)
class ImuBlocks:
    """Compressed IMU data per interval (see module docstring).

    d : (24, N) Q^T W y, R : (96, N) R factors, const_chi2 : (6,) per-channel constant c,
    n_used : (6,) samples used per channel, n_rank : (6,) rank per channel (4 when >= 4 used).
    """

    d: np.ndarray
    R: np.ndarray
    const_chi2: np.ndarray
    n_used: np.ndarray
    n_rank: np.ndarray


def compress_imu(mesh: Mesh, y_imu: np.ndarray, valid: np.ndarray, sigma: np.ndarray) -> ImuBlocks:
    """Per-interval thin-QR compression of the IMU samples.

    Parameters
    ----------
    y_imu : (S, 6) measured specific force and rate, IMU axes, samples from the first node on.
    valid : (S, 6) bool, False for masked samples.
    sigma : (6,) 1-sigma noise per channel.
    """
    k = mesh.samples_per_interval
    n = mesh.n_intervals
    lag = lagrange_matrix(np.arange(k + 1) / k)  # sample at the end node belongs to the next interval
    lag = lag[:k]
    d, big_r = np.zeros((24, n)), np.zeros((96, n))
    const, used, rank = np.zeros(6), np.zeros(6, int), np.zeros(6, int)
    for i in range(n):
        rows = slice(i * k, (i + 1) * k)
        for c in range(6):
            w = valid[rows, c] / sigma[c]
            a, wy = lag * w[:, None], y_imu[rows, c] * w
            q, r = np.linalg.qr(a)
            qty = q.T @ wy
            d[4 * c:4 * c + 4, i] = qty
            big_r[16 * c:16 * c + 16, i] = r.ravel(order="F")
            const[c] += wy @ wy - qty @ qty
            used[c] += int(valid[rows, c].sum())
            rank[c] += min(int(valid[rows, c].sum()), 4)
    # the last node's own sample
    return ImuBlocks(d, big_r, const, used, rank)
