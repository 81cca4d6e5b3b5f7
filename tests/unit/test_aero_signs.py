"""Aerodynamic signs and magnitudes (docs/design.md: Aerodynamics), on hand-computed cases.

Common numbers: rho = 1.0 kg/m^3, S = 1.2 m^2, d = 1.0 m, airspeed V = 5 m/s, so
qbar = rho V^2 / 2 = 12.5 Pa, qbar S = 15 N and qbar S d = 15 N m. The (4, 0, 3) and (4, 3, 0)
velocities have sin(alpha_T) = 3/5 = 0.6 exactly. Coefficients: C_A = 0.8 + 0.1 sin^2 aT,
C_N = 0.5 sin aT, C_m = -0.1 sin aT, C_mq = -0.2, C_lp = -0.01.
All expectations are exact up to floating point (the crossflow guard 1e-6 m/s changes e_c by
~1e-14 relative at 3 m/s crossflow), hence tolerances of 1e-9.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from casrecon.physics.aero import (
    DISPERSION_NAMES,
    AeroDatabase,
    AnalyticCoefficients,
    DispersionSizes,
    SpinVanes,
    aero_force_moment,
    flow_angles,
)
from casrecon.physics.sensors import imu_specific_force
from casrecon.physics.vehicle import Vehicle

COEF = AnalyticCoefficients(CA0=0.8, CA2=0.1, CNa=0.5, Cma=-0.1, Cmq0=-0.2, Clp=-0.01)
SIZES = DispersionSizes(CA_mult=0.1, CN_add=0.01, CNY_mult=0.2, CY_add=0.02, Cm_add=0.004,
                        Cmn_mult=0.3, Cn_add=0.005, Cmq_mult=0.5, Cl_add=0.0002, CLa_mult=0.6)
DB = AeroDatabase("hand", COEF, SIZES)
TOL = 1e-9


def fm(v_body, omega=(0, 0, 0), disp=None, mrp_minus_cm=(0, 0, 0), db=DB, rho=1.0):
    d = np.zeros(len(DISPERSION_NAMES)) if disp is None else disp
    f, m = aero_force_moment(db, ca.DM(v_body), ca.DM(omega), rho, 340.0, ca.DM(d), 1.2, 1.0,
                             ca.DM(mrp_minus_cm))
    return np.asarray(f, float).ravel(), np.asarray(m, float).ravel()


def one(name: str, value: float = 1.0) -> np.ndarray:
    d = np.zeros(len(DISPERSION_NAMES))
    d[DISPERSION_NAMES.index(name)] = value
    return d


def test_flow_angles_definitions():
    fl = flow_angles(ca.DM([4.0, 3.0, 0.0]))
    assert float(fl.speed) == pytest.approx(5.0)
    assert float(fl.beta) == pytest.approx(np.arcsin(0.6), abs=TOL)   # beta = asin(v / V)
    assert float(fl.alpha) == pytest.approx(0.0, abs=TOL)
    assert float(fl.alpha_t) == pytest.approx(np.arccos(0.8), abs=TOL)
    fl = flow_angles(ca.DM([4.0, 0.0, 3.0]))
    assert float(fl.alpha) == pytest.approx(np.arctan2(3, 4), abs=TOL)  # alpha = atan2(w, u)
    assert float(fl.alpha_t) == pytest.approx(np.arccos(0.8), abs=TOL)
    assert np.asarray(fl.crossflow_dir, float).ravel() == pytest.approx([0, 0, 1], abs=TOL)


def test_positive_alpha_nose_down_moment_and_normal_force_opposes_crossflow():
    f, m = fm([4.0, 0.0, 3.0])
    # C_A = 0.8 + 0.1 * 0.36 = 0.836 -> F_x = -15 * 0.836 = -12.54 N
    # C_N = 0.5 * 0.6 = 0.3, crossflow +z -> F_z = -15 * 0.3 = -4.5 N (against the crossflow)
    assert f == pytest.approx([-12.54, 0.0, -4.5], abs=TOL)
    # C_m = -0.1 * 0.6 = -0.06 -> M_y = 15 * -0.06 = -0.9 N m: nose down, into the wind
    assert m == pytest.approx([0.0, -0.9, 0.0], abs=TOL)


def test_positive_beta_restoring_yaw_moment():
    f, m = fm([4.0, 3.0, 0.0])
    # crossflow +y: F_y = -qbar S C_N = -4.5 N; C_n,body = -C_m e_c,y = +0.06 -> M_z = +0.9 N m:
    # yawing nose right (+z) turns the nose toward the sideslip, i.e. into the wind
    assert f == pytest.approx([-12.54, -4.5, 0.0], abs=TOL)
    assert m == pytest.approx([0.0, 0.0, 0.9], abs=TOL)


def test_axisymmetric_crossflow_at_any_aerodynamic_roll_angle():
    # crossflow of 3 m/s at phi_A = atan2(v, w) = 30 deg: same magnitudes, rotated
    s, c = 0.5, np.sqrt(3) / 2
    f, m = fm([4.0, 3 * s, 3 * c])
    assert f == pytest.approx([-12.54, -4.5 * s, -4.5 * c], abs=TOL)
    # moment is perpendicular to crossflow: (0, e_z, -e_y) C_m qbar S d
    assert m == pytest.approx([0.0, -0.9 * c, 0.9 * s], abs=TOL)


def test_pure_drag_specific_force_at_the_cm():
    # alpha_T = 0 and IMU at the CM: f = -qbar S C_A / m along body x.
    # By hand: qbar = 0.5 * 1.0 * 40^2 = 800 Pa, qbar S C_A = 800 * 1.2 * 0.8 = 768 N,
    # m = 96 kg -> f_x = -8.0 m/s^2 (and nothing else)
    f, m = fm([40.0, 0.0, 0.0])
    assert f == pytest.approx([-768.0, 0.0, 0.0], abs=1e-9)
    assert m == pytest.approx([0.0, 0.0, 0.0], abs=1e-9)
    veh = Vehicle("drag", 96.0, np.diag([10.0, 8.0, 8.0]), (0, 0, 0), (0, 0, 0), 1.2, 1.0)
    spec = np.asarray(imu_specific_force(veh, ca.DM(f), ca.DM.zeros(3), ca.DM.zeros(3)), float).ravel()
    assert spec == pytest.approx([-8.0, 0.0, 0.0], abs=1e-12)


def test_moment_transfer_to_cm():
    # Axial and normal force only (C_m = 0), MRP at r = r_MRP - r_cm = (0.2, 0, 0.05) m.
    db = AeroDatabase("noCm", AnalyticCoefficients(CA0=0.8, CNa=0.5), DispersionSizes())
    f, m = fm([4.0, 0.0, 3.0], db=db, mrp_minus_cm=(0.2, 0.0, 0.05))
    # F = (-15 * 0.8, 0, -15 * 0.3) = (-12, 0, -4.5) N
    # r x F = (0 * -4.5 - 0.05 * 0, 0.05 * -12 - 0.2 * -4.5, 0.2 * 0 - 0 * -12) = (0, 0.3, 0) N m:
    # a normal force ahead of the CM pitches the nose up (away from the wind)
    assert f == pytest.approx([-12.0, 0.0, -4.5], abs=TOL)
    assert m == pytest.approx([0.0, 0.3, 0.0], abs=TOL)


def test_damping_terms():
    # alpha_T = 0 at V = 5: qbar S d (d / 2V) = 15 * 0.1 = 1.5 N m s
    # rates (p, q, r) = (2, 0.5, -0.4): M = 1.5 * (C_lp p, C_mq q, C_mq r) = (-0.03, -0.15, 0.12)
    f, m = fm([5.0, 0.0, 0.0], omega=(2.0, 0.5, -0.4))
    assert m == pytest.approx([-0.03, -0.15, 0.12], abs=TOL)


# Each dispersion factor at delta = 1 (its 3-sigma) against the nominal, on the flow where its
# effect is defined. Expected (F, M) written out by hand; every other component must not change.
CASES = {
    # C_A (1 + 0.1): F_x = -15 * 0.8 * 1.1 = -13.2 N at alpha_T = 0
    "CA_mult": ([5, 0, 0], (0, 0, 0), ([-13.2, 0, 0], [0, 0, 0])),
    # adders at alpha_T = 0 give the stated body coefficient: C_N,body = 0.01 -> F_z = -0.15 N
    "CN_add": ([5, 0, 0], (0, 0, 0), ([-12.0, 0, -0.15], [0, 0, 0])),
    # C_Y,body = 0.02 -> F_y = +0.3 N
    "CY_add": ([5, 0, 0], (0, 0, 0), ([-12.0, 0.3, 0], [0, 0, 0])),
    # C_m,body = 0.004 -> M_y = 15 * 0.004 = 0.06 N m
    "Cm_add": ([5, 0, 0], (0, 0, 0), ([-12.0, 0, 0], [0, 0.06, 0])),
    # C_n,body = 0.005 -> M_z = 0.075 N m
    "Cn_add": ([5, 0, 0], (0, 0, 0), ([-12.0, 0, 0], [0, 0, 0.075])),
    # C_l = 0.0002 -> M_x = 0.003 N m
    "Cl_add": ([5, 0, 0], (0, 0, 0), ([-12.0, 0, 0], [0.003, 0, 0])),
    # C_N/C_Y multiplier 1.2 at alpha = 36.87 deg: F_z = -4.5 * 1.2 = -5.4 N; moments unchanged
    "CNY_mult": ([4, 0, 3], (0, 0, 0), ([-12.54, 0, -5.4], [0, -0.9, 0])),
    # C_m/C_n multiplier 1.3: M_y = -0.9 * 1.3 = -1.17 N m; forces unchanged
    "Cmn_mult": ([4, 0, 3], (0, 0, 0), ([-12.54, 0, -4.5], [0, -1.17, 0])),
    # C_mq (1 + 0.5) = -0.3 with q = 0.5, r = -0.4: M = 1.5 * (-0.3) * (q, r) = (-0.225, 0.18)
    "Cmq_mult": ([5, 0, 0], (0, 0.5, -0.4), ([-12.0, 0, 0], [0, -0.225, 0.18])),
}


@pytest.mark.parametrize("name", list(CASES))
def test_dispersion_factor(name):
    v, w, (f_exp, m_exp) = CASES[name]
    f, m = fm(v, omega=w, disp=one(name))
    assert f == pytest.approx(f_exp, abs=TOL)
    assert m == pytest.approx(m_exp, abs=TOL)
    # and a negative factor moves the same components the other way by the same amount
    f0, m0 = fm(v, omega=w)
    fn, mn = fm(v, omega=w, disp=one(name, -1.0))
    assert fn - f0 == pytest.approx(-(f - f0), abs=TOL)
    assert mn - m0 == pytest.approx(-(m - m0), abs=TOL)
    assert np.any(np.abs(np.r_[f - f0, m - m0]) > 1e-3)  # the factor does something


def test_multipliers_act_on_yaw_plane_too():
    # sideslip (4, 3, 0): C_N/C_Y mult scales F_y = -4.5 -> -5.4; C_m/C_n mult scales M_z 0.9 -> 1.17
    f, _ = fm([4, 3, 0], disp=one("CNY_mult"))
    assert f[1] == pytest.approx(-5.4, abs=TOL)
    _, m = fm([4, 3, 0], disp=one("Cmn_mult"))
    assert m[2] == pytest.approx(1.17, abs=TOL)


# Zephyr vanes (DAVINCI Table 4): K = 18, R = 0.696 m, S_k = 3995.8 mm^2, alpha_k = 11 deg, C_La = 2 pi / 5
VANES = SpinVanes(count=18, radius_m=0.696, area_m2=3995.8e-6, incidence_deg=11.0)


def test_vane_roll_moment_and_equilibrium():
    # p = 0, qbar = 1000 Pa: M = 18 * 1000 * 0.1919862 rad * 1.2566371 * 3.9958e-3 * 0.696
    #                          = 12.0772 N m (0.1919862 = 11 deg in rad)
    m0 = float(VANES.roll_moment(1000.0, 40.0, 0.0, 1.0))
    assert m0 == pytest.approx(12.0772, rel=1e-4)
    # p_eq = V tan(11 deg) / R = 40 * 0.1943803 / 0.696 = 11.1713 rad/s
    p_eq = VANES.equilibrium_roll_rate(40.0)
    assert p_eq == pytest.approx(11.1713, rel=1e-4)
    assert float(VANES.roll_moment(1000.0, 40.0, p_eq, 1.0)) == pytest.approx(0.0, abs=1e-12)
    assert float(VANES.roll_moment(1000.0, 40.0, 1.5 * p_eq, 1.0)) < 0  # spinning too fast brakes


def test_vane_lift_slope_dispersion_through_aero():
    # CLa_mult = 1 with U = 0.6 scales the vane moment by 1.6; V = 5, qbar = 12.5, p = 0:
    # vane M_x = 18 * 12.5 * 0.1919862 * 1.2566371 * 3.9958e-3 * 0.696 = 0.150965 N m
    db = AeroDatabase("vanes", AnalyticCoefficients(CA0=0.8), SIZES, vanes=VANES)
    _, m0 = fm([5, 0, 0], db=db)
    _, m1 = fm([5, 0, 0], db=db, disp=one("CLa_mult"))
    assert m0[0] == pytest.approx(0.150965, rel=1e-4)
    assert m1[0] == pytest.approx(1.6 * m0[0], rel=1e-12)
