"""Pre-solve plausibility of the inputs against each other: what passes every file's own rules but
cannot belong to the same drop, found in milliseconds from the data already read.

- **barometer against the atmosphere** (:data:`BARO_RATIO` = 0.5 to 2): the median, over the
  barometer samples of the fitted span, of the measured pressure over the pressure the sounding
  (or the standard atmosphere) gives at the GPS altitude of the sample (interpolated between good
  fixes). A factor of 2 is 5.5 km of altitude, beyond any bias or weather; a file in hPa read as
  Pa gives 0.01, kPa 0.001. When the GPS gives no height (a flight computer's latitude/longitude
  log) the pressure at the site's ground altitude is the reference and the lower end is multiplied
  by the fall of pressure over :data:`NO_HEIGHT_SPAN_M` = 12 km above it (about 0.19: 0.097). Refused
  (an :class:`~casrecon.io.errors.InputError` on the barometer file, at the first sample compared),
  naming the ratio and the unit whose factor brings it nearest 1.
- **IMU impact against the GPS descent** (:data:`IMPACT_TIME_TOL_S` = 0.5 s, 6-DOF drops): the GPS's
  descent ends between the last fix descending faster than half its peak descent speed (after the
  IMU's release) and the next fix (rows with a 3D fix, whatever their accuracy: a receiver on the
  ground reports growing hAcc, and 40 m/s against 0 needs no accuracy filter); the IMU's impact (put on the GPS clock by
  ``[sensors.imu.clock] utc_at_zero``) must fall there, within 0.5 s (ten times the default clock
  offset prior, 2.5 periods of a 5 Hz receiver). The IMU log of another drop fails it (measured:
  ees-drop-4's IMU with ees-drop-1's GPS, impact 0.7 s early, which the impact-altitude check,
  50 m at 41 m/s, lets through). Skipped when the track ends descending (no end seen).
- **sounding's own date and place** (:data:`SOUNDING_MAX_DAYS` = 1 day, :data:`SOUNDING_MAX_KM` =
  100 km): when its file gives them (:mod:`casrecon.io.sounding_origin`), against the drop's
  (``[release] time_utc`` or the fitted span's start; ``[site]``). A warning only (logged, and
  printed by the command line, once per process however often the data are prepared), naming
  both: a sounding of the nearest station and day can be the best there is.
"""

from __future__ import annotations

import functools
import logging
import math

import numpy as np

from casrecon.io.baro import BaroLog, pressure_unit_hint
from casrecon.io.errors import InputError
from casrecon.io.flysight import GpsTrack, iso_utc, no_fix_mask
from casrecon.io.sounding_levels import Sounding
from casrecon.physics.atmosphere import standard_pressure

logger = logging.getLogger(__name__)

BARO_RATIO = (0.5, 2.0)
#: Without GPS heights: the span above the ground the vehicle may be anywhere in, m.
NO_HEIGHT_SPAN_M = 12000.0
#: Fewest barometer samples the comparison needs.
BARO_MIN_SAMPLES = 5
IMPACT_TIME_TOL_S = 0.5
#: The GPS shows a drop only when its peak descent speed (after the IMU's release) exceeds this, m/s.
MIN_DESCENT_MPS = 10.0
SOUNDING_MAX_DAYS = 1.0
SOUNDING_MAX_KM = 100.0
EARTH_RADIUS_KM = 6371.0


def _pressure(sounding: Sounding | None, alt_msl_m):
    return standard_pressure(alt_msl_m) if sounding is None else sounding_pressure(sounding, alt_msl_m)


def sounding_pressure(sounding: Sounding, alt_msl_m: np.ndarray) -> np.ndarray:
    """The sounding's pressure, Pa, at ``alt_msl_m`` (log-linear between levels, held beyond them)."""
    return np.exp(np.interp(alt_msl_m, sounding.altitude_msl_m, np.log(sounding.pressure_pa)))


