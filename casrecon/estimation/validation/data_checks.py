"""The pre-solve data check every fit runs: after the files are read and before any NLP is built
(milliseconds), data that cannot give a trustworthy fit are refused with one located
:class:`~casrecon.io.errors.InputError` (``casrecon: FILE:LINE: field 'F': MESSAGE``, exit status 2).

Run by :func:`casrecon.estimation.sixdof.fitdata.load_fit_data` (the 6-DOF fit, the joint fit, ``casrecon.fit``,
``sensitivity`` and the estimator Monte Carlo) and :func:`casrecon.estimation.pointmass.fit.prepare_data`
(the point-mass fit). :func:`casrecon.estimation.validation.precheck.check_problem` runs it alone on a folder.

Checks and thresholds (module constants):

- **IMU** (6-DOF), the rules of :mod:`casrecon.io.imu_checks`: the accelerometer unit on the whole log
  (median specific force 0.25 to 4 g), then over the fit window: gaps (a step over 1.5 sample periods),
  the gyro unit (rates over 2000 deg/s for 5 % of the samples), saturation (over 25 % of an axis at
  its declared limit), a stuck channel (one reading for 1 s); a gyro sample over 50 rad/s or an
  accelerometer sample over 2000 m/s^2 in the window is only logged as a warning (one glitch can do it).
- **GPS fixes**: a row with a fix whose hAcc, vAcc or sAcc is not > 0 is refused by the reader
  (:func:`casrecon.io.flysight.read_flysight`); rows without a 3D fix (``gpsFix`` other than 3 or 4,
  or latitude, longitude and height all 0) are dropped, with a note in the fit's notes.
- **GPS coverage** (:data:`GPS_MAX_GAP_S` = 3 s): no stretch of the fit window (6-DOF) or of the
  fitted segment (point-mass) longer than 3 s without a good fix, counting from its start and to
  its end.
- **release time** (:data:`RELEASE_TIME_TOL_S` = 60 s): the release found in (or given for) the IMU
  log, put on UTC by ``[sensors.imu.clock] utc_at_zero``, must lie within 60 s of ``[release]
  time_utc``; a time written to the minute passes, a wrong hour, day or time zone does not.
- **release and impact altitude** (:data:`RELEASE_ALT_TOL_M` = 100 m, :data:`IMPACT_ALT_TOL_M` = 50 m):
  the GPS altitude at impact (nearest good fix within 3 s, carried to the instant by its vertical
  speed) within 50 m of ``ground_alt_msl_m``, then at release within 100 m of ``ground_alt_msl_m +
  h_agl_m``.
- **sounding coverage**: the sounding's top level at or above the release altitude (the higher of
  ``[site]`` + ``[release]`` and the highest good fix of the window); point-mass: above the highest
  good fix of the segment. Above its top the atmosphere would be held constant.
- **inputs against each other** (:mod:`casrecon.estimation.validation.consistency`): the IMU's impact
  against the end of the GPS's descent; the barometer (``[sensors.baro]``) against the sounding at the
  GPS altitude; and, a warning only, the sounding's own date and place against the drop's
  (point-mass: the sounding's only).
"""

from __future__ import annotations

import logging

import numpy as np

from casrecon.estimation.validation.consistency import check_baro, check_impact_time, sounding_origin_warning, warn_once
from casrecon.io.baro import read_baro
from casrecon.io.errors import InputError
from casrecon.io.flysight import GpsTrack, iso_utc
from casrecon.io.gps_rules import GpsQuality, good_fixes
from casrecon.io.imu import ImuLog
from casrecon.io.imu_checks import accel_unit_finding, imu_findings, unit_warnings
from casrecon.io.pointmass_problem import PointMassConfig
from casrecon.io.problem import ProblemConfig
from casrecon.io.sounding import Sounding, read_sounding

logger = logging.getLogger(__name__)

GPS_MAX_GAP_S = 3.0
RELEASE_TIME_TOL_S = 60.0
RELEASE_ALT_TOL_M = 100.0
IMPACT_ALT_TOL_M = 50.0


def check_accel_unit(cfg: ProblemConfig, imu: ImuLog) -> None:
    """The accelerometer unit, before release and impact are looked for in the specific force."""
    found = accel_unit_finding(imu, cfg.imu.spec)
    if found is not None:
        raise found.error(imu.path)


