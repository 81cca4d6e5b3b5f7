"""A sounding's own launch time and place, read from what its file says about itself, for the
pre-solve warning on a sounding of another day or site
(:func:`casrecon.estimation.validation.consistency.sounding_origin_warning`).

What each format carries (nothing is guessed: a field the file does not give stays None):

- University of Wyoming TEXT:CSV: the ``time``, ``latitude`` and ``longitude`` columns of the first
  level (``2010-12-09 11:06:00``, degrees);
- University of Wyoming TEXT:LIST: the title line ``... Observations at 12Z 22 May 2011`` (time),
  and ``Station latitude:`` / ``Station longitude:`` when the station-information block is there;
- IGRA2 v2: the launch's ``#`` header: year, month, day, hour (99: unknown, then 00 is taken),
  LAT and LON (degrees times 10000);
- plain CSV: its ``#`` description lines, when they hold a date ``YYYY-MM-DD`` (with ``HH:MM``
  or ``HHZ`` after it, else 00 UTC) and ``lat X lon Y`` (``latitude``/``longitude``, ``=`` or ``:``
  allowed), as :func:`casrecon.io.sounding.write_sounding_csv` keeps a Wyoming sounding's.
"""

from __future__ import annotations

import calendar
import re
from dataclasses import dataclass

_MONTHS = {m.lower(): k for k, m in enumerate(calendar.month_abbr) if m}
_ISO = re.compile(r"(\d{4})-(\d\d)-(\d\d)(?:[ T_](\d\d)(?::(\d\d)(?::(\d\d))?|Z)?)?")
_LAT = re.compile(r"\blat(?:itude)?\s*[=:]?\s*(-?\d+(?:\.\d+)?)", re.IGNORECASE)
_LON = re.compile(r"\blon(?:gitude)?\s*[=:]?\s*(-?\d+(?:\.\d+)?)", re.IGNORECASE)
_WYOMING_TITLE = re.compile(r"Observations at (\d\d)Z (\d{1,2}) ([A-Za-z]{3}) (\d{4})")
_STATION_LAT = re.compile(r"Station latitude:\s*(-?\d+(?:\.\d+)?)")
_STATION_LON = re.compile(r"Station longitude:\s*(-?\d+(?:\.\d+)?)")


@dataclass(frozen=True)
class SoundingOrigin:
    """When and where a sounding was launched, as far as its file says.

    Attributes
    ----------
    time_unix_s : float or None
        Launch (or nominal observation) time, UTC, Unix seconds.
    lat_deg, lon_deg : float or None
        Launch site, degrees (north, east positive).
    line : int or None
        1-based line of the file that says so (the first one used).
    """

    time_unix_s: float | None = None
    lat_deg: float | None = None
    lon_deg: float | None = None
    line: int | None = None

    @property
    def known(self) -> bool:
        """Whether the file gives the time or the place."""
        return self.time_unix_s is not None or self.lat_deg is not None


#: What a file that says nothing about its launch gives.
NO_ORIGIN = SoundingOrigin()


def _utc(year: int, month: int, day: int, hour: int = 0, minute: int = 0, second: int = 0) -> float | None:
    try:
        return float(calendar.timegm((year, month, day, hour, minute, second, 0, 0, 0))) if (
            1 <= month <= 12 and 1 <= day <= 31 and 0 <= hour <= 23 and 0 <= minute <= 59) else None
    except (OverflowError, ValueError):
        return None


def _place(lat: float | None, lon: float | None) -> tuple[float | None, float | None]:
    """Both coordinates, when both are given and inside their ranges; else neither."""
    if lat is None or lon is None or not (-90.0 <= lat <= 90.0 and -180.0 <= lon <= 360.0):
        return None, None
    return lat, (lon - 360.0 if lon > 180.0 else lon)


def origin_from_text(text: str, line: int | None = None) -> SoundingOrigin:
    """The date and place written in free text (a plain CSV's description, a Wyoming CSV's first
    level as ``time`` and ``lat X lon Y``); fields not found stay None."""
    when = None
    m = _ISO.search(text)
    if m:
        y, mo, d, h, mi, s = (int(g) if g else 0 for g in m.groups())
        when = _utc(y, mo, d, h, mi, s)
    lat_m, lon_m = _LAT.search(text), _LON.search(text)
    lat, lon = _place(float(lat_m.group(1)) if lat_m else None, float(lon_m.group(1)) if lon_m else None)
    return SoundingOrigin(when, lat, lon, line if (when is not None or lat is not None) else None)


def wyoming_csv_origin(time: str, lat: str | None, lon: str | None, line: int) -> SoundingOrigin:
    """A Wyoming TEXT:CSV's first level: its ``time`` cell and its ``latitude``/``longitude`` cells."""
    when = origin_from_text(time).time_unix_s
    try:
        la, lo = _place(float(lat) if lat else None, float(lon) if lon else None)
    except ValueError:
        la = lo = None
    return SoundingOrigin(when, la, lo, line if (when is not None or la is not None) else None)


def wyoming_list_origin(lines: list[str]) -> SoundingOrigin:
    """A Wyoming TEXT:LIST's title line (time) and station-information block (place)."""
    when = line = None
    for k, text in enumerate(lines):
        m = _WYOMING_TITLE.search(text)
        if m and m.group(3).lower() in _MONTHS:
            when = _utc(int(m.group(4)), _MONTHS[m.group(3).lower()], int(m.group(2)), int(m.group(1)))
            line = k + 1
            break
    lat = lon = None
    for k, text in enumerate(lines):
        if (m := _STATION_LAT.search(text)) is not None:
            lat = float(m.group(1))
            line = line or k + 1
        if (m := _STATION_LON.search(text)) is not None:
            lon = float(m.group(1))
    lat, lon = _place(lat, lon)
    return SoundingOrigin(when, lat, lon, line if (when is not None or lat is not None) else None)


def igra2_origin(header: str, line: int) -> SoundingOrigin:
    """An IGRA2 v2 launch header: YEAR MONTH DAY HOUR (columns 14 to 26), LAT (56 to 62) and LON
    (64 to 71), both degrees times 10000."""
    try:
        y, mo, d, h = int(header[13:17]), int(header[18:20]), int(header[21:23]), int(header[24:26])
    except ValueError:
        return SoundingOrigin()
    when = _utc(y, mo, d, 0 if h == 99 else h)
    try:
        lat, lon = _place(int(header[55:62]) / 1e4, int(header[63:71]) / 1e4)
    except ValueError:
        lat = lon = None
    return SoundingOrigin(when, lat, lon, line if (when is not None or lat is not None) else None)
