"""Aerodynamic coefficient formulas of casrecon.analysis.aero_coefficients on hand states.

- the database coefficients against the analytic model by hand: at a hand state in still air with
  air-relative body velocity (4, 0, 3) m/s (sin alpha_T = 0.6, e_c = (0, 0, 1)), C_A = CA0 + CA2 0.36,
  C_N = CNa 0.6, C_m = Cma 0.6 (no rates), C_Y = C_n = C_l = 0;
- the reconstructed coefficients from the model's own noise-free IMU output (specific force at an
  IMU off the centre of mass, in rotated IMU axes, plus biases) equal the database's, with rates,
  an MRP off the centre of mass and a full inertia tensor: the IMU-to-centre-of-mass and
  centre-of-mass-to-MRP transfers and the Euler term are right;
- the Savitzky-Golay smoothing: exact on a cubic (value and derivative, also at the window's
  edge), NaN next to a saturated sample, and its stated noise covariance matches Monte Carlo.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import UTTR, simple_vehicle, still_air

from casrecon.analysis import aero_columns as cols
from casrecon.analysis.aero_coefficients import coefficient_functions, smoothed_imu
from casrecon.physics.aero import AeroDatabase, AnalyticCoefficients, DispersionSizes
from casrecon.physics.dynamics import FlightModel, default_parameters
from casrecon.physics.rotations import dcm_body_to_ned
from casrecon.physics.sensors import imu_angular_rate, imu_specific_force

COEF = AnalyticCoefficients(CA0=0.8, CA2=0.1, CNa=0.5, Cma=-0.1, Cmq0=-0.2, Clp=-0.01, Cl0=0.001)
DB = AeroDatabase("hand", COEF, DispersionSizes())
INDEX = {c: i for i, c in enumerate(cols.COEFFICIENTS)}


def _rot(axis: int, angle: float) -> np.ndarray:
    c, s = np.cos(angle), np.sin(angle)
    i, j = [k for k in range(3) if k != axis]
    r = np.eye(3)
    r[i, i], r[i, j], r[j, i], r[j, j] = c, -s, s, c
    return r


def _quat(r: np.ndarray) -> np.ndarray:
    """Scalar-first quaternion of a rotation matrix (trace > 0 here)."""
    q0 = 0.5 * np.sqrt(1 + np.trace(r))
    return np.array([q0, r[2, 1] - r[1, 2], r[0, 2] - r[2, 0], r[1, 0] - r[0, 1]]) / np.r_[1.0, 4 * q0, 4 * q0, 4 * q0]


def _state(model: FlightModel, v_body: np.ndarray, c_nb: np.ndarray, omega) -> np.ndarray:
    """State at 500 m AGL whose air-relative body velocity is ``v_body`` (still air)."""
    q = _quat(c_nb)
    assert np.allclose(np.asarray(dcm_body_to_ned(ca.DM(q))), c_nb)
    return np.r_[0.0, 0.0, -500.0, c_nb @ v_body, q, omega]


def _hand_model(**vehicle) -> FlightModel:
    return FlightModel(simple_vehicle(**vehicle), DB, still_air(), UTTR)


def test_database_coefficients_by_hand():
    model = _hand_model()
    db, _ = coefficient_functions(model)
    c_nb = _rot(2, 0.3) @ _rot(1, -0.2)
    x = _state(model, np.array([4.0, 0.0, 3.0]), c_nb, np.zeros(3))
    c = np.asarray(db(x, default_parameters(), np.zeros(9))).ravel()
    s = 0.6
    expected = {"CA": 0.8 + 0.1 * s**2, "CY": 0.0, "CN": 0.5 * s, "Cl": 0.001, "Cm": -0.1 * s, "Cn": 0.0,
                "CN_crossflow": 0.5 * s, "Cm_crossflow": -0.1 * s}
    for name, value in expected.items():
        assert c[INDEX[name]] == pytest.approx(value, abs=1e-9), name
    # crossflow along +y instead: C_Y,body = -C_N, C_n,body = -C_m; the crossflow-plane values unchanged
    x = _state(model, np.array([4.0, 3.0, 0.0]), c_nb, np.zeros(3))
    c = np.asarray(db(x, default_parameters(), np.zeros(9))).ravel()
    for name, value in {"CY": -0.5 * s, "CN": 0.0, "Cn": 0.1 * s, "Cm": 0.0, "CN_crossflow": 0.5 * s,
                        "Cm_crossflow": -0.1 * s}.items():
        assert c[INDEX[name]] == pytest.approx(value, abs=1e-9), name


def test_reconstructed_from_the_model_imu_output_equals_the_database():
    inertia = np.array([[10.0, -0.3, 0.2], [-0.3, 8.0, 0.1], [0.2, 0.1, 8.5]])
    imu_to_body = _rot(0, 0.4) @ _rot(2, -1.1)
    model = _hand_model(inertia_kgm2=inertia, cm_m=(-0.25, 0.01, -0.02), mrp_m=(-0.3, 0.0, 0.0),
                        imu_position_m=(-0.1, 0.05, 0.03), imu_to_body=imu_to_body)
    db, rec = coefficient_functions(model)
    p = default_parameters(CA_mult=0.0, wind_bias_n=1.5, wind_bias_e=-0.7)
    x = _state(model, np.array([30.0, -4.0, 6.0]), _rot(1, -1.2) @ _rot(0, 0.5), np.array([0.4, -0.9, 1.3]))
    d = np.zeros(9)
    t = model.terms(ca.DM(x), ca.DM(p))
    f_imu = np.asarray(imu_specific_force(model.vehicle, t["force_body"], ca.DM(x[10:13]), t["omega_dot"])).ravel()
    w_imu = np.asarray(imu_angular_rate(model.vehicle, ca.DM(x[10:13]))).ravel()
    wdot_imu = imu_to_body.T @ np.asarray(t["omega_dot"]).ravel()
    bias = np.array([0.03, -0.02, 0.05, 0.002, -0.001, 0.003])
    expected = np.asarray(db(x, p, d)).ravel()
    got = np.asarray(rec(x, p, d, bias, f_imu + bias[:3], w_imu + bias[3:], wdot_imu)).ravel()
    assert np.abs(expected[INDEX["Cm"]]) > 1e-3 and np.abs(expected[INDEX["Cl"]]) > 1e-4  # not a trivial case
    np.testing.assert_allclose(got, expected, rtol=1e-9, atol=1e-12)
    # the comparison can fail: leaving the biases in breaks it
    wrong = np.asarray(rec(x, p, d, np.zeros(6), f_imu + bias[:3], w_imu + bias[3:], wdot_imu)).ravel()
    assert np.abs(wrong - expected).max() > 1e-4


def _signal(t: np.ndarray) -> np.ndarray:
    return np.column_stack([1 + 2 * t - 0.5 * t**2 + 0.3 * t**3 + k for k in range(6)])


def test_smoothing_is_exact_on_a_cubic_and_flags_saturation():
    dt = 0.002
    t = np.arange(0, 2.0, dt)
    y = _signal(t)
    valid = np.ones(t.size, bool)
    nodes = t[[0, 10, 400, 777, t.size - 3, t.size - 1]]
    s, cov = smoothed_imu(t, y[:, :3], y[:, 3:], valid, nodes, np.full(6, 0.1))
    np.testing.assert_allclose(s[:, :6], _signal(nodes), rtol=1e-9)
    deriv = 2 - nodes + 0.9 * nodes**2
    np.testing.assert_allclose(s[:, 6:], np.column_stack([deriv] * 3), rtol=1e-7)
    assert np.all(np.diagonal(cov, axis1=1, axis2=2) > 0)
    valid[405] = False
    s, _ = smoothed_imu(t, y[:, :3], y[:, 3:], valid, nodes, np.full(6, 0.1))
    assert np.isnan(s[2]).all() and not np.isnan(s[[0, 1, 3, 4, 5]]).any()


def _check_against_draws(draws: np.ndarray, predicted: np.ndarray) -> None:
    n = draws.shape[0]
    empirical = np.cov(draws.T)
    # variances within 3.5 standard errors of a variance estimate (sqrt(2 / n) relative)
    np.testing.assert_allclose(np.diag(empirical), np.diag(predicted), rtol=3.5 * np.sqrt(2 / n))
    # rate and angular acceleration of one gyro: correlated as stated (zero for a centred window)
    r_pred = predicted[3, 6] / np.sqrt(predicted[3, 3] * predicted[6, 6])
    r_emp = empirical[3, 6] / np.sqrt(empirical[3, 3] * empirical[6, 6])
    assert abs(r_emp - r_pred) < 4 / np.sqrt(n)


SIGMA = np.array([0.05, 0.05, 0.05, 0.002, 0.002, 0.002])
DT = 0.002


def test_smoothing_noise_covariance_matches_monte_carlo_inside():
    """One long noise record, nodes 60 samples apart (more than the 51-sample window): independent draws."""
    n_nodes = 3000
    t = np.arange(60 * n_nodes + 60) * DT
    noise = np.random.default_rng(3).normal(size=(t.size, 6)) * SIGMA
    nodes = t[60 * np.arange(1, n_nodes)]
    s, cov = smoothed_imu(t, noise[:, :3], noise[:, 3:], np.ones(t.size, bool), nodes, SIGMA)
    assert np.allclose(cov, cov[0])
    _check_against_draws(s, cov[0])


def test_smoothing_noise_covariance_matches_monte_carlo_at_the_edge():
    """The sixth sample of a record: a one-sided window with other weights (and correlated rate and
    angular acceleration)."""
    n_runs = 800
    t = np.arange(120) * DT
    rng = np.random.default_rng(4)
    valid = np.ones(t.size, bool)
    draws = np.empty((n_runs, 9))
    for k in range(n_runs):
        noise = rng.normal(size=(t.size, 6)) * SIGMA
        draws[k], cov = (a[0] for a in smoothed_imu(t, noise[:, :3], noise[:, 3:], valid, t[[5]], SIGMA))
    assert abs(cov[3, 6]) > 0.2 * np.sqrt(cov[3, 3] * cov[6, 6])
    _check_against_draws(draws, cov)
