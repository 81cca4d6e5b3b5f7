"""Synthetic flight data in the real formats, from a known truth (seeded, deterministic).

What is made, and the simplifications kept (documented for whoever fits it):

- **IMU** at ``rate_hz`` on its own clock (IMU time 0 = ``clock_utc_at_zero`` as recorded; the true
  UTC of a sample is that plus ``t_imu`` plus the truth ``clock_offset_s``). Before release the
  vehicle hangs still at the release attitude (specific force -g, rates as at release); in flight
  the simulator's samples fall exactly on the IMU clock; after impact a 20 ms half-sine ground-reaction
  pulse (60 g, clipped by the accelerometers) is followed by rest at the impact attitude. Truth bias plus
  white noise (``accel_noise_mps2``, ``gyro_noise_dps``) are added and
  values beyond the declared saturation limits are clipped to them, as a real device does.
- **GPS** (FlySight 1 CSV, ``rate_hz`` on whole UTC multiples of the period): antenna position and
  velocity from the lever arm; before release it moves with the helicopter at the release
  velocity. Each fix carries hAcc, vAcc, sAcc, and its error is drawn with exactly those 1-sigma
  values per axis (north and east from hAcc, down from vAcc, each velocity component from sAcc).
  The first fixes are a cold start (accuracies from tens of metres down to nominal), and fixes
  after impact are poor (a receiver on its side in the dirt: accuracies growing, numSV falling).
  With ``[truth] gps_position_time_s`` / ``gps_velocity_time_s`` the errors are time-correlated
  (:func:`~casrecon.simulation.model_errors.gps_error_factors`); by default white.
- **Atmosphere-profile error** (``[truth] profile_wind_sigma_mps``, ``profile_density_sigma``): the
  truth flies the sounding plus a drawn error profile
  (:func:`~casrecon.simulation.model_errors.flown_atmosphere`), while the data the fit reads keep
  the original sounding; the error is kept on :class:`SyntheticData` (``profile_error``).
- **truth.json**: every parameter the estimator may estimate, by the names it uses, in the units
  of the results' ``parameters.json`` (gyro biases in deg/s, as ``[truth] gyro_bias_dps``), each
  named in ``units``.
"""

from __future__ import annotations

import dataclasses
import datetime as dt
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np
import pymap3d

from casrecon.io.baro import write_baro_csv
from casrecon.io.errors import InputError
from casrecon.io.flysight import GpsTrack, write_flysight1
from casrecon.io.imu import ACCEL_SCALE, GYRO_SCALE, write_imu_csv
from casrecon.io.units import output_unit
from casrecon.physics.aero import DISPERSION_NAMES
from casrecon.physics.dynamics import OUTPUT_NAMES
from casrecon.physics.rotations import dcm_body_to_ned
from casrecon.scenario import Scenario
from casrecon.simulation.error_families import Span, SyntheticWorld
from casrecon.simulation.model_errors import (
    ProfileError,
    draw_profile_error,
    flown_atmosphere,
    gps_error_factors,
    profile_grid,
)
from casrecon.simulation.simulate import Simulator, Trajectory

COLD_START_FIXES = 12
IMPACT_PULSE_S = 0.02   # half-sine ground-reaction pulse at impact, s
IMPACT_PULSE_G = 60.0   # its peak specific force, g (the accelerometers clip it)
POOR_FIX_GROWTH = 4.0  # hAcc growth after impact, m/s


@dataclass(frozen=True)
class SyntheticData:
    """Arrays ready for the file writers, and the truth behind them."""

    trajectory: Trajectory
    imu_time_s: np.ndarray
    imu_accel_mps2: np.ndarray
    imu_gyro_radps: np.ndarray
    gps: GpsTrack
    truth: dict
    baro_time_unix_s: np.ndarray | None = None   # UTC of the barometer samples (with [sensors.baro])
    baro_pressure_pa: np.ndarray | None = None
    profile_error: ProfileError | None = None   # flown-minus-sounding atmosphere (with a [truth] profile error)


def _unix(t: dt.datetime) -> float:
    return t.timestamp()


def truth_disturbance(scenario: Scenario, seed: int | None = None):
    """The truth's Gauss-Markov disturbance realisation as a function of flight time (s) ->
    (n, 9) array, or None without ``[truth]`` gusts or model errors. Seeded by (seed, 1)."""
    truth = scenario.config.truth
    if truth is None or truth.disturbance is None:
        return None
    dt_s = scenario.config.simulation.dt_s
    grid = np.arange(-dt_s, scenario.config.simulation.t_max_s + 2 * dt_s, dt_s)
    values = truth.disturbance.sample(grid, np.random.default_rng([truth.seed if seed is None else seed, 1]))

    def disturbance(t: np.ndarray) -> np.ndarray:
        return np.column_stack([np.interp(t, grid, values[:, i]) for i in range(values.shape[1])])

    return disturbance