def check_baro(log: BaroLog, sample_unix_s: np.ndarray, span_unix_s: tuple[float, float], track: GpsTrack,
               good: np.ndarray, ground_alt_msl_m: float, sounding: Sounding | None) -> None:
    """Refuse a barometer whose pressure is not within BARO_RATIO of the atmosphere's at the GPS altitude.

    Parameters
    ----------
    log : BaroLog
        The barometer file as read.
    sample_unix_s : (N,) array
        Its sample times on the GPS clock (UTC Unix seconds, or the clock the track is on), s.
    span_unix_s : (float, float)
        The fitted span on that clock, s.
    track, good : GpsTrack, (M,) bool array
        The GPS track and its good fixes.
    ground_alt_msl_m : float
        The site's ground altitude, m MSL (used when the track has no height).
    sounding : Sounding or None
        The atmosphere's sounding; None: the standard atmosphere.
    """
    use = np.flatnonzero((sample_unix_s >= span_unix_s[0]) & (sample_unix_s <= span_unix_s[1]))
    fixes = good & np.isfinite(track.h_msl_m)
    t_fix = track.time_unix_s[fixes]
    if t_fix.size >= 2:
        use = use[(sample_unix_s[use] >= t_fix[0]) & (sample_unix_s[use] <= t_fix[-1])]
        height = np.interp(sample_unix_s[use], t_fix, track.h_msl_m[fixes])
        where = f"at the GPS altitude ({height.min():.0f} to {height.max():.0f} m MSL)"
        lo, hi = BARO_RATIO
    else:
        height = np.full(use.size, float(ground_alt_msl_m))
        where = f"at the ground altitude {ground_alt_msl_m:.0f} m MSL (the GPS ({track.path}) gives no height)"
        top = ground_alt_msl_m + NO_HEIGHT_SPAN_M
        lo, hi = BARO_RATIO[0] * float(_pressure(sounding, top) / _pressure(sounding, ground_alt_msl_m)), BARO_RATIO[1]
    if use.size < BARO_MIN_SAMPLES:
        return
    expected = _pressure(sounding, height)
    measured = log.pressure_pa[use]
    ratio = float(np.median(measured / expected))
    if lo <= ratio <= hi:
        return
    atmosphere = "the standard atmosphere" if sounding is None else f"the sounding ({sounding.path})"
    line = None if log.lines is None else int(log.lines[use[0]])
    span = "" if t_fix.size >= 2 else f"; the lower end times the fall of pressure over {NO_HEIGHT_SPAN_M:g} m"
    raise InputError(log.path, f"measured pressure {np.median(measured):.6g} Pa (median of {use.size} samples in the "
                     f"fitted span, {measured.min():.6g} to {measured.max():.6g} Pa) is {ratio:.3g} times the "
                     f"{np.median(expected):.0f} Pa of {atmosphere} {where}; expected a ratio of {lo:.3g} to {hi:.3g} "
                     f"({BARO_RATIO[0]:g} to {BARO_RATIO[1]:g}: a factor of 2 is 5.5 km of altitude{span}); "
                     f"{pressure_unit_hint(lo / ratio, hi / ratio, log.pressure_column)}",
                     line=line, field=log.pressure_column)


