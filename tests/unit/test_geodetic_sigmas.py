"""Issue 52: the sigmas of latitude, longitude and h_MSL from those of the NED positions, and the
kinematic parameters in degrees like every other kind's."""

from __future__ import annotations

import types

import numpy as np
import pymap3d
import pytest

from casrecon.estimation.sixdof.parameters import ParameterSet, ParameterSpec
from casrecon.io.gps_rules import geodetic_sigmas, ned_to_geodetic
from casrecon.output.columns import geodetic_columns
from casrecon.output.kinematic_results import parameters_document
from casrecon.physics.dynamics import Site


@pytest.mark.parametrize("lat0", [0.0, 41.8, -67.5])
def test_geodetic_sigmas_are_the_geodetic_change_of_a_one_sigma_ned_step(lat0):
    # a 1 m step north, east or down, converted exactly by pymap3d, moves latitude, longitude and
    # height by the sigmas of a 1 m sigma (first order: the step is 1e-7 of the Earth radius)
    site = Site(lat_deg=lat0, lon_deg=-87.6, ground_alt_msl_m=180.0)
    pos = np.array([[300.0, -500.0, -3000.0], [-2000.0, 1500.0, -800.0]])
    lat, lon, h = ned_to_geodetic(pos, site)
    sig = np.array([[2.0, 3.0, 5.0], [0.5, 0.25, 7.0]])
    s_lat, s_lon, s_h = geodetic_sigmas(lat, h, sig)
    for axis, got, index in ((0, s_lat, 0), (1, s_lon, 1), (2, s_h, 2)):
        step = np.zeros_like(pos)
        step[:, axis] = sig[:, axis]
        moved = np.column_stack(pymap3d.ned2geodetic(*(pos + step).T, site.lat_deg, site.lon_deg,
                                                     site.ground_alt_msl_m))
        change = np.abs(moved[:, index] - np.column_stack([lat, lon, h])[:, index])
        # the NED frame is the site's, not the point's: its axes differ by distance / radius (5e-4)
        np.testing.assert_allclose(got, change, rtol=2e-3)
    # at 41.8 deg 1 m north is 1/111 km of latitude, 1 m east 1/(83 km) of longitude
    if lat0 == 41.8:
        assert s_lat[0] == pytest.approx(2.0 / 111_080.0, rel=1e-3)
        assert s_lon[0] == pytest.approx(3.0 / 83_000.0, rel=5e-3)


def test_geodetic_columns_interleave_values_and_three_sigmas():
    site = Site(lat_deg=41.8, lon_deg=-87.6, ground_alt_msl_m=180.0)
    pos, three = np.array([[10.0, 20.0, -30.0]]), np.array([[3.0, 6.0, 9.0]])
    cols = geodetic_columns(pos, three, site)
    assert list(cols) == ["latitude_deg", "latitude_deg_3sigma", "longitude_deg", "longitude_deg_3sigma",
                          "h_msl_m", "h_msl_m_3sigma"]
    assert cols["h_msl_m_3sigma"][0] == 9.0 and cols["h_msl_m"][0] == pytest.approx(210.0, abs=1e-3)
    assert cols["latitude_deg_3sigma"][0] == pytest.approx(geodetic_sigmas([41.8], [210.0], three)[0][0], rel=1e-6)


def test_kinematic_parameters_leave_in_degrees():
    # the estimator's SI values (rad/s, rad) leave in deg/s and deg, sigmas and priors alike
    specs = (ParameterSpec("gyro_bias_x", "imu", 1e-3, 2e-3, "rad/s"),
             ParameterSpec("accel_bias_x", "imu", 0.05, 0.05, "m/s^2"),
             ParameterSpec("gyro_misalignment_xy", "imu", 1e-3, 1e-3, "rad"))
    result = types.SimpleNamespace(params=ParameterSet(specs), values=np.array([1e-3, 0.02, -2e-3]),
                                   sigma=np.array([1e-4, 0.01, 5e-4]), reduced_chi2=4.0,
                                   parameter_covariance=np.diag([1e-8, 1e-4, 2.5e-7]))
    doc = parameters_document(result)["parameters"]
    gyro = doc["gyro_bias_x"]
    assert gyro["unit"] == "deg/s" and gyro["value"] == pytest.approx(np.degrees(1e-3))
    assert gyro["sigma"] == pytest.approx(np.degrees(1e-4)) and gyro["three_sigma"] == pytest.approx(np.degrees(3e-4))
    assert gyro["prior_sigma"] == pytest.approx(np.degrees(2e-3))
    assert gyro["sigma_chi2_scaled"] == pytest.approx(2 * np.degrees(1e-4))
    assert doc["gyro_misalignment_xy"]["unit"] == "deg"
    assert doc["gyro_misalignment_xy"]["value"] == pytest.approx(np.degrees(-2e-3))
    assert doc["accel_bias_x"] == {**doc["accel_bias_x"], "unit": "m/s^2", "value": 0.02, "sigma": 0.01}