def truth_profile_error(scenario: Scenario, seed: int | None = None) -> ProfileError | None:
    """The flown-minus-sounding atmosphere error of ``seed`` (default ``[truth] seed``), or None
    without a ``[truth]`` profile error (:func:`~casrecon.simulation.model_errors.draw_profile_error`
    on :func:`~casrecon.simulation.model_errors.profile_grid`)."""
    truth = scenario.config.truth
    if truth is None or not truth.errors.profile:
        return None
    grid = profile_grid(scenario.atmosphere.altitude_range_m, scenario.config.site.ground_alt_msl_m,
                        scenario.release_alt_msl_m)
    return draw_profile_error(truth.errors, grid, truth.seed if seed is None else seed)


def flown_scenario(scenario: Scenario, profile: ProfileError | None) -> Scenario:
    """The scenario whose model flies the sounding plus ``profile`` (``scenario`` itself for None)."""
    return scenario if profile is None else scenario.flying(flown_atmosphere(scenario.atmosphere, profile))


def simulate_truth(scenario: Scenario, seed: int | None = None) -> tuple[Trajectory, float]:
    """Simulate the truth flight on the IMU's true clock grid (with the truth's disturbance
    realisation and atmosphere-profile error for ``seed``, default ``[truth] seed``, if it has them).

    Returns the trajectory and ``t_zero``: the release time on the IMU clock (s), so that a sample
    at IMU time ``t_imu`` happened at flight time ``t_imu - t_zero``.
    """
    return _fly(flown_scenario(scenario, truth_profile_error(scenario, seed)), seed)


def _fly(scenario: Scenario, seed: int | None, world: SyntheticWorld | None = None) -> tuple[Trajectory, float]:
    cfg = scenario.config
    dt_s = 1.0 / cfg.imu.rate_hz
    clock = cfg.truth.clock_offset_s if cfg.truth else 0.0
    t_zero = _unix(cfg.release.time_utc) - _unix(cfg.imu.clock_utc_at_zero) - clock
    first = dt_s - (t_zero % dt_s) if t_zero % dt_s > 1e-12 else dt_s
    sim = Simulator(scenario.model, dt_s=dt_s, substeps=max(1, round(dt_s / cfg.simulation.dt_s)))
    traj = sim.run(scenario.release_state(), scenario.truth_parameters(), cfg.simulation.t_max_s, first,
                   disturbance=with_world_gusts(truth_disturbance(scenario, seed), world))
    if not traj.impacted:
        raise RuntimeError(f"{cfg.name}: no ground impact within t_max_s = {cfg.simulation.t_max_s} s")
    return traj, t_zero


def _gravity_body(scenario: Scenario, state: np.ndarray) -> np.ndarray:
    g = np.asarray(scenario.model.gravity_ned(state), float).ravel()
    return np.asarray(dcm_body_to_ned(state[6:10]), float).T @ g


def _imu_signals(scenario: Scenario, traj: Trajectory, t_zero: float):
    """Noise-free IMU signals (IMU axes) on the IMU clock from pre-release to post-impact."""
    cfg = scenario.config
    dt_s = 1.0 / cfg.imu.rate_hz
    r_ib = np.asarray(scenario.config.vehicle.imu_to_body)
    k_fly = int(round((t_zero + traj.time_s[1]) / dt_s))  # first in-flight sample on the IMU clock
    in_flight = slice(1, traj.time_s.size - 1)  # release sample is pre-flight; impact is off-grid
    n_fly, n_post = traj.time_s.size - 2, int(round(cfg.simulation.post_impact_s / dt_s))
    time = dt_s * np.arange(k_fly + n_fly + n_post)  # the log starts at IMU time 0
    t_pre = time[:k_fly]
    col = OUTPUT_NAMES.index
    f_fly = traj.outputs[in_flight, col("imu_fx"):col("imu_fz") + 1]
    w_fly = traj.outputs[in_flight, col("gyro_x"):col("gyro_z") + 1]
    f_pre = r_ib.T @ -_gravity_body(scenario, traj.states[0])
    f_post = r_ib.T @ -_gravity_body(scenario, traj.states[-1])
    w_pre = r_ib.T @ traj.states[0, 10:13]
    accel = np.vstack([np.tile(f_pre, (t_pre.size, 1)), f_fly, np.tile(f_post, (n_post, 1))
                       + _impact_pulse(traj, r_ib, dt_s, n_post)])
    gyro = np.vstack([np.tile(w_pre, (t_pre.size, 1)), w_fly, np.zeros((n_post, 3))])
    return time, accel, gyro


