"""The inputs of a kinematic fit from a 6-DOF problem (``problem.toml`` with a vehicle, IMU, GPS and
optional barometer): the same files, windows and data rules as the dynamic fit, so the two can be
compared, and no use of the aerodynamic model (docs/design.md: Kinematic reconstruction).
"""

from __future__ import annotations

import math

import numpy as np

from casrecon.estimation.fitdata import FitData, load_fit_data
from casrecon.estimation.kinematic_data import KinematicData, KinematicOptions
from casrecon.io.baro import read_baro
from casrecon.io.problem import ProblemConfig
from casrecon.physics.atmosphere import Atmosphere
from casrecon.physics.vehicle import Vehicle


def options_from_problem(cfg: ProblemConfig, **overrides) -> KinematicOptions:
    """Kinematic options from a 6-DOF problem's sensor settings: the IMU's noise and bias sigmas,
    the antenna lever arm (vehicle file, turned into IMU axes), the site, gravity and Earth rotation
    of ``[dynamics]``, the GPS error model and the clock-offset prior. Gyros are taken to sense
    the rate against NED, as casrecon's 6-DOF model and simulator assume. ``overrides`` replace
    fields (e.g. ``gyro_scale_sigma=0.01``)."""
    vehicle: Vehicle = cfg.vehicle
    lever_body = np.asarray(vehicle.gps_position_m, float) - np.asarray(vehicle.imu_position_m, float)
    lever_imu = np.asarray(vehicle.imu_to_body, float).T @ lever_body
    est, imu = cfg.estimation, cfg.imu
    fields = dict(
        gyro_noise_radps=imu.gyro_noise_radps, accel_noise_mps2=imu.accel_noise_mps2,
        gyro_bias_sigma_radps=imu.gyro_bias_sigma_radps, accel_bias_sigma_mps2=imu.accel_bias_sigma_mps2,
        gps_lever_m=tuple(float(x) for x in lever_imu), latitude_rad=math.radians(cfg.site.lat_deg),
        ground_alt_msl_m=cfg.site.ground_alt_msl_m, gravity=cfg.dynamics.gravity,
        earth_rotation=cfg.dynamics.earth_rotation, gyro_senses_earth_rate=False,
        clock_sigma_s=est.clock_sigma_s if est.estimate_clock else 0.0, clock_guess_s=est.clock_offset_guess_s,
        gps_errors=cfg.gps.error_model, linear_solver=est.linear_solver,
        baro_bias_sigma_pa=cfg.baro.bias_sigma_pa if cfg.baro is not None else 50.0)
    fields.update(overrides)
    return KinematicOptions(**fields)


def data_from_problem(cfg: ProblemConfig, fit_data: FitData | None = None,
                      atmosphere: Atmosphere | None = None) -> KinematicData:
    """The problem's IMU (IMU axes, saturation flags), GPS fixes (on the IMU clock with the guessed
    clock offset) and barometer over the dynamic fit's window."""
    data = fit_data if fit_data is not None else load_fit_data(cfg)
    guess = cfg.estimation.clock_offset_guess_s
    baro_t = baro_p = None
    noise = 3.0
    if cfg.baro is not None and cfg.baro.file is not None:
        log = read_baro(cfg.baro.file)
        t = log.time_s - cfg.imu.clock_utc_at_zero.timestamp() - guess if log.clock == "utc" else log.time_s
        keep = (t >= data.window[0]) & (t <= data.window[1])
        baro_t, baro_p, noise = t[keep], log.pressure_pa[keep], cfg.baro.noise_pa
    y = np.column_stack([data.gps_pos_ned, data.gps_vel_ned])
    return KinematicData(data.imu_time_s, data.gyro_imu, data.accel_imu, data.gyro_valid, data.accel_valid,
                         data.gps_time_s - guess, y, data.gps_sigma, data.window, baro_t, baro_p, noise, atmosphere,
                         data.notes)
