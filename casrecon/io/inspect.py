"""``casrecon inspect FILE``: say what an input file is, what it holds and what looks wrong.

Problems reported:

- GPS cold start: leading fixes with ``hAcc > 10 m`` or ``vAcc > 10 m`` or ``sAcc > 1 m/s``
  or ``0 <= numSV < 6``, and the time the first good fix arrives;
- gaps: steps longer than twice the median step (count and the largest);
- IMU saturation: samples equal to an axis' extreme value when that value repeats
  (at least 3 samples), the signature of a clipped sensor;
- IMU warnings (``WARNING:`` lines), by the rules the fits apply (:mod:`casrecon.io.imu_checks`):
  gaps over 1.5 sample periods, a unit that gives implausible values (gyros over 2000 deg/s,
  a median specific force outside 0.25 to 4 g; and, warned only, any gyro sample over 50 rad/s or
  accelerometer sample over 2000 m/s^2, with the likely unit), a channel stuck at one reading for 1 s (a gyro
  saturated for the whole log is one);
- NMEA logs and flight-computer GNSS CSVs: which components the file holds (a missing one, NaN, is
  left out of every fit), the accuracies assumed, and the lines skipped (bad checksums, stale repeats);
- barometer CSVs (``time_s``/``time_unix_s``/``ts`` with ``pressure_pa``/``pressure_hpa``/``P``): span,
  rate, gaps and pressure range, and a warning when the median pressure is outside the standard
  atmosphere's from :data:`BARO_FLIGHT_ALT_M` (-500 m to 12 km MSL), with the likely unit (the fits
  compare each sample with the atmosphere at the GPS altitude:
  :mod:`casrecon.estimation.validation.consistency`);
- GPS warnings: rows without a 3D fix (``gpsFix`` 0, 1, 2 or 5, or latitude, longitude and height
  all 0), which every fit drops;
- soundings: the launch date and place the file gives (:mod:`casrecon.io.sounding_origin`, which the
  fits compare with the drop's), levels dropped for missing values, IGRA2 launches that are truncated, and a University
  of Wyoming TEXT:LIST that looks truncated (a last level cut short, or levels ending below
  :data:`WYOMING_TOP_HPA` with nothing after them).
"""

from __future__ import annotations

import re
from collections.abc import Callable
from pathlib import Path

import numpy as np

from casrecon.io._csvtools import read_lines
from casrecon.io.baro import PRESSURE_COLUMNS, TIME_COLUMNS, BaroLog, pressure_unit_hint, read_baro
from casrecon.io.errors import InputError
from casrecon.io.flysight import GpsTrack, iso_utc, no_fix_mask, read_flysight
from casrecon.io.gps_files import gps_file_kind, read_gps_track
from casrecon.io.imu import ImuCsvSpec, ImuLog, read_imu_csv
from casrecon.io.imu_checks import imu_findings, unit_warnings
from casrecon.io.sensor import SensorLog, is_flysight2_sensor, read_flysight2_sensor
from casrecon.io.sounding import detect_sounding_format, igra2_launches, read_sounding
from casrecon.io.sounding_levels import Sounding
from casrecon.physics.atmosphere import standard_pressure

SUPPORTED = ("FlySight 1 CSV, FlySight 2 TRACK.CSV and SENSOR.CSV, NMEA 0183 log, GNSS CSV "
             "(ts,latitude,longitude,satellites), barometer CSV (time_s or ts, pressure_pa or P), "
             "University of Wyoming TEXT:CSV or "
             "TEXT:LIST sounding, IGRA2 v2 sounding, plain sounding CSV "
             "(altitude_msl_m,pressure_pa,...), IMU CSV (time_s,ax,ay,az,wx,wy,wz or "
             "ts,...,Ax,Ay,Az,Gx,Gy,Gz)")
ROCKET_SPEC = ImuCsvSpec(time_column="ts", accel_columns=("Ax", "Ay", "Az"),
                         gyro_columns=("Gx", "Gy", "Gz"), gyro_unit="deg/s")
COLD_H_ACC_M = 10.0
COLD_V_ACC_M = 10.0
COLD_S_ACC_MPS = 1.0
COLD_MIN_SV = 6
SATURATION_MIN_REPEATS = 3
#: Altitudes (m MSL) a drop flies at: a barometer's median pressure outside the standard atmosphere's
#: between them is warned about.
BARO_FLIGHT_ALT_M = (-500.0, 12000.0)
#: A complete Wyoming TEXT:LIST download reaches this pressure or lower (hPa) and ends with a text block.
WYOMING_TOP_HPA = 100.0


