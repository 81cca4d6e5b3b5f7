"""IMU logs in CSV: a time column, three accelerometer and three gyro columns, named by a spec.

Rules kept by :func:`read_imu_csv` (violations raise a located
:class:`~casrecon.io.errors.InputError`):

- the first line is the header; columns are found by name, extra columns (text ones
  included) are ignored, blank lines at the end are ignored;
- every used cell must be a finite number (blank, ``nan`` and ``inf`` are errors);
- time must be strictly increasing (backwards and duplicated times are errors); gaps (a
  step much longer than the others) are kept as read, not filled: ``casrecon inspect``
  reports them and :func:`casrecon.io.decimate.decimate_imu` refuses a log with gaps;
- units are declared in the spec, never guessed from the file: an unknown unit name is a
  ``ValueError`` when the spec is built (``InputError`` naming the field when it comes from
  ``problem.toml``);
- the spec's ``axes`` rotation (file axes to IMU axes) is applied on read, after the unit
  conversion; saturation is judged on the file's columns and carried to every IMU axis the
  rotation mixes that column into;
- a sample is *saturated* on an axis when its value, in the file's unit, is at or beyond the
  declared limit: ``v <= low + 1e-9 |low|`` or ``v >= high - 1e-9 |high|``. Saturated values
  are kept as read and flagged; they must not be used as measurements.

The file is read in blocks of whole lines (memory bounded: the raw text is never held
whole). A block of plain decimal numbers is parsed by
:func:`casrecon.io._csvtools.parse_numeric_block` (numpy over the bytes, exact, two
threads); any other block (text columns, NaN, a bad row...) takes the slow path
(``numpy.loadtxt``, then a per-cell pass that locates the first bad line and column).
2 000 000 rows of 7 columns read in about 2 s on two cores (``benchmarks/bench_imu_read.py``).
"""

from __future__ import annotations

from collections import deque
from concurrent.futures import ThreadPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io._csvtools import (
    CHUNK_BYTES,
    check_increasing,
    decode_block,
    find_columns,
    iter_line_blocks,
    parse_floats,
    parse_numeric_block,
    split_rows,
)
from casrecon.io.errors import InputError, plain_repr

STANDARD_GRAVITY = 9.80665
TIME_SCALE = {"s": 1.0, "ms": 1e-3, "us": 1e-6}
ACCEL_SCALE = {"m/s^2": 1.0, "g": STANDARD_GRAVITY}
GYRO_SCALE = {"rad/s": 1.0, "deg/s": np.pi / 180.0}
SATURATION_RTOL = 1e-9
#: Threads parsing blocks of a large file (numpy releases the GIL in the fast parser).
READ_THREADS = 2
#: Tolerance of the orthonormality check of a declared axes matrix.
AXES_TOL = 1e-6
_AXIS_INDEX = {"x": 0, "y": 1, "z": 2}


def axes_matrix(axes: str | tuple | list | np.ndarray | None) -> np.ndarray:
    """The 3x3 rotation from the file's axes to the IMU axes that ``axes`` declares.

    Parameters
    ----------
    axes : str, 3x3 array_like or None
        None: identity. A signed permutation string ``"x,-z,y"``: IMU x is the file's x,
        IMU y is minus the file's z, IMU z is the file's y (each file axis used once). Or a
        3x3 matrix ``R`` with ``v_imu = R @ v_file``.

    Returns
    -------
    numpy.ndarray
        (3, 3) proper rotation.

    Raises
    ------
    ValueError
        On a malformed string, a matrix that is not 3x3, not finite, not orthonormal
        (within 1e-6) or with determinant -1 (a reflection: left-handed file axes).
    """
    if axes is None:
        return np.eye(3)
    if isinstance(axes, str):
        parts = [p.strip().lower() for p in axes.split(",")]
        R = np.zeros((3, 3))
        used = []
        for k, p in enumerate(parts):
            sign = -1.0 if p.startswith("-") else 1.0
            name = p.lstrip("+-")
            if len(parts) != 3 or name not in _AXIS_INDEX or len(p) - len(name) > 1:
                raise ValueError(f"axes '{axes}' must be three signed file axes like "
                                 "'x,-z,y'")
            used.append(name)
            R[k, _AXIS_INDEX[name]] = sign
        if sorted(used) != ["x", "y", "z"]:
            raise ValueError(f"axes '{axes}' must use each of x, y, z once")
    else:
        try:
            R = np.array(axes, dtype=np.float64)
        except (TypeError, ValueError):
            raise ValueError(f"axes must be a string like 'x,-z,y' or a 3x3 matrix, got "
                             f"{plain_repr(axes)}") from None
        if R.shape != (3, 3) or not np.isfinite(R).all():
            raise ValueError(f"axes matrix must be 3x3 and finite, got shape {R.shape}")
        if not np.allclose(R @ R.T, np.eye(3), rtol=0, atol=AXES_TOL):
            raise ValueError("axes matrix is not orthonormal (R R^T != I within 1e-6)")
    if np.linalg.det(R) < 0:
        raise ValueError(f"axes {plain_repr(axes)} has determinant -1: a reflection, not a rotation "
                         "(the file's axes would be left-handed)")
    return R


