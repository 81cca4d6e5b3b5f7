"""The GPS rules every fit applies, in one place: which fixes are good enough to use (a 3D fix, and
the quality thresholds), and how a fix becomes an antenna position and velocity in the site's NED
frame with its 1-sigma accuracies (north and east by hAcc, down by vAcc, each velocity component by
sAcc, or per axis by ``velocity_sigma_mps``), and back (:func:`ned_to_geodetic`, for the latitude, longitude
and h_MSL columns of the results).

Missing components: a track may hold NaN for what its file does not give (no vertical velocity in NMEA,
no altitude and no velocity in a latitude/longitude-only GNSS log). :func:`fixes_ned` returns such a
component as NaN with an infinite sigma; a consumer whitening by 1/sigma gives it zero weight once the
NaN is replaced by any finite number, and counts only finite-sigma components as measurements. The
quality rules test an accuracy only where it is known (a NaN accuracy belongs to a missing component).

Used by the 6-DOF fit (thresholds from ``[estimation]``) and the point-mass fit (``[quality]``).
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass

import numpy as np
import pymap3d

from casrecon.io.flysight import GpsTrack, no_fix_mask
from casrecon.io.toml_fields import Fields
from casrecon.physics.dynamics import Site
from casrecon.physics.sensor_errors import MAX_CORRELATED_FRACTION, GpsErrorModel


@dataclass(frozen=True)
class GpsQuality:
    """Fixes reporting worse accuracy than these (1-sigma) or fewer satellites are dropped, and so
    are rows without a 3D fix (:func:`casrecon.io.flysight.no_fix_mask`).

    Parameters
    ----------
    max_h_acc_m, max_v_acc_m : float
        Largest reported horizontal and vertical accuracy, m.
    max_s_acc_mps : float
        Largest reported speed accuracy, m/s.
    min_num_sv : int
        Fewest satellites (not tested where the file has no numSV).
    """

    max_h_acc_m: float = 10.0
    max_v_acc_m: float = 10.0
    max_s_acc_mps: float = 1.0
    min_num_sv: int = 6

    def describe(self) -> str:
        """The rules in words, for notes on what was dropped."""
        return (f"no 3D fix, hAcc > {self.max_h_acc_m} m, vAcc > {self.max_v_acc_m} m, sAcc > "
                f"{self.max_s_acc_mps} m/s or numSV < {self.min_num_sv}")


def good_fixes(track: GpsTrack, q: GpsQuality) -> np.ndarray:
    """Boolean mask of the fixes of ``track`` that hold a 3D fix and pass the quality rules ``q``."""
    sv_ok = (track.num_sv < 0) | (track.num_sv >= q.min_num_sv)
    # "not worse than": a NaN accuracy (missing component) passes; a fix without position passes no rule
    return ~(track.h_acc_m > q.max_h_acc_m) & ~(track.v_acc_m > q.max_v_acc_m) & ~(
        track.s_acc_mps > q.max_s_acc_mps) & sv_ok & ~no_fix_mask(track) & np.isfinite(track.lat_deg + track.lon_deg)


#: The quality rules as keys of a problem's GPS table: (key, GpsQuality field, the track's field,
#: whether a fix fails by being above the value, what the field is).
QUALITY_KEYS = (("max_h_acc_m", "h_acc_m", True, "hAcc", "m"), ("max_v_acc_m", "v_acc_m", True, "vAcc", "m"),
                ("max_s_acc_mps", "s_acc_mps", True, "sAcc", "m/s"), ("min_num_sv", "num_sv", False, "numSV", ""))
#: A filter "removes nearly every fix" when fewer than this fraction of the fixes with a position pass it.
NEARLY_ALL = 0.05


def filter_note(track: GpsTrack, q: GpsQuality, table: str = "gps") -> str | None:
    """When the quality rules ``q`` remove every fix of ``track`` with a position, or nearly all (fewer
    than :data:`NEARLY_ALL` of them pass), the rules that do it, as keys of the problem's ``[table]``
    with their values and how many fixes each removes (``[gps] max_h_acc_m = 0.01 removes 2311 of
    2320 fixes (hAcc above it)``); None otherwise."""
    fixed = ~no_fix_mask(track) & np.isfinite(track.lat_deg + track.lon_deg)
    n = int(fixed.sum())
    if not n or good_fixes(track, q).sum() >= NEARLY_ALL * n:
        return None
    parts = []
    for key, field, above, name, unit in QUALITY_KEYS:
        value, values = getattr(q, key), getattr(track, field)
        if field == "num_sv":
            removed = fixed & (values >= 0) & (values < value)
        else:
            removed = fixed & (values > value)
        if removed.any():
            side = "above" if above else "below"
            parts.append((int(removed.sum()), f"{key} = {value} removes {int(removed.sum())} of {n} fixes "
                                              f"({name} {side} it{', ' + unit if unit else ''})"))
    if not parts:
        return None
    rules = "; ".join(text for _, text in sorted(parts, key=lambda x: -x[0]))
    return f"the GPS quality filter of [{table}] leaves {int(good_fixes(track, q).sum())} of {n} fixes: {rules}"


def no_fix_note(track: GpsTrack, mask: np.ndarray | None = None) -> str | None:
    """A note on the rows without a 3D fix (within ``mask`` when given) that a fit drops, or None."""
    bad = no_fix_mask(track) if mask is None else no_fix_mask(track) & mask
    n = int(bad.sum())
    if not n:
        return None
    values = sorted({int(v) for v in track.gps_fix[bad]})
    how = (f"gpsFix {', '.join(map(str, values))}" if values != [-1]
           else "latitude, longitude and height all 0")
    return f"{n} GPS rows without a 3D fix ({how}) dropped"


def fixes_ned(track: GpsTrack, site: Site, idx,
              velocity_sigma_mps: tuple[float, float, float] | None = None
              ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Antenna position and velocity of the fixes ``idx`` in the site's NED frame, with their 1-sigma.

    Parameters
    ----------
    track : GpsTrack
        The fixes as read (NaN where the file gives no value).
    site : Site
        Origin of the NED frame (its ground point, height MSL).
    idx : index array or boolean mask
        The fixes wanted.
    velocity_sigma_mps : (3,) floats, optional
        1-sigma of the north, east and down velocity, m/s, replacing the receiver's sAcc on every axis
        (``[gps] velocity_sigma_mps``). Default: sAcc on each axis.

    Returns
    -------
    pos : (n, 3) array
        Antenna position, m, NED from the site's ground point.
    vel : (n, 3) array
        Antenna velocity, m/s, NED.
    sigma : (n, 6) array
        1-sigma of the six: hAcc, hAcc, vAcc (m), then sAcc or ``velocity_sigma_mps`` (m/s).

    Notes
    -----
    A component the track does not give (value or accuracy NaN) is NaN in ``pos``/``vel`` and has an
    infinite sigma. Without a height (``h_msl_m`` NaN) the north and east positions are those of the
    latitude and longitude at the site's ground altitude, and down is missing: the horizontal error of
    that choice is d * dh / R_earth (d the horizontal distance from the site, dh the height above the
    ground), 0.8 m at 1 km from the site and 5 km up, below a receiver's typical 2 to 5 m.
    """
    h = np.asarray(track.h_msl_m[idx], dtype=float)
    no_h = ~np.isfinite(h)
    n, e, d = pymap3d.geodetic2ned(track.lat_deg[idx], track.lon_deg[idx], np.where(no_h, site.ground_alt_msl_m, h),
                                   site.lat_deg, site.lon_deg, site.ground_alt_msl_m)
    pos = np.column_stack([n, e, np.where(no_h, np.nan, d)])
    vel = np.column_stack([track.vel_n_mps[idx], track.vel_e_mps[idx], track.vel_d_mps[idx]])
    s_acc = np.asarray(track.s_acc_mps[idx], dtype=float)
    vel_sigma = ([s_acc] * 3 if velocity_sigma_mps is None
                 else [np.full(s_acc.shape, float(v)) for v in velocity_sigma_mps])
    sigma = np.column_stack([track.h_acc_m[idx], track.h_acc_m[idx], track.v_acc_m[idx], *vel_sigma]).astype(float)
    values = np.column_stack([pos, vel])
    sigma = np.where(np.isfinite(values) & np.isfinite(sigma), sigma, np.inf)
    return pos, vel, sigma