def _impact_pulse(traj: Trajectory, r_ib: np.ndarray, dt_s: float, n: int) -> np.ndarray:
    """Ground reaction at impact in IMU axes: a half-sine opposing the impact velocity."""
    v = traj.states[-1, 3:6]
    direction = -(np.asarray(dcm_body_to_ned(traj.states[-1, 6:10]), float).T @ v) / np.linalg.norm(v)
    t = dt_s * np.arange(n)
    shape = np.where(t < IMPACT_PULSE_S, np.sin(np.pi * t / IMPACT_PULSE_S), 0.0)
    return np.outer(shape * IMPACT_PULSE_G * 9.80665, r_ib.T @ direction)


def _clip(values: np.ndarray, limits, scale: float) -> np.ndarray:
    if limits is None:
        return values
    lo = np.array([p[0] for p in limits]) * scale
    hi = np.array([p[1] for p in limits]) * scale
    return np.clip(values, lo, hi)


def _noisy_imu(scenario: Scenario, traj: Trajectory, t_zero: float, rng: np.random.Generator):
    cfg, truth = scenario.config, scenario.config.truth
    time, accel, gyro = _imu_signals(scenario, traj, t_zero)
    accel = accel + np.asarray(truth.accel_bias_mps2) + rng.normal(0, cfg.imu.accel_noise_mps2, accel.shape)
    gyro = gyro + np.asarray(truth.gyro_bias_radps) + rng.normal(0, cfg.imu.gyro_noise_radps, gyro.shape)
    spec = cfg.imu.spec
    accel = _clip(accel, spec.accel_limits, ACCEL_SCALE[spec.accel_unit])
    gyro = _clip(gyro, spec.gyro_limits, GYRO_SCALE[spec.gyro_unit])
    return time, accel, gyro


def _gps_track(scenario: Scenario, traj: Trajectory, rng: np.random.Generator, seed: int,
               world: SyntheticWorld | None = None) -> GpsTrack:
    cfg = scenario.config
    period = 1.0 / cfg.gps.rate_hz
    t_rel = _unix(cfg.release.time_utc)
    start = np.ceil((t_rel - cfg.simulation.pre_release_s - COLD_START_FIXES * period) / period) * period
    stop = t_rel + traj.flight_time_s + cfg.simulation.post_impact_s
    utc = np.arange(start, stop, period)
    t = utc - t_rel
    col = OUTPUT_NAMES.index
    ant = traj.outputs[:, col("gps_n"):col("gps_vd") + 1]
    pos = np.column_stack([np.interp(t, traj.time_s, ant[:, i]) for i in range(6)])
    before, after = t < 0, t > traj.flight_time_s
    pos[before, :3] = ant[0, :3] + np.outer(t[before], ant[0, 3:])
    pos[before, 3:] = ant[0, 3:]
    pos[after, :3], pos[after, 3:] = ant[-1, :3], 0.0
    h_acc, v_acc, s_acc, num_sv = _accuracies(cfg.gps, t, traj.flight_time_s, rng)
    sigma = np.column_stack([h_acc, h_acc, v_acc, s_acc, s_acc, s_acc])
    white = rng.normal(size=pos.shape)
    if world is not None and world.gps_factors is not None:
        factors = world.gps_factors(utc, white, sigma)
    else:
        factors = gps_error_factors(utc, cfg.truth.errors, white, seed)
    meas = pos + factors * sigma
    site = cfg.site
    lat, lon, alt = pymap3d.ned2geodetic(meas[:, 0], meas[:, 1], meas[:, 2], site.lat_deg, site.lon_deg,
                                         site.ground_alt_msl_m)
    return GpsTrack(path="", format="flysight1", time_unix_s=np.round(utc, 3), lat_deg=lat, lon_deg=lon,
                    h_msl_m=alt, vel_n_mps=meas[:, 3], vel_e_mps=meas[:, 4], vel_d_mps=meas[:, 5],
                    h_acc_m=h_acc, v_acc_m=v_acc, s_acc_mps=s_acc, num_sv=num_sv)


