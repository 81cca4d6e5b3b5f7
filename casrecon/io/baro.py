"""Barometer: its ``[sensors.baro]`` settings, and its files (static pressure against time, from a
FlySight 2 ``SENSOR.CSV`` or a plain CSV).

Plain CSV (``write_baro_csv`` writes it): a header line, then one sample per line, columns found
by name (others ignored):

- time: ``time_unix_s`` (UTC, Unix seconds: the receiver's clock, like GPS fixes) or ``time_s``
  (seconds on the IMU clock), or ``ts`` (a flight computer's clock, the clock of its IMU ``ts``: the IMU
  clock);
- pressure: ``pressure_pa`` (Pa) or ``pressure_hpa`` (hPa = mbar), or ``P`` (Pa).

The CATS flight computer's ``baro.csv`` (``ts,id,T,P``: s, sensor id, temperature C, pressure Pa) is one
of these (``ts`` and ``P``); a file whose ``id`` column names more than one sensor is refused (one file
per sensor).

Rules (violations raise a located :class:`~casrecon.io.errors.InputError`): every cell used is a
finite number; times strictly increase; pressure lies in (0, 120000] Pa; at least two samples.
A FlySight 2 ``SENSOR.CSV`` is recognised by its ``$FLYS`` layout and read with
:func:`casrecon.io.sensor.read_flysight2_sensor` (its ``BARO`` rows, on UTC).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io._csvtools import check_increasing, find_columns, parse_floats, read_lines, split_rows
from casrecon.io.errors import InputError
from casrecon.io.sensor import is_flysight2_sensor, read_flysight2_sensor
from casrecon.io.toml_fields import Fields

#: Highest plausible static pressure, Pa (sea level is 101325 Pa; the Dead Sea about 107000 Pa).
MAX_PRESSURE_PA = 120000.0
#: Time columns of a plain CSV and the clock each one is on.
TIME_COLUMNS = {"time_unix_s": "utc", "time_s": "imu", "ts": "imu"}
#: Pressure columns of a plain CSV and their factor to Pa.
PRESSURE_COLUMNS = {"pressure_pa": 1.0, "pressure_hpa": 100.0, "P": 1.0}
#: Units a pressure file may be in by mistake (read as Pa), and their factor to Pa, most likely first.
PRESSURE_UNITS = {"hPa (mbar)": 100.0, "kPa": 1000.0, "mmHg (torr)": 133.322, "inHg": 3386.39, "psi": 6894.76}


def pressure_unit_hint(low: float, high: float, column: str | None) -> str:
    """What to do about pressures read too small by a factor between ``low`` and ``high``: the unit of
    PRESSURE_UNITS whose factor lies there, nearest their geometric mean, for a message; ``column``:
    the column read."""
    fits = {name: f for name, f in PRESSURE_UNITS.items() if low <= f <= high}
    if not fits:
        return "check the pressure column, its unit and the sensor"
    name = min(fits, key=lambda n: abs(np.log(fits[n] / np.sqrt(low * high))))
    what = f"the file is probably in {name} (x {fits[name]:g})"
    if fits[name] == 100.0 and column in ("pressure_pa", "P"):
        return f"{what}: name its column pressure_hpa"
    return f"{what}: convert it to Pa"


@dataclass(frozen=True)
class BaroConfig:
    """A barometer (``[sensors.baro]``; the table absent: no barometer).

    Parameters
    ----------
    file : Path or None
        FlySight 2 SENSOR.CSV or plain barometer CSV (None: only for synthetic data).
    noise_pa : float
        1-sigma white noise of one sample, Pa.
    bias_sigma_pa : float
        1-sigma of the sensor's constant pressure bias (its prior when ``bias_prior``), Pa.
    bias_prior : bool
        Whether the bias has its zero-mean prior.
    rate_hz : float
        Sample rate of the synthetic barometer, Hz.
    position_error_sigma : float
        1-sigma prior of the static-port position-error coefficient k (the sensor reads
        p + k qbar, dimensionless); 0: not estimated (k = 0). Measured on ees-drop-1-baro: an
        unmodelled k = 0.01 (under 10 Pa) put the clock offset 10.6 sigma off with white-looking
        pressure residuals, so estimate it for a sensor inside a fast vehicle.
    """

    file: Path | None
    noise_pa: float = 3.0
    bias_sigma_pa: float = 50.0
    bias_prior: bool = True
    rate_hz: float = 25.0
    position_error_sigma: float = 0.0


#: 1-sigma prior of the kinematic fit's barometric height scale k (pressure read at the ground altitude
#: plus the height above the ground times 1 + k): the temperature of the day differing from the
#: profile's moves pressure altitude by about 3.5 % per 10 K. The kinematic problems' default
#: (``[baro] height_scale_sigma``) and the kinematic check's of a 6-DOF fit.
HEIGHT_SCALE_SIGMA = 0.03


def parse_baro(t: Fields | None) -> BaroConfig | None:
    """The ``[sensors.baro]`` table, or None when absent."""
    if t is None:
        return None
    d = BaroConfig  # the defaults, written once: on the record's fields
    cfg = BaroConfig(file=t.path_of("file", must_exist=False), noise_pa=t.number("noise_pa", d.noise_pa, positive=True),
                     bias_sigma_pa=t.number("bias_sigma_pa", d.bias_sigma_pa, positive=True),
                     bias_prior=t.boolean("bias_prior", d.bias_prior),
                     rate_hz=t.number("rate_hz", d.rate_hz, positive=True),
                     position_error_sigma=t.number("position_error_sigma", d.position_error_sigma, minimum=0.0))
    t.reject_unknown()
    return cfg


@dataclass(frozen=True)
class BaroLog:
    """Barometer samples.

    Attributes
    ----------
    path : Path
    time_s : (N,) array
        Sample times: UTC Unix seconds when ``clock == "utc"``, IMU-clock seconds when ``"imu"``.
    pressure_pa : (N,) array
        Static pressure, Pa.
    clock : {"utc", "imu"}
    notes : tuple of str
        What the reader noted (a SENSOR.CSV's dropped ``$TIME`` rows).
    lines : (N,) int array or None
        1-based line of each sample in the file (None: not kept, FlySight 2 SENSOR.CSV).
    pressure_column : str or None
        The pressure column read (``pressure_pa``, ``pressure_hpa``, ``P``); None for SENSOR.CSV.
    """

    path: Path
    time_s: np.ndarray
    pressure_pa: np.ndarray
    clock: str
    notes: tuple[str, ...] = ()
    lines: np.ndarray | None = None
    pressure_column: str | None = None


def read_baro(path: str | Path) -> BaroLog:
    """Read a barometer file (FlySight 2 SENSOR.CSV or the plain CSV of the module docstring)."""
    path = Path(path)
    lines = read_lines(path)
    if is_flysight2_sensor(lines):
        log = read_flysight2_sensor(path)
        if log.baro_time_unix_s.size < 2:
            raise InputError(path, f"holds {log.baro_time_unix_s.size} BARO rows; a barometer fit needs at least 2")
        return BaroLog(path, log.baro_time_unix_s, log.baro_pressure_pa, "utc",
                       (log.clock_fit.dropped_note(),) if log.clock_fit.dropped else ())
    header = [h.strip() for h in lines[0].split(",")]
    time_col = next((c for c in TIME_COLUMNS if c in header), None)
    pressure_col = next((c for c in PRESSURE_COLUMNS if c in header), None)
    if time_col is None or pressure_col is None:
        raise InputError(path, "a barometer CSV needs a time column (time_unix_s for UTC, time_s or ts for the IMU "
                         "clock) and a pressure column (pressure_pa, pressure_hpa or P in Pa) named in its header "
                         "line; "
                         f"{'no time column' if time_col is None else 'no pressure column'} found", line=1)
    cols = find_columns(path, header, (time_col, pressure_col), line=1, kind="a barometer CSV")
    body = [ln for ln in lines[1:] if ln.strip()]
    numbers = [k + 2 for k, ln in enumerate(lines[1:]) if ln.strip()]
    if len(body) < 2:
        raise InputError(path, f"holds {len(body)} samples; a barometer fit needs at least 2")
    rows = split_rows(path, body, numbers, len(header))
    t = parse_floats(path, [r[cols[time_col]] for r in rows], numbers, time_col)
    p = parse_floats(path, [r[cols[pressure_col]] for r in rows], numbers, pressure_col)
    p = p * PRESSURE_COLUMNS[pressure_col]
    check_increasing(path, t, numbers, time_col)
    if "id" in header:
        ids = [r[header.index("id")].strip() for r in rows]
        other = next((k for k, i in enumerate(ids) if i != ids[0]), None)
        if other is not None:
            raise InputError(path, f"sensor id {ids[other]!r} after {ids[0]!r}: one barometer per file expected",
                             line=numbers[other], field="id")
    bad = np.flatnonzero((p <= 0) | (p > MAX_PRESSURE_PA))
    if bad.size:
        k = int(bad[0])
        raise InputError(path, f"pressure {p[k]:g} Pa is outside (0, {MAX_PRESSURE_PA:g}] Pa (is the unit right? "
                         f"{pressure_col})", line=numbers[k], field=pressure_col)
    return BaroLog(path, t, p, TIME_COLUMNS[time_col], lines=np.asarray(numbers, dtype=np.int64),
                   pressure_column=pressure_col)


def write_baro_csv(path: str | Path, time_unix_s: np.ndarray, pressure_pa: np.ndarray) -> None:
    """Write a plain barometer CSV on UTC (``time_unix_s,pressure_pa``; ms and mPa resolution)."""
    data = np.column_stack([time_unix_s, pressure_pa])
    np.savetxt(path, data, delimiter=",", header="time_unix_s,pressure_pa", comments="", fmt=["%.3f", "%.3f"])