def present(sigma: np.ndarray) -> np.ndarray:
    """Mask of the components :func:`fixes_ned` gives (finite sigma): the measurements a fit counts."""
    return np.isfinite(sigma)


def interpolate_fixes(t_out: np.ndarray, t: np.ndarray, pos: np.ndarray, vel: np.ndarray
                      ) -> tuple[np.ndarray, np.ndarray]:
    """Position and velocity (len(t_out), 3 each) at the times ``t_out`` from fixes at ``t`` with NaN where a
    component is missing (:func:`fixes_ned`), for initial guesses: each component interpolated through its
    finite values; a velocity component no fix gives is the derivative of its position; a position
    component no fix gives (no height) is the integral of its velocity from 0, else 0."""
    out = [np.full((t_out.size, 3), np.nan), np.full((t_out.size, 3), np.nan)]
    for j, values in enumerate((pos, vel)):
        for i in range(3):
            ok = np.isfinite(values[:, i])
            if ok.any():
                out[j][:, i] = np.interp(t_out, t[ok], values[ok, i])
    p, v = out
    for i in range(3):
        if np.isnan(v[:, i]).any():
            v[:, i] = np.gradient(p[:, i], t_out) if np.isfinite(p[:, i]).all() and t_out.size > 1 else 0.0
        if np.isnan(p[:, i]).any():
            p[:, i] = np.r_[0.0, np.cumsum(np.diff(t_out) * 0.5 * (v[1:, i] + v[:-1, i]))]
    return p, v


