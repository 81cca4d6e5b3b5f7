"""NMEA 0183 logs (GGA, RMC, VTG, GSA sentences) read into a :class:`~casrecon.io.flysight.GpsTrack`
(format ``"nmea"``).

Rules kept by :func:`read_nmea` (a violation raises a located :class:`~casrecon.io.errors.InputError`):

- a sentence is ``$TTSSS,f1,f2,...*hh``; talkers GP, GN, GL, GA and BD are read, other talkers and
  other sentence types (GSV, GLL, TXT, proprietary ``$P...``) are skipped and counted in the track's
  notes; a line whose checksum (``*hh``, XOR of the characters between ``$`` and ``*``) is missing or
  wrong is skipped and counted (a logger cut mid-line, a serial glitch): only a file with no usable
  sentence left is an error;
- a sentence with a good checksum and a malformed field (latitude ``abc``) is an error naming its line
  and field;
- sentences are grouped into epochs by their UTC time of day (GGA and RMC carry it; VTG and GSA join
  the epoch of the last timed sentence before them); the date comes from RMC (``ddmmyy``) or, for a
  GGA-only log, from the ``date`` argument (``[gps] date``), else an error; a time of day more than
  12 h earlier than the previous one is the next day (midnight); epoch times must strictly increase;
- latitude and longitude from GGA (else RMC), height above mean sea level from GGA's altitude (GGA
  gives the height above the geoid, i.e. MSL, with the geoid separation in a separate field);
  horizontal velocity from RMC's speed and course (else VTG's): north = s cos(course),
  east = s sin(course), with a blank course at zero speed read as zero velocity; NMEA carries no
  vertical velocity: ``vel_d_mps`` is NaN (unknown), as is every value an epoch does not give;
- fix type ``gps_fix``: from GSA (1 -> 0 no fix, 2 -> 2D, 3 -> 3D), else 3 when GGA's quality is 1 to 5
  (GPS, DGPS, PPS, RTK fixed or float) and 0 when it is 0 or 6 (dead reckoning) to 8; an RMC status
  ``V`` or mode ``N`` marks no fix; :func:`casrecon.io.flysight.no_fix_mask` then keeps these out of a fit;
- accuracies (NMEA gives none): 1-sigma position error = DOP x :data:`UERE_M`; the horizontal error
  HDOP x UERE is the radial (2D) one, so each of north and east gets HDOP x UERE / sqrt(2) (``h_acc_m``),
  vertical VDOP x UERE (``v_acc_m``; VDOP from GSA, else sqrt(PDOP^2 - HDOP^2), else
  :data:`VDOP_PER_HDOP` x HDOP); HDOP from GGA, else GSA; an epoch without any DOP takes
  :data:`FALLBACK_HDOP` (counted in the notes); speed accuracy :data:`SPEED_SIGMA_MPS`.
"""

from __future__ import annotations

import datetime as dt
import math
import re
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from casrecon.io._csvtools import read_lines
from casrecon.io.errors import InputError
from casrecon.io.flysight import GpsTrack

#: 1-sigma user equivalent range error of a single-frequency receiver, m. Position error (1-sigma) =
#: DOP x UERE (e.g. S. Wormley, "GPS Errors & Estimating Your Receiver's Accuracy",
#: edu-observatory.org/gps/gps_accuracy.html: EPE(1-sigma) = HDOP x UERE); a modern single-frequency
#: UERE is about 3 to 5 m without differential corrections: casrecon takes 4 m.
UERE_M = 4.0
#: VDOP per HDOP when an epoch gives neither VDOP nor PDOP (typically 1.5 to 2 for a clear sky).
VDOP_PER_HDOP = 1.7
#: HDOP taken for an epoch without any DOP (a fair sky; such epochs are counted in the notes).
FALLBACK_HDOP = 2.0
#: 1-sigma of each horizontal velocity component, m/s: NMEA gives no speed accuracy. Doppler speed of a
#: consumer receiver is good to about 0.05 to 0.1 m/s; 0.2 m/s also covers the 0.1 kn (0.05 m/s)
#: resolution of many loggers and an unknown filter.
SPEED_SIGMA_MPS = 0.2
#: Talker IDs read: GPS, multi-GNSS, GLONASS, Galileo, BeiDou.
TALKERS = ("GP", "GN", "GL", "GA", "BD")
SENTENCES = ("GGA", "RMC", "VTG", "GSA")
KNOT_MPS = 1852.0 / 3600.0
_SENTENCE = re.compile(r"\$([A-Z]{2})([A-Z]{3}),(.*)\*([0-9A-Fa-f]{2})")


