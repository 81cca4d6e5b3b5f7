"""IMU logs in CSV: a time column, three accelerometer and three gyro columns, named by a spec.

Rules kept by :func:`read_imu_csv` (violations raise a located
:class:`~casrecon.io.errors.InputError`):

- the first line is the header; columns are found by name, extra columns (text ones
  included) are ignored, blank lines at the end are ignored;
- every used cell must be a finite number (blank, ``nan`` and ``inf`` are errors);
- time must be strictly increasing (backwards and duplicated times are errors);
- a sample is *saturated* on an axis when its value, in the file's unit, is at or beyond the
  declared limit: ``v <= low + 1e-9 |low|`` or ``v >= high - 1e-9 |high|``. Saturated values
  are kept as read and flagged; they must not be used as measurements.

Parsing is vectorised (numpy string to float conversion); only on failure does a slow pass
look for the offending line, so 20 000 rows read in a few tens of milliseconds.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io._csvtools import check_increasing, find_columns, parse_floats, read_lines, split_rows
from casrecon.io.errors import InputError

STANDARD_GRAVITY = 9.80665
TIME_SCALE = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
ACCEL_SCALE = {"m/s^2": 1.0, "g": STANDARD_GRAVITY}
GYRO_SCALE = {"rad/s": 1.0, "deg/s": np.pi / 180.0}
SATURATION_RTOL = 1e-9


def _check_limits(name: str, limits: tuple[tuple[float, float], ...] | None) -> None:
    if limits is None:
        return
    try:
        pairs = [(float(lo), float(hi)) for lo, hi in limits]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a tuple of (low, high) pairs, got {limits!r}") from None
    if len(pairs) not in (1, 3):
        raise ValueError(f"{name} needs 3 (low, high) pairs, one per axis (or 1 for all), "
                         f"got {len(pairs)}")
    for lo, hi in pairs:
        if not (np.isfinite(lo) and np.isfinite(hi) and lo < hi):
            raise ValueError(f"{name}: each pair must be finite with low < high, got "
                             f"({lo}, {hi})")


@dataclass(frozen=True)
class ImuCsvSpec:
    """How an IMU CSV is laid out: column names, units and saturation limits.

    Attributes
    ----------
    time_column : str
        Name of the time column.
    accel_columns, gyro_columns : tuple of 3 str
        Names of the x, y, z accelerometer and gyro columns (IMU axes).
    time_unit : str
        ``"s"``, ``"ms"`` or ``"us"``.
    accel_unit : str
        ``"m/s^2"`` or ``"g"`` (g = 9.80665 m/s^2).
    gyro_unit : str
        ``"rad/s"`` or ``"deg/s"``.
    accel_limits, gyro_limits : tuple of (low, high) or None
        Per-axis saturation limits in ``accel_unit`` / ``gyro_unit`` (3 pairs, or 1 pair
        applied to all axes); None means no saturation flagging.

    Raises
    ------
    ValueError
        On an unknown unit, column tuples not of length 3, or bad limits.
    """

    time_column: str = "time_s"
    accel_columns: tuple[str, str, str] = ("ax", "ay", "az")
    gyro_columns: tuple[str, str, str] = ("wx", "wy", "wz")
    time_unit: str = "s"
    accel_unit: str = "m/s^2"
    gyro_unit: str = "rad/s"
    accel_limits: tuple[tuple[float, float], ...] | None = None
    gyro_limits: tuple[tuple[float, float], ...] | None = None

    def __post_init__(self) -> None:
        for name, value, allowed in (("time_unit", self.time_unit, TIME_SCALE),
                                     ("accel_unit", self.accel_unit, ACCEL_SCALE),
                                     ("gyro_unit", self.gyro_unit, GYRO_SCALE)):
            if value not in allowed:
                raise ValueError(f"{name} '{value}' is not supported; use one of "
                                 f"{', '.join(allowed)}")
        for name, cols in (("accel_columns", self.accel_columns),
                           ("gyro_columns", self.gyro_columns)):
            if len(cols) != 3 or not all(isinstance(c, str) and c for c in cols):
                raise ValueError(f"{name} must be 3 non-empty column names, got {cols!r}")
        names = [self.time_column, *self.accel_columns, *self.gyro_columns]
        if len(set(names)) != len(names):
            raise ValueError(f"column names must be distinct, got {names}")
        _check_limits("accel_limits", self.accel_limits)
        _check_limits("gyro_limits", self.gyro_limits)

    @property
    def columns(self) -> list[str]:
        """Time, accelerometer and gyro column names in that order."""
        return [self.time_column, *self.accel_columns, *self.gyro_columns]


@dataclass(frozen=True)
class ImuLog:
    """An IMU log in SI units, IMU axes.

    Attributes
    ----------
    path : str
        File read.
    time_s : numpy.ndarray
        IMU clock, s, strictly increasing.
    accel_mps2 : numpy.ndarray
        (N, 3) specific force, m/s^2.
    gyro_radps : numpy.ndarray
        (N, 3) angular rate, rad/s.
    accel_saturated, gyro_saturated : numpy.ndarray
        (N, 3) bool, true where the sample is at or beyond its saturation limit.
    """

    path: str
    time_s: np.ndarray
    accel_mps2: np.ndarray
    gyro_radps: np.ndarray
    accel_saturated: np.ndarray
    gyro_saturated: np.ndarray

    @property
    def n(self) -> int:
        """Number of samples."""
        return int(self.time_s.size)


def saturation_mask(values: np.ndarray, limits: tuple[tuple[float, float], ...] | None,
                    ) -> np.ndarray:
    """Flag samples at or beyond per-axis limits (same unit as ``values``).

    Parameters
    ----------
    values : numpy.ndarray
        (N, 3) samples.
    limits : tuple of (low, high) or None
        3 pairs (or 1 for all axes).

    Returns
    -------
    numpy.ndarray
        (N, 3) bool.
    """
    if limits is None:
        return np.zeros(values.shape, dtype=bool)
    pairs = np.array(limits, dtype=np.float64).reshape(-1, 2)
    pairs = np.broadcast_to(pairs, (3, 2))
    lo, hi = pairs[:, 0], pairs[:, 1]
    return (values <= lo + SATURATION_RTOL * np.abs(lo)) | \
        (values >= hi - SATURATION_RTOL * np.abs(hi))


def read_imu_csv(path: str | Path, spec: ImuCsvSpec = ImuCsvSpec()) -> ImuLog:  # noqa: B008
    """Read an IMU CSV laid out as ``spec`` says.

    Parameters
    ----------
    path : str or Path
        CSV file with a header line.
    spec : ImuCsvSpec
        Column names, units and saturation limits.

    Returns
    -------
    ImuLog
        Samples in SI units with saturation flags.

    Raises
    ------
    InputError
        Missing column, truncated row, unparseable or non-finite number, time not strictly
        increasing, no data rows; located by line and column.
    """
    lines = read_lines(path)
    while lines and not lines[-1].strip():
        lines.pop()
    header = [h.strip() for h in lines[0].split(",")]
    col = find_columns(path, header, spec.columns, line=1)
    if len(lines) < 2:
        raise InputError(path, "no data rows after the header", line=1)
    numbers = np.arange(2, len(lines) + 1)
    table = _read_table(path, lines[1:], numbers, len(header), [col[c] for c in spec.columns],
                        spec.columns)
    t = table[:, 0] * TIME_SCALE[spec.time_unit]
    check_increasing(path, t, numbers, spec.time_column)
    acc, gyr = table[:, 1:4], table[:, 4:7]
    return ImuLog(str(path), t, acc * ACCEL_SCALE[spec.accel_unit],
                  gyr * GYRO_SCALE[spec.gyro_unit], saturation_mask(acc, spec.accel_limits),
                  saturation_mask(gyr, spec.gyro_limits))


def _read_table(path: str | Path, body: list[str], numbers: np.ndarray, ncols: int,
                usecols: list[int], names: list[str]) -> np.ndarray:
    """Parse the used columns of the data rows into an (N, len(usecols)) float array.

    Fast path: a comma count per row and ``numpy.loadtxt``. If anything is wrong, a slow
    pass over the rows finds and reports the first bad line and column.
    """
    counts = np.fromiter((ln.count(",") for ln in body), dtype=np.int64, count=len(body))
    if np.all(counts == ncols - 1):
        try:
            table = np.loadtxt(body, delimiter=",", usecols=usecols, comments=None, ndmin=2,
                               dtype=np.float64)
        except ValueError:
            table = None
        if table is not None and table.shape == (len(body), len(usecols)) \
                and np.isfinite(table).all():
            return table
    rows = split_rows(path, body, numbers, ncols)
    return np.column_stack([parse_floats(path, [r[k] for r in rows], numbers, name)
                            for k, name in zip(usecols, names, strict=True)])


def write_imu_csv(path: str | Path, time_s: np.ndarray, accel_mps2: np.ndarray,
                  gyro_radps: np.ndarray, spec: ImuCsvSpec = ImuCsvSpec()) -> None:  # noqa: B008
    """Write an IMU CSV in the columns and units of ``spec``.

    Time is written with ``%.15g`` (sub-microsecond for hours of log), accelerometer and
    gyro values with ``%.9g``.

    Parameters
    ----------
    path : str or Path
        Output file (overwritten).
    time_s : numpy.ndarray
        (N,) time, s.
    accel_mps2 : numpy.ndarray
        (N, 3) specific force, m/s^2.
    gyro_radps : numpy.ndarray
        (N, 3) angular rate, rad/s.
    spec : ImuCsvSpec
        Column names and units to write in.

    Raises
    ------
    ValueError
        If the array shapes do not agree.
    """
    t = np.asarray(time_s, dtype=np.float64).reshape(-1)
    acc = np.asarray(accel_mps2, dtype=np.float64)
    gyr = np.asarray(gyro_radps, dtype=np.float64)
    if acc.shape != (t.size, 3) or gyr.shape != (t.size, 3):
        raise ValueError(f"need time (N,), accel (N, 3), gyro (N, 3); got {t.shape}, "
                         f"{acc.shape}, {gyr.shape}")
    t = t / TIME_SCALE[spec.time_unit]
    acc = acc / ACCEL_SCALE[spec.accel_unit]
    gyr = gyr / GYRO_SCALE[spec.gyro_unit]
    out = [",".join(spec.columns)]
    fmt = "{:.15g}," + ",".join(["{:.9g}"] * 6)
    out.extend(fmt.format(t[k], *acc[k], *gyr[k]) for k in range(t.size))
    Path(path).write_text("\n".join(out) + "\n", encoding="utf-8")
