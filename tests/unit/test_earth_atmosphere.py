"""WGS-84 gravity, Coriolis sign, and the sounding atmosphere (docs/design.md: Gravity and
Earth rotation; Atmosphere)."""

from __future__ import annotations

import math

import casadi as ca
import numpy as np
import pytest

from casrecon.io.sounding import read_sounding
from casrecon.physics.atmosphere import EXTENSION_M, GAMMA_AIR, R_AIR, Atmosphere, AtmosphereCorrections
from casrecon.physics.earth import EARTH_RATE, coriolis_acceleration, earth_rate_ned, normal_gravity


def test_normal_gravity_reference_values():
    # WGS-84 (NIMA TR8350.2): equator 9.7803253359, pole 9.8321849378 m/s^2.
    assert normal_gravity(0.0, 0.0) == pytest.approx(9.7803253359, abs=1e-10)
    assert normal_gravity(math.pi / 2, 0.0) == pytest.approx(9.8321849378, abs=1e-9)
    # 45 deg from Somigliana's closed form with a = 6378137, b = 6356752.3142 m, worked out by hand:
    # (a ge cos^2 + b gp sin^2) / sqrt(a^2 cos^2 + b^2 sin^2) = 9.8061977693 m/s^2.
    # (The often-quoted 9.80619920 is the truncated 1980 series formula, 1.4e-6 higher.)
    g45 = normal_gravity(math.radians(45.0), 0.0)
    assert g45 == pytest.approx(9.8061977693, abs=1e-9)
    assert g45 == pytest.approx(9.80619920, abs=2e-6)


def test_free_air_gradient():
    # dg/dh = -2 g / a (1 + f + m - 2 f sin^2 lat) = -3.0855e-6 /s^2 per m at 45 deg
    # (the textbook 3.086e-6); checked over 1 km where the h^2 term adds only 0.15 %.
    lat = math.radians(45.0)
    grad = (normal_gravity(lat, 0.0) - normal_gravity(lat, 1000.0)) / 1000.0
    assert grad == pytest.approx(3.086e-6, rel=2e-3)


def test_earth_rate_in_ned():
    # Omega_NED = Omega (cos lat, 0, -sin lat): up-pointing component in the northern hemisphere
    w = np.asarray(earth_rate_ned(math.radians(30.0)), float).ravel()
    assert w == pytest.approx([EARTH_RATE * math.sqrt(3) / 2, 0.0, -EARTH_RATE / 2], rel=1e-12)


def test_coriolis_deflects_to_the_right_in_the_north():
    lat = math.radians(45.0)
    s = math.sin(lat)
    # southward 10 m/s: Omega x v = (0, Omega_d v_n, 0) = (0, (-Omega s)(-10), 0); a = -2 Omega x v
    # = (0, -20 Omega s, 0) = (0, -1.03126e-3, 0): westward, i.e. to the right of a south-going body
    a = np.asarray(coriolis_acceleration(lat, np.array([-10.0, 0.0, 0.0])), float).ravel()
    assert a == pytest.approx([0.0, -20 * EARTH_RATE * s, 0.0], rel=1e-12)
    assert a[1] == pytest.approx(-1.03126e-3, rel=1e-5)
    # falling at 10 m/s: a = (0, 2 Omega cos(lat) v_d, 0), eastward
    a = np.asarray(coriolis_acceleration(lat, np.array([0.0, 0.0, 10.0])), float).ravel()
    assert a == pytest.approx([0.0, 20 * EARTH_RATE * math.cos(lat), 0.0], rel=1e-12)


# A 3-level sounding: 1000, 2000, 3000 m MSL
H = [1000.0, 2000.0, 3000.0]
P = [100000.0, 90000.0, 80000.0]
T = [288.15, 281.65, 275.15]


def test_density_from_ideal_gas_when_absent():
    atm = Atmosphere(H, P, T, [0, 0, 0], [0, 0, 0])
    # rho = p / (R T) = 100000 / (287.05287 * 288.15) = 1.2089810 kg/m^3 at a level (the spline
    # interpolates its knots, so a level is reproduced to rounding)
    s = atm.at(1000.0)
    assert float(s.density) == pytest.approx(1.2089810, rel=1e-7)
    assert float(s.density) == pytest.approx(100000 / (R_AIR * 288.15), rel=1e-12)
    assert float(s.sound_speed) == pytest.approx(math.sqrt(GAMMA_AIR * R_AIR * 288.15), rel=1e-12)
    # a measured density column is used as given
    atm2 = Atmosphere(H, P, T, [0, 0, 0], [0, 0, 0], density_kgm3=[1.1, 1.0, 0.9])
    assert float(atm2.at(2000.0).density) == pytest.approx(1.0, rel=1e-12)