def inspect_file(path: str | Path) -> str:
    """Detect the kind of an input file and describe it.

    Parameters
    ----------
    path : str or Path
        Any casrecon input data file.

    Returns
    -------
    str
        Multi-line human-readable report: kind, rows, time span, columns and units, value
        ranges and obvious problems.

    Raises
    ------
    InputError
        If the file is unreadable, of an unknown kind (the message lists the supported
        kinds) or malformed (the reader's located error).
    """
    lines = read_lines(path)
    first = lines[0].strip() if lines else ""
    header = [h.strip() for h in first.split(",")]
    if is_flysight2_sensor(lines):
        return _report_sensor(read_flysight2_sensor(path))
    gps_kind = gps_file_kind(lines)
    if gps_kind == "flysight":
        return _report_gps(read_flysight(path), lines)
    if gps_kind is not None:
        return _report_partial_gps(read_gps_track(path))
    if detect_sounding_format(lines) is not None:
        return _report_sounding(read_sounding(path), lines, Path(path).read_bytes().endswith(b"\n"))
    for spec in (ImuCsvSpec(), ROCKET_SPEC):
        if all(c in header for c in spec.columns):
            return _report_imu(read_imu_csv(path, spec), spec)
    if is_baro_csv(header):
        return _report_baro(read_baro(path))
    raise InputError(path, f"unknown kind of file; supported: {SUPPORTED}", line=1)


def _gaps(t: np.ndarray, when: Callable[[float], str] = lambda x: f"t = {x:.6g} s") -> str:
    if t.size < 3:
        return "gaps: too few samples to judge"
    step = np.diff(t)
    med = float(np.median(step))
    big = step > 2.0 * med
    if not big.any():
        return f"gaps: none longer than 2x the median step ({med:.4g} s)"
    k = int(np.argmax(step))
    return (f"gaps: {int(big.sum())} steps longer than 2x the median step ({med:.4g} s); "
            f"largest {step[k]:.4g} s after sample {k} ({when(t[k])})")


def _span(t: np.ndarray) -> str:
    step = float(np.median(np.diff(t))) if t.size > 1 else float("nan")
    rate = f", {1.0 / step:.4g} Hz" if step > 0 else ""
    return f"{t[-1] - t[0]:.6g} s, median step {step:.4g} s{rate}"


def _gps_columns(lines: list[str], fmt: str) -> str:
    if fmt == "flysight1":
        names = lines[0].split(",")
        units = lines[1].split(",") if len(lines) > 1 else [""] * len(names)
    else:
        names = next(ln.split(",")[2:] for ln in lines if ln.startswith("$COL,GNSS"))
        units = next((ln.split(",")[2:] for ln in lines if ln.startswith("$UNIT,GNSS")),
                     [""] * len(names))
    units = [*units, *[""] * len(names)]
    return ", ".join(f"{n.strip()} [{u.strip().strip('()')}]" if u.strip() else n.strip()
                     for n, u in zip(names, units, strict=False))


def _cold_start(g: GpsTrack) -> str:
    bad = (g.h_acc_m > COLD_H_ACC_M) | (g.v_acc_m > COLD_V_ACC_M) \
        | (g.s_acc_mps > COLD_S_ACC_MPS) | ((g.num_sv >= 0) & (g.num_sv < COLD_MIN_SV))
    rule = (f"hAcc > {COLD_H_ACC_M:g} m or vAcc > {COLD_V_ACC_M:g} m or sAcc > "
            f"{COLD_S_ACC_MPS:g} m/s or numSV < {COLD_MIN_SV}")
    if bad.all():
        return f"cold start: every fix is poor ({rule}); no good fix"
    lead = int(np.argmax(~bad))
    later = int(bad[lead:].sum())
    text = (f"cold start: {lead} leading fixes poor ({rule}); good fixes start at "
            f"{iso_utc(g.time_unix_s[lead])} (+{g.time_unix_s[lead] - g.time_unix_s[0]:.1f} s)")
    return text + (f"; {later} poor fixes later in the track" if later else "")


