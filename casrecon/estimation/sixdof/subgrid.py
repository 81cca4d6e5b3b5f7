"""What a Gauss-Markov disturbance does between the nodes (docs/design.md, Weak-constraint
disturbances).

A fit with disturbance states (gusts, model-error force and moment) has each disturbance entry's
values at the nodes and at the interval midpoints; the collocation sees it through the quadratic
q(t) through those three values. The process it assumes (:mod:`casrecon.physics.disturbance`,
correlation time tau, sigma s) departs from q by e(t), zero at the three points. This module gives
what the fit needs of e, for a stationary process (exact kernels, not a Brownian-bridge
approximation):

- the standard deviation of its integral over an interval (:func:`subgrid_integral_sigma`), the
  prior of the sub-grid integral unknowns, which change the state over the interval by B times
  themselves, B the state derivative's sensitivity at the midpoint of a reference trajectory;
- the covariance of the IMU samples' departures within an interval: an accelerometer sample at t
  sees S e(t), a gyro sample G J(t) with J(t) = I(t) - H01(t/h) I(h), I(t) the integral of e from
  0 to t (the model's rate between nodes is the cubic Hermite through the node values and slopes,
  H01 its basis function of the end value); S, G the specific force's and angular acceleration's
  sensitivities on the reference trajectory (:func:`interval_kernels`, :class:`SubgridModel`).

The departures of two intervals are independent given the node and midpoint values (the process
is Markov). Linearising on a reference trajectory (the initial guess) is enough: the sensitivities
depend on airspeed, dynamic pressure and tilt, which the GPS and IMU fix before any fit.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.estimation.sixdof.transcription import ACCEL_TAU, disturbance_selection, hermite_basis, lagrange_matrix
from casrecon.physics.dynamics import FlightModel
from casrecon.physics.sensors import imu_specific_force

#: Sub-steps per IMU sample of the grid on which the kernels are integrated.
KERNEL_SUBSTEPS = 32


def _departure(h_s: float, m: int) -> tuple[np.ndarray, np.ndarray]:
    """Grid times t (m + 1 points on [0, h_s], m even) and the matrix taking a process's values on
    them to its departure e from the quadratic through its values at 0, h_s / 2 and h_s."""
    t = np.linspace(0.0, h_s, m + 1)
    depart = np.eye(m + 1)
    depart[:, [0, m // 2, m]] -= lagrange_matrix(t / h_s, ACCEL_TAU)
    return t, depart


def _running_integral(h_s: float, m: int) -> np.ndarray:
    """(m + 1, m + 1) trapezoid-rule matrix: row i integrates grid values from 0 to t_i."""
    step = h_s / m
    out = np.tril(np.ones((m + 1, m + 1))) * step
    out[:, 0] -= 0.5 * step
    out[np.diag_indices(m + 1)] -= 0.5 * step
    out[0] = 0.0
    return out


def _stationary(t: np.ndarray, time_s: float) -> np.ndarray:
    """Covariance of a unit-variance first-order Gauss-Markov process at times t."""
    return np.exp(-np.abs(t[:, None] - t[None, :]) / time_s)


def interval_kernels(h_s: float, samples: int, time_s: np.ndarray,
                     substeps: int = KERNEL_SUBSTEPS) -> tuple[np.ndarray, np.ndarray]:
    """Covariances of e and J (module docstring) at an interval's samples, per unit-variance
    process.

    Parameters
    ----------
    h_s : float
        Interval length, s.
    samples : int
        Samples per interval, at fractions i / samples of it (i = 0 .. samples - 1; the first on
        the node).
    time_s : (n,) array
        Correlation time of each process, s.
    substeps : int
        Integration grid steps per sample (even).

    Returns
    -------
    accel, gyro : (n, samples, samples) arrays
        Cov(e(t_i), e(t_j)) (units of the process squared) and Cov(J(t_i), J(t_j)) (times s^2).
    """
    m = samples * substeps
    t, depart = _departure(h_s, m)
    integral = _running_integral(h_s, m)
    h01 = hermite_basis(t / h_s)[:, 2]
    remainder = (integral - np.outer(h01, integral[-1])) @ depart
    at = np.arange(samples) * substeps
    accel, gyro = [], []
    for tc in np.atleast_1d(np.asarray(time_s, float)):
        cov = _stationary(t, tc)
        accel.append((depart @ cov @ depart.T)[np.ix_(at, at)])
        gyro.append((remainder @ cov @ remainder.T)[np.ix_(at, at)])
    return np.array(accel), np.array(gyro)


def subgrid_integral_sigma(sigma: np.ndarray, time_s: np.ndarray, h_s: float,
                           substeps: int = 16 * KERNEL_SUBSTEPS) -> np.ndarray:
    """1-sigma (SI times s) of the integral over an interval of h_s seconds of each process's
    departure from the quadratic through its values at the interval's ends and midpoint
    (processes of sigma ``sigma`` and correlation time ``time_s``): what Simpson's rule on those
    values leaves out of the process's integral. ``substeps``: grid steps (even)."""
    t, depart = _departure(h_s, substeps)
    row = _running_integral(h_s, substeps)[-1] @ depart
    return np.array([s_ * np.sqrt(max(float(row @ _stationary(t, tc) @ row), 0.0))
                     for s_, tc in zip(np.asarray(sigma, float), np.asarray(time_s, float))])


