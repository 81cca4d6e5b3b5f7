"""The 6-DOF equations of motion as CasADi functions shared by simulator and estimator
(docs/design.md: Equations of motion).

State x (13): NED position of the centre of mass relative to the site's ground reference point (m),
NED velocity (m/s), quaternion body to NED (scalar first), body angular rate (rad/s).

Model parameters p (:data:`PARAMETER_NAMES`): the aero dispersion factors, then the atmosphere
corrections (wind bias north/east m/s, density factor, wind gradient north/east 1/s) and the rotor
downwash below the helicopter (m/s, downwards, decaying as exp(-distance fallen / length)).

Disturbance d (9, :data:`DISTURBANCE_NAMES`, zero unless given): a time-varying wind perturbation
(gust, NED, m/s) added to the sounding's wind, and model-error force (body axes, N) and moment
(about the centre of mass, body axes, N m) added to the aerodynamic ones. The simulator takes a
Gauss-Markov realisation of it; the fit can estimate it at the nodes (weak-constraint option).

    m dv/dt = C_nb F_b + m g - 2 m Omega x v
    I dw/dt = M_cm - w x (I w)
    dq/dt   = q (x) (0, w) / 2
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import casadi as ca
import numpy as np

from casrecon.physics.aero import DISPERSION_NAMES, AeroDatabase, aero_force_moment, flow_angles
from casrecon.physics.atmosphere import Atmosphere, AtmosphereCorrections
from casrecon.physics.earth import coriolis_acceleration, normal_gravity
from casrecon.physics.rotations import dcm_body_to_ned, euler_from_quat, quat_derivative
from casrecon.physics.sensors import gps_antenna_ned, imu_angular_rate, imu_specific_force
from casrecon.physics.vehicle import Vehicle

STATE_NAMES = ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d", "q0", "q1", "q2", "q3",
               "omega_x", "omega_y", "omega_z")
ATMOSPHERE_PARAMETER_NAMES = ("wind_bias_n", "wind_bias_e", "density_factor",
                              "wind_gradient_n", "wind_gradient_e", "downwash_mps", "sounding_shift_m")
PARAMETER_NAMES = DISPERSION_NAMES + ATMOSPHERE_PARAMETER_NAMES
#: Entries of the disturbance input: gust wind (NED, m/s), model-error force (body, N) and moment (body, N m).
DISTURBANCE_NAMES = ("gust_n", "gust_e", "gust_d", "force_x", "force_y", "force_z",
                     "moment_x", "moment_y", "moment_z")
#: Names of the rows of :meth:`FlightModel.outputs`.
OUTPUT_NAMES = ("h_agl", "roll", "pitch", "yaw", "alpha", "beta", "alpha_t", "qbar", "mach",
                "airspeed", "imu_fx", "imu_fy", "imu_fz", "gyro_x", "gyro_y", "gyro_z",
                "gps_n", "gps_e", "gps_d", "gps_vn", "gps_ve", "gps_vd")


@dataclass(frozen=True)
class Site:
    """The local NED frame's origin: geodetic latitude/longitude (deg) and ground altitude (m MSL)."""

    lat_deg: float
    lon_deg: float
    ground_alt_msl_m: float


@dataclass(frozen=True)
class DynamicsOptions:
    """Switches of the equations of motion.

    Parameters
    ----------
    gravity : {"wgs84", "constant", "off"}
        WGS-84 normal gravity with free-air height change; its value at the ground, constant; none.
    earth_rotation : bool
        Coriolis acceleration from the Earth's rate at the site latitude.
    aerodynamics : bool
        Aerodynamic force and moment.
    downwash_length_m : float
        e-folding distance, fallen below the release altitude, of the rotor-downwash hypothesis:
        vertical wind downwash_mps * exp(-(h_release - h) / downwash_length_m).
    """

    gravity: str = "wgs84"
    earth_rotation: bool = True
    aerodynamics: bool = True
    downwash_length_m: float = 30.0

    def __post_init__(self) -> None:
        if self.gravity not in ("wgs84", "constant", "off"):
            raise ValueError(f"gravity must be 'wgs84', 'constant' or 'off', not {self.gravity!r}")


def gravity_vector(site: Site, options: DynamicsOptions, alt_msl_m):
    """Gravity in NED (m/s^2) at altitude ``alt_msl_m`` per :class:`DynamicsOptions`."""
    if options.gravity == "off":
        return ca.DM.zeros(3)
    h = site.ground_alt_msl_m if options.gravity == "constant" else alt_msl_m
    return ca.vertcat(0, 0, normal_gravity(math.radians(site.lat_deg), h))


def default_parameters(**values: float) -> np.ndarray:
    """Parameter vector with every entry zero except the named ones."""
    p = np.zeros(len(PARAMETER_NAMES))
    for name, value in values.items():
        p[PARAMETER_NAMES.index(name)] = value
    return p


