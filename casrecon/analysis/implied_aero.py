"""The aerodynamics a kinematic (IMU-driven) reconstruction implies, with 3-sigma bands.

A kinematic fit knows where the vehicle was, how it was oriented and what its IMU measured, but
uses no aerodynamic model. With the vehicle's mass properties and the air it flew through, that is
enough to say which aerodynamic force and moment acted, at which total angle of attack, Mach number
and dynamic pressure:

- the IMU samples corrected by the fitted biases, scale factors and misalignments, smoothed by the
  Savitzky-Golay filter of :mod:`casrecon.analysis.aero_coefficients` (which also gives the angular
  acceleration), turned into body axes and moved to the centre of mass, give the force and the
  moment about the MRP (:func:`~casrecon.analysis.aero_coefficients.imu_force_moment`);
- the fitted IMU position, velocity and attitude, moved to the centre of mass, minus the sounding's
  wind give the air-relative velocity, hence alpha_T, Mach and qbar; the sounding's density gives qbar.

The kinematic fit does not estimate the air: the sounding's constant wind and density errors enter
as unknowns with their prior (:class:`AirPrior`, the ``[atmosphere]`` 3-sigma of the dynamic fit).
Bands by the delta method: the Jacobian of every output with respect to the node's state and the
IMU parameters, times their covariance block from the fit; plus the air prior; plus the IMU noise
through the filter (exact for the linear filter); the three added as independent.

For a vehicle with an aerodynamic database the database's coefficients along the implied flow (no
dispersion; or any dispersion vector given) are computed alongside, for figures and for the
comparison with a dynamic fit (:mod:`casrecon.analysis.kinematic_check`).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.analysis import aero_columns as cols
from casrecon.analysis.aero_coefficients import coefficient_vector, imu_force_moment, smoothed_imu
from casrecon.estimation.kinematic.fit import KinematicResult
from casrecon.estimation.kinematic.terms import KINEMATIC_SCALE, N_STATE
from casrecon.physics.aero import DISPERSION_NAMES, AeroDatabase, aero_force_moment, flow_angles
from casrecon.physics.atmosphere import Atmosphere, AtmosphereCorrections
from casrecon.physics.preintegration import IMU_PARAMETERS, N_IMU_PARAMETERS, imu_gains
from casrecon.physics.rotations import dcm_body_to_ned
from casrecon.physics.vehicle import Vehicle

N_COEF = len(cols.COEFFICIENTS)
#: Rows of the banded outputs: the coefficients, alpha_T (deg), qbar (Pa), Mach.
N_BANDED = N_COEF + 3
N_AIR = 3


@dataclass(frozen=True)
class AirPrior:
    """What is known of the air a kinematic fit did not estimate: the sounding's constant error.

    Attributes
    ----------
    wind_sigma_mps : float
        1-sigma of the constant error of each horizontal wind component, m/s.
    density_sigma : float
        1-sigma of the relative density error (dimensionless).
    """

    wind_sigma_mps: float
    density_sigma: float

    @property
    def covariance(self) -> np.ndarray:
        """Diagonal covariance of (wind_bias_n m/s, wind_bias_e m/s, density_factor)."""
        return np.diag([self.wind_sigma_mps ** 2, self.wind_sigma_mps ** 2, self.density_sigma ** 2])


def node_function(vehicle: Vehicle, atmosphere: Atmosphere, ground_alt_msl_m: float,
                  aero: AeroDatabase | None) -> ca.Function:
    """``(zs[10], theta[24], air[3], s[9], disp[n]) -> (y, J)`` for one node.

    zs: the node's scaled kinematic state (IMU position m NED, velocity m/s, IMU-to-NED quaternion);
    theta: the IMU parameters (:data:`~casrecon.physics.preintegration.IMU_PARAMETERS`, SI); air:
    wind bias north and east (m/s) and density factor; s: smoothed specific force (m/s^2), rate
    (rad/s) and angular acceleration (rad/s^2), IMU axes, as measured; disp: dispersion factors of
    the database. y = [implied coefficients (8); alpha_T deg; qbar Pa; Mach; database coefficients
    (8, NaN-free zeros without a database)]; J = d(first N_BANDED rows of y)/d(zs, theta, air, s).
    """
    zs, theta = ca.SX.sym("zs", N_STATE), ca.SX.sym("theta", N_IMU_PARAMETERS)
    air_p, s = ca.SX.sym("air", N_AIR), ca.SX.sym("s", 9)
    disp = ca.SX.sym("disp", len(DISPERSION_NAMES))
    x = zs * ca.DM(KINEMATIC_SCALE)
    q = x[6:10] / ca.norm_2(x[6:10])
    r_ib = ca.DM(np.asarray(vehicle.imu_to_body, float))
    c_nb = dcm_body_to_ned(q) @ r_ib.T
    gyro_gain, accel_gain = imu_gains(theta)
    f_b = r_ib @ (accel_gain @ s[0:3] - theta[3:6])
    w_b = r_ib @ (gyro_gain @ s[3:6] - theta[0:3])
    wdot_b = r_ib @ (gyro_gain @ s[6:9])
    lever = ca.DM(vehicle.lever(vehicle.imu_position_m))
    p_cm = x[0:3] - c_nb @ lever
    v_cm = x[3:6] - c_nb @ ca.cross(w_b, lever)
    air = atmosphere.at(ground_alt_msl_m - p_cm[2], AtmosphereCorrections(air_p[0], air_p[1], air_p[2]))
    v_air_body = c_nb.T @ (v_cm - air.wind_ned)
    fl = flow_angles(v_air_body)
    qbar = 0.5 * air.density * fl.speed ** 2
    force, moment = imu_force_moment(vehicle, f_b, w_b, wdot_b)
    implied = coefficient_vector(force, moment, qbar, vehicle.ref_area_m2, vehicle.ref_length_m, fl.crossflow_dir)
    banded = ca.vertcat(implied, fl.alpha_t * 180 / np.pi, qbar, fl.speed / air.sound_speed)
    if aero is None:
        database = ca.DM.zeros(N_COEF)
    else:
        f_db, m_db = aero_force_moment(aero, v_air_body, w_b, air.density, air.sound_speed, disp,
                                       vehicle.ref_area_m2, vehicle.ref_length_m, ca.DM.zeros(3))
        database = coefficient_vector(f_db, m_db, qbar, vehicle.ref_area_m2, vehicle.ref_length_m,
                                      fl.crossflow_dir)
    jac = ca.jacobian(banded, ca.vertcat(zs, theta, air_p, s))
    return ca.Function("implied_aero_node", [zs, theta, air_p, s, disp], [ca.vertcat(banded, database), jac])


def imu_parameter_vector(result: KinematicResult) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(theta (24, SI, zero where not estimated), positions in theta of the estimated ones, their z
    columns, their scales (z times scale is SI))."""
    names = list(result.params.names)
    theta = np.zeros(N_IMU_PARAMETERS)
    where, fitted = [], []
    for i, name in enumerate(IMU_PARAMETERS):
        if name in names:
            j = names.index(name)
            theta[i] = result.values[j]
            where.append(i)
            fitted.append(j)
    fitted = np.array(fitted, np.int64)
    return theta, np.array(where, np.int64), result.parameter_columns[fitted], result.params.scales[fitted]


