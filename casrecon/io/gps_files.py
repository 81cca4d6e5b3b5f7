"""Any GPS file a fit can take, told from its first lines: FlySight 1 or 2 track
(:mod:`casrecon.io.flysight`), NMEA 0183 log (:mod:`casrecon.io.nmea`) or flight-computer GNSS CSV
(:mod:`casrecon.io.gnss_csv`), each read into a :class:`~casrecon.io.flysight.GpsTrack`."""

from __future__ import annotations

import datetime as dt
from pathlib import Path

from casrecon.io._csvtools import read_lines
from casrecon.io.errors import InputError
from casrecon.io.flysight import GpsTrack, read_flysight
from casrecon.io.gnss_csv import is_gnss_csv, read_gnss_csv
from casrecon.io.nmea import is_nmea, read_nmea

#: GPS file kinds :func:`gps_file_kind` tells apart.
GPS_KINDS = ("flysight", "nmea", "gnss-csv")


def gps_file_kind(lines: list[str]) -> str | None:
    """``"flysight"``, ``"nmea"`` or ``"gnss-csv"`` from a file's lines, or None for none of these."""
    first = lines[0].strip() if lines else ""
    header = [h.strip() for h in first.split(",")]
    if first.startswith("$FLYS") or ("time" in header and "lat" in header):
        return "flysight"
    if is_nmea(lines):
        return "nmea"
    if is_gnss_csv(header):
        return "gnss-csv"
    return None


def read_gps_track(path: str | Path, date: dt.date | None = None, utc_at_zero_s: float = 0.0) -> GpsTrack:
    """Read a GPS file of any kind of :data:`GPS_KINDS`.

    Parameters
    ----------
    path : str or Path
        The file.
    date : datetime.date, optional
        UTC date of an NMEA log without RMC sentences (``[gps] date``).
    utc_at_zero_s : float
        UTC (s since 1970) of ``ts = 0`` of a flight-computer GNSS CSV (default 0: its own clock).

    Raises
    ------
    InputError
        Located, for a malformed file or one of another kind.
    """
    kind = gps_file_kind(read_lines(path))
    if kind == "flysight":
        return read_flysight(path)
    if kind == "nmea":
        return read_nmea(path, date)
    if kind == "gnss-csv":
        return read_gnss_csv(path, utc_at_zero_s)
    raise InputError(path, "not a GPS file: expected a FlySight 1 or 2 track, an NMEA 0183 log ($GPGGA, $GNRMC, "
                           "...) or a GNSS CSV (ts,latitude,longitude[,satellites])", line=1)