def check_drop_data(cfg: ProblemConfig, imu: ImuLog, track: GpsTrack, release: float, impact: float,
                    window: tuple[float, float], sounding: Sounding | None = None) -> None:
    """Every check of a 6-DOF drop (see the module docstring); raises the first failure.

    Parameters
    ----------
    cfg : ProblemConfig
        The problem.
    imu, track : ImuLog, GpsTrack
        The data as read.
    release, impact : float
        Release and impact on the IMU clock, s.
    window : (float, float)
        The fit window on the IMU clock, s.
    sounding : Sounding, optional
        The problem's sounding file as already read (read here when not given).
    """
    sounding = read_sounding(cfg.atmosphere.sounding, launch=cfg.atmosphere.launch) if sounding is None else sounding
    span = slice(int(np.searchsorted(imu.time_s, window[0] - 1e-9)),
                 int(np.searchsorted(imu.time_s, window[1] + 1e-9, side="right")))
    for found in imu_findings(imu, cfg.imu.spec, span):
        raise found.error(imu.path)
    for found in unit_warnings(imu, cfg.imu.spec, span):
        logger.warning("%s", found.error(imu.path))
    zero = cfg.imu.clock_utc_at_zero.timestamp()
    _check_release_time(cfg, zero + release)
    good = good_fixes(track, cfg.estimation.gps_quality)
    t_gps = track.time_unix_s - zero
    check_coverage(track, good, t_gps, window, "the fit window", lambda t: f"IMU t = {t:.3f} s")
    ground = cfg.site.ground_alt_msl_m
    h_impact = _altitude_at(track, good, t_gps, impact)
    if h_impact is not None and abs(h_impact - ground) > IMPACT_ALT_TOL_M:
        raise InputError(cfg.path, f"ground at {ground:g} m MSL but the GPS ({track.path}) puts the impact (IMU t = "
                         f"{impact:.3f} s) at {h_impact:.0f} m MSL, {h_impact - ground:+.0f} m from it; expected "
                         f"within {IMPACT_ALT_TOL_M:g} m", field="site.ground_alt_msl_m")
    h_release = _altitude_at(track, good, t_gps, release)
    stated = ground + cfg.release.h_agl_m
    if h_release is not None and abs(h_release - stated) > RELEASE_ALT_TOL_M:
        raise InputError(cfg.path, f"release {cfg.release.h_agl_m:g} m above the ground ({stated:.0f} m MSL) but "
                         f"the GPS ({track.path}) puts the release at {h_release:.0f} m MSL, "
                         f"{h_release - ground:.0f} m above the ground; expected them within {RELEASE_ALT_TOL_M:g} m "
                         "(check [release] h_agl_m and [site] ground_alt_msl_m)", field="release.h_agl_m")
    in_window = good & (t_gps >= window[0]) & (t_gps <= window[1])
    top_needed = max(ground + cfg.release.h_agl_m, float(track.h_msl_m[in_window].max(initial=-np.inf)))
    check_sounding_top(cfg.atmosphere.sounding, cfg.atmosphere.launch, top_needed, "the release altitude", sounding)
    check_impact_time(imu.path, track, zero, release, impact)
    if cfg.baro is not None and cfg.baro.file is not None and cfg.baro.file.exists():  # (missing: the fit says so)
        log = read_baro(cfg.baro.file)
        check_baro(log, log.time_s + (0.0 if log.clock == "utc" else zero), (zero + window[0], zero + window[1]),
                   track, good, ground, sounding)
    warning = sounding_origin_warning(sounding, cfg.release.time_utc.timestamp(), cfg.site.lat_deg, cfg.site.lon_deg,
                                      "[release] time_utc and [site]")
    if warning is not None:
        warn_once(warning)