def _report_gps(g: GpsTrack, lines: list[str]) -> str:
    kind = "FlySight 1 GPS track" if g.format == "flysight1" else "FlySight 2 GNSS track"
    t = g.time_unix_s
    gs = np.hypot(g.vel_n_mps, g.vel_e_mps)
    out = [f"{g.path}: {kind} ({g.format})",
           f"rows: {g.n}",
           f"time: {iso_utc(t[0])} to {iso_utc(t[-1])} UTC ({_span(t)})",
           f"columns: {_gps_columns(lines, g.format)}",
           f"altitude hMSL: {g.h_msl_m.min():.1f} to {g.h_msl_m.max():.1f} m",
           f"latitude: {g.lat_deg.min():.6f} to {g.lat_deg.max():.6f} deg; longitude: "
           f"{g.lon_deg.min():.6f} to {g.lon_deg.max():.6f} deg",
           f"velD: {g.vel_d_mps.min():.2f} to {g.vel_d_mps.max():.2f} m/s; ground speed max "
           f"{gs.max():.2f} m/s",
           f"accuracy: hAcc {g.h_acc_m.min():.2f} to {g.h_acc_m.max():.1f} m, vAcc "
           f"{g.v_acc_m.min():.2f} to {g.v_acc_m.max():.1f} m, sAcc {g.s_acc_mps.min():.2f} "
           f"to {g.s_acc_mps.max():.2f} m/s",
           _cold_start(g),
           _gaps(t, lambda x: f"at {iso_utc(x)}")]
    no_fix = no_fix_mask(g)
    if no_fix.any():
        k = int(np.argmax(no_fix))
        values = sorted({int(v) for v in g.gps_fix[no_fix]})
        how = f"gpsFix {', '.join(map(str, values))}" if values != [-1] else "latitude, longitude and height all 0"
        out.append(f"WARNING: {int(no_fix.sum())} rows without a 3D fix ({how}), the first at {iso_utc(t[k])}; "
                   "a fit drops them")
    return "\n".join(out)


def is_baro_csv(header: list[str]) -> bool:
    """Whether a CSV header (cells) names a barometer CSV's time and pressure columns."""
    return any(c in header for c in TIME_COLUMNS) and any(c in header for c in PRESSURE_COLUMNS)


def _range(name: str, v: np.ndarray, unit: str, fmt: str = ".2f") -> str:
    ok = np.isfinite(v)
    if not ok.any():
        return f"{name}: not in the file (missing: a fit leaves it out)"
    return f"{name}: {np.min(v[ok]):{fmt}} to {np.max(v[ok]):{fmt}} {unit}" + (
        "" if ok.all() else f" ({int((~ok).sum())} rows without it)")


def _report_partial_gps(g: GpsTrack) -> str:
    """An NMEA log or GNSS CSV: what it holds, what it lacks, what the reader assumed."""
    kind = {"nmea": "NMEA 0183 log", "gnss-csv": "GNSS CSV (flight computer clock)"}[g.format]
    t = g.time_unix_s
    when = (lambda x: f"at {iso_utc(x)}") if g.format == "nmea" else (lambda x: f"ts = {x:.3f} s")
    span = (f"{iso_utc(t[0])} to {iso_utc(t[-1])} UTC" if g.format == "nmea"
            else f"ts {t[0]:.3f} to {t[-1]:.3f} s")
    out = [f"{g.path}: {kind} ({g.format})", f"rows: {g.n} fixes", f"time: {span} ({_span(t)})",
           _range("latitude", g.lat_deg, "deg", ".6f"), _range("longitude", g.lon_deg, "deg", ".6f"),
           _range("altitude hMSL", g.h_msl_m, "m", ".1f"), _range("velN", g.vel_n_mps, "m/s"),
           _range("velE", g.vel_e_mps, "m/s"), _range("velD", g.vel_d_mps, "m/s"),
           _range("accuracy hAcc (per axis)", g.h_acc_m, "m"), _range("accuracy vAcc", g.v_acc_m, "m"),
           _range("accuracy sAcc", g.s_acc_mps, "m/s"), _gaps(t, when)]
    sv = g.num_sv[g.num_sv >= 0]
    out.append(f"satellites: {sv.min()} to {sv.max()}" if sv.size else "satellites: not given")
    out.extend(f"note: {n}" for n in g.notes)
    no_fix = no_fix_mask(g)
    if no_fix.any():
        out.append(f"WARNING: {int(no_fix.sum())} rows without a usable fix (first {when(t[int(np.argmax(no_fix))])}); "
                   "a fit drops them")
    return "\n".join(out)


