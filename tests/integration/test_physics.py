"""Whole-model checks of the 6-DOF equations and the RK4 simulator against closed forms and
conservation laws (docs/design.md: Equations of motion)."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import PROBLEMS, UTTR, simple_vehicle, still_air

from casrecon.io.vehicle_files import load_aero, load_vehicle
from casrecon.physics.aero import AeroDatabase, AnalyticCoefficients, DispersionSizes
from casrecon.physics.dynamics import DynamicsOptions, FlightModel, default_parameters
from casrecon.physics.earth import EARTH_RATE, normal_gravity
from casrecon.physics.rotations import dcm_body_to_ned, euler_deg_to_quat
from casrecon.simulation.simulate import Simulator

DRAG = AeroDatabase("drag", AnalyticCoefficients(CA0=0.8, CA2=0.1, CNa=0.5, Cma=-0.1, Cmq0=-0.2),
                    DispersionSizes())
NO_AERO = DynamicsOptions(gravity="constant", earth_rotation=False, aerodynamics=False)


def state(pos, vel, q, w) -> np.ndarray:
    return np.concatenate([pos, vel, q, w]).astype(float)


def test_vacuum_fall_is_a_parabola():
    # aero and Coriolis off, constant g: z(t) = z0 + v0 t + g t^2 / 2 and horizontal motion uniform.
    # RK4 integrates a quadratic exactly, so only rounding remains: 1e-8 m over 20 s (5000 steps of
    # ~1e-13 m rounding each) is a tolerance with ample headroom, and far below any modelling error.
    model = FlightModel(simple_vehicle(), DRAG, still_air(), UTTR, NO_AERO)
    x0 = state([5.0, -3.0, -3000.0], [2.0, -1.0, -4.0], euler_deg_to_quat([10, -60, 30]), [0.1, 0.2, -0.3])
    traj = Simulator(model, dt_s=0.004, chunk=500).run(x0, default_parameters(), t_max_s=20.0)
    g = normal_gravity(math.radians(UTTR.lat_deg), UTTR.ground_alt_msl_m)
    t = traj.time_s
    assert not traj.impacted and t[-1] >= 20.0  # runs in whole chunks, so may pass t_max
    assert traj.state("pos_d") == pytest.approx(-3000.0 - 4.0 * t + 0.5 * g * t**2, abs=1e-8)
    assert traj.state("vel_d") == pytest.approx(-4.0 + g * t, abs=1e-9)
    assert traj.state("pos_n") == pytest.approx(5.0 + 2.0 * t, abs=1e-8)
    assert traj.state("pos_e") == pytest.approx(-3.0 - 1.0 * t, abs=1e-8)
    # gravity is not sensed: the IMU (at the CM) reads zero in free fall
    assert np.abs(traj.outputs[:, 10:13]).max() < 1e-12


def test_aligned_fall_in_still_air_does_not_rotate():
    # Nose straight down (q = (cos 45, 0, -sin 45, 0): pitch -90 deg), velocity along the nose,
    # no rates, no wind, no Coriolis, axisymmetric body with CM and MRP on the axis: alpha_T = 0
    # for ever, so no moment and no rotation. The only seed of rotation is rounding in C_bn v
    # (~1e-15 m/s of crossflow), hence the 1e-9 rad/s bound.
    veh = simple_vehicle(cm_m=(-0.25, 0.0, 0.0), mrp_m=(-0.27, 0.0, 0.0))
    opts = DynamicsOptions(gravity="wgs84", earth_rotation=False, aerodynamics=True)
    model = FlightModel(veh, DRAG, still_air(), UTTR, opts)
    q0 = np.array([math.cos(math.pi / 4), 0.0, -math.sin(math.pi / 4), 0.0])
    x0 = state([0, 0, -800.0], [0, 0, 5.0], q0, [0, 0, 0])
    traj = Simulator(model, dt_s=0.01, chunk=500).run(x0, default_parameters(), t_max_s=60.0)
    assert traj.impacted
    assert np.abs(traj.states[:, 10:13]).max() < 1e-9
    assert np.abs(traj.states[:, 6:10] - q0).max() < 1e-9
    assert np.abs(traj.states[:, [0, 1, 3, 4]]).max() < 1e-9  # falls straight down
    # and drag did act: terminal speed sqrt(2 m g / (rho S C_A)) ~ 40 m/s, far from free fall
    assert 30.0 < traj.state("vel_d")[-1] < 50.0


def test_torque_free_tumbling_conserves_momentum_and_energy():
    # Zephyr full inertia tensor (non-zero products), aero and gravity off. In NED the angular
    # momentum H = C_nb I w is constant and so is T = w.I w / 2. Global RK4 error ~ (w h)^4 per
    # unit time: with |w| ~ 2.3 rad/s and h = 2 ms over 10 s, a few 1e-11 relative; 1e-9 allows
    # for rounding. Halving h must not make it worse (it is rounding-dominated at this size).
    veh = load_vehicle(PROBLEMS / "vehicles" / "davinci-ztu.toml")
    inertia = np.asarray(veh.inertia_kgm2)
    assert abs(inertia[0, 1]) > 0.1 and abs(inertia[0, 2]) > 0.1  # products really present
    opts = DynamicsOptions(gravity="off", earth_rotation=False, aerodynamics=False)
    model = FlightModel(veh, DRAG, still_air(), UTTR, opts)
    x0 = state([0, 0, -1000.0], [0, 0, 0], euler_deg_to_quat([20, -50, 70]), [1.5, -1.2, 1.3])
    traj = Simulator(model, dt_s=0.002, chunk=1000).run(x0, default_parameters(), t_max_s=10.0)
    h = np.array([np.asarray(dcm_body_to_ned(x[6:10]), float) @ inertia @ x[10:13] for x in traj.states])
    energy = 0.5 * np.einsum("ij,jk,ik->i", traj.states[:, 10:13], inertia, traj.states[:, 10:13])
    assert np.abs(h - h[0]).max() / np.linalg.norm(h[0]) < 1e-9
    assert np.abs(energy / energy[0] - 1).max() < 1e-9
    # and it really tumbles: the body rates change by order one
    assert np.ptp(traj.states[:, 10:13], axis=0).max() > 0.5


def test_coriolis_deflects_a_vacuum_fall_east():
    # Fall from rest, aero off, constant g, Earth rotation on: to first order in Omega,
    # y_east(t) = (1/3) Omega g t^3 cos(lat). At lat 40.19 deg, g = 9.8005, t = 40 s:
    # (1/3) * 7.292115e-5 * 9.8005 * 64000 * 0.76382 = 11.646 m. Second-order terms are
    # O(Omega t) ~ 3e-3 relative, so 1 % is a check with headroom, not a loosened one.
    opts = DynamicsOptions(gravity="constant", earth_rotation=True, aerodynamics=False)
    model = FlightModel(simple_vehicle(), DRAG, still_air(), UTTR, opts)
    x0 = state([0, 0, -9000.0], [0, 0, 0], euler_deg_to_quat([0, -90, 0]), [0, 0, 0])
    traj = Simulator(model, dt_s=0.01, chunk=1000).run(x0, default_parameters(), t_max_s=40.0)
    g = normal_gravity(math.radians(UTTR.lat_deg), UTTR.ground_alt_msl_m)
    k = int(np.argmin(np.abs(traj.time_s - 40.0)))
    t = traj.time_s[k]
    assert t == pytest.approx(40.0, abs=1e-9)
    expected = EARTH_RATE * g * t**3 * math.cos(math.radians(UTTR.lat_deg)) / 3
    assert expected == pytest.approx(11.646, rel=1e-3)
    assert traj.state("pos_e")[k] == pytest.approx(expected, rel=0.01)
    assert abs(traj.state("pos_n")[k]) < 0.01 * expected  # north-south effect is second order


def test_impact_event_lands_on_the_ground():
    # EES vehicle and aero, short drop from 60 m: the last sample is on the ground to 1e-6 m,
    # after the previous sample and within one output step of it.
    veh = load_vehicle(PROBLEMS / "vehicles" / "ees-test-article.toml")
    aero = load_aero(PROBLEMS / "aero" / "ees-sphere-cone.toml")
    model = FlightModel(veh, aero, still_air(wind_east_mps=3.0), UTTR, DynamicsOptions())
    x0 = state([0, 0, -60.0], [-5.0, 1.0, 0.0], euler_deg_to_quat([0, -80, 0]), [0, 0.2, 0])
    sim = Simulator(model, dt_s=0.01, chunk=100)
    traj = sim.run(x0, default_parameters(), t_max_s=100.0)
    assert traj.impacted
    assert abs(traj.output("h_agl")[-1]) < 1e-6 and abs(traj.state("pos_d")[-1]) < 1e-6
    assert np.all(traj.output("h_agl")[:-1] > 0)
    assert 0 < traj.time_s[-1] - traj.time_s[-2] <= 0.01 + 1e-12
    # a free fall from 60 m takes sqrt(2 * 60 / 9.8) = 3.5 s; drag only lengthens it
    assert 3.4 < traj.flight_time_s < 5.0