#: The start of an NMEA 0183 line: a standard sentence (talker and type, ``$GPGGA,``) or a proprietary
#: one (``$P`` and the maker's code, ``$PVER,``, ``$PTH,``, ``$PUBX,``), which the reader skips.
_NMEA_HEAD = re.compile(r"\$(?:[A-Z]{5}|P[A-Z0-9]{2,})[,*]")


def is_nmea(lines: list[str]) -> bool:
    """Whether the first non-blank lines look like NMEA 0183 (``$GPGGA,...``, ``$GNRMC,...``, or a
    logger's proprietary ``$P...`` sentences)."""
    heads = [ln.strip() for ln in lines[:20] if ln.strip()][:5]
    return bool(heads) and sum(_NMEA_HEAD.match(h) is not None for h in heads) >= max(1, len(heads) // 2)


@dataclass
class _Epoch:
    line: int
    tod_s: float
    date: dt.date | None = None
    v: dict = field(default_factory=dict)


def _checksum_ok(body: str, given: str) -> bool:
    x = 0
    for ch in body:
        x ^= ord(ch)
    return x == int(given, 16)


class _Fields:
    """The fields of one sentence, parsed with located errors."""

    def __init__(self, path, line: int, kind: str, cells: list[str]) -> None:
        self.path, self.line, self.kind, self.cells = path, line, kind, cells

    def error(self, name: str, message: str) -> InputError:
        return InputError(self.path, message, line=self.line, field=f"{self.kind} {name}")

    def cell(self, k: int) -> str:
        return self.cells[k].strip() if k < len(self.cells) else ""

    def number(self, k: int, name: str) -> float:
        """Field k as a number, NaN when blank."""
        text = self.cell(k)
        if not text:
            return math.nan
        try:
            value = float(text)
        except ValueError:
            raise self.error(name, f"expected a number, got {text[:20]!r}") from None
        if not math.isfinite(value):
            raise self.error(name, f"expected a finite number, got {text[:20]!r}")
        return value

    def dop(self, k: int, name: str) -> float:
        """Field k as a dilution of precision (a ratio >= 0), NaN when blank."""
        value = self.number(k, name)
        if value < 0:
            raise self.error(name, f"expected a dilution of precision >= 0, got {self.cell(k)[:20]!r}")
        return value

    def time_of_day(self, k: int) -> float | None:
        text = self.cell(k)
        if not text:
            return None
        m = re.fullmatch(r"(\d\d)(\d\d)(\d\d(?:\.\d+)?)", text)
        if m is None or int(m[1]) > 23 or int(m[2]) > 59 or float(m[3]) >= 61:
            raise self.error("time", f"expected UTC time hhmmss.ss, got {text[:20]!r}")
        return int(m[1]) * 3600 + int(m[2]) * 60 + float(m[3])

    def angle(self, k: int, name: str, degree_digits: int, hemispheres: str) -> float:
        """ddmm.mmmm (latitude) or dddmm.mmmm (longitude) with its hemisphere in field k + 1; NaN if blank."""
        text, hemi = self.cell(k), self.cell(k + 1)
        if not text:
            return math.nan
        m = re.fullmatch(rf"(\d{{{degree_digits}}})(\d\d(?:\.\d+)?)", text)
        if m is None or float(m[2]) >= 60 or hemi not in hemispheres:
            raise self.error(name, f"expected {'d' * degree_digits}mm.mmmm and {' or '.join(hemispheres)}, "
                                   f"got {text[:20]!r},{hemi[:3]!r}")
        value = int(m[1]) + float(m[2]) / 60.0
        limit = 90 if degree_digits == 2 else 180
        if value > limit:
            raise self.error(name, f"{value:g} deg is beyond {limit} deg")
        return -value if hemi in "SW" else value


def _velocity(f: _Fields, k_speed: int, k_course: int, speed_factor: float) -> tuple[float, float]:
    speed = f.number(k_speed, "speed") * speed_factor
    course = f.number(k_course, "course")
    if speed < 0:
        raise f.error("speed", f"speed {speed:g} m/s is negative")
    if math.isnan(course):
        return (0.0, 0.0) if speed == 0 else (math.nan, math.nan)
    rad = math.radians(course)
    return speed * math.cos(rad), speed * math.sin(rad)


def _parse(f: _Fields, sentence: str, v: dict) -> None:
    """Put what sentence ``sentence`` gives into the epoch values ``v`` (the first sentence of a kind wins)."""
    if sentence == "GGA":
        v.setdefault("lat", f.angle(1, "latitude", 2, "NS"))
        v.setdefault("lon", f.angle(3, "longitude", 3, "EW"))
        quality = f.number(5, "quality")
        v.setdefault("gga_quality", quality)
        v.setdefault("num_sv", f.number(6, "satellites"))
        v.setdefault("hdop", f.dop(7, "HDOP"))
        v.setdefault("h_msl", f.number(8, "altitude"))
    elif sentence == "RMC":
        v.setdefault("rmc_valid", f.cell(1) == "A" and f.cell(11)[:1] not in ("N", "E"))
        v.setdefault("lat_rmc", f.angle(2, "latitude", 2, "NS"))
        v.setdefault("lon_rmc", f.angle(4, "longitude", 3, "EW"))
        v.setdefault("vel", _velocity(f, 6, 7, KNOT_MPS))
    elif sentence == "VTG":
        if f.cell(0) and f.cell(1) not in ("T", ""):
            raise f.error("course", f"expected the true course followed by T, got {f.cell(1)[:5]!r}")
        knots = bool(f.cell(4))
        v.setdefault("vel_vtg", _velocity(f, 4 if knots else 6, 0, KNOT_MPS if knots else 1.0 / 3.6))
    elif sentence == "GSA":
        mode = f.number(1, "fix mode")
        if not math.isnan(mode) and mode not in (1, 2, 3):
            raise f.error("fix mode", f"expected 1, 2 or 3, got {f.cell(1)[:5]!r}")
        v.setdefault("gsa_mode", mode)
        for name, k in (("pdop", 14), ("hdop_gsa", 15), ("vdop", 16)):
            v.setdefault(name, f.dop(k, name.upper().split("_")[0]))


def _date(f: _Fields) -> dt.date | None:
    text = f.cell(8)
    if not text:
        return None
    try:
        return dt.datetime.strptime(text, "%d%m%y").date()
    except ValueError:
        raise f.error("date", f"expected ddmmyy, got {text[:10]!r}") from None


def read_nmea(path: str | Path, date: dt.date | str | None = None) -> GpsTrack:
    """Read an NMEA 0183 log into a GpsTrack (see the module docstring for the rules).

    Parameters
    ----------
    path : str or Path
        The log.
    date : datetime.date or ``"YYYY-MM-DD"``, optional
        UTC date of the first epoch, for a log whose sentences carry no date (GGA only). RMC dates
        take precedence where present.

    Returns
    -------
    GpsTrack
        One fix per epoch, format ``"nmea"``; NaN for what the log does not give (always ``vel_d_mps``);
        ``notes`` count the skipped lines and the assumptions taken.

    Raises
    ------
    InputError
        Located by line and field, for a malformed sentence, a missing date, times not increasing, or
        a file without a usable sentence.
    """
    if isinstance(date, str):
        try:
            date = dt.date.fromisoformat(date)
        except ValueError:
            raise InputError(path, f"expected a date YYYY-MM-DD, got {date!r}", field="date") from None
    lines = read_lines(path)
    epochs: list[_Epoch] = []
    counts = {"bad checksum": 0, "no checksum": 0, "not NMEA": 0, "other sentences": 0, "before any time": 0}
    for number, raw in enumerate(lines, start=1):
        line = raw.strip()
        if not line:
            continue
        m = _SENTENCE.fullmatch(line)
        if m is None:
            counts["no checksum" if re.match(r"\$[A-Z]{5},", line) else "not NMEA"] += 1
            continue
        if not _checksum_ok(line[1:line.rindex("*")], m[4]):
            counts["bad checksum"] += 1
            continue
        talker, sentence = m[1], m[2]
        if talker not in TALKERS or sentence not in SENTENCES:
            counts["other sentences"] += 1
            continue
        f = _Fields(path, number, talker + sentence, m[3].split(","))
        tod = f.time_of_day(0) if sentence in ("GGA", "RMC") else None
        if tod is not None and (not epochs or epochs[-1].tod_s != tod):
            epochs.append(_Epoch(number, tod))
        if not epochs:
            counts["before any time"] += 1
            continue
        if sentence == "RMC":
            epochs[-1].date = epochs[-1].date or _date(f)
        _parse(f, sentence, epochs[-1].v)
    if not epochs:
        skipped = ", ".join(f"{n} {k}" for k, n in counts.items() if n)
        raise InputError(path, f"no usable NMEA sentence (GGA or RMC with a time; talkers {', '.join(TALKERS)})"
                               + (f"; skipped: {skipped}" if skipped else ""))
    return _build(path, epochs, date, counts)


def _build(path, epochs: list[_Epoch], date: dt.date | None, counts: dict) -> GpsTrack:
    day = next((e.date for e in epochs if e.date is not None), None)
    if day is None:
        if date is None:
            raise InputError(path, "the log's sentences carry no date (no RMC); give the UTC date of the first "
                                   "fix (read_nmea date=..., problem key [gps] date = \"YYYY-MM-DD\")",
                             line=epochs[0].line, field="date")
        day = date
    elif epochs[0].date is None:
        # epochs before the first RMC: its date, or the day before when they are later in the day
        first = next(e for e in epochs if e.date is not None)
        day = first.date - dt.timedelta(days=1) if epochs[0].tod_s > first.tod_s else first.date
    times, previous = [], None
    for e in epochs:
        if e.date is not None:
            day = e.date
        elif previous is not None and e.tod_s < previous - 43200.0:
            day = day + dt.timedelta(days=1)
        t = dt.datetime(day.year, day.month, day.day, tzinfo=dt.UTC).timestamp() + e.tod_s
        if times and t <= times[-1]:  # (sentences of one time of day are one epoch: a repeat comes back)
            raise InputError(path, f"epoch time goes backwards ({times[-1]:.3f} then {t:.3f} s since 1970); NMEA "
                                   "epochs must strictly increase", line=e.line, field="time")
        times.append(t)
        previous = e.tod_s
    n = len(epochs)
    col = {k: np.full(n, np.nan) for k in ("lat", "lon", "h", "vn", "ve", "hdop", "vdop", "fix", "sv")}
    no_dop = 0
    for i, e in enumerate(epochs):
        v = e.v
        lat, lon = v.get("lat", math.nan), v.get("lon", math.nan)
        if math.isnan(lat) or math.isnan(lon):
            lat, lon = v.get("lat_rmc", math.nan), v.get("lon_rmc", math.nan)
        vn, ve = v.get("vel", (math.nan, math.nan))
        if math.isnan(vn):
            vn, ve = v.get("vel_vtg", (math.nan, math.nan))
        hdop = v.get("hdop", math.nan)
        if math.isnan(hdop):
            hdop = v.get("hdop_gsa", math.nan)
        vdop = v.get("vdop", math.nan)
        pdop = v.get("pdop", math.nan)
        if math.isnan(vdop) and pdop >= hdop:
            vdop = math.sqrt(pdop * pdop - hdop * hdop)
        if math.isnan(hdop):
            hdop, no_dop = FALLBACK_HDOP, no_dop + 1
        if math.isnan(vdop):
            vdop = VDOP_PER_HDOP * hdop
        col["lat"][i], col["lon"][i], col["h"][i] = lat, lon, v.get("h_msl", math.nan)
        col["vn"][i], col["ve"][i], col["hdop"][i], col["vdop"][i] = vn, ve, hdop, vdop
        col["fix"][i] = _fix_type(v)
        col["sv"][i] = v.get("num_sv", math.nan)
    h_acc = col["hdop"] * UERE_M / math.sqrt(2.0)
    v_acc = np.where(np.isfinite(col["h"]), col["vdop"] * UERE_M, np.nan)
    fix = np.where(np.isfinite(col["lat"] + col["lon"]), col["fix"], 0).astype(np.int64)
    s_acc = np.where(np.isfinite(col["vn"] + col["ve"]), SPEED_SIGMA_MPS, np.nan)
    notes = [f"NMEA: {n} epochs; accuracies from DOP x UERE {UERE_M:g} m (north and east HDOP x UERE / sqrt 2, "
             f"down VDOP x UERE), speed 1-sigma {SPEED_SIGMA_MPS:g} m/s; no vertical velocity (NaN)"]
    skipped = ", ".join(f"{k} {num}" for k, num in counts.items() if num)
    if skipped:
        notes.append(f"NMEA lines skipped: {skipped}")
    if no_dop:
        notes.append(f"{no_dop} epochs without any DOP took HDOP {FALLBACK_HDOP:g}")
    return GpsTrack(str(path), "nmea", np.asarray(times), col["lat"], col["lon"], col["h"], col["vn"], col["ve"],
                    np.full(n, np.nan), h_acc, v_acc, s_acc,
                    np.where(np.isfinite(col["sv"]), col["sv"], -1).astype(np.int64), fix, tuple(notes))


def _fix_type(v: dict) -> int:
    """u-blox style gpsFix of an epoch (see the module docstring)."""
    if v.get("rmc_valid") is False:
        return 0
    mode = v.get("gsa_mode", math.nan)
    if not math.isnan(mode):
        return {1: 0, 2: 2, 3: 3}[int(mode)]
    quality = v.get("gga_quality", math.nan)
    if not math.isnan(quality):
        return 3 if 1 <= quality <= 5 else 0
    return 3 if v.get("rmc_valid") else 0