def sensitivity_function(model: FlightModel, active) -> ca.Function:
    """``sens(x, p) -> (imu (6, n_u), state (13, n_u))`` at zero disturbance: the derivatives in
    the disturbance entries ``active`` of the specific force (rows 0-2, IMU axes, m/s^2 per unit)
    and the angular acceleration (rows 3-5, IMU axes, rad/s^2 per unit), and of the state
    derivative (SI per unit)."""
    x, p = ca.SX.sym("x", model.n_states), ca.SX.sym("p", model.n_params)
    u = ca.SX.sym("u", len(active))
    terms = model.terms(x, p, disturbance_selection(active) @ u)
    c_ib = ca.DM(np.asarray(model.vehicle.imu_to_body)).T
    f = imu_specific_force(model.vehicle, terms["force_body"], x[10:13], terms["omega_dot"])
    zero = ca.DM.zeros(len(active))
    imu = ca.substitute(ca.jacobian(ca.vertcat(f, c_ib @ terms["omega_dot"]), u), u, zero)
    state = ca.substitute(ca.jacobian(terms["xdot"], u), u, zero)
    return ca.Function("disturbance_sensitivity", [x, p], [imu, state])


@dataclass(frozen=True)
class SubgridModel:
    """What the disturbances do between the nodes, linearised on a reference trajectory.

    Attributes
    ----------
    imu_covariance : (N, 6, k, k) array
        Per interval and IMU channel, the covariance of the samples' departures (S e and G J of the
        module docstring; SI units of the channel squared).
    state_sensitivity : (13 n_u, N) array
        Per interval, the state derivative's sensitivity B (13, n_u; column major) to the
        disturbances at the interval's midpoint: the sub-grid integrals change the state by B ui.
    """

    imu_covariance: np.ndarray
    state_sensitivity: np.ndarray

    @classmethod
    def on(cls, model: FlightModel, active, sigma: np.ndarray, time_s: np.ndarray, h_s: float, samples: int,
           states: np.ndarray, params: np.ndarray) -> SubgridModel:
        """The model for disturbance entries ``active`` of prior sigma ``sigma`` (SI) and
        correlation time ``time_s`` (s) on a mesh of ``h_s`` seconds with ``samples`` IMU samples
        per interval, linearised on the reference node states ``states`` (K, 13; SI; an initial
        guess will do: the sensitivities depend on airspeed, dynamic pressure and tilt) and model
        parameters ``params``."""
        n_u, n_nodes = len(active), states.shape[0]
        k_accel, k_gyro = interval_kernels(h_s, samples, time_s)
        mid = 0.5 * (states[:-1] + states[1:])
        both = np.vstack([states, mid])
        imu, state = sensitivity_function(model, active).map(both.shape[0])(
            both.T, np.tile(np.asarray(params, float)[:, None], (1, both.shape[0])))
        imu = np.asarray(imu).reshape(6, both.shape[0], n_u)[:, :n_nodes]  # the map puts (6, n_u) blocks side by side
        weight = 0.5 * (imu[:, :-1] ** 2 + imu[:, 1:] ** 2) * np.asarray(sigma, float) ** 2  # (6, N, n_u)
        cov = np.empty((n_nodes - 1, 6, samples, samples))
        cov[:, :3] = np.einsum("cnj,jab->ncab", weight[:3], k_accel)
        cov[:, 3:] = np.einsum("cnj,jab->ncab", weight[3:], k_gyro)
        state = np.asarray(state).reshape(13, both.shape[0], n_u)[:, n_nodes:]  # (13, N, n_u)
        return cls(cov, state.transpose(1, 2, 0).reshape(n_nodes - 1, 13 * n_u).T)
