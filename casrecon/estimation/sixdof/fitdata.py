"""Measured data prepared for one drop's fit: IMU in body axes on its own clock, GPS antenna
fixes in the site's NED frame, release and impact instants, the fit window, and the rules that
drop or mask samples (all counted, so reports can say what was left out and why).

Time base: the IMU clock. A GPS fix stamped at UTC ``u`` happened at IMU time
``u - clock_utc_at_zero - clock_offset``; the clock offset is estimated, so this module keeps GPS
times as ``u - clock_utc_at_zero`` and the transcription subtracts the offset.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from casrecon.estimation.validation.data_checks import check_accel_unit, check_drop_data
from casrecon.io.flysight import GpsTrack, no_fix_mask, read_flysight
from casrecon.io.gps_rules import fixes_ned, good_fixes, no_fix_note
from casrecon.io.imu import ImuLog, read_imu_csv
from casrecon.io.problem import ProblemConfig
from casrecon.io.sounding import Sounding

#: Release is the first sample whose specific force magnitude falls below this fraction of g.
RELEASE_FORCE_FRACTION = 0.5
#: Impact is the first sample after release whose specific force exceeds this many g.
IMPACT_FORCE_G = 3.0
G0 = 9.80665


class FitDataError(ValueError):
    """The data cannot support a fit (no release found, window empty, too few GPS fixes)."""


@dataclass(frozen=True)
class FitData:
    """One drop's measurements, ready for transcription (SI units, body axes, IMU clock)."""

    imu_time_s: np.ndarray       # (N,)
    accel_body: np.ndarray       # (N, 3) specific force, body axes
    gyro_body: np.ndarray        # (N, 3) rate, body axes
    accel_valid: np.ndarray      # (N, 3) bool, per IMU axis (False: saturated)
    gyro_valid: np.ndarray       # (N, 3) bool
    accel_imu: np.ndarray        # (N, 3) as measured, IMU axes (biases live in IMU axes)
    gyro_imu: np.ndarray         # (N, 3)
    gps_time_s: np.ndarray       # (M,) UTC minus clock_utc_at_zero, s
    gps_pos_ned: np.ndarray      # (M, 3) antenna, m
    gps_vel_ned: np.ndarray      # (M, 3) m/s
    gps_sigma: np.ndarray        # (M, 6) 1-sigma: hAcc, hAcc, vAcc, sAcc x 3 (inf: component not in the file)
    release_imu_s: float
    impact_imu_s: float
    window: tuple[float, float]  # fit window on the IMU clock
    notes: tuple[str, ...]       # what was dropped or masked, and why


def _events(imu: ImuLog, cfg: ProblemConfig) -> tuple[float, float, list[str]]:
    est, notes = cfg.estimation, []
    mag = np.linalg.norm(imu.accel_mps2, axis=1)
    release = est.release_imu_s
    if release is None:
        below = np.nonzero(mag < RELEASE_FORCE_FRACTION * G0)[0]
        if below.size == 0:
            raise FitDataError(f"{imu.path}: no release found (specific force never falls below "
                               f"{RELEASE_FORCE_FRACTION} g); give [estimation] release_imu_s")
        release = float(imu.time_s[below[0]])
        notes.append(f"release found from the IMU at t = {release:.3f} s (|f| < {RELEASE_FORCE_FRACTION} g)")
    impact = est.impact_imu_s
    if impact is None:
        after = np.nonzero((mag > IMPACT_FORCE_G * G0) & (imu.time_s > release + 1.0))[0]
        if after.size == 0:
            raise FitDataError(f"{imu.path}: no impact found (specific force never exceeds "
                               f"{IMPACT_FORCE_G} g after release); give [estimation] impact_imu_s")
        impact = float(imu.time_s[after[0]])
        notes.append(f"impact found from the IMU at t = {impact:.3f} s (|f| > {IMPACT_FORCE_G} g)")
    return release, impact, notes


