"""The inputs of a kinematic fit: from a kinematic problem (:func:`inputs_from_config`), or from a 6-DOF
problem (``problem.toml`` with a vehicle, IMU, GPS and
optional barometer): the same files, windows and data rules as the dynamic fit, so the two can be
compared, and no use of the aerodynamic model (docs/design.md: Kinematic reconstruction).
"""

from __future__ import annotations

import math

import numpy as np

from casrecon.estimation.kinds.gps import fix_sigma
from casrecon.estimation.kinematic.data import KinematicData, KinematicOptions
from casrecon.estimation.kinematic.imu_record import aliased_samples, check_span, read_imu_record
from casrecon.estimation.sixdof.fitdata import FitData, FitDataError, load_fit_data
from casrecon.estimation.validation.consistency import check_baro, sounding_origin_warning, warn_once
from casrecon.io.baro import BaroConfig, read_baro
from casrecon.io.gps_files import read_gps_track
from casrecon.io.gps_rules import fixes_ned, good_fixes
from casrecon.io.kinematic_problem import KinematicConfig
from casrecon.io.problem import ProblemConfig
from casrecon.io.sounding import read_sounding
from casrecon.physics.atmosphere import Atmosphere
from casrecon.physics.vehicle import Vehicle

#: A common clock after this (2001-09-09 UTC, Unix seconds) is taken as UTC: the sounding's date is compared.
UTC_AFTER_S = 1e9


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
        baro_bias_sigma_pa=cfg.baro.bias_sigma_pa if cfg.baro is not None else BaroConfig.bias_sigma_pa)
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
    sigma = fix_sigma(data, cfg.gps.error_model)  # the error's size the fit assumes
    return KinematicData(data.imu_time_s, data.gyro_imu, data.accel_imu, data.gyro_valid, data.accel_valid,
                         data.gps_time_s - guess, y, sigma, data.window, baro_t, baro_p, noise, atmosphere,
                         data.notes, imu_file=str(cfg.imu.file))


def inputs_from_config(cfg: KinematicConfig) -> tuple[KinematicData, KinematicOptions]:
    """Read a kinematic problem's files onto one clock and restrict them to the span reconstructed
    (``[segment]``, by default where the IMU record and the good fixes overlap). Times in the
    returned data are seconds after ``time_ref_s`` (the span's start on the common clock).

    Raises
    ------
    InputError
        A file that cannot be read, or an IMU span its checks refuse (:mod:`.imu_record`); located.
    FitDataError
        Too few samples or fixes in the span.
    """
    imu = cfg.imu
    record = read_imu_record(imu)
    m = record.log
    notes: list[str] = list(record.notes)
    t_imu, gyro, accel = m.time_s, m.gyro_radps, m.accel_mps2
    gyro_ok, accel_ok = ~m.gyro_saturated, ~m.accel_saturated
    track = read_gps_track(cfg.gps_file, cfg.gps_date, imu.utc_at_zero_s)
    good = good_fixes(track, cfg.quality)
    notes += list(track.notes)
    t_fix = track.time_unix_s
    lo = max(t_imu[0], t_fix[good].min() if good.any() else np.inf)
    hi = min(t_imu[-1], t_fix[good].max() if good.any() else -np.inf)
    start = lo if cfg.start_s is None else max(cfg.start_s, t_imu[0])
    end = hi if cfg.end_s is None else min(cfg.end_s, t_imu[-1])
    if not end - start >= 1.0:
        raise FitDataError(f"{cfg.path}: the span reconstructed ({start:.3f} to {end:.3f} s) is shorter than 1 s or "
                           "outside the IMU record and the good fixes; check [segment] start_s/end_s")
    keep = good & (t_fix >= start) & (t_fix <= end)
    if keep.sum() < 3:
        raise FitDataError(f"{cfg.gps_file}: only {int(keep.sum())} good fixes in {start:.3f} to {end:.3f} s")
    notes.append(f"{int(keep.sum())} good fixes of {int(((t_fix >= start) & (t_fix <= end)).sum())} in the span")
    pos, vel, sigma = fixes_ned(track, cfg.site, keep, cfg.velocity_sigma_mps)
    sel = (t_imu >= start - 1.0) & (t_imu <= end + 1.0)
    notes += check_span(record, start - 1.0, end + 1.0)
    aliased, aliased_notes = aliased_samples(record, start - 1.0, end + 1.0)
    notes += aliased_notes
    sounding = None if cfg.sounding is None else read_sounding(cfg.sounding)
    baro_t = baro_p = None
    if cfg.baro_file is not None:
        blog = read_baro(cfg.baro_file)
        notes += [n for n in blog.notes if n not in notes]  # the IMU's SENSOR.CSV read again: its note once
        tb = blog.time_s + (imu.utc_at_zero_s if blog.clock == "imu" else 0.0)
        check_baro(blog, tb, (start, end), track, good, cfg.site.ground_alt_msl_m, sounding)
        bk = (tb >= start) & (tb <= end)
        baro_t, baro_p = tb[bk] - start, blog.pressure_pa[bk]
    if sounding is not None:
        warning = sounding_origin_warning(sounding, start if start > UTC_AFTER_S else None, cfg.site.lat_deg,
                                          cfg.site.lon_deg, "the span's start and [site]")
        if warning is not None:
            warn_once(warning)
    atmosphere = (Atmosphere.standard() if sounding is None else
                  Atmosphere.from_sounding(sounding, cfg.site.ground_alt_msl_m, cfg.humidity))
    data = KinematicData(t_imu[sel] - start, gyro[sel], accel[sel], gyro_ok[sel], accel_ok[sel], t_fix[keep] - start,
                         np.column_stack([pos, vel]), sigma, (0.0, end - start), baro_t, baro_p, cfg.baro_noise_pa,
                         atmosphere, tuple(notes), time_ref_s=float(start), imu_file=m.path,
                         imu_lines=np.flatnonzero(sel) + 2 if m.line_numbers is None else m.line_numbers[sel],
                         imu_aliased=aliased if aliased.any() else None)
    options = KinematicOptions(
        gyro_noise_radps=imu.gyro_noise_radps, accel_noise_mps2=imu.accel_noise_mps2,
        gyro_bias_sigma_radps=imu.gyro_bias_sigma_radps, accel_bias_sigma_mps2=imu.accel_bias_sigma_mps2,
        gyro_scale_sigma=imu.gyro_scale_sigma, accel_scale_sigma=imu.accel_scale_sigma,
        gyro_misalignment_sigma=imu.gyro_misalignment_sigma, accel_misalignment_sigma=imu.accel_misalignment_sigma,
        gps_lever_m=cfg.gps_lever_m,
        latitude_rad=math.radians(cfg.site.lat_deg), ground_alt_msl_m=cfg.site.ground_alt_msl_m,
        gravity=cfg.dynamics.gravity, earth_rotation=cfg.dynamics.earth_rotation,
        gyro_senses_earth_rate=imu.gyro_senses_earth_rate, clock_sigma_s=cfg.clock_sigma_s,
        max_node_spacing_s=cfg.max_node_spacing_s, gps_errors=cfg.gps_errors, baro_bias_sigma_pa=cfg.baro_bias_sigma_pa,
        baro_height_scale_sigma=cfg.baro_height_scale_sigma,
        linear_solver=cfg.linear_solver, max_iter=cfg.max_iter, tol=cfg.tol)
    return data, options