class FlightModel:
    """A vehicle flying through an atmosphere: builds the CasADi right-hand side and outputs.

    Attributes
    ----------
    rhs : casadi.Function
        ``rhs(x[13], p[np]) -> xdot[13]``.
    rhs_d : casadi.Function
        ``rhs_d(x, p, d[9]) -> xdot`` with the disturbance input d (:data:`DISTURBANCE_NAMES`).
    outputs_d : casadi.Function
        ``outputs_d(x, p, d) -> y``.
    outputs : casadi.Function
        ``outputs(x, p) -> y[len(OUTPUT_NAMES)]``: altitude AGL (m), Euler angles, flow angles (rad),
        qbar (Pa), Mach, airspeed (m/s), noise-free IMU specific force (m/s^2) and rate (rad/s) in
        IMU axes, GPS antenna NED position (m) and velocity (m/s).
    """

    def __init__(self, vehicle: Vehicle, aero: AeroDatabase, atmosphere: Atmosphere, site: Site,
                 options: DynamicsOptions = DynamicsOptions(), release_alt_msl_m: float | None = None) -> None:
        self.vehicle, self.aero, self.atmosphere = vehicle, aero, atmosphere
        self.site, self.options = site, options
        self.release_alt_msl_m = release_alt_msl_m
        self._inertia = ca.DM(np.asarray(vehicle.inertia_kgm2))
        self._inertia_inv = ca.DM(np.linalg.inv(np.asarray(vehicle.inertia_kgm2)))
        x = ca.SX.sym("x", len(STATE_NAMES))
        p = ca.SX.sym("p", len(PARAMETER_NAMES))
        d = ca.SX.sym("d", len(DISTURBANCE_NAMES))
        terms = self.terms(x, p, d)
        self.rhs_d = ca.Function("rhs_d", [x, p, d], [terms["xdot"]], ["x", "p", "d"], ["xdot"])
        self.outputs_d = ca.Function("outputs_d", [x, p, d], [self._outputs(x, terms)], ["x", "p", "d"], ["y"])
        zero = ca.DM.zeros(len(DISTURBANCE_NAMES))
        self.rhs = ca.Function("rhs", [x, p], [self.rhs_d(x, p, zero)], ["x", "p"], ["xdot"])
        self.outputs = ca.Function("outputs", [x, p], [self.outputs_d(x, p, zero)], ["x", "p"], ["y"])

    @property
    def n_states(self) -> int:
        return len(STATE_NAMES)

    @property
    def n_params(self) -> int:
        return len(PARAMETER_NAMES)

    def altitude_msl(self, x):
        """Altitude above mean sea level (m) of state ``x``."""
        return self.site.ground_alt_msl_m - x[2]

    def downwash(self, x, magnitude):
        """Vertical (down) wind of the rotor-downwash hypothesis at state ``x``, m/s."""
        if self.release_alt_msl_m is None:
            return 0
        fallen = ca.fmax(self.release_alt_msl_m - self.altitude_msl(x), 0)
        return magnitude * ca.exp(-fallen / self.options.downwash_length_m)

    def gravity_ned(self, x):
        """Gravity vector in NED, m/s^2, per :class:`DynamicsOptions`."""
        return gravity_vector(self.site, self.options, self.altitude_msl(x))

    def acceleration_ned(self, x, specific_force_ned=0):
        """NED acceleration (m/s^2) at state ``x`` of a body that feels ``specific_force_ned``
        (m/s^2, NED; 0: no force but gravity): that, gravity (:meth:`gravity_ned`) and, with
        ``earth_rotation``, the Coriolis term, summed in that order (the simulator's bytes)."""
        accel = specific_force_ned + self.gravity_ned(x)
        if self.options.earth_rotation:
            accel = accel + coriolis_acceleration(math.radians(self.site.lat_deg), x[3:6])
        return accel

    def terms(self, x, p, d=None) -> dict:
        """Every intermediate of the equations of motion, for ``x``, ``p`` and the disturbance
        ``d`` (CasADi; ``d`` None is no disturbance)."""
        v_ned, q, w = x[3:6], x[6:10], x[10:13]
        corr = AtmosphereCorrections(*[p[len(DISPERSION_NAMES) + i] for i in range(5)],
                                     altitude_shift_m=p[PARAMETER_NAMES.index("sounding_shift_m")])
        air = self.atmosphere.at(self.altitude_msl(x), corr)
        downwash = self.downwash(x, p[PARAMETER_NAMES.index("downwash_mps")])
        gust = ca.vertcat(0, 0, downwash) if d is None else d[0:3] + ca.vertcat(0, 0, downwash)
        air = replace(air, wind_ned=air.wind_ned + gust)
        c_nb = dcm_body_to_ned(q)
        v_air_body = c_nb.T @ (v_ned - air.wind_ned)
        veh = self.vehicle
        if self.options.aerodynamics:
            force, moment = aero_force_moment(
                self.aero, v_air_body, w, air.density, air.sound_speed, p[:len(DISPERSION_NAMES)],
                veh.ref_area_m2, veh.ref_length_m, ca.DM(veh.lever(veh.mrp_m)))
        else:
            force, moment = ca.DM.zeros(3), ca.DM.zeros(3)
        if d is not None:
            force, moment = force + d[3:6], moment + d[6:9]
        accel = self.acceleration_ned(x, c_nb @ force / veh.mass_kg)
        w_dot = self._inertia_inv @ (moment - ca.cross(w, self._inertia @ w))
        xdot = ca.vertcat(v_ned, accel, quat_derivative(q, w), w_dot)
        return {"xdot": xdot, "force_body": force, "moment_cm": moment, "omega_dot": w_dot,
                "v_air_body": v_air_body, "air": air}

    def _outputs(self, x, t: dict):
        fl = flow_angles(t["v_air_body"])
        qbar = 0.5 * t["air"].density * fl.speed**2
        gps_p, gps_v = gps_antenna_ned(self.vehicle, x[0:3], x[3:6], x[6:10], x[10:13])
        return ca.vertcat(
            -x[2], euler_from_quat(x[6:10]), fl.alpha, fl.beta, fl.alpha_t, qbar,
            fl.speed / t["air"].sound_speed, fl.speed,
            imu_specific_force(self.vehicle, t["force_body"], x[10:13], t["omega_dot"]),
            imu_angular_rate(self.vehicle, x[10:13]), gps_p, gps_v)