def check_impact_time(imu_path, track: GpsTrack, zero_unix_s: float, release: float,
                      impact: float) -> None:
    """Refuse an IMU impact more than IMPACT_TIME_TOL_S away from the end of the GPS's descent.

    Parameters
    ----------
    imu_path : str or Path
        The IMU file (named in the error).
    track : GpsTrack
        The GPS track.
    zero_unix_s : float
        UTC of the IMU clock's zero (``[sensors.imu.clock] utc_at_zero``), Unix seconds.
    release, impact : float
        The IMU's release and impact on its clock, s.
    """
    t_fix = track.time_unix_s - zero_unix_s
    # every row with a 3D fix: the receiver's accuracy grows on the ground (poor fixes), but a speed
    # of 40 m/s against 0 needs no accuracy filter
    idx = np.flatnonzero(~no_fix_mask(track) & (t_fix > release) & np.isfinite(track.vel_d_mps))
    if idx.size < 2:
        return
    vd = track.vel_d_mps[idx]
    peak = float(vd.max())
    if peak < MIN_DESCENT_MPS:
        return
    fast = np.flatnonzero(vd > 0.5 * peak)
    last = int(fast[-1])
    if last == idx.size - 1:
        return
    a, b = float(t_fix[idx[last]]), float(t_fix[idx[last + 1]])
    if a - IMPACT_TIME_TOL_S <= impact <= b + IMPACT_TIME_TOL_S:
        return
    off = impact - a if impact < a else impact - b
    raise InputError(imu_path, f"the IMU's impact (t = {impact:.3f} s, {iso_utc(zero_unix_s + impact)} "
                     f"by utc_at_zero) is {abs(off):.2f} s {'before' if off < 0 else 'after'} the GPS's end of descent "
                     f"({track.path}: {vd[last]:.1f} m/s down at {iso_utc(track.time_unix_s[idx[last]])}, "
                     f"{vd[last + 1]:.1f} m/s at {iso_utc(track.time_unix_s[idx[last + 1]])}; peak {peak:.1f} m/s); "
                     f"expected within {IMPACT_TIME_TOL_S:g} s: is the IMU log of this drop, and its clock right?",
                     )


def distance_km(lat1: float, lon1: float, lat2: float, lon2: float) -> float:
    """Great-circle distance, km, between two points given in degrees."""
    p1, p2 = math.radians(lat1), math.radians(lat2)
    dp, dl = p2 - p1, math.radians(lon2 - lon1)
    h = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    return 2 * EARTH_RADIUS_KM * math.asin(min(1.0, math.sqrt(h)))


def sounding_origin_warning(sounding: Sounding, when_unix_s: float | None, lat_deg: float, lon_deg: float,
                            source: str) -> str | None:
    """A one-line warning when the sounding's own date or place (when its file gives them) is more
    than SOUNDING_MAX_DAYS or SOUNDING_MAX_KM from the drop's, naming both; else None.

    Parameters
    ----------
    sounding : Sounding
        The sounding as read.
    when_unix_s : float or None
        The drop's time, UTC Unix seconds (None: not on UTC, the date is not compared).
    lat_deg, lon_deg : float
        The drop's site, degrees.
    source : str
        Where the drop's time and place come from (for the message).
    """
    o = sounding.origin
    far = []
    if o.time_unix_s is not None and when_unix_s is not None:
        days = (when_unix_s - o.time_unix_s) / 86400.0
        if abs(days) > SOUNDING_MAX_DAYS:
            far.append(f"{abs(days):.1f} days {'before' if days < 0 else 'after'} its launch")
    if o.lat_deg is not None and o.lon_deg is not None:
        km = distance_km(o.lat_deg, o.lon_deg, lat_deg, lon_deg)
        if km > SOUNDING_MAX_KM:
            far.append(f"{km:.0f} km from it")
    if not far:
        return None
    launched = " at ".join(x for x in (
        None if o.time_unix_s is None else iso_utc(o.time_unix_s),
        None if o.lat_deg is None else f"lat {o.lat_deg:.4f} lon {o.lon_deg:.4f}") if x)
    drop = (f"{'' if when_unix_s is None else iso_utc(when_unix_s) + ' at '}lat {lat_deg:.4f} lon {lon_deg:.4f}")
    return str(InputError(sounding.path, f"WARNING: the sounding was launched {launched} and the drop is "
                          f"{' and '.join(far)} ({drop}, {source}); expected within {SOUNDING_MAX_DAYS:g} day and "
                          f"{SOUNDING_MAX_KM:g} km: is it the sounding of this drop? (used as given)", line=o.line))


@functools.lru_cache(maxsize=256)
def warn_once(message: str) -> None:
    """Log ``message`` as a warning, once per process (a fit prepares its data more than once)."""
    logger.warning("%s", message)