def _gps(track: GpsTrack, cfg: ProblemConfig, window: tuple[float, float], notes: list[str]):
    quality = cfg.estimation.gps_quality
    t = track.time_unix_s - cfg.imu.clock_utc_at_zero.timestamp()
    in_window = (t >= window[0]) & (t <= window[1])
    good = good_fixes(track, quality)
    no_fix = no_fix_note(track, in_window)
    if no_fix:
        notes.append(f"{no_fix} (in the window)")
    n_bad = int(np.sum(in_window & ~good & ~no_fix_mask(track)))
    if n_bad:
        notes.append(f"{n_bad} GPS fixes in the window dropped for poor accuracy ({quality.describe()})")
    keep = in_window & good
    if keep.sum() < 3:
        raise FitDataError(f"{track.path}: only {keep.sum()} usable GPS fixes in the fit window")
    return (t[keep], *fixes_ned(track, cfg.site, keep, cfg.gps.velocity_sigma_mps))


def patch_saturated(time: np.ndarray, values: np.ndarray, valid: np.ndarray, span: int = 25):
    """The EES paper's patch: each run of saturated samples on an axis is replaced by a
    second-order polynomial fitted to up to ``span`` good samples on either side of it.

    Returns patched values and an all-True validity array (patched samples are then used as data,
    which is what the paper did; the default ``mask`` leaves them out instead).
    """
    out = values.copy()
    for axis in range(values.shape[1]):
        bad = ~valid[:, axis]
        edges = np.flatnonzero(np.diff(np.r_[0, bad.astype(int), 0]))
        for start, stop in zip(edges[::2], edges[1::2]):
            idx = np.r_[max(start - span, 0):start, stop:min(stop + span, len(time))]
            idx = idx[valid[idx, axis]]
            if idx.size >= 3:
                coef = np.polyfit(time[idx] - time[start], values[idx, axis], 2)
                out[start:stop, axis] = np.polyval(coef, time[start:stop] - time[start])
    return out, np.ones_like(valid)


def load_fit_data(cfg: ProblemConfig, sounding: Sounding | None = None) -> FitData:
    """Read the problem's IMU and GPS files, check them (:mod:`casrecon.estimation.validation.data_checks`: a
    failure is a located :class:`~casrecon.io.errors.InputError`) and prepare them for the fit.
    ``sounding``: the problem's sounding file as already read (:attr:`casrecon.scenario.Scenario.sounding`),
    else the check reads it."""
    if cfg.imu.file is None or cfg.gps.file is None:
        raise FitDataError(f"{cfg.path}: [sensors.imu] file and [sensors.gps] file are needed for a fit")
    imu = read_imu_csv(cfg.imu.file, cfg.imu.spec)
    track = read_flysight(cfg.gps.file)
    check_accel_unit(cfg, imu)
    release, impact, notes = _events(imu, cfg)
    window = (release + cfg.estimation.start_after_release_s, impact - cfg.estimation.end_before_impact_s)
    if window[1] - window[0] < 1.0:
        raise FitDataError(f"{cfg.path}: fit window {window[0]:.2f} to {window[1]:.2f} s is shorter than 1 s")
    check_drop_data(cfg, imu, track, release, impact, window, sounding)
    r_ib = np.asarray(cfg.vehicle.imu_to_body)
    accel_valid, gyro_valid = ~imu.accel_saturated, ~imu.gyro_saturated
    sel = (imu.time_s >= window[0] - 1e-9) & (imu.time_s <= window[1] + 1e-9)
    for kind, valid in (("accelerometer", accel_valid), ("gyro", gyro_valid)):
        n_sat = int((~valid[sel]).sum())
        if n_sat:
            notes.append(f"{n_sat} saturated {kind} axis-samples in the window "
                         f"({cfg.estimation.saturation} applied)")
    gps = _gps(track, cfg, window, notes)
    t, accel, gyro = imu.time_s[sel], imu.accel_mps2[sel], imu.gyro_radps[sel]
    accel_valid, gyro_valid = accel_valid[sel], gyro_valid[sel]
    if cfg.estimation.saturation == "polynomial":
        accel, accel_valid = patch_saturated(t, accel, accel_valid)
        gyro, gyro_valid = patch_saturated(t, gyro, gyro_valid)
    return FitData(t, accel @ r_ib.T, gyro @ r_ib.T, accel_valid, gyro_valid, accel, gyro, *gps,
                   release, impact, window, tuple(notes))
