"""FlySight 2 ``SENSOR.CSV``: IMU, barometer and the ``$TIME`` rows, on GPS/UTC time.

Layout (as the device writes it): ``$FLYS,1``, ``$VAR`` lines, then per row kind a
``$COL,KIND,name,...`` and a ``$UNIT,KIND,unit,...`` line, ``$DATA``, then data rows
``$KIND,v1,v2,...`` in time order of the sensor clock (s since power-on).

Rules kept by :func:`read_flysight2_sensor` (violations raise a located
:class:`~casrecon.io.errors.InputError`, nothing else escapes):

- kinds read: ``IMU`` (``time,wx,wy,wz,ax,ay,az``), ``BARO`` (``time,pressure,
  temperature``) and ``TIME`` (``time,tow,week``); columns are found by name in the
  ``$COL`` line, extra columns (IMU temperature) are ignored. Other kinds (``MAG``, ``HUM``,
  ``VBAT``, ...) are skipped and counted in ``SensorLog.skipped_rows``;
- units come from the ``$UNIT`` line of the kind and must be known: time ``s``; gyro
  ``deg/s`` or ``rad/s``; accelerometer ``g`` (9.80665 m/s^2) or ``m/s^2``; pressure ``Pa``,
  ``hPa`` or ``mbar``; temperature ``deg C`` or ``K``; ``tow`` ``s``; ``week`` blank. A
  missing ``$UNIT`` line or an unknown unit is an error naming the line and column;
- every used cell must be a finite number: blank, ``nan`` and ``inf`` are errors; a row
  with the wrong number of fields, a data line not starting with ``$``, a row of a kind
  read without its ``$COL`` line, and a last line cut mid-write are errors;
- within each kind, sensor time must be strictly increasing: a duplicated or backwards
  timestamp is an error with its line; gaps are kept (no sample is invented);
  ``casrecon inspect`` reports the sample rates;
- pressure must be positive and temperature above 0 K;
- the gyro's scale: the FlySight 2 firmware (``FlySight/imu.c``, every version to 2026-02) writes
  ``count * FS / 32768`` (FS the full scale, +-2000 deg/s by default), but the IMU (ST LSM6DSO)
  has a sensitivity of 8.75, 17.5, 35 and 70 mdps per count at +-250, 500, 1000 and 2000 deg/s,
  ``FLYSIGHT2_GYRO_SCALE`` (= 70 / (2e6 / 32768) = 1.14688) times the firmware's, at every full
  scale. The rates read are multiplied by it (``SensorLog.gyro_scale_applied``; pass
  ``gyro_scale=1.0`` for a firmware that converts by the datasheet). Measured without the fit
  (``benchmarks/fs2_gyro_scale.py``, docs/studies/kinematic.md): the accelerometer's gravity
  direction between still spells on the ground against the integrated logged rates asks for
  1.152 +- 0.016 times them, and canopy turns against the GNSS course 1.16 +- 0.07. The
  accelerometer's counts (0.488 mg at +-16 g) match the datasheet and are read as written;
- the clock: GPS time ``week * 604800 + tow`` is fitted to the sensor time of the ``$TIME``
  rows by least squares, ``gps = offset + (1 + drift) * sensor`` (:class:`ClockFit`). At
  least 2 ``$TIME`` rows are needed; GPS time must be strictly increasing, ``tow`` in
  ``[0, 604800)``, ``week`` a whole number. With 4 rows or more, a robust line (median of
  the slopes between rows half the record apart, median offset) is drawn first and rows off it
  by more than ``CLOCK_RESIDUAL_LIMIT_S`` (50 ms) are dropped from the fit, named with their
  offsets in :meth:`ClockFit.dropped_note` (not logged here: ``casrecon inspect`` prints it, the
  kinematic fit and the barometer reader (``BaroLog.notes``) carry it in their notes, once): on real
  FlySight 2 files the first ``$TIME`` row after the fix is often about 0.9 s off while the
  others fit within a millisecond. Half the rows or more off the line is an error, and so is
  a kept row off the least-squares refit by more than the limit, or a drift beyond
  ``MAX_DRIFT_PPM`` (1000 ppm, a crystal is tens of ppm). IMU and baro samples before the first or after the last
  ``$TIME`` row are mapped with the same line (extrapolation; the drift makes that good to
  microseconds over minutes);
- the time base of ``tow``/``week``: ``time_base="utc"`` (the default) takes them as UTC
  time of week, ``unix = 315964800 + week * 604800 + tow``; ``time_base="gps"`` takes them
  as GPS time and subtracts the GPS - UTC leap seconds of the date
  (:data:`GPS_UTC_LEAP_TABLE`; ``GPS_UTC_LEAP_SECONDS`` = 18 s since 2017-01-01). The
  default is measured, not assumed: on the real FlySight 2 file of the Skydive Chicago jump
  (firmware v2024.08.07) the barometric altitude under canopy matches the same jump's
  TRACK.CSV hMSL (UTC) best at a shift of 18.0 s (RMS 4.8 m) if the leap seconds are
  applied and at 0 s without them: the device's ``$TIME`` rows already count UTC.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from casrecon.io._csvtools import check_increasing, find_columns, parse_floats, read_lines, split_rows
from casrecon.io.errors import InputError
from casrecon.io.imu import STANDARD_GRAVITY

#: GPS epoch 1980-01-06T00:00:00Z as Unix seconds.
GPS_EPOCH_UNIX_S = 315964800.0
SECONDS_PER_WEEK = 604800.0
#: GPS - UTC in seconds since 2017-01-01 (the last leap second, 2016-12-31T23:59:60Z).
GPS_UTC_LEAP_SECONDS = 18
#: (UTC Unix time from which it holds, GPS - UTC seconds), for every leap second since 1980.
GPS_UTC_LEAP_TABLE = (
    (315964800, 0), (362793600, 1), (394329600, 2), (425865600, 3), (489024000, 4),
    (567993600, 5), (631152000, 6), (662688000, 7), (709948800, 8), (741484800, 9),
    (773020800, 10), (820454400, 11), (867715200, 12), (915148800, 13), (1136073600, 14),
    (1230768000, 15), (1341100800, 16), (1435708800, 17), (1483228800, GPS_UTC_LEAP_SECONDS),
)
CLOCK_RESIDUAL_LIMIT_S = 0.05
#: LSM6DSO gyro sensitivity over the FlySight 2 firmware's count * full-scale / 32768:
#: 70 mdps per count at +-2000 deg/s against 2e6 / 32768 (the same ratio at every full scale).
FLYSIGHT2_GYRO_SCALE = 70.0 * 32768.0 / 2.0e6
MAX_DRIFT_PPM = 1000.0
ZERO_C_K = 273.15

_TIME_UNITS = {"s": 1.0}
_GYRO_UNITS = {"deg/s": np.pi / 180.0, "rad/s": 1.0}
_ACCEL_UNITS = {"g": STANDARD_GRAVITY, "m/s^2": 1.0, "m/s2": 1.0}
_PRESSURE_UNITS = {"Pa": 1.0, "hPa": 100.0, "mbar": 100.0}
_TEMPERATURE_UNITS = {"deg C": ZERO_C_K, "K": 0.0}  # offset to kelvin
_KINDS = {
    "IMU": {"time": _TIME_UNITS, "wx": _GYRO_UNITS, "wy": _GYRO_UNITS, "wz": _GYRO_UNITS,
            "ax": _ACCEL_UNITS, "ay": _ACCEL_UNITS, "az": _ACCEL_UNITS},
    "BARO": {"time": _TIME_UNITS, "pressure": _PRESSURE_UNITS,
             "temperature": _TEMPERATURE_UNITS},
    "TIME": {"time": _TIME_UNITS, "tow": _TIME_UNITS, "week": {"": 1.0}},
}


def gps_to_unix(gps_s: np.ndarray | float) -> np.ndarray:
    """Unix UTC seconds from GPS seconds since the GPS epoch, with the leap seconds."""
    g = np.asarray(gps_s, dtype=np.float64) + GPS_EPOCH_UNIX_S
    starts = np.array([s + leap for s, leap in GPS_UTC_LEAP_TABLE], dtype=np.float64)
    leaps = np.array([leap for _, leap in GPS_UTC_LEAP_TABLE], dtype=np.float64)
    k = np.clip(np.searchsorted(starts, g, side="right") - 1, 0, None)
    return g - leaps[k]


@dataclass(frozen=True)
class ClockFit:
    """Least-squares line from the sensor clock to GPS time, from the ``$TIME`` rows.

    ``gps_s = offset_s + (1 + drift_ppm * 1e-6) * sensor_s`` with ``gps_s`` the ``$TIME``
    rows' ``week * 604800 + tow`` (seconds since 1980-01-06 on the rows' time base).

    Attributes
    ----------
    offset_s : float
        GPS time at sensor time 0, s.
    drift_ppm : float
        Rate of the sensor clock against GPS, parts per million (positive: the sensor clock
        runs slow).
    residual_rms_s, max_residual_s : float
        RMS and largest absolute residual of the ``$TIME`` rows about the line, s.
    n_rows : int
        Number of ``$TIME`` rows fitted.
    leap_seconds : int
        GPS - UTC leap seconds subtracted (0 when the ``$TIME`` rows count UTC); applied
        by the leap-second table per sample when not 0.
    path : str
        The file, for the note.
    dropped : tuple of (int, float)
        ``$TIME`` rows left out of the fit: (line of the file, offset from the fitted line, s).
    """

    offset_s: float
    drift_ppm: float
    residual_rms_s: float
    max_residual_s: float
    n_rows: int
    leap_seconds: int
    path: str = ""
    dropped: tuple[tuple[int, float], ...] = ()

    def dropped_note(self) -> str:
        """One line naming the dropped ``$TIME`` rows and how far off they were ("" when none)."""
        if not self.dropped:
            return ""
        rows = ", ".join(f"line {line} ({off:+.3f} s)" for line, off in self.dropped[:5])
        more = f" and {len(self.dropped) - 5} more" if len(self.dropped) > 5 else ""
        return (f"{self.path}: {len(self.dropped)} '$TIME' row(s) off the clock line by more than "
                f"{CLOCK_RESIDUAL_LIMIT_S:g} s dropped from the clock fit: {rows}{more}; "
                f"{self.n_rows} rows fitted")

    def gps_seconds(self, sensor_s: np.ndarray | float) -> np.ndarray:
        """GPS seconds since the GPS epoch at the given sensor times."""
        x = np.asarray(sensor_s, dtype=np.float64)
        return self.offset_s + x + self.drift_ppm * 1e-6 * x

    def unix_utc(self, sensor_s: np.ndarray | float) -> np.ndarray:
        """Unix UTC seconds at the given sensor times."""
        g = self.gps_seconds(sensor_s)
        return gps_to_unix(g) if self.leap_seconds else g + GPS_EPOCH_UNIX_S


@dataclass(frozen=True)
class SensorLog:
    """A FlySight 2 sensor log in SI units on UTC time.

    Attributes
    ----------
    path : str
        File read.
    imu_time_unix_s : numpy.ndarray
        (N,) UTC time of the IMU samples, Unix seconds.
    imu_gyro_radps, imu_accel_mps2 : numpy.ndarray
        (N, 3) angular rate (rad/s) and specific force (m/s^2), FlySight IMU axes.
    baro_time_unix_s : numpy.ndarray
        (M,) UTC time of the barometer samples.
    baro_pressure_pa, baro_temperature_k : numpy.ndarray
        (M,) static pressure, Pa, and the sensor's temperature, K (the device's inside,
        not the air's).
    clock_fit : ClockFit
        Sensor clock to GPS time.
    imu_time_sensor_s, baro_time_sensor_s : numpy.ndarray
        The same samples' times on the sensor clock, s.
    row_counts : dict
        Data rows per kind, every kind of the file.
    skipped_rows : dict
        Rows of the kinds not read (``MAG``, ``HUM``, ``VBAT``, ...), per kind.
    gyro_scale_applied : float
        Factor the logged rates were multiplied by (``FLYSIGHT2_GYRO_SCALE`` by default; module
        docstring).
    imu_lines : numpy.ndarray
        (N,) 1-based line of each IMU sample in the file.
    """

    path: str
    imu_time_unix_s: np.ndarray
    imu_gyro_radps: np.ndarray
    imu_accel_mps2: np.ndarray
    baro_time_unix_s: np.ndarray
    baro_pressure_pa: np.ndarray
    baro_temperature_k: np.ndarray
    clock_fit: ClockFit
    imu_time_sensor_s: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    baro_time_sensor_s: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0))
    row_counts: dict = field(default_factory=dict)
    skipped_rows: dict = field(default_factory=dict)
    gyro_scale_applied: float = 1.0
    imu_lines: np.ndarray = field(repr=False, default_factory=lambda: np.zeros(0, np.int64))


def is_flysight2_sensor(lines: list[str]) -> bool:
    """True when the lines are a FlySight 2 file whose header declares IMU or BARO rows
    and no GNSS rows (a ``SENSOR.CSV``)."""
    if not lines or not lines[0].strip().startswith("$FLYS"):
        return False
    kinds = set()
    for line in lines[:200]:
        if line.startswith("$DATA"):
            break
        f = line.split(",")
        if f[0].strip() == "$COL" and len(f) > 1:
            kinds.add(f[1].strip())
    return bool({"IMU", "BARO"} & kinds) and "GNSS" not in kinds


def read_flysight2_sensor(path: str | Path, time_base: str = "utc",
                          gyro_scale: float = FLYSIGHT2_GYRO_SCALE) -> SensorLog:
    """Read a FlySight 2 ``SENSOR.CSV``: IMU and barometer on UTC time via the ``$TIME`` rows.

    Parameters
    ----------
    path : str or Path
        The sensor file.
    time_base : str
        ``"utc"`` (default, what FlySight 2 writes) or ``"gps"``: the time scale of the
        ``$TIME`` rows' week and tow (see the module docstring).
    gyro_scale : float
        Factor applied to the logged angular rates (default ``FLYSIGHT2_GYRO_SCALE``: the IMU's
        datasheet sensitivity over the firmware's conversion; 1.0 reads them as written).

    Returns
    -------
    SensorLog
        IMU (rad/s, m/s^2) and barometer (Pa, K) samples on UTC time, the clock fit, and
        row counts.

    Raises
    ------
    InputError
        On any malformed content (module docstring: NaN/inf/blank values, duplicated or
        backwards timestamps, unknown or missing units, missing columns, cut rows, a
        ``$TIME`` row off the clock line), located by line and column.
    """
    if time_base not in ("utc", "gps"):
        raise ValueError(f"time_base must be 'utc' or 'gps', got {time_base!r}")
    if not (np.isfinite(gyro_scale) and gyro_scale > 0):
        raise ValueError(f"gyro_scale must be a positive number, got {gyro_scale!r}")
    lines = read_lines(path, require_final_newline=True)
    while lines and not lines[-1].strip():
        lines.pop()
    if not lines or not lines[0].strip().startswith("$FLYS"):
        raise InputError(path, "not a FlySight 2 file: expected '$FLYS' on the first line",
                         line=1)
    cols: dict[str, tuple[list[str], int]] = {}
    units: dict[str, tuple[list[str], int]] = {}
    data_at = None
    for k, line in enumerate(lines):
        f = [x.strip() for x in line.split(",")]
        if f[0] in ("$COL", "$UNIT") and len(f) > 1:
            (cols if f[0] == "$COL" else units).setdefault(f[1], (f[2:], k + 1))
        elif f[0] == "$DATA":
            data_at = k + 1
            break
    if data_at is None:
        raise InputError(path, "FlySight 2 header has no '$DATA' line", line=len(lines))
    if "GNSS" in cols and not ({"IMU", "BARO"} & set(cols)):
        raise InputError(path, "FlySight 2 TRACK.CSV (GNSS rows), not a SENSOR.CSV; read it "
                         "with read_flysight", line=1)
    rows: dict[str, tuple[list[str], list[int]]] = {}
    counts: dict[str, int] = {}
    for k in range(data_at, len(lines)):
        line = lines[k]
        if not line.startswith("$"):
            raise InputError(path, "data line does not start with '$' (expected '$IMU,...', "
                             "'$BARO,...', '$TIME,...')", line=k + 1)
        kind, _, rest = line[1:].partition(",")
        kind = kind.strip()
        counts[kind] = counts.get(kind, 0) + 1
        if kind in _KINDS:
            body, numbers = rows.setdefault(kind, ([], []))
            body.append(rest)
            numbers.append(k + 1)
    values = {kind: _read_kind(path, kind, cols, units, *rows[kind]) for kind in rows}
    if "TIME" not in values:
        raise InputError(path, "no '$TIME' rows: the sensor clock cannot be tied to GPS time",
                         field="$TIME")
    if "IMU" not in values and "BARO" not in values:
        raise InputError(path, "no '$IMU' or '$BARO' rows", field="$IMU")
    fit = _fit_clock(path, values["TIME"], rows["TIME"][1], time_base)
    imu = values.get("IMU", {name: np.zeros(0) for name in _KINDS["IMU"]})
    baro = values.get("BARO", {name: np.zeros(0) for name in _KINDS["BARO"]})
    if baro["pressure"].size and np.any(baro["pressure"] <= 0):
        k = int(np.argmax(baro["pressure"] <= 0))
        raise InputError(path, f"pressure must be positive, got {baro['pressure'][k]:g} Pa",
                         line=rows["BARO"][1][k], field="pressure")
    if baro["temperature"].size and np.any(baro["temperature"] <= 0):
        k = int(np.argmax(baro["temperature"] <= 0))
        raise InputError(path, f"temperature below absolute zero ({baro['temperature'][k]:g} K)",
                         line=rows["BARO"][1][k], field="temperature")
    gyro = gyro_scale * np.column_stack([imu["wx"], imu["wy"], imu["wz"]]).reshape(-1, 3)
    accel = np.column_stack([imu["ax"], imu["ay"], imu["az"]]).reshape(-1, 3)
    return SensorLog(str(path), fit.unix_utc(imu["time"]), gyro, accel,
                     fit.unix_utc(baro["time"]), baro["pressure"], baro["temperature"], fit,
                     imu["time"], baro["time"], counts,
                     {k: n for k, n in counts.items() if k not in _KINDS}, float(gyro_scale),
                     np.asarray(rows["IMU"][1] if "IMU" in rows else [], np.int64))


def _read_kind(path: str | Path, kind: str, cols: dict, units: dict, body: list[str],
               numbers: list[int]) -> dict[str, np.ndarray]:
    """Parse the rows of one kind into SI columns (temperatures in K)."""
    if kind not in cols:
        raise InputError(path, f"'${kind}' rows but no '$COL,{kind},...' header line",
                         line=numbers[0], field=f"$COL,{kind}")
    header, header_line = cols[kind]
    wanted = _KINDS[kind]
    col = find_columns(path, header, list(wanted), line=header_line, kind=f"a FlySight 2 {kind} header")
    if kind not in units:
        raise InputError(path, f"no '$UNIT,{kind},...' line: the units of the {kind} rows are "
                         "unknown", line=header_line, field=f"$UNIT,{kind}")
    unit_row, unit_line = units[kind]
    split = split_rows(path, body, numbers, len(header))
    out = {}
    for name, known in wanted.items():
        unit = unit_row[col[name]] if col[name] < len(unit_row) else ""
        if unit not in known:
            raise InputError(path, f"unknown unit '{unit[:20]}' for {kind} column {name}; "
                             f"expected {' or '.join(repr(u) for u in known)}",
                             line=unit_line, field=name)
        raw = parse_floats(path, [r[col[name]] for r in split], numbers, name)
        with np.errstate(over="ignore"):
            out[name] = raw + known[unit] if name == "temperature" else raw * known[unit]
        overflow = np.isfinite(raw) & ~np.isfinite(out[name])
        if overflow.any():
            k = int(np.argmax(overflow))
            raise InputError(path, f"{name} {raw[k]:g} {unit} is beyond the range of numbers in SI units",
                             line=numbers[k], field=name)
    check_increasing(path, out["time"], numbers, "time")
    return out


def _fit_clock(path: str | Path, tv: dict[str, np.ndarray], numbers: list[int],
               time_base: str) -> ClockFit:
    """Least-squares sensor-clock-to-GPS line of the ``$TIME`` rows, checked."""
    x, tow, week = tv["time"], tv["tow"], tv["week"]
    for name, bad in (("tow", (tow < 0) | (tow >= SECONDS_PER_WEEK)),
                      ("week", (week < 0) | (week != np.round(week)) | (week > 1e5))):
        if bad.any():
            k = int(np.argmax(bad))
            raise InputError(path, f"{name} {tv[name][k]:g} out of range (tow in [0, 604800) "
                             "s, week a whole number)", line=numbers[k], field=name)
    if x.size < 2:
        raise InputError(path, f"{x.size} '$TIME' row; at least 2 are needed to fit the sensor "
                         "clock", line=numbers[0], field="$TIME")
    gps = week * SECONDS_PER_WEEK + tow
    check_increasing(path, gps, numbers, "tow")
    x0, g0 = x[0], gps[0]
    dx, dg = x - x0, gps - g0
    keep = np.ones(x.size, bool)
    if x.size >= 4:
        # a robust first line (median of slopes over half the record, median offset), then the rows
        # within the limit of it are kept: one bad row cannot tilt the line the others are tested on
        h = x.size // 2
        b0 = float(np.median((dg[h:2 * h] - dg[:h]) / (dx[h:2 * h] - dx[:h])))
        a0 = float(np.median(dg - b0 * dx))
        keep = np.abs(dg - a0 - b0 * dx) <= CLOCK_RESIDUAL_LIMIT_S
        if 2 * keep.sum() <= x.size:
            k = int(np.argmax(~keep))
            raise InputError(path, f"only {int(keep.sum())} of {x.size} '$TIME' rows lie within "
                             f"{CLOCK_RESIDUAL_LIMIT_S:g} s of one clock line (more than half are needed); "
                             f"this one is off it by {dg[k] - a0 - b0 * dx[k]:+.3f} s", line=numbers[k], field="$TIME")
    A = np.column_stack([np.ones(int(keep.sum())), dx[keep]])
    (a, b), *_ = np.linalg.lstsq(A, dg[keep], rcond=None)
    res = dg[keep] - (a + b * dx[keep])
    drift_ppm = (b - 1.0) * 1e6
    if abs(drift_ppm) > MAX_DRIFT_PPM:
        raise InputError(path, f"sensor clock drift {drift_ppm:.1f} ppm against GPS time is "
                         f"beyond {MAX_DRIFT_PPM:g} ppm: the '$TIME' rows are inconsistent",
                         line=numbers[0], field="$TIME")
    kept_lines = np.asarray(numbers)[keep]
    k = int(np.argmax(np.abs(res)))
    if abs(res[k]) > CLOCK_RESIDUAL_LIMIT_S:
        raise InputError(path, f"'$TIME' row off the clock fit by {res[k]:+.3f} s (limit "
                         f"{CLOCK_RESIDUAL_LIMIT_S:g} s)", line=int(kept_lines[k]), field="$TIME")
    dropped = tuple((int(numbers[i]), float(dg[i] - a - b * dx[i])) for i in np.flatnonzero(~keep))
    offset = g0 + a - b * x0
    leap = int(round((g0 + GPS_EPOCH_UNIX_S) - float(gps_to_unix(g0)))) if time_base == "gps" \
        else 0
    fit = ClockFit(float(offset), float(drift_ppm), float(np.sqrt(np.mean(res ** 2))),
                   float(np.abs(res).max()), int(keep.sum()), leap, str(path), dropped)
    return fit