def _check_limits(name: str, limits: tuple[tuple[float, float], ...] | None) -> None:
    if limits is None:
        return
    try:
        pairs = [(float(lo), float(hi)) for lo, hi in limits]
    except (TypeError, ValueError):
        raise ValueError(f"{name} must be a tuple of (low, high) pairs, got {plain_repr(limits)}") from None
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
        applied to all axes), for the file's columns in the order given; None means no
        saturation flagging.
    axes : str, 3x3 tuple or None
        Rotation from the file's axes to the IMU axes, applied on read: a signed
        permutation ``"x,-z,y"`` or a 3x3 matrix (see :func:`axes_matrix`); None is the
        identity.

    Raises
    ------
    ValueError
        On an unknown unit, column tuples not of length 3, bad limits or bad axes.
    """

    time_column: str = "time_s"
    accel_columns: tuple[str, str, str] = ("ax", "ay", "az")
    gyro_columns: tuple[str, str, str] = ("wx", "wy", "wz")
    time_unit: str = "s"
    accel_unit: str = "m/s^2"
    gyro_unit: str = "rad/s"
    accel_limits: tuple[tuple[float, float], ...] | None = None
    gyro_limits: tuple[tuple[float, float], ...] | None = None
    axes: str | tuple[tuple[float, float, float], ...] | None = None

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
                raise ValueError(f"{name} must be 3 non-empty column names, got {plain_repr(cols)}")
        names = [self.time_column, *self.accel_columns, *self.gyro_columns]
        if len(set(names)) != len(names):
            raise ValueError(f"column names must be distinct, got {names}")
        _check_limits("accel_limits", self.accel_limits)
        _check_limits("gyro_limits", self.gyro_limits)
        if self.axes is not None and not isinstance(self.axes, str):
            object.__setattr__(self, "axes", tuple(tuple(float(x) for x in row)
                                                   for row in axes_matrix(self.axes)))
        axes_matrix(self.axes)

    @property
    def rotation(self) -> np.ndarray:
        """(3, 3) rotation from the file's axes to the IMU axes (``v_imu = R @ v_file``)."""
        return axes_matrix(self.axes)

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
    line_numbers : numpy.ndarray or None
        (N,) 1-based line of each sample in its file; None: sample k on line k + 2 (an IMU CSV).
    """

    path: str
    time_s: np.ndarray
    accel_mps2: np.ndarray
    gyro_radps: np.ndarray
    accel_saturated: np.ndarray
    gyro_saturated: np.ndarray
    line_numbers: np.ndarray | None = None

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


def read_imu_csv(path: str | Path, spec: ImuCsvSpec = ImuCsvSpec(),  # noqa: B008
                 *, chunk_bytes: int = CHUNK_BYTES) -> ImuLog:
    """Read an IMU CSV laid out as ``spec`` says.

    Parameters
    ----------
    path : str or Path
        CSV file with a header line.
    spec : ImuCsvSpec
        Column names, units, saturation limits and axes.
    chunk_bytes : int
        Size of the blocks the file is read in (memory bound; results do not depend on it).

    Returns
    -------
    ImuLog
        Samples in SI units and IMU axes, with saturation flags.

    Raises
    ------
    InputError
        Missing column, truncated row, unparseable or non-finite number (NaN, inf, blank),
        time not strictly increasing (duplicated or backwards), no data rows, binary or
        non-UTF-8 bytes; located by line and column.

    Notes
    -----
    Gaps are kept as read (no row is invented); units are those of the spec (an unknown
    one is refused when the spec is built).
    """
    blocks = iter_line_blocks(path, chunk_bytes)
    line0, block = next(blocks)
    cut = block.index(b"\n") + 1
    header = [h.strip() for h in decode_block(path, block[:cut], line0)[0].split(",")]
    col = find_columns(path, header, spec.columns, line=1, kind="an IMU CSV")
    usecols = [col[c] for c in spec.columns]
    ncols = len(header)
    size = Path(path).stat().st_size
    cap = size // (2 * ncols) + 2
    table = np.empty((cap, 7), dtype=np.float64)  # pages untouched beyond n cost no memory

    def parse(item: tuple[int, bytes]) -> np.ndarray:
        first, blk = item
        fast = parse_numeric_block(blk, ncols)
        if fast is not None:
            return fast[:, usecols]
        lines = decode_block(path, blk, first)
        return _read_table(path, lines, np.arange(first, first + len(lines)), ncols, usecols,
                           spec.columns)

    def body():
        if cut < len(block):
            yield line0 + 1, block[cut:]
        yield from blocks

    n = 0
    with ThreadPoolExecutor(READ_THREADS) as pool:
        pending: deque = deque()
        items = body()
        while True:
            for item in items:
                pending.append(pool.submit(parse, item))
                if len(pending) >= 2 * READ_THREADS:
                    break
            if not pending:
                break
            part = pending.popleft().result()
            if n + part.shape[0] > table.shape[0]:
                table = np.concatenate([table[:n], np.empty((part.shape[0] + n, 7))])
            table[n:n + part.shape[0]] = part
            n += part.shape[0]
    if n == 0:
        raise InputError(path, "no data rows after the header", line=1)
    numbers = range(2, n + 2)
    t = table[:n, 0] * TIME_SCALE[spec.time_unit]
    check_increasing(path, t, numbers, spec.time_column)
    acc_file, gyr_file = table[:n, 1:4], table[:n, 4:7]
    acc_sat = saturation_mask(acc_file, spec.accel_limits)
    gyr_sat = saturation_mask(gyr_file, spec.gyro_limits)
    acc = acc_file * ACCEL_SCALE[spec.accel_unit]
    gyr = gyr_file * GYRO_SCALE[spec.gyro_unit]
    del table, acc_file, gyr_file
    if spec.axes is not None:
        R = spec.rotation
        acc, gyr = acc @ R.T, gyr @ R.T
        mix = (np.abs(R) > AXES_TOL).astype(np.int64)  # IMU axis k mixes file axis j
        acc_sat, gyr_sat = (acc_sat @ mix.T) > 0, (gyr_sat @ mix.T) > 0
    return ImuLog(str(path), t, acc, gyr, acc_sat, gyr_sat)


def _read_table(path: str | Path, body: list[str], numbers, ncols: int,
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
