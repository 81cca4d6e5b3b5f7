"""Point-mass (3-DOF) model for a body that carried only a GPS: a skydiver, a capsule without IMU.

State x (6): NED position (m) and velocity (m/s) of the antenna. Drag acts against the
air-relative velocity with a drag area CdA (m^2); optional horizontal lift areas (A_N, A_E) give a
force 1/2 rho |v_a|^2 A along north and east (fixed directions, so the model stays smooth when the
body falls straight down, where any direction "across the flow" would be undefined):

    m dv/dt = 1/2 rho |v_a| (-v_a CdA + |v_a| (A_N n + A_E e)) + m g - 2 m Omega x v,  v_a = v - w

Gravity, Coriolis and the atmosphere are those of the 6-DOF model (shared functions).
"""

from __future__ import annotations

import math

import casadi as ca

from casrecon.physics.atmosphere import Atmosphere, AtmosphereCorrections
from casrecon.physics.dynamics import DynamicsOptions, Site, gravity_vector
from casrecon.physics.earth import coriolis_acceleration

DEFAULT_OPTIONS = DynamicsOptions()
"""Default dynamics options (a frozen dataclass, so one shared instance is safe)."""

POINT_MASS_STATES = ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")


class PointMassModel:
    """Drag-only point mass of ``mass_kg`` in an :class:`Atmosphere` over a :class:`Site`.

    Attributes
    ----------
    rhs : casadi.Function
        ``rhs(x[6], area[3], wind_bias[2]) -> xdot[6]`` with area = (CdA, A_N, A_E) in m^2
        and the wind bias (north, east) in m/s.
    """

    def __init__(self, atmosphere: Atmosphere, site: Site, mass_kg: float,
                 options: DynamicsOptions = DEFAULT_OPTIONS) -> None:
        self.atmosphere, self.site, self.mass_kg, self.options = atmosphere, site, float(mass_kg), options
        x, area, wb = ca.SX.sym("x", 6), ca.SX.sym("area", 3), ca.SX.sym("wb", 2)
        self.rhs = ca.Function("point_mass_rhs", [x, area, wb], [self.derivative(x, area, wb)])

    def altitude_msl(self, x):
        return self.site.ground_alt_msl_m - x[2]

    def derivative(self, x, area, wind_bias):
        """State derivative (SX/MX/DM) for areas (CdA, A_N, A_E) in m^2 and wind bias (m/s)."""
        air = self.atmosphere.at(self.altitude_msl(x), AtmosphereCorrections(wind_bias[0], wind_bias[1]))
        v = x[3:6]
        v_air = v - air.wind_ned
        speed = ca.sqrt(ca.sumsqr(v_air) + 1e-6)
        force = -v_air * area[0] + speed * ca.vertcat(area[1], area[2], 0)
        accel = 0.5 * air.density * speed * force / self.mass_kg
        accel += gravity_vector(self.site, self.options, self.altitude_msl(x))
        if self.options.earth_rotation:
            accel += coriolis_acceleration(math.radians(self.site.lat_deg), v)
        return ca.vertcat(v, accel)