def _report_baro(b: BaroLog) -> str:
    clock = "UTC" if b.clock == "utc" else "IMU clock"
    t = b.time_s
    span = f"{iso_utc(t[0])} to {iso_utc(t[-1])} UTC" if b.clock == "utc" else f"{t[0]:.6g} to {t[-1]:.6g} s IMU clock"
    out = [f"{b.path}: barometer CSV ({clock})", f"rows: {t.size}", f"time: {span} ({_span(t)})",
           f"pressure: {b.pressure_pa.min():.0f} to {b.pressure_pa.max():.0f} Pa", _gaps(t)]
    med = float(np.median(b.pressure_pa))
    low, high = (float(standard_pressure(h)) for h in BARO_FLIGHT_ALT_M[::-1])
    if not low <= med <= high:
        hint = pressure_unit_hint(low / med, high / med, b.pressure_column)
        out.append(f"WARNING: {b.pressure_column or 'pressure'}: median pressure {med:.6g} Pa, outside the standard "
                   f"atmosphere's {low:.0f} to {high:.0f} Pa from {BARO_FLIGHT_ALT_M[0]:g} to {BARO_FLIGHT_ALT_M[1]:g} "
                   f"m MSL; {hint}")
    return "\n".join(out)


def _humidity_line(s: Sounding) -> str:
    """What the sounding says of humidity, and what the atmosphere makes of it."""
    if s.dewpoint_k is None:
        return "humidity: no dewpoint (dry air assumed)"
    used = "" if s.density_kgm3 is None else " (not used: the density is given)"
    n = int(np.isfinite(s.dewpoint_k).sum())
    return f"humidity: dewpoint at {n} of {s.n} levels{used}"


def _origin_line(s: Sounding) -> str:
    """The launch date and place the sounding's file gives."""
    o = s.origin
    if not o.known:
        return "launch date and place: not in the file (the fits cannot compare them with the drop's)"
    when = "date not in the file" if o.time_unix_s is None else iso_utc(o.time_unix_s)
    where = "place not in the file" if o.lat_deg is None else f"lat {o.lat_deg:.4f} lon {o.lon_deg:.4f}"
    return f"launch: {when}, {where} (line {o.line})"


def _report_sounding(s: Sounding, lines: list[str], final_newline: bool = True) -> str:
    speed = np.hypot(s.wind_north_mps, s.wind_east_mps)
    names = {"wyoming-csv": "University of Wyoming TEXT:CSV sounding",
             "wyoming-list": "University of Wyoming TEXT:LIST sounding",
             "igra2": "IGRA2 v2 sounding", "plain-csv": "plain CSV sounding"}
    out = [f"{s.path}: {names[s.format]} ({s.format})",
           f"description: {s.description or '(none in file)'}",
           f"levels: {s.n} usable, {s.dropped_levels} dropped (missing a required value or "
           "repeating an altitude)",
           f"altitude MSL: {s.altitude_msl_m[0]:.0f} to {s.altitude_msl_m[-1]:.0f} m",
           f"pressure: {s.pressure_pa.max() / 100:.1f} to {s.pressure_pa.min() / 100:.1f} hPa",
           f"temperature: {s.temperature_k.min():.1f} to {s.temperature_k.max():.1f} K",
           f"wind speed: {speed.min():.1f} to {speed.max():.1f} m/s",
           f"density: {'given' if s.density_kgm3 is not None else 'not given'}",
           _humidity_line(s), _origin_line(s)]
    if s.format == "igra2":
        for k, info in enumerate(igra2_launches(s.path, lines)):
            note = "" if info.present_levels == info.declared_levels else (
                f"; TRUNCATED: {info.present_levels} of {info.declared_levels} levels present")
            out.append(f"launch {k}: {info.description}, line {info.line}, "
                       f"{info.declared_levels} levels{note}")
    if s.format == "wyoming-list":
        out.extend(_wyoming_list_truncation(s, lines, final_newline))
    return "\n".join(out)


def _wyoming_list_truncation(s: Sounding, lines: list[str], final_newline: bool) -> list[str]:
    """Warnings when a TEXT:LIST looks cut: the last level line cut short, or levels that stop below
    WYOMING_TOP_HPA with nothing after them (a complete download ends with the station information)."""
    head = next(k for k, ln in enumerate(lines) if "PRES" in ln.split() and "HGHT" in ln.split())
    rows = [k for k in range(head + 2, len(lines)) if lines[k].strip() and not lines[k].strip().startswith("---")]
    last = next((i for i, k in enumerate(rows) if re.match(r"\s*[A-Za-z<]", lines[k])), len(rows))
    out = []
    if last == len(rows) and rows and not final_newline:
        out.append(f"WARNING: TRUNCATED: the last level (line {rows[-1] + 1}) has no line terminator: the file was "
                   "cut mid-line and its last values may be partial")
    top_hpa = s.pressure_pa[-1] / 100
    if last == len(rows) and top_hpa > WYOMING_TOP_HPA:
        out.append(f"WARNING: possibly TRUNCATED: the levels stop at {top_hpa:.1f} hPa ({s.altitude_msl_m[-1]:.0f} m) "
                   f"with nothing after them; a complete TEXT:LIST goes on to {WYOMING_TOP_HPA:g} hPa or above and "
                   "ends with the station information")
    return out