def node_covariances(result: KinematicResult, theta_cols: np.ndarray) -> np.ndarray:
    """(K, 10 + n, 10 + n) covariance of each node's scaled state with the parameters in
    ``theta_cols`` (the fit's covariance blocks, :meth:`GaugeCovariance.blocks`)."""
    sets = [result.state_columns[k] for k in range(result.node_time_s.size)]
    return np.array(result.covariance.blocks(sets, shared=theta_cols))


def implied_aero(result: KinematicResult, vehicle: Vehicle, atmosphere: Atmosphere, air_prior: AirPrior,
                 aero: AeroDatabase | None = None, dispersions: np.ndarray | None = None) -> dict[str, np.ndarray]:
    """The aerodynamics a kinematic reconstruction implies, at its nodes, with 3-sigma bands.

    Parameters
    ----------
    result : KinematicResult
        A converged kinematic fit (IMU states, parameters and their covariance).
    vehicle : Vehicle
        Mass (kg), inertia (kg m^2), centre of mass, IMU mount and position, MRP, reference area
        (m^2) and length (m).
    atmosphere : Atmosphere
        The sounding (or standard atmosphere) the air-relative velocity and qbar are taken from.
    air_prior : AirPrior
        Its constant wind and density errors (1-sigma), carried into the bands.
    aero : AeroDatabase or None
        With a database, its coefficients along the implied flow are returned too (``database``
        columns) with ``dispersions`` (default all 0).

    Returns
    -------
    dict of str to (K,) array
        :func:`implied_columns`: IMU-clock time (s), alpha_T (deg), qbar (Pa), Mach and each with
        its 3-sigma, and per coefficient the implied value and 3-sigma (and the database's value).
        NaN where the IMU filter window holds a saturated sample.
    """
    data, options = result.data, result.options
    k = result.node_time_s.size
    valid = data.accel_valid.all(axis=1) & data.gyro_valid.all(axis=1)
    gyro_sigma, accel_sigma = data.noise_sigmas(options)
    sigma6 = np.r_[np.median(accel_sigma, axis=0), np.median(gyro_sigma, axis=0)]
    s, cov_s = smoothed_imu(data.imu_time_s, data.accel_mps2, data.gyro_radps, valid, result.node_time_s, sigma6)
    theta, where, theta_cols, scale_theta = imu_parameter_vector(result)
    disp = np.zeros(len(DISPERSION_NAMES)) if dispersions is None else np.asarray(dispersions, float)
    fn = node_function(vehicle, atmosphere, options.ground_alt_msl_m, aero).map(k, "thread", 2)
    zs = result.z[result.state_columns].T
    y, jac = fn(zs, np.repeat(theta[:, None], k, axis=1), np.zeros((N_AIR, k)), np.nan_to_num(s).T,
                np.repeat(disp[:, None], k, axis=1))
    y = np.asarray(y).T
    n_in = N_STATE + N_IMU_PARAMETERS + N_AIR + 9
    jac = np.asarray(jac).reshape(N_BANDED, k, n_in).transpose(1, 0, 2)        # (K, N_BANDED, n_in)
    j_state = jac[:, :, :N_STATE]
    j_theta = jac[:, :, N_STATE + where]                                       # SI theta
    j_air = jac[:, :, N_STATE + N_IMU_PARAMETERS:N_STATE + N_IMU_PARAMETERS + N_AIR]
    j_s = jac[:, :, N_STATE + N_IMU_PARAMETERS + N_AIR:]
    j_z = np.concatenate([j_state, j_theta * scale_theta[None, None, :]], axis=2)  # scaled z units
    var = np.einsum("kij,kjl,kil->ki", j_z, node_covariances(result, theta_cols), j_z)
    var += np.einsum("kij,jl,kil->ki", j_air, air_prior.covariance, j_air)
    var += np.einsum("kij,kjl,kil->ki", j_s, cov_s, j_s)
    three = 3.0 * np.sqrt(np.maximum(var, 0.0))
    bad = np.isnan(s[:, 0])
    y[bad, :N_COEF] = np.nan
    three[bad, :N_COEF] = np.nan
    out = {cols.TIME_IMU: result.node_time_s, cols.ALPHA_T: y[:, N_COEF], ALPHA_T_3SIGMA: three[:, N_COEF],
           cols.QBAR: y[:, N_COEF + 1], QBAR_3SIGMA: three[:, N_COEF + 1],
           MACH: y[:, N_COEF + 2], MACH_3SIGMA: three[:, N_COEF + 2]}
    for i, c in enumerate(cols.COEFFICIENTS):
        out[cols.column(c, IMPLIED)] = y[:, i]
        out[cols.sigma_column(c, IMPLIED)] = three[:, i]
        out[cols.column(c, DATABASE)] = y[:, N_BANDED + i] if aero is not None else np.full(k, np.nan)
    return {name: out[name] for name in implied_columns()}


#: Variants of the implied-aero table: from the kinematic fit and the IMU, and the database along its flow.
IMPLIED, DATABASE = "implied", "database"
#: Flow columns with their 3-sigma: Mach (dimensionless), alpha_T (deg), qbar (Pa).
MACH = "mach"
ALPHA_T_3SIGMA, QBAR_3SIGMA, MACH_3SIGMA = (f"{c}_{cols.THREE_SIGMA}" for c in (cols.ALPHA_T, cols.QBAR, MACH))


def implied_columns() -> tuple[str, ...]:
    """Columns of ``implied_aero.csv``, in file order."""
    out = [cols.TIME_IMU, cols.ALPHA_T, ALPHA_T_3SIGMA, cols.QBAR, QBAR_3SIGMA, MACH, MACH_3SIGMA]
    for c in cols.COEFFICIENTS:
        out += [cols.column(c, IMPLIED), cols.sigma_column(c, IMPLIED), cols.column(c, DATABASE)]
    return tuple(out)
