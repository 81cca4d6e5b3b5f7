"""WGS-84 normal gravity and the Earth's rotation in the local NED frame (docs/design.md: Gravity and Earth rotation).

The NED frame is tangent at the reference point (lat0, lon0) on the ground; its down axis is
taken along the local normal gravity, and curvature over a drop's few kilometres is neglected.
"""

from __future__ import annotations

import math

import casadi as ca

#: WGS-84 semi-major axis, m.
WGS84_A = 6378137.0
#: WGS-84 flattening.
WGS84_F = 1.0 / 298.257223563
#: WGS-84 first eccentricity squared.
WGS84_E2 = 6.69437999014e-3
#: Normal gravity at the equator, m/s^2.
WGS84_GAMMA_E = 9.7803253359
#: Somigliana constant k = (b gamma_p) / (a gamma_e) - 1.
WGS84_K = 1.93185265241e-3
#: m = omega^2 a^2 b / GM.
WGS84_M = 3.44978650684e-3
#: Earth rotation rate, rad/s.
EARTH_RATE = 7.292115e-5


def normal_gravity(lat_rad: float, h_m):
    """WGS-84 normal gravity magnitude (m/s^2) at geodetic latitude and height.

    Somigliana's closed formula on the ellipsoid, with the second-order free-air correction in
    height (NIMA TR8350.2 eq. 4-3). Includes the centrifugal part, so no separate centrifugal
    term belongs in the equations of motion.

    Parameters
    ----------
    lat_rad : float
        Geodetic latitude, rad.
    h_m : float or CasADi expression
        Height above the ellipsoid, m (mean sea level is used; the difference is negligible).
    """
    s2 = math.sin(lat_rad) ** 2
    g0 = WGS84_GAMMA_E * (1 + WGS84_K * s2) / math.sqrt(1 - WGS84_E2 * s2)
    c1 = 2.0 / WGS84_A * (1 + WGS84_F + WGS84_M - 2 * WGS84_F * s2)
    return g0 * (1 - c1 * h_m + 3.0 * h_m * h_m / WGS84_A**2)


def earth_rate_ned(lat_rad: float):
    """Earth's angular velocity in NED at latitude ``lat_rad``, rad/s (3-vector)."""
    return ca.DM([EARTH_RATE * math.cos(lat_rad), 0.0, -EARTH_RATE * math.sin(lat_rad)])


def coriolis_acceleration(lat_rad: float, v_ned):
    """Coriolis acceleration ``-2 Omega x v`` in NED, m/s^2, for NED velocity ``v_ned`` (m/s)."""
    return -2 * ca.cross(earth_rate_ned(lat_rad), v_ned)
