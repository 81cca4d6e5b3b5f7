"""GNSS logs of flight computers that write latitude and longitude only, on their own clock (the CATS
flight computer's ``gnssInfo.csv``: ``ts,latitude,longitude,satellites``), read into a
:class:`~casrecon.io.flysight.GpsTrack` (format ``"gnss-csv"``).

Time base: ``ts`` is the flight computer's clock (s), the clock of its IMU (``imu.csv`` ``ts``); the log
holds no UTC. The track's ``time_unix_s`` is ``utc_at_zero_s + ts``: with the default ``utc_at_zero_s = 0``
it is the IMU clock itself, and a fit that maps a fix stamped ``u`` to IMU time ``u - utc_at_zero`` (see
:mod:`casrecon.estimation.sixdof.fitdata`) takes ``[sensors.imu.clock] utc_at_zero = "1970-01-01T00:00:00Z"``
(or the same instant given to both).

Rules (violations raise a located :class:`~casrecon.io.errors.InputError`):

- columns found by name: ``ts`` (s), ``latitude``, ``longitude`` (deg, WGS-84); ``satellites`` optional;
  other columns ignored; every cell used is a finite number; ``ts`` strictly increases;
  latitude within +-90 and longitude within +-180 deg;
- missing components: no altitude (``h_msl_m``, ``v_acc_m`` NaN) and no velocity (NaN, ``s_acc_mps``
  NaN): a fit uses the horizontal position only (:func:`casrecon.io.gps_rules.fixes_ned`);
- horizontal accuracy: the log gives none; each of north and east takes ``h_acc_m`` (default
  :data:`DEFAULT_H_ACC_M`);
- ``satellites`` 0 is no fix (``gps_fix`` 0, dropped by a fit); a count above :data:`MAX_SATELLITES`
  is not a count (the CATS log writes 193 while positions update): ``num_sv`` -1 (unknown); other rows
  ``gps_fix`` 3 (a horizontal fix; the log does not say 2D or 3D);
- stale rows: the logger writes its last fix at every log epoch, so a row whose latitude and longitude
  repeat the previous row's exactly holds no new fix: it is dropped (counted in the track's notes);
  the first row of a new position is kept, stamped when the logger wrote it.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from casrecon.io._csvtools import check_increasing, find_columns, parse_floats, read_lines, split_rows
from casrecon.io.errors import InputError
from casrecon.io.flysight import GpsTrack

#: Columns a flight-computer GNSS CSV must have (satellites is optional).
COLUMNS = ("ts", "latitude", "longitude")
#: 1-sigma of each horizontal position component when the log gives no accuracy, m: a consumer receiver
#: with a fair sky has HDOP about 1 to 1.5 and a 3 to 5 m UERE (:data:`casrecon.io.nmea.UERE_M`), i.e.
#: 3 to 5 m radial, 2 to 3.5 m per axis; 5 m also covers a tumbling vehicle's antenna.
DEFAULT_H_ACC_M = 5.0
#: Largest plausible satellite count (GPS + GLONASS + Galileo + BeiDou in view).
MAX_SATELLITES = 99


def is_gnss_csv(header: list[str]) -> bool:
    """Whether a CSV header (cells) is that of a flight-computer GNSS log."""
    return all(c in header for c in COLUMNS) and "hMSL" not in header


def read_gnss_csv(path: str | Path, utc_at_zero_s: float = 0.0, h_acc_m: float = DEFAULT_H_ACC_M) -> GpsTrack:
    """Read a flight-computer GNSS CSV (see the module docstring for the rules and the time base).

    Parameters
    ----------
    path : str or Path
        The log.
    utc_at_zero_s : float
        UTC (s since 1970) of ``ts = 0``; default 0: ``time_unix_s`` is the flight computer's clock.
    h_acc_m : float
        1-sigma of each horizontal position component, m.

    Returns
    -------
    GpsTrack
        Format ``"gnss-csv"``; stale repeats dropped; NaN altitude and velocity.
    """
    lines = read_lines(path)
    header = [h.strip() for h in lines[0].split(",")]
    col = find_columns(path, header, COLUMNS, line=1, kind="a GNSS CSV (ts,latitude,longitude,satellites)")
    body = [ln for ln in lines[1:] if ln.strip()]
    numbers = [k + 2 for k, ln in enumerate(lines[1:]) if ln.strip()]
    if not body:
        raise InputError(path, "no data rows after the header", line=1)
    rows = split_rows(path, body, numbers, len(header))
    t, lat, lon = (parse_floats(path, [r[col[c]] for r in rows], numbers, c) for c in COLUMNS)
    check_increasing(path, t, numbers, "ts")
    for name, v, limit in (("latitude", lat, 90.0), ("longitude", lon, 180.0)):
        bad = np.flatnonzero(np.abs(v) > limit)
        if bad.size:
            k = int(bad[0])
            raise InputError(path, f"{name} {v[k]:g} deg is beyond +-{limit:g} deg", line=numbers[k], field=name)
    sv = np.full(t.size, -1, dtype=np.int64)
    if "satellites" in header:
        k = header.index("satellites")
        got = parse_floats(path, [r[k] for r in rows], numbers, "satellites")
        sv = np.where(got <= MAX_SATELLITES, got, -1).astype(np.int64)
    stale = np.r_[False, (lat[1:] == lat[:-1]) & (lon[1:] == lon[:-1])]
    keep = ~stale
    n = int(keep.sum())
    fix = np.where(sv[keep] == 0, 0, 3).astype(np.int64)
    nan = np.full(n, np.nan)
    notes = (f"GNSS CSV: {n} fixes on the flight computer clock (time_unix_s = {utc_at_zero_s:g} + ts); "
             f"{int(stale.sum())} rows repeating the previous position dropped (stale); no altitude, no velocity; "
             f"horizontal 1-sigma {h_acc_m:g} m per axis (assumed)",)
    return GpsTrack(str(path), "gnss-csv", utc_at_zero_s + t[keep], lat[keep], lon[keep], nan, nan, nan.copy(),
                    nan.copy(), np.full(n, float(h_acc_m)), nan.copy(), nan.copy(), sv[keep], fix, notes)
