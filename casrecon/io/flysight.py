"""FlySight GPS tracks: FlySight 1 CSV and FlySight 2 ``TRACK.CSV``, read and (FS1) written.

Rules kept by :func:`read_flysight` (all violations raise a located
:class:`~casrecon.io.errors.InputError`, nothing else escapes):

- columns are found by name, never by position; extra columns are ignored;
- the required columns are ``time, lat, lon, hMSL, velN, velE, velD, hAcc, vAcc, sAcc``;
  ``numSV`` and ``gpsFix`` are optional (``-1`` where absent or blank);
- the units row must give the expected unit for every column used (``deg``, ``m``, ``m/s``;
  FlySight 1 writes them in parentheses), an unknown unit is an error naming line and column;
- every value must be a finite number: blank cells, ``nan`` and ``inf`` are errors;
- times are ISO-8601 UTC (ending in ``Z``) and must be strictly increasing: a time going
  backwards *and a duplicated timestamp* are errors;
- a row with too few fields, or a last line without line terminator (file cut mid-write),
  is an error; trailing blank lines are ignored;
- the accuracies hAcc, vAcc and sAcc of a row that has a fix must be > 0: a receiver's
  1-sigma estimate is never zero or negative, so such a row is corrupt (an error naming its
  line). Rows *without* a fix (:func:`no_fix_mask`: ``gpsFix`` 0, 1, 2 or 5, or latitude,
  longitude and height all exactly 0 where the file has no ``gpsFix``) are kept as read,
  whatever their accuracies, and never used by a fit.

Every fix is kept, including cold-start fixes with poor accuracy: filtering on
``h_acc_m``/``v_acc_m``/``s_acc_mps``/``num_sv`` is the caller's decision
(:func:`casrecon.io.inspect.inspect_file` reports them).
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io._csvtools import check_increasing, find_columns, parse_floats, read_lines, split_rows
from casrecon.io.errors import InputError

#: Required columns and the unit each must have in the units row.
REQUIRED_UNITS: dict[str, str] = {
    "lat": "deg", "lon": "deg", "hMSL": "m", "velN": "m/s", "velE": "m/s", "velD": "m/s",
    "hAcc": "m", "vAcc": "m", "sAcc": "m/s",
}
#: Largest value accepted in the count columns (numSV, gpsFix); a receiver tracks a few dozen satellites.
MAX_COUNT = 255
_ISO_UTC = re.compile(r"\d{4}-\d\d-\d\dT\d\d:\d\d:\d\d(\.\d{1,6})?Z")
_FS1_HEADER = ("time", "lat", "lon", "hMSL", "velN", "velE", "velD", "hAcc", "vAcc", "sAcc",
               "heading", "cAcc", "gpsFix", "numSV")
_FS1_UNITS = ("", "(deg)", "(deg)", "(m)", "(m/s)", "(m/s)", "(m/s)", "(m)", "(m)", "(m/s)",
              "(deg)", "(deg)", "", "")


@dataclass(frozen=True)
class GpsTrack:
    """A GPS track as recorded by a FlySight.

    Attributes
    ----------
    path : str
        File the track was read from.
    format : str
        ``"flysight1"`` or ``"flysight2"``.
    time_unix_s : numpy.ndarray
        UTC time of each fix, seconds since 1970-01-01 (float64, ms resolution kept).
    lat_deg, lon_deg : numpy.ndarray
        WGS-84 geodetic latitude and longitude, degrees.
    h_msl_m : numpy.ndarray
        Height above mean sea level, m.
    vel_n_mps, vel_e_mps, vel_d_mps : numpy.ndarray
        NED velocity, m/s (down positive).
    h_acc_m, v_acc_m : numpy.ndarray
        Receiver's horizontal and vertical position accuracy estimates, m.
    s_acc_mps : numpy.ndarray
        Receiver's speed accuracy estimate, m/s.
    num_sv : numpy.ndarray
        Satellites used (int64), ``-1`` where the file has no value.
    gps_fix : numpy.ndarray, optional
        The receiver's fix type (int64; u-blox/FlySight ``gpsFix``: 0 none, 1 dead reckoning,
        2 2D, 3 3D, 4 GNSS + dead reckoning, 5 time only), ``-1`` where the file has no value
        (FlySight 2 tracks have none). Default: all ``-1``.
    notes : tuple of str, optional
        What the reader skipped or assumed (other readers than FlySight: NMEA, GNSS CSV). Default: none.

    Notes
    -----
    Other readers (:mod:`casrecon.io.nmea`, :mod:`casrecon.io.gnss_csv`) give NaN for a value their file
    does not hold (vertical velocity, altitude, accuracies of those): see
    :func:`casrecon.io.gps_rules.fixes_ned`.
    """

    path: str
    format: str
    time_unix_s: np.ndarray
    lat_deg: np.ndarray
    lon_deg: np.ndarray
    h_msl_m: np.ndarray
    vel_n_mps: np.ndarray
    vel_e_mps: np.ndarray
    vel_d_mps: np.ndarray
    h_acc_m: np.ndarray
    v_acc_m: np.ndarray
    s_acc_mps: np.ndarray
    num_sv: np.ndarray
    gps_fix: np.ndarray | None = None
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        if self.gps_fix is None:
            object.__setattr__(self, "gps_fix", np.full(np.shape(self.time_unix_s), -1, dtype=np.int64))

    @property
    def n(self) -> int:
        """Number of fixes."""
        return int(self.time_unix_s.size)


#: ``gpsFix`` values of a position fix a fit can use: 3 (3D) and 4 (GNSS + dead reckoning).
FIX_3D = (3, 4)


def no_fix_mask(track: GpsTrack) -> np.ndarray:
    """Rows of ``track`` that hold no usable 3D position fix: ``gpsFix`` present and not 3 or 4
    (0 no fix, 1 dead reckoning only, 2 2D, 5 time only), or, where the file gives no ``gpsFix``,
    latitude, longitude and height all exactly 0 (the receiver's placeholder without a fix)."""
    zero = (track.lat_deg == 0) & (track.lon_deg == 0) & (track.h_msl_m == 0)
    known = track.gps_fix >= 0
    return np.where(known, ~np.isin(track.gps_fix, FIX_3D), zero)


def iso_utc(t_unix_s: float | np.ndarray) -> str | np.ndarray:
    """Format UTC seconds since 1970 as ISO-8601 with milliseconds and a ``Z``."""
    ms = np.round(np.asarray(t_unix_s, dtype=np.float64) * 1000.0).astype(np.int64)
    text = np.char.add(np.datetime_as_string(ms.astype("datetime64[ms]"), unit="ms"), "Z")
    return str(text) if text.ndim == 0 else text


def parse_iso_times(path: str | Path, cells: list[str], line_numbers: list[int],
                    field: str = "time") -> np.ndarray:
    """Parse ISO-8601 UTC times (``2019-05-25T20:21:18.60Z``) to Unix seconds.

    Vectorised through ``numpy.datetime64``; on failure a slow pass finds the bad line.

    Raises
    ------
    InputError
        On a time that is not ``YYYY-MM-DDThh:mm:ss[.fff]Z``, with its line.
    """
    texts = [c.strip() for c in cells]
    good = [_ISO_UTC.fullmatch(c) is not None for c in texts]
    try:
        if not all(good):
            raise ValueError
        us = np.array([c[:-1] for c in texts], dtype="datetime64[us]").astype(np.int64)
    except ValueError:
        for k, text in enumerate(texts):
            try:
                if not good[k]:
                    raise ValueError
                np.datetime64(text[:-1], "us")
            except ValueError:
                raise InputError(path, f"bad time '{text[:40]}'; expected ISO-8601 UTC like "
                                 "2019-05-25T20:21:18.60Z", line=line_numbers[k],
                                 field=field) from None
        raise InputError(path, "bad time", field=field) from None
    return us.astype(np.float64) / 1e6


def read_flysight(path: str | Path) -> GpsTrack:
    """Read a FlySight 1 CSV or FlySight 2 ``TRACK.CSV``, detecting which from the first line.

    Parameters
    ----------
    path : str or Path
        The track file.

    Returns
    -------
    GpsTrack
        All fixes of the file, in file order (strictly increasing time).

    Raises
    ------
    InputError
        On any malformed content (see the module docstring for the rules: missing column,
        unknown unit, truncated row, unparseable / NaN / infinite number, time going
        backwards, duplicated timestamp), located by line and column. A FlySight 2
        ``SENSOR.CSV`` is recognised and refused (it holds no track: read it with
        :func:`casrecon.io.sensor.read_flysight2_sensor`).

    Notes
    -----
    NaN, inf and blank values are errors (``numSV`` may be blank: -1); duplicated and
    backwards timestamps are errors; gaps are kept as recorded (``casrecon inspect``
    reports them); an unknown unit in the units row is an error.
    """
    lines = read_lines(path, require_final_newline=True)
    while lines and not lines[-1].strip():
        lines.pop()
    first = lines[0].strip() if lines else ""
    if first.startswith("$FLYS"):
        return _read_fs2(path, lines)
    if "time" in first.split(",") and "lat" in first.split(","):
        return _read_fs1(path, lines)
    raise InputError(path, "not a FlySight track: expected a FlySight 1 header "
                     "'time,lat,lon,hMSL,...' or a FlySight 2 '$FLYS' first line", line=1)


def _read_fs1(path: str | Path, lines: list[str]) -> GpsTrack:
    header = [h.strip() for h in lines[0].split(",")]
    start = 1
    units: list[str] | None = None
    if len(lines) > 1 and (lines[1].startswith(",") or "(" in lines[1]):
        units = [u.strip().strip("()") for u in lines[1].split(",")]
        start = 2
    return _build(path, "flysight1", (header, 1), units, 2, lines[start:], start + 1)


def _read_fs2(path: str | Path, lines: list[str]) -> GpsTrack:
    header: list[str] | None = None
    units: list[str] | None = None
    unit_line = header_line = 0
    data_at = None
    kinds = []
    for k, line in enumerate(lines):
        fields = [f.strip() for f in line.split(",")]
        if fields[0] == "$COL" and len(fields) > 1:
            kinds.append(fields[1])
            if fields[1] == "GNSS":
                header, header_line = fields[2:], k + 1
        elif fields[0] == "$UNIT" and len(fields) > 1 and fields[1] == "GNSS":
            units, unit_line = fields[2:], k + 1
        elif fields[0] == "$DATA":
            data_at = k + 1
            break
    if header is None:
        if {"IMU", "BARO"} & set(kinds):
            raise InputError(path, "FlySight 2 SENSOR.CSV holds no GNSS track; read it with "
                             "casrecon.io.sensor.read_flysight2_sensor")
        raise InputError(path, "FlySight 2 file without a '$COL,GNSS,...' header line",
                         field="$COL,GNSS")
    if data_at is None:
        raise InputError(path, "FlySight 2 header has no '$DATA' line", line=len(lines))
    body, numbers = [], []
    for k in range(data_at, len(lines)):
        line = lines[k]
        if line.startswith("$GNSS"):
            body.append(line.split(",", 1)[1] if "," in line else "")
            numbers.append(k + 1)
        elif not line.startswith("$"):
            raise InputError(path, "data line does not start with '$' (expected '$GNSS,...')",
                             line=k + 1)
    return _build(path, "flysight2", (header, header_line), units, unit_line, body, numbers)


def _check_units(path: str | Path, header: list[str], units: list[str] | None,
                 unit_line: int) -> None:
    if units is None:
        return
    for k, name in enumerate(header):
        expected = REQUIRED_UNITS.get(name)
        if expected is None:
            continue
        got = units[k] if k < len(units) else ""
        if got != expected:
            raise InputError(path, f"unknown unit '{got}' for column {name}; expected "
                             f"'{expected}'", line=unit_line, field=name)


def _build(path: str | Path, fmt: str, located_header: tuple[list[str], int],
           units: list[str] | None,
           unit_line: int, body: list[str], first: int | list[int]) -> GpsTrack:
    """Parse the data rows of either format into a GpsTrack.

    ``located_header`` is (column names, 1-based header line); ``first`` is the line of
    ``body[0]`` (rows contiguous) or the list of line numbers of every row.
    """
    wanted = ["time", *REQUIRED_UNITS]
    header, header_line = located_header
    col = find_columns(path, header, wanted, line=header_line, kind="a FlySight track")
    _check_units(path, header, units, unit_line)
    numbers = list(range(first, first + len(body))) if isinstance(first, int) else first
    if not body:
        raise InputError(path, "no data rows after the header")
    rows = split_rows(path, body, numbers, len(header))
    cols = {name: [r[col[name]] for r in rows] for name in wanted}
    t = parse_iso_times(path, cols["time"], numbers)
    check_increasing(path, t, numbers, "time", fmt=lambda x: str(iso_utc(x)))
    v = {name: parse_floats(path, cols[name], numbers, name) for name in REQUIRED_UNITS}
    counts = {}
    for name in ("numSV", "gpsFix"):
        counts[name] = np.full(t.size, -1, dtype=np.int64)
        if name in header:
            k = header.index(name)
            got = parse_floats(path, [r[k] for r in rows], numbers, name, allow_empty=True)
            bad = np.flatnonzero(~np.isnan(got) & ~((got >= 0) & (got <= MAX_COUNT) & (got == np.round(got))))
            if bad.size:
                raise InputError(path, f"{name} {got[bad[0]]:g} is not a count (expected a whole number from 0 to "
                                       f"{MAX_COUNT}, or empty)", line=numbers[bad[0]], field=name)
            counts[name] = np.where(np.isnan(got), -1, np.nan_to_num(got)).astype(np.int64)
    track = GpsTrack(str(path), fmt, t, v["lat"], v["lon"], v["hMSL"], v["velN"], v["velE"],
                     v["velD"], v["hAcc"], v["vAcc"], v["sAcc"], counts["numSV"], counts["gpsFix"])
    _check_accuracies(path, track, numbers)
    return track


def _check_accuracies(path: str | Path, track: GpsTrack, numbers: list[int]) -> None:
    """Refuse a row with a fix whose hAcc, vAcc or sAcc is not > 0 (corrupt: the fit divides by them)."""
    fixed = ~no_fix_mask(track)
    for name, unit, acc in (("hAcc", "m", track.h_acc_m), ("vAcc", "m", track.v_acc_m),
                            ("sAcc", "m/s", track.s_acc_mps)):
        bad = fixed & ~(acc > 0)
        if bad.any():
            k = int(np.argmax(bad))
            raise InputError(path, f"accuracy {float(acc[k]):g} {unit} at {iso_utc(track.time_unix_s[k])}; expected "
                             "> 0 (a receiver's 1-sigma estimate is positive: a zero or negative one marks a "
                             "corrupt row)", line=int(numbers[k]), field=name)


def write_flysight1(path: str | Path, track: GpsTrack) -> None:
    """Write a track in exactly the FlySight 1 CSV layout.

    Header line and units line as the device writes them, then one row per fix with the
    device's precision (lat/lon 1e-7 deg, heights 1 mm, velocities 1 cm/s). Times are
    ``2019-05-25T20:21:18.60Z`` (centiseconds, as the device) when every time is a whole
    number of 10 ms, otherwise with milliseconds. ``gpsFix`` is the track's (3 where unknown); ``heading`` is the
    course over ground from velN/velE (deg, 0..360) and ``cAcc`` the course accuracy
    ``sAcc / ground speed`` in degrees (capped at 180); ``numSV`` is blank where ``-1``.

    Parameters
    ----------
    path : str or Path
        Output file (overwritten).
    track : GpsTrack
        The fixes to write.
    """
    ms = np.round(np.asarray(track.time_unix_s, dtype=np.float64) * 1000.0).astype(np.int64)
    times = np.datetime_as_string(ms.astype("datetime64[ms]"), unit="ms")
    cut = -1 if np.all(ms % 10 == 0) else None
    times = [f"{t[:cut]}Z" for t in times]
    gs = np.hypot(track.vel_n_mps, track.vel_e_mps)
    heading = np.degrees(np.arctan2(track.vel_e_mps, track.vel_n_mps)) % 360.0
    c_acc = np.minimum(np.degrees(track.s_acc_mps / np.maximum(gs, 1e-9)), 180.0)
    fix = np.where(track.gps_fix < 0, 3, track.gps_fix)
    out = [",".join(_FS1_HEADER), ",".join(_FS1_UNITS)]
    for k in range(track.n):
        sv = "" if track.num_sv[k] < 0 else str(int(track.num_sv[k]))
        out.append(f"{times[k]},{track.lat_deg[k]:.7f},{track.lon_deg[k]:.7f},"
                   f"{track.h_msl_m[k]:.3f},{track.vel_n_mps[k]:.2f},{track.vel_e_mps[k]:.2f},"
                   f"{track.vel_d_mps[k]:.2f},{track.h_acc_m[k]:.3f},{track.v_acc_m[k]:.3f},"
                   f"{track.s_acc_mps[k]:.2f},{heading[k]:.5f},{c_acc[k]:.5f},{fix[k]},{sv}")
    Path(path).write_text("\n".join(out) + "\n", encoding="utf-8")