def _baro_samples(scenario: Scenario, traj: Trajectory, seed: int) -> tuple[np.ndarray, np.ndarray]:
    """Barometer samples on UTC at ``[sensors.baro] rate_hz`` from pre-release to post-impact: the
    flown atmosphere's pressure (the sounding's) at the true centre-of-mass altitude, plus the true bias, the true
    static-port error ``baro_qbar_coef`` times qbar, and white noise
    (own random stream (seed, 2), so the IMU and GPS data do not depend on whether there is one)."""
    cfg = scenario.config
    period = 1.0 / cfg.baro.rate_hz
    t_rel = _unix(cfg.release.time_utc)
    start = np.ceil((t_rel - cfg.simulation.pre_release_s) / period) * period
    utc = np.arange(start, t_rel + traj.flight_time_s + cfg.simulation.post_impact_s, period)
    t = np.clip(utc - t_rel, 0.0, traj.flight_time_s)
    h_msl = cfg.site.ground_alt_msl_m + np.interp(t, traj.time_s, traj.output("h_agl"))
    qbar = np.interp(t, traj.time_s, traj.output("qbar"))
    h = ca.SX.sym("h")
    pressure = ca.Function("pressure", [h], [scenario.atmosphere.at(h).pressure]).map(utc.size)
    rng = np.random.default_rng((seed, 2))
    p = (np.asarray(pressure(h_msl[None, :])).ravel() + cfg.truth.baro_bias_pa + cfg.truth.baro_qbar_coef * qbar
         + cfg.baro.noise_pa * rng.normal(size=utc.size))
    return np.round(utc, 3), p


def _accuracies(gps, t: np.ndarray, t_impact: float, rng: np.random.Generator):
    """Reported 1-sigma accuracies per fix: cold start, nominal with jitter, poor after impact."""
    jitter = 1 + 0.1 * rng.uniform(-1, 1, t.size)
    decay = np.exp(-np.arange(t.size) / 3.0) * 40.0
    h_acc = gps.h_acc_m * jitter + decay
    v_acc = gps.v_acc_m * jitter + 1.3 * decay
    s_acc = gps.s_acc_mps * jitter + 0.1 * decay
    late = np.clip(t - t_impact, 0, None)
    h_acc, v_acc, s_acc = h_acc + POOR_FIX_GROWTH * late, v_acc + 2 * POOR_FIX_GROWTH * late, s_acc + 0.5 * late
    num_sv = np.where(t > t_impact, 5, 14) - (decay > 5).astype(int) * 8
    return np.round(h_acc, 3), np.round(v_acc, 3), np.round(s_acc, 3), num_sv.astype(np.int64)


#: SI unit of each truth parameter that is not a normalised aero factor (those are "-").
TRUTH_UNITS = {"wind_bias_n": "m/s", "wind_bias_e": "m/s", "density_factor": "-", "clock_offset_s": "s",
               "downwash_mps": "m/s", "sounding_shift_m": "m", "baro_bias_pa": "Pa", "baro_qbar_coef": "-",
               **{f"accel_bias_{a}": "m/s^2" for a in "xyz"}, **{f"gyro_bias_{a}": "rad/s" for a in "xyz"}}


def truth_document_parameters(values: dict[str, float]) -> tuple[dict[str, float], dict[str, str]]:
    """The truth parameters (SI, :func:`truth_parameters_by_name`) in their output units
    (:func:`~casrecon.io.units.output_unit`: gyro biases in deg/s) and those units, by name."""
    out, units = {}, {}
    for name, value in values.items():
        units[name], factor = output_unit(TRUTH_UNITS.get(name, "-"))
        out[name] = value * factor
    return out, units


def truth_parameters_by_name(scenario: Scenario) -> dict[str, float]:
    """Every estimable parameter's true value, by the estimator's names (SI units)."""
    truth = scenario.config.truth
    out = {n: float(truth.dispersions[n]) for n in DISPERSION_NAMES}
    out.update(wind_bias_n=truth.wind_bias_mps[0], wind_bias_e=truth.wind_bias_mps[1],
               density_factor=truth.density_factor, clock_offset_s=truth.clock_offset_s,
               downwash_mps=truth.downwash_mps, sounding_shift_m=truth.sounding_shift_m)
    for axis, a, g in zip("xyz", truth.accel_bias_mps2, truth.gyro_bias_radps):
        out[f"accel_bias_{axis}"] = float(a)
        out[f"gyro_bias_{axis}"] = float(g)
    if scenario.config.baro is not None:
        out["baro_bias_pa"] = truth.baro_bias_pa
        out["baro_qbar_coef"] = truth.baro_qbar_coef
    return out


def with_world_gusts(disturbance, world: SyntheticWorld | None):
    """The disturbance function (flight time s -> (n, 9)) with ``world``'s gusts added to its
    first three entries (``disturbance`` itself without them; a zero disturbance when it is None)."""
    if world is None or world.gusts is None:
        return disturbance

    def total(t: np.ndarray) -> np.ndarray:
        t = np.atleast_1d(np.asarray(t, float))
        out = np.zeros((t.size, 9)) if disturbance is None else np.array(disturbance(t), float)
        out[:, :3] += world.gusts(t)
        return out

    return total