def _report_sensor(s: SensorLog) -> str:
    c = s.clock_fit
    base = "UTC" if c.leap_seconds == 0 else f"GPS, minus {c.leap_seconds} leap seconds"
    out = [f"{s.path}: FlySight 2 sensor log (SENSOR.CSV)",
           "rows: " + ", ".join(f"{k} {n}" for k, n in s.row_counts.items())
           + (f" (skipped: {', '.join(s.skipped_rows)})" if s.skipped_rows else ""),
           f"clock fit ($TIME rows, time base {base}): {c.n_rows} rows, drift "
           f"{c.drift_ppm:+.3f} ppm, residual RMS {c.residual_rms_s * 1e3:.3f} ms (max "
           f"{c.max_residual_s * 1e3:.3f} ms)"]
    if c.dropped:
        out.append("NOTE: " + c.dropped_note())
    for name, t in (("IMU", s.imu_time_unix_s), ("BARO", s.baro_time_unix_s)):
        if t.size:
            out.append(f"{name} time: {iso_utc(t[0])} to {iso_utc(t[-1])} UTC ({_span(t)})")
            out.append(f"{name} " + _gaps(t, lambda x: f"at {iso_utc(x)}"))
        else:
            out.append(f"{name}: no rows")
    if s.baro_pressure_pa.size:
        out.append(f"pressure: {s.baro_pressure_pa.min():.0f} to {s.baro_pressure_pa.max():.0f} "
                   f"Pa; sensor temperature {s.baro_temperature_k.min():.1f} to "
                   f"{s.baro_temperature_k.max():.1f} K")
    if s.imu_accel_mps2.size:
        out.append(f"IMU |accel| max {np.linalg.norm(s.imu_accel_mps2, axis=1).max():.2f} m/s^2, "
                   f"|gyro| max {np.degrees(np.linalg.norm(s.imu_gyro_radps, axis=1)).max():.1f} "
                   f"deg/s (the logged rates times {s.gyro_scale_applied:.5g}: the IMU's datasheet "
                   "sensitivity over the firmware's count * full scale / 32768)")
    return "\n".join(out)


def _saturation(name: str, values: np.ndarray, axes: tuple[str, str, str]) -> list[str]:
    out = []
    for k, axis in enumerate(axes):
        v = values[:, k]
        for label, extreme in (("max", v.max()), ("min", v.min())):
            count = int(np.count_nonzero(v == extreme))
            if count >= SATURATION_MIN_REPEATS and v.min() != v.max():
                out.append(f"possible {name} saturation: {count} samples of {axis} at its "
                           f"{label} {extreme:.6g}")
    return out


def _report_imu(m: ImuLog, spec: ImuCsvSpec) -> str:
    acc = m.accel_mps2
    gyr = np.degrees(m.gyro_radps)
    out = [f"{m.path}: IMU CSV",
           f"rows: {m.n}",
           f"time: {m.time_s[0]:.6g} to {m.time_s[-1]:.6g} s IMU clock ({_span(m.time_s)})",
           f"columns: {spec.time_column} [{spec.time_unit}], "
           f"{', '.join(spec.accel_columns)} [{spec.accel_unit}], "
           f"{', '.join(spec.gyro_columns)} [{spec.gyro_unit}] (other columns ignored)"]
    for k in range(3):
        out.append(f"{spec.accel_columns[k]}: {acc[:, k].min():.3f} to {acc[:, k].max():.3f} "
                   f"m/s^2; {spec.gyro_columns[k]}: {gyr[:, k].min():.2f} to "
                   f"{gyr[:, k].max():.2f} deg/s")
    out.append(_gaps(m.time_s))
    sat = _saturation("accelerometer", acc, spec.accel_columns) \
        + _saturation("gyro", gyr, spec.gyro_columns)
    out.extend(sat or ["saturation: no axis sits repeatedly at its extreme value"])
    out.extend(f"WARNING: line {f.line}: {f.field}: {f.message}" if f.line else f"WARNING: {f.field}: {f.message}"
               for f in imu_findings(m, spec) + unit_warnings(m, spec))
    return "\n".join(out)