def test_wind_from_direction_through_plain_csv(tmp_path):
    # wind from the west (270 deg) at 10 m/s blows east; from the north (0 deg) at 4 m/s blows south
    f = tmp_path / "s.csv"
    f.write_text("altitude_msl_m,pressure_pa,temperature_k,wind_dir_deg,wind_speed_mps\n"
                 "1000,100000,288.15,270,10\n2000,90000,281.65,270,10\n"
                 "3000,80000,275.15,0,4\n4000,70000,268.65,0,4\n")
    atm = Atmosphere.from_sounding(read_sounding(f))
    assert np.asarray(atm.at(1000.0).wind_ned, float).ravel() == pytest.approx([0.0, 10.0, 0.0], abs=1e-9)
    assert np.asarray(atm.at(4000.0).wind_ned, float).ravel() == pytest.approx([-4.0, 0.0, 0.0], abs=1e-9)


def test_corrections_applied():
    atm = Atmosphere(H, P, T, [1.0, 2.0, 3.0], [-1.0, -2.0, -3.0], gradient_ref_alt_msl_m=1000.0)
    base = atm.at(2000.0)
    corr = AtmosphereCorrections(wind_bias_n=1.5, wind_bias_e=-0.5, density_factor=0.02,
                                 wind_gradient_n=1e-3, wind_gradient_e=-2e-3)
    s = atm.at(2000.0, corr)
    # wind = level + bias + gradient * (2000 - 1000): n = 2 + 1.5 + 1.0 = 4.5, e = -2 - 0.5 - 2.0 = -4.5
    assert np.asarray(s.wind_ned, float).ravel() == pytest.approx([4.5, -4.5, 0.0], abs=1e-9)
    assert float(s.density) == pytest.approx(1.02 * float(base.density), rel=1e-12)
    assert float(s.pressure) == pytest.approx(float(base.pressure), rel=1e-12)  # only density scales


def test_continued_smoothly_beyond_the_sounding():
    """Beyond its end levels each quantity continues by its spline's second-order Taylor polynomial
    (continuous first and second derivatives across the end level, where a drop's last nodes
    cross the lowest level) for EXTENSION_M, and is held beyond; inside, the spline is unchanged."""
    atm = Atmosphere(H, P, T, [1.0, 2.0, 3.0], [0.0, 0.0, 5.0])
    h = ca.SX.sym("h")
    s = atm.at(h)
    f = ca.Function("f", [h], [ca.vertcat(ca.log(s.density), ca.log(s.pressure), s.temperature, s.wind_ned[:2])])
    d1 = ca.Function("d1", [h], [ca.jacobian(f(h), h)])
    d2 = ca.Function("d2", [h], [ca.jacobian(ca.jacobian(f(h), h), h)])
    for end in (1000.0, 3000.0):
        for derivative in (d1, d2):
            below, above = np.asarray(derivative(end - 1e-7)).ravel(), np.asarray(derivative(end + 1e-7)).ravel()
            assert below == pytest.approx(above, rel=1e-5, abs=1e-9)   # no kink at the end level
    low, below = np.asarray(f(1000.0)).ravel(), np.asarray(f(1000.0 - 50.0)).ravel()
    slope = np.log(P[1] / P[0]) / (H[1] - H[0])
    assert below[1] - low[1] == pytest.approx(-50.0 * slope, rel=0.05)      # log pressure continued
    for far in (300.0, 5000.0):                                             # held beyond the continuation
        assert np.asarray(f(1000.0 - far)).ravel() == pytest.approx(np.asarray(f(1000.0 - EXTENSION_M)).ravel())
        assert np.asarray(f(3000.0 + far)).ravel() == pytest.approx(np.asarray(f(3000.0 + EXTENSION_M)).ravel())
    assert float(atm.at(1000.0).pressure) > float(atm.at(1500.0).pressure) > float(atm.at(2000.0).pressure)


def test_rejects_unordered_levels():
    with pytest.raises(ValueError, match="strictly increasing"):
        Atmosphere([1000.0, 900.0], [1e5, 9e4], [288, 287], [0, 0], [0, 0])