def _check_release_time(cfg: ProblemConfig, release_utc: float) -> None:
    stated = cfg.release.time_utc.timestamp()
    diff = release_utc - stated
    if abs(diff) <= RELEASE_TIME_TOL_S:
        return
    how = f"{abs(diff) / 3600:.1f} h" if abs(diff) >= 3600 else f"{abs(diff):.0f} s"
    raise InputError(cfg.path, f"release at {iso_utc(stated)} but the IMU log ({cfg.imu.file}) releases at "
                     f"{iso_utc(release_utc)} ([sensors.imu.clock] utc_at_zero + the release found on the IMU clock), "
                     f"{how} {'later' if diff > 0 else 'earlier'}; expected them within {RELEASE_TIME_TOL_S:g} s "
                     "(check [release] time_utc, its time zone and utc_at_zero)", field="release.time_utc")


def _altitude_at(track: GpsTrack, good: np.ndarray, t: np.ndarray, when: float) -> float | None:
    """GPS altitude (m MSL) at ``when`` from the nearest good fix within GPS_MAX_GAP_S, carried by its
    vertical speed; None without such a fix."""
    idx = np.flatnonzero(good)
    if idx.size == 0:
        return None
    k = idx[int(np.argmin(np.abs(t[idx] - when)))]
    if abs(t[k] - when) > GPS_MAX_GAP_S:
        return None
    return float(track.h_msl_m[k] - track.vel_d_mps[k] * (when - t[k]))


def check_coverage(track: GpsTrack, good: np.ndarray, t: np.ndarray, span: tuple[float, float], what: str,
                   when, field: str = "time") -> None:
    """Refuse a stretch of ``span`` (times ``t`` run on) longer than GPS_MAX_GAP_S without a good fix.

    ``when`` formats a time of ``t`` for the message (with its clock's name).
    """
    inside = np.flatnonzero(good & (t >= span[0]) & (t <= span[1]))
    edges = np.r_[span[0], t[inside], span[1]]
    holes = np.diff(edges)
    k = int(np.argmax(holes))
    if holes[k] <= GPS_MAX_GAP_S:
        return
    a, b = edges[k], edges[k + 1]
    start = "the start of " + what if k == 0 else when(a)
    end = "its end" if k == holes.size - 1 else when(b)
    n_good = int(good.sum())
    have = (f"the track's {n_good} good fixes run from {iso_utc(track.time_unix_s[good][0])} to "
            f"{iso_utc(track.time_unix_s[good][-1])}" if n_good else "the track has no good fix")
    raise InputError(track.path, f"no good GPS fix for {b - a:.1f} s, from {start} to {end} ({what}: "
                     f"{when(span[0])} to {when(span[1])}); expected one at least every {GPS_MAX_GAP_S:g} s; {have}",
                     field=field)


def check_sounding_top(path, launch: int, altitude_msl_m: float, what: str, sounding: Sounding | None = None) -> None:
    """Refuse a sounding whose top level is below ``altitude_msl_m`` (``what``, for the message);
    ``sounding``: the file ``path`` as already read (else it is read here)."""
    sounding = read_sounding(path, launch=launch) if sounding is None else sounding
    top = float(sounding.altitude_msl_m[-1])
    if top < altitude_msl_m:
        raise InputError(path, f"the sounding stops at {top:.0f} m MSL ({sounding.pressure_pa[-1] / 100:.1f} hPa), "
                         f"below {what} {altitude_msl_m:.0f} m MSL; expected levels up to it (is the file "
                         "truncated?)", field="altitude")


def check_point_mass_data(cfg: PointMassConfig, track: GpsTrack, quality: GpsQuality,
                          span_unix_s: tuple[float, float]) -> None:
    """The point-mass checks: GPS coverage of the segment, the sounding's top above its highest fix, and
    (a warning) the sounding's own date and place against the segment's start and ``[site]``."""
    good = good_fixes(track, quality)
    check_coverage(track, good, track.time_unix_s, span_unix_s, "the fitted segment", lambda t: f"{iso_utc(t)}")
    if cfg.sounding is not None:
        sounding = read_sounding(cfg.sounding)
        seg = good & (track.time_unix_s >= span_unix_s[0]) & (track.time_unix_s <= span_unix_s[1])
        check_sounding_top(cfg.sounding, 0, float(track.h_msl_m[seg].max(initial=-np.inf)),
                           "the segment's highest good fix", sounding)
        warning = sounding_origin_warning(sounding, span_unix_s[0], cfg.site.lat_deg, cfg.site.lon_deg,
                                          "the segment's start and [site]")
        if warning is not None:
            warn_once(warning)
