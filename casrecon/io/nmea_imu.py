"""IMU samples a logger writes as NMEA 0183 proprietary sentences (``$PIMU,t,ax,ay,az,wx,wy,wz*hh``).

There is no standard layout, so the caller names it: the sentence tag (``PIMU``), the name of every
field after the tag in order (:class:`NmeaImuLayout`), and an :class:`~casrecon.io.imu.ImuCsvSpec`
whose column names are among those field names (it carries the units, saturation limits and axes,
exactly as for an IMU CSV). Rules kept by :func:`read_nmea_imu` (violations raise a located
:class:`~casrecon.io.errors.InputError`):

- lines ``$<tag>,...`` are read; blank lines are ignored; every other line (the GPS sentences, other
  proprietary ones, text) is skipped and counted in the notes;
- a checksum ``*hh`` (XOR of the characters between ``$`` and ``*``), when the line has one, must
  match: a line whose checksum is wrong is skipped and counted (a serial glitch, a line cut
  mid-write), as :mod:`casrecon.io.nmea` does; a file with no sentence of the tag left is an error;
- a read sentence must have exactly as many fields as the layout names (an error naming the line);
  every field the spec uses must be a finite number (an error naming the line and field);
- the time field is a number on the logger's clock in the spec's ``time_unit`` (``s``, ``ms``,
  ``us``; not a ``hhmmss`` time of day), strictly increasing (an error naming the line);
- units, saturation flags and the axes rotation are those of :func:`casrecon.io.imu.read_imu_csv`.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io._csvtools import check_increasing, read_lines
from casrecon.io.errors import InputError
from casrecon.io.imu import ACCEL_SCALE, AXES_TOL, GYRO_SCALE, TIME_SCALE, ImuCsvSpec, ImuLog, saturation_mask


@dataclass(frozen=True)
class NmeaImuLayout:
    """Where the IMU values sit in a proprietary NMEA sentence.

    Attributes
    ----------
    tag : str
        The sentence's address after ``$``: ``P`` and the maker's code, e.g. ``"PIMU"``.
    fields : tuple of str
        The name of every field after the tag, in order (``"-"`` or any other unused name for
        fields to ignore); the spec's time, accelerometer and gyro column names must be among them.

    Raises
    ------
    ValueError
        A tag that is not ``P`` and 1 to 8 capitals or digits, or fields with repeated names
        (other than ``"-"``).
    """

    tag: str = "PIMU"
    fields: tuple[str, ...] = ("time_s", "ax", "ay", "az", "wx", "wy", "wz")

    def __post_init__(self) -> None:
        t = self.tag
        if not (isinstance(t, str) and 2 <= len(t) <= 9 and t[0] == "P" and t[1:].isalnum()
                and t[1:] == t[1:].upper() and t.isascii()):
            raise ValueError(f"tag must be 'P' and 1 to 8 capitals or digits (e.g. 'PIMU'), got {t!r}")
        object.__setattr__(self, "fields", tuple(self.fields))
        named = [f for f in self.fields if f != "-"]
        if not all(isinstance(f, str) and f for f in self.fields) or len(set(named)) != len(named):
            raise ValueError(f"fields must be distinct non-empty names ('-' for unused), got {self.fields}")


def _checksum(body: str) -> int:
    c = 0
    for ch in body:
        c ^= ord(ch)
    return c


def read_nmea_imu(path: str | Path, layout: NmeaImuLayout = NmeaImuLayout(),  # noqa: B008
                  spec: ImuCsvSpec = ImuCsvSpec()) -> tuple[ImuLog, tuple[str, ...]]:  # noqa: B008
    """Read the IMU samples of one proprietary NMEA sentence type.

    Parameters
    ----------
    path : str or Path
        The log (any mix of NMEA sentences, one per line).
    layout : NmeaImuLayout
        The sentence tag and the names of its fields in order.
    spec : ImuCsvSpec
        Which fields are the time, accelerometer and gyro (by name), their units (time s, ms or
        us; m/s^2 or g; rad/s or deg/s), saturation limits and axes.

    Returns
    -------
    ImuLog
        Samples in SI units (time on the logger's clock, s) and IMU axes, with saturation flags.
    tuple of str
        Notes: how many other lines were skipped, and how many sentences of the tag had a wrong
        checksum.

    Raises
    ------
    InputError
        A spec column the layout does not name, no sentence of the tag, a sentence with the wrong
        number of fields, a used field that is not a finite number, a time not strictly
        increasing; located by line and field.
    """
    missing = [c for c in spec.columns if c not in layout.fields]
    if missing:
        raise InputError(path, f"the layout of '${layout.tag}' names no field {', '.join(missing)} "
                         f"(fields: {', '.join(layout.fields)})", field=missing[0])
    use = [layout.fields.index(c) for c in spec.columns]
    head = f"${layout.tag},"
    rows, numbers = [], []
    other = bad_sum = 0
    for k, raw in enumerate(read_lines(path)):
        line = raw.strip()
        if not line:
            continue
        if not line.startswith(head):
            other += 1
            continue
        body, star, given = line[1:].partition("*")
        if star:
            try:
                ok = len(given) == 2 and int(given, 16) == _checksum(body)
            except ValueError:
                ok = False
            if not ok:
                bad_sum += 1
                continue
        cells = body.split(",")[1:]
        if len(cells) != len(layout.fields):
            raise InputError(path, f"'${layout.tag}' sentence with {len(cells)} fields; its layout names "
                             f"{len(layout.fields)} ({', '.join(layout.fields)})", line=k + 1)
        values = []
        for j, name in zip(use, spec.columns):
            try:
                v = float(cells[j])
            except ValueError:
                v = float("nan")
            if not np.isfinite(v):
                raise InputError(path, f"field {name} (field {j + 1} after '${layout.tag}') must be a finite "
                                 f"number, got {cells[j].strip()[:20]!r}", line=k + 1, field=name)
            values.append(v)
        rows.append(values)
        numbers.append(k + 1)
    if not rows:
        raise InputError(path, f"no '${layout.tag}' sentence with a good checksum ({other} other lines, "
                         f"{bad_sum} with a wrong checksum)", line=1)
    table = np.array(rows, dtype=np.float64)
    t = table[:, 0] * TIME_SCALE[spec.time_unit]
    check_increasing(path, t, numbers, spec.time_column)
    acc_sat = saturation_mask(table[:, 1:4], spec.accel_limits)
    gyr_sat = saturation_mask(table[:, 4:7], spec.gyro_limits)
    acc = table[:, 1:4] * ACCEL_SCALE[spec.accel_unit]
    gyr = table[:, 4:7] * GYRO_SCALE[spec.gyro_unit]
    if spec.axes is not None:
        rot = spec.rotation
        acc, gyr = acc @ rot.T, gyr @ rot.T
        mix = (np.abs(rot) > AXES_TOL).astype(np.int64)
        acc_sat, gyr_sat = (acc_sat @ mix.T) > 0, (gyr_sat @ mix.T) > 0
    notes = []
    if other:
        notes.append(f"{path}: {other} line(s) other than '${layout.tag}' skipped")
    if bad_sum:
        notes.append(f"{path}: {bad_sum} '${layout.tag}' sentence(s) with a wrong checksum skipped")
    return ImuLog(str(path), t, acc, gyr, acc_sat, gyr_sat), tuple(notes)