def world_span(scenario: Scenario) -> Span:
    """Where a drop of ``scenario`` flies, for :func:`~.error_families.family_world`: the extents of
    the profile grid, the ground and release altitudes (m MSL) and ``[simulation] t_max_s``."""
    cfg = scenario.config
    grid = profile_grid(scenario.atmosphere.altitude_range_m, cfg.site.ground_alt_msl_m, scenario.release_alt_msl_m)
    return Span(float(grid[0]), float(grid[-1]), cfg.site.ground_alt_msl_m, scenario.release_alt_msl_m,
                cfg.simulation.t_max_s)


def make_synthetic(scenario: Scenario, seed: int | None = None, world: SyntheticWorld | None = None) -> SyntheticData:
    """Simulate the truth and make IMU and GPS data; ``seed`` overrides ``[truth] seed``; ``world``
    (:mod:`~.error_families`) replaces the ``[truth]`` profile error and GPS errors where it has its
    own and adds its gusts. InputError naming the problem file when it has no ``[truth]`` table."""
    cfg = scenario.config
    if cfg.truth is None:
        raise InputError(cfg.path, "no [truth] table: synthetic data are simulated from its dispersions, biases "
                                   "and seed; add one (an empty [truth] is enough: the nominal database, no "
                                   "biases, seed 0)", field="truth")
    seed = cfg.truth.seed if seed is None else seed
    rng = np.random.default_rng(seed)
    profile = truth_profile_error(scenario, seed)
    if world is not None and world.profile_error is not None:
        profile = world.profile_error
    flown = flown_scenario(scenario, profile)
    traj, t_zero = _fly(flown, seed, world)
    imu_t, accel, gyro = _noisy_imu(scenario, traj, t_zero, rng)
    gps = _gps_track(scenario, traj, rng, seed, world)
    parameters, units = truth_document_parameters(truth_parameters_by_name(scenario))
    truth = {"problem": cfg.name, "seed": seed, "parameters": parameters, "units": units,
             "release_imu_time_s": t_zero, "release_utc": cfg.release.time_utc.isoformat(),
             "summary": traj.summary()}
    if profile is not None or cfg.truth.errors.coloured_gps:
        truth["model_errors"] = dataclasses.asdict(cfg.truth.errors)
    if world is not None:
        truth["error_family"] = world.name
    baro = _baro_samples(flown, traj, seed) if cfg.baro is not None else (None, None)
    return SyntheticData(traj, imu_t, accel, gyro, gps, truth, *baro, profile_error=profile)


def with_synthetic_data(scenario: Scenario, folder: Path, seed: int = 0) -> Scenario:
    """The scenario with fresh synthetic sensor data in place of its own.

    Parameters
    ----------
    scenario : Scenario
        The drop to simulate (its ``[truth]`` and sensor specifications).
    folder : Path
        Existing folder that receives ``imu.csv`` and ``gps.csv`` (FlySight 1); it must outlive
        the use of the returned scenario.
    seed : int
        Noise seed of :func:`make_synthetic`.

    Returns
    -------
    Scenario
        A copy whose IMU and GPS files are the ones written to ``folder`` (its sounding is the
        original one, also when the truth flew a profile error).
    """
    return synthetic_scenario(scenario, folder, seed)[0]


def synthetic_scenario(scenario: Scenario, folder: Path, seed: int = 0,
                       world: SyntheticWorld | None = None) -> tuple[Scenario, SyntheticData]:
    """:func:`with_synthetic_data` that also returns the :class:`SyntheticData` written (the truth
    trajectory and the drawn profile error); ``world`` as :func:`make_synthetic`'s."""
    cfg = scenario.config
    data = make_synthetic(scenario, seed=seed, world=world)
    write_imu_csv(folder / "imu.csv", data.imu_time_s, data.imu_accel_mps2, data.imu_gyro_radps, cfg.imu.spec)
    write_flysight1(folder / "gps.csv", data.gps)
    baro = cfg.baro
    if baro is not None:
        write_baro_csv(folder / "baro.csv", data.baro_time_unix_s, data.baro_pressure_pa)
        baro = dataclasses.replace(baro, file=folder / "baro.csv")
    new = dataclasses.replace(cfg, imu=dataclasses.replace(cfg.imu, file=folder / "imu.csv"),
                              gps=dataclasses.replace(cfg.gps, file=folder / "gps.csv"), baro=baro)
    return Scenario.from_config(new), data
