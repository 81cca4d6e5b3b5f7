"""Which kind of input a data file is, told from its first lines (the same rules as
``casrecon inspect``): FlySight 2 SENSOR.CSV, FlySight GPS track, NMEA 0183 log, flight-computer GNSS
CSV, sounding, IMU CSV in one of the two layouts :mod:`casrecon.io.inspect` knows, or barometer CSV."""

from __future__ import annotations

from pathlib import Path

from casrecon.io._csvtools import read_lines
from casrecon.io.errors import InputError
from casrecon.io.gps_files import gps_file_kind
from casrecon.io.imu import ImuCsvSpec
from casrecon.io.inspect import ROCKET_SPEC, SUPPORTED, is_baro_csv
from casrecon.io.sensor import is_flysight2_sensor
from casrecon.io.sounding import detect_sounding_format

#: The kinds :func:`input_kind` tells apart.
KINDS = ("flysight2-sensor", "gps", "nmea", "gnss-csv", "sounding", "imu", "baro")


def input_kind(path: str | Path) -> tuple[str, ImuCsvSpec | None]:
    """The kind of the data file ``path`` (one of :data:`KINDS`) and, for an IMU CSV, the layout
    its header matches. InputError (located) for an unreadable file or an unknown kind."""
    lines = read_lines(path)
    first = lines[0].strip() if lines else ""
    header = [h.strip() for h in first.split(",")]
    if is_flysight2_sensor(lines):
        return "flysight2-sensor", None
    gps_kind = gps_file_kind(lines)
    if gps_kind is not None:
        return ("gps" if gps_kind == "flysight" else gps_kind), None
    if detect_sounding_format(lines) is not None:
        return "sounding", None
    for spec in (ImuCsvSpec(), ROCKET_SPEC):
        if all(c in header for c in spec.columns):
            return "imu", spec
    if is_baro_csv(header):
        return "baro", None
    raise InputError(path, f"unknown kind of file; supported: {SUPPORTED}", line=1)