def ned_to_geodetic(pos_ned: np.ndarray, site: Site) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Latitude and longitude (deg, WGS-84) and height above mean sea level (m) of NED positions
    (n, 3; m from the site's ground point): ``pymap3d.ned2geodetic``, the exact inverse of
    :func:`fixes_ned` (heights in and out are MSL, the site's ground altitude being MSL)."""
    pos = np.atleast_2d(np.asarray(pos_ned, dtype=float))
    lat, lon, h = pymap3d.ned2geodetic(pos[:, 0], pos[:, 1], pos[:, 2], site.lat_deg, site.lon_deg,
                                       site.ground_alt_msl_m)
    return np.asarray(lat, dtype=float), np.asarray(lon, dtype=float), np.asarray(h, dtype=float)


#: WGS-84 semi-major axis (m) and first eccentricity squared.
WGS84_A_M = 6378137.0
WGS84_E2 = 6.69437999014e-3


def geodetic_sigmas(latitude_deg, h_m, sigma_ned) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Sigmas of latitude and longitude (deg) and of height (m) from the sigmas of NED positions.

    To first order a north error dN moves the latitude by dN / (M + h) rad and an east error dE
    the longitude by dE / ((N + h) cos(lat)) rad, where M = a (1 - e^2) / (1 - e^2 sin^2 lat)^1.5
    and N = a / (1 - e^2 sin^2 lat)^0.5 are the WGS-84 meridian and prime-vertical radii of
    curvature at the point; a down error lowers the height by dD. So the latitude sigma is the
    north sigma over (M + h) and the longitude sigma the east sigma over (N + h) cos(lat), both
    converted to deg, and the height sigma is the down sigma. The NED frame's axes are the site's,
    turned from the point's own by its distance over the Earth radius (1e-3 rad at 6 km), which is
    neglected; so is the height's geoid undulation (1e-5 relative in the radii).

    Parameters
    ----------
    latitude_deg : array_like
        (n,) latitude of the points, deg.
    h_m : array_like
        (n,) height of the points (MSL, taken as ellipsoidal for the radii), m.
    sigma_ned : array_like
        (n, 3) sigmas (any multiple: 1- or 3-sigma) of the north, east and down positions, m.

    Returns
    -------
    sigma_latitude_deg, sigma_longitude_deg, sigma_h_m : ndarray
        (n,) each, the same multiple of sigma as ``sigma_ned``.
    """
    lat = np.radians(np.asarray(latitude_deg, dtype=float))
    h = np.asarray(h_m, dtype=float)
    sig = np.atleast_2d(np.asarray(sigma_ned, dtype=float))
    w = 1.0 - WGS84_E2 * np.sin(lat) ** 2
    meridian = WGS84_A_M * (1.0 - WGS84_E2) / w ** 1.5
    prime = WGS84_A_M / np.sqrt(w)
    return (np.degrees(sig[:, 0] / (meridian + h)), np.degrees(sig[:, 1] / ((prime + h) * np.cos(lat))),
            sig[:, 2].copy())


def gps_error_model(t: Fields) -> GpsErrorModel:
    """The GPS error model keys of ``[sensors.gps]`` (6-DOF) or ``[gps]`` (point-mass problems)."""
    default = GpsErrorModel()
    times = [t.number(f"{g}_error_time_s", getattr(default, f"{g}_time_s"), minimum=0.0)
             for g in ("position", "velocity")]
    fractions = []
    for g in ("position", "velocity"):
        key = f"{g}_correlated_fraction"
        f = t.number(key, getattr(default, f"{g}_fraction"), minimum=0.0)
        if f > MAX_CORRELATED_FRACTION:
            raise t.error(key, f"expected a fraction of the variance in [0, {MAX_CORRELATED_FRACTION}] (some white "
                               f"noise must remain), got {f}")
        fractions.append(f)
    scales = [t.number(f"{g}_accuracy_scale", 1.0, positive=True) for g in ("position", "velocity")]
    return GpsErrorModel(times[0], times[1], fractions[0], fractions[1], scales[0], scales[1])


def gps_date(t: Fields) -> dt.date | None:
    """``date`` of a GPS table: the UTC date (``"YYYY-MM-DD"`` or a TOML date) of the first fix of an
    NMEA log whose sentences carry none (GGA only); None when absent."""
    value = t.raw("date", None)
    if value is None or (isinstance(value, dt.date) and not isinstance(value, dt.datetime)):
        return value
    if isinstance(value, str):
        try:
            return dt.date.fromisoformat(value)
        except ValueError:
            pass
    raise t.error("date", f"expected a UTC date YYYY-MM-DD, got {value!r}")


def velocity_sigma(t: Fields) -> tuple[float, float, float] | None:
    """``velocity_sigma_mps`` of a GPS table: [north, east, down] 1-sigma (m/s, each > 0) replacing the
    receiver's sAcc on each axis (:func:`fixes_ned`); None when absent."""
    v = t.vector("velocity_sigma_mps", 3)
    if v is not None and min(v) <= 0:
        raise t.error("velocity_sigma_mps", f"expected three positive numbers [north, east, down] m/s, got {list(v)}")
    return v
