"""Hermite-Simpson collocation on a uniform mesh of the IMU clock, and how the data enter it.

Mesh
    Nodes every ``samples_per_interval`` IMU samples (13 at 500 Hz by default: h = 26 ms), the first node on
    the first IMU sample of the fit window. The state between nodes is the cubic Hermite polynomial
    through (x_k, f_k) and (x_k+1, f_k+1), f = rhs(x); the compressed Hermite-Simpson defect is
    x_k+1 - x_k - h/6 (f_k + 4 f_m + f_k+1) with x_m = (x_k + x_k+1)/2 + h/8 (f_k - f_k+1).

IMU samples (every one, at its own time)
    Each sample is compared with the model on the collocation polynomial at its own time:
    - gyros: the rate part of the cubic Hermite state polynomial, exactly: w(t_i) = B_i c with B the
      Hermite basis and c = (w_k, h dw_k/dt, w_k+1, h dw_k+1/dt) in IMU axes, plus the bias;
    - accelerometers: the model's specific force at the collocation points tau = 0, 1/2, 1 (the
      nodes and the Hermite-Simpson midpoint, where the dynamics are evaluated anyway), interpolated
      by the quadratic through them: f(t_i) = L_i c.
    The discretisation error (state polynomial and interpolation) falls as h^4; it is what limits
    the mesh: see ``EstimationConfig.interval_s``.
    For one channel of one interval the samples' squared whitened residuals are
    sum_i w_i (y_i - B_i c)^2 = |Q^T W y - R c|^2 + r0 with W B = Q R (thin QR over the unmasked
    samples, W = 1 / sigma) and r0 = |(I - Q Q^T) W y|^2 independent of the unknowns. The NLP
    carries the rows Q^T W y - R c (3 per accelerometer, 4 per gyro channel and interval); r0 is
    added back for the chi-square. This is an exact rewriting of the per-sample sum, not a
    decimation: masked (saturated) samples simply have w_i = 0. With disturbance states the
    samples of an interval also carry correlated errors (what the disturbance does between the
    collocation points, :mod:`casrecon.estimation.sixdof.subgrid`), and W is the inverse Cholesky factor of
    their whole covariance instead of 1 / sigma; the rewriting stays exact.

GPS fixes
    Each fix is compared with the antenna position and velocity on the collocation polynomial at
    its own time, t_fix - clock_offset on the IMU clock (so the clock offset is estimable).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.physics.disturbance import N_DISTURBANCES
from casrecon.physics.dynamics import FlightModel
from casrecon.physics.sensors import gps_antenna_ned, imu_angular_rate, imu_specific_force

#: Collocation points (fractions of an interval) at which the accelerometer model is evaluated.
ACCEL_TAU = (0.0, 0.5, 1.0)
#: Basis size per IMU channel (ax, ay, az: quadratic Lagrange; wx, wy, wz: cubic Hermite).
CHANNEL_BASIS = (3, 3, 3, 4, 4, 4)
#: Offsets of each channel's rows in d (and its coefficients), and of its R factor.
D_OFFSETS = np.cumsum((0,) + CHANNEL_BASIS)
R_OFFSETS = np.cumsum((0,) + tuple(n * n for n in CHANNEL_BASIS))
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


def collocated_state(model: FlightModel, tau, h, xk, xk1, pk, pk1, sel, uk, uk1):
    """The state (SI) at fraction ``tau`` of an interval of length ``h`` on its collocation polynomial:
    the cubic Hermite through the node states ``xk``, ``xk1`` and the model's derivatives there
    (parameters ``pk``, ``pk1``; disturbances ``sel @ uk``, ``sel @ uk1``)."""
    return hermite(tau, h, xk, model.rhs_d(xk, pk, sel @ uk), xk1, model.rhs_d(xk1, pk1, sel @ uk1))


def hermite(tau, h, xk, fk, xk1, fk1):
    """Cubic Hermite state at fraction ``tau`` of an interval of length ``h``."""
    t2, t3 = tau * tau, tau * tau * tau
    return ((2 * t3 - 3 * t2 + 1) * xk + (t3 - 2 * t2 + tau) * h * fk
            + (-2 * t3 + 3 * t2) * xk1 + (t3 - t2) * h * fk1)


def hermite_basis(tau: np.ndarray) -> np.ndarray:
    """Columns h00, h10, h01, h11 of the cubic Hermite basis at fractions ``tau`` (see :func:`hermite`)."""
    t2, t3 = tau * tau, tau * tau * tau
    return np.column_stack([2 * t3 - 3 * t2 + 1, t3 - 2 * t2 + tau, -2 * t3 + 3 * t2, t3 - t2])


def channel_bases(k: int) -> list[np.ndarray]:
    """The (k x n_basis) basis of each IMU channel for the k samples of an interval."""
    tau = np.arange(k) / k
    lag, her = lagrange_matrix(tau, ACCEL_TAU), hermite_basis(tau)
    return [lag, lag, lag, her, her, her]


def lagrange_matrix(tau_samples: np.ndarray, nodes=ACCEL_TAU) -> np.ndarray:
    """L[i, j] = l_j(tau_i): Lagrange basis of ``nodes`` evaluated at the sample fractions."""
    nodes = np.asarray(nodes)
    out = np.ones((tau_samples.size, nodes.size))
    for j, tj in enumerate(nodes):
        for m, tm in enumerate(nodes):
            if m != j:
                out[:, j] *= (tau_samples - tm) / (tj - tm)
    return out


def selection_matrix(n_rows: int, rows) -> ca.DM:
    """(n_rows, len(rows)) matrix putting a short vector into the entries ``rows`` of a longer one."""
    s = np.zeros((n_rows, len(rows)))
    s[np.asarray(rows, int), np.arange(len(rows))] = 1.0
    return ca.DM(s)


def disturbance_selection(active) -> ca.DM:
    """(9, n_u) matrix putting the estimated disturbance entries ``active`` into d."""
    return selection_matrix(N_DISTURBANCES, active)


def imu_model_function(model: FlightModel, active=()) -> ca.Function:
    """``imu(x, p, u) -> (xdot, [specific force (3); rate (3)])``: the state derivative and the
    noise- and bias-free IMU output in IMU axes, from one evaluation of the equations of motion;
    ``u`` the values of the disturbance entries ``active`` (empty for a strong-constraint fit)."""
    x = ca.SX.sym("x", model.n_states)
    p = ca.SX.sym("p", model.n_params)
    u = ca.SX.sym("u", len(active))
    t = model.terms(x, p, disturbance_selection(active) @ u if len(active) else None)
    y = ca.vertcat(imu_specific_force(model.vehicle, t["force_body"], x[10:13], t["omega_dot"]),
                   imu_angular_rate(model.vehicle, x[10:13]))
    return ca.Function("imu_model", [x, p, u], [t["xdot"], y])


def interval_function(model: FlightModel, h: float, active=()) -> ca.Function:
    """``interval(xk, xk1, pk, pk1, bias6, d, R, uk, uk1, um, ui, bu) -> (defect13 scaled, r_imu, c)``
    for one interval.

    ``pk``, ``pk1`` are the model parameters at the two nodes (they differ only by the
    atmosphere-profile corrections; linear in between); ``d`` holds Q^T W y of the 6 IMU channels
    and ``R`` their R factors (column major), stacked at ``D_OFFSETS`` and ``R_OFFSETS``; ``bias6``
    the accelerometer and gyro biases (IMU axes); ``c`` the model's basis coefficients of every
    channel (see the module docstring); ``uk``, ``uk1`` the estimated disturbance entries
    ``active`` at the two nodes and ``um`` at the midpoint, where the collocation evaluates the
    dynamics too (Simpson's rule and the accelerometers' quadratic see the disturbance at three
    points; docs/design.md, Weak-constraint disturbances), and ``ui`` the integral over the interval
    of its departure from the quadratic through those three values (SI times s), which adds
    B ui to what Simpson's rule gives the state's change, B = ``bu`` reshaped (13, n_u) (column
    major) the state derivative's sensitivity to the disturbances on a reference trajectory
    (:mod:`casrecon.estimation.sixdof.subgrid`).
    """
    xk, xk1 = ca.SX.sym("xk", 13), ca.SX.sym("xk1", 13)
    pk, pk1, b = ca.SX.sym("pk", model.n_params), ca.SX.sym("pk1", model.n_params), ca.SX.sym("b", 6)
    d, rr = ca.SX.sym("d", int(D_OFFSETS[-1])), ca.SX.sym("R", int(R_OFFSETS[-1]))
    uk, uk1, um = ca.SX.sym("uk", len(active)), ca.SX.sym("uk1", len(active)), ca.SX.sym("um", len(active))
    ui, bu = ca.SX.sym("ui", len(active)), ca.SX.sym("bu", 13 * len(active))
    imu = imu_model_function(model, active)
    (fk, yk), (fk1, yk1) = imu(xk, pk, uk), imu(xk1, pk1, uk1)
    xm = 0.5 * (xk + xk1) + h / 8 * (fk - fk1)
    fm, ym = imu(xm, 0.5 * (pk + pk1), um)
    subgrid = ca.reshape(bu, 13, len(active)) @ ui if len(active) else 0
    defect = (xk1 - xk - h / 6 * (fk + 4 * fm + fk1) - subgrid) / ca.DM(STATE_SCALE)
    c_ib = ca.DM(np.asarray(model.vehicle.imu_to_body)).T
    wdot_k, wdot_k1 = c_ib @ fk[10:13], c_ib @ fk1[10:13]
    coefs = [ca.vertcat(yk[c], ym[c], yk1[c]) + b[c] for c in range(3)]
    coefs += [ca.vertcat(yk[c] + b[c], h * wdot_k[c - 3], yk1[c] + b[c], h * wdot_k1[c - 3]) for c in range(3, 6)]
    res = []
    for c, n in enumerate(CHANNEL_BASIS):
        r_c = ca.reshape(rr[int(R_OFFSETS[c]):int(R_OFFSETS[c + 1])], n, n)
        res.append(d[int(D_OFFSETS[c]):int(D_OFFSETS[c + 1])] - r_c @ coefs[c])
    return ca.Function("interval", [xk, xk1, pk, pk1, b, d, rr, uk, uk1, um, ui, bu],
                       [defect, ca.vertcat(*res), ca.vertcat(*coefs)],
                       ["xk", "xk1", "pk", "pk1", "bias", "d", "R", "uk", "uk1", "um", "ui", "bu"],
                       ["defect", "r_imu", "c"])


def gps_function(model: FlightModel, h: float, active=()) -> ca.Function:
    """``gps(xk, xk1, pk, pk1, tau, y6, inv_sigma6, uk, uk1) -> r6``: whitened antenna position/velocity
    residual (``pk``, ``pk1``: model parameters at the two nodes; ``uk``, ``uk1``: the estimated
    disturbance entries ``active`` at the two nodes)."""
    xk, xk1 = ca.SX.sym("xk", 13), ca.SX.sym("xk1", 13)
    pk, pk1, tau = ca.SX.sym("pk", model.n_params), ca.SX.sym("pk1", model.n_params), ca.SX.sym("tau")
    y, w = ca.SX.sym("y", 6), ca.SX.sym("w", 6)
    uk, uk1 = ca.SX.sym("uk", len(active)), ca.SX.sym("uk1", len(active))
    sel = disturbance_selection(active)
    x = collocated_state(model, tau, h, xk, xk1, pk, pk1, sel, uk, uk1)
    pos, vel = gps_antenna_ned(model.vehicle, x[0:3], x[3:6], x[6:10], x[10:13])
    return ca.Function("gps", [xk, xk1, pk, pk1, tau, y, w, uk, uk1], [(y - ca.vertcat(pos, vel)) * w])


@dataclass(frozen=True)
class ImuBlocks:
    """Compressed IMU data per interval (see module docstring).

    d : (D_OFFSETS[-1], N) Q^T W y, R : (R_OFFSETS[-1], N) R factors, const_chi2 : (6,) per-channel
    constant r0, n_used : (6,) samples used per channel.
    """

    d: np.ndarray
    R: np.ndarray
    const_chi2: np.ndarray
    n_used: np.ndarray


def compress_imu(mesh: Mesh, y_imu: np.ndarray, valid: np.ndarray, sigma: np.ndarray,
                 extra_covariance: np.ndarray | None = None) -> ImuBlocks:
    """Per-interval thin-QR compression of the IMU samples.

    Parameters
    ----------
    y_imu : (S, 6) measured specific force and rate, IMU axes, samples from the first node on
        (the sample at the last node is not used).
    valid : (S, 6) bool, False for masked samples.
    sigma : (6,) 1-sigma noise per channel.
    extra_covariance : (N, 6, k, k) array, optional
        Errors correlated between the samples of one interval, added to the white noise (per
        interval and channel, SI squared; :mod:`casrecon.estimation.sixdof.subgrid`). The samples are then
        whitened by the Cholesky factor of sigma^2 I + extra instead of 1 / sigma.
    """
    k, n = mesh.samples_per_interval, mesh.n_intervals
    bases = channel_bases(k)
    d, big_r = np.zeros((int(D_OFFSETS[-1]), n)), np.zeros((int(R_OFFSETS[-1]), n))
    const, used = np.zeros(6), np.zeros(6, int)
    for c, basis in enumerate(bases):
        ok = valid[:n * k, c].reshape(n, k)
        if extra_covariance is None:
            w = ok / sigma[c]
            wy = y_imu[:n * k, c].reshape(n, k) * w
            wb = basis[None, :, :] * w[:, :, None]
        else:
            wy, wb = _correlated_whitening(y_imu[:n * k, c].reshape(n, k), ok, basis, sigma[c],
                                           extra_covariance[:, c])
        q, r = np.linalg.qr(wb)  # batched over intervals
        qty = np.einsum("nkb,nk->nb", q, wy)
        d[D_OFFSETS[c]:D_OFFSETS[c + 1]] = qty.T
        big_r[R_OFFSETS[c]:R_OFFSETS[c + 1]] = r.transpose(0, 2, 1).reshape(n, -1).T  # column major
        const[c] = float(np.sum(wy * wy) - np.sum(qty * qty))
        used[c] = int(valid[:n * k, c].sum())
    return ImuBlocks(d, big_r, const, used)


def _correlated_whitening(y: np.ndarray, ok: np.ndarray, basis: np.ndarray, sigma: float,
                          extra: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """L^-1 y and L^-1 B per interval, L L^T = sigma^2 I + extra over the unmasked samples (a masked
    sample's row and column are replaced by the identity's and its data and basis rows by zeros, so
    it adds nothing); y, ok (N, k), basis (k, m), extra (N, k, k)."""
    k = basis.shape[0]
    keep = ok[:, :, None] & ok[:, None, :]
    cov = np.where(keep, extra, 0.0) + np.eye(k)[None] * np.where(ok, sigma * sigma, 1.0)[:, :, None]
    chol = np.linalg.cholesky(cov)
    rhs = np.concatenate([np.where(ok, y, 0.0)[:, :, None], basis[None] * ok[:, :, None]], axis=2)
    white = np.linalg.solve(chol, rhs)
    return white[:, :, 0], white[:, :, 1:]
