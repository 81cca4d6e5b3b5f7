"""Balloon soundings (radiosondes): pressure, temperature and wind against altitude.

Formats read by :func:`read_sounding` (detected from the content, not the file name):

``wyoming-csv``
    University of Wyoming TEXT:CSV, columns ``quantity_unit`` found by name
    (``pressure_hPa``, ``geopotential height_m``, ``temperature_C``,
    ``wind direction_degree``, ``wind speed_m/s``; ``dew point temperature_C`` when present).
``wyoming-list``
    University of Wyoming TEXT:LIST, fixed-width columns ``PRES HGHT TEMP DWPT ... DRCT SKNT``
    under a units line (hPa, m, C, C, deg, knot) between dashed lines, with or without the
    station line above (DWPT optional).
``igra2``
    IGRA2 v2 data file: ``#`` header line per launch, then fixed-width levels (PRESS Pa,
    GPH m, TEMP 0.1 C, DPDP (dewpoint depression) 0.1 C, WDIR deg, WSPD 0.1 m/s; -9999 and
    -8888 missing).
``plain-csv``
    ``altitude_msl_m,pressure_pa,temperature_k`` and either ``wind_dir_deg,wind_speed_mps``
    (meteorological "from" direction) or ``wind_north_mps,wind_east_mps``, optionally
    ``density_kgm3`` and ``dewpoint_k``; columns by name in any order, leading ``#`` lines are
    a description.

The rules every format's levels follow (which are dropped, which are errors; the optional
dewpoint) are those of :mod:`casrecon.io.sounding_levels`, which also holds :class:`Sounding`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io._csvtools import find_columns, parse_floats, read_lines, split_rows
from casrecon.io.errors import InputError
from casrecon.io.sounding_levels import Sounding, checked_wind, sounding_from_levels
from casrecon.io.sounding_origin import (
    NO_ORIGIN,
    igra2_origin,
    origin_from_text,
    wyoming_csv_origin,
    wyoming_list_origin,
)

KNOT_MPS = 1852.0 / 3600.0
ZERO_C_K = 273.15
_IGRA_HEADER = re.compile(r"^#[A-Z0-9]{11} \d{4} \d\d \d\d \d\d")
_PLAIN_REQUIRED = ("altitude_msl_m", "pressure_pa", "temperature_k")


@dataclass(frozen=True)
class Igra2Launch:
    """One launch (sounding) header of an IGRA2 file.

    Attributes
    ----------
    line : int
        1-based line of the ``#`` header.
    description : str
        Station, date and hour.
    declared_levels : int
        NUMLEV of the header.
    present_levels : int
        Data lines actually following the header.
    """

    line: int
    description: str
    declared_levels: int
    present_levels: int


def detect_sounding_format(lines: list[str]) -> str | None:
    """Name the sounding format of a file's lines, or None if it is not a sounding."""
    head = [ln for ln in lines[:40] if ln.strip()]
    if not head:
        return None
    if _IGRA_HEADER.match(head[0]):
        return "igra2"
    first = head[0].lower()
    if "pressure_hpa" in first and "geopotential height" in first:
        return "wyoming-csv"
    if any(("PRES" in ln.split() and "HGHT" in ln.split()) for ln in head):
        return "wyoming-list"
    plain = next((ln for ln in head if not ln.startswith("#")), "")
    if "altitude_msl_m" in [c.strip() for c in plain.split(",")]:
        return "plain-csv"
    return None


def read_sounding(path: str | Path, launch: int = 0) -> Sounding:
    """Read a sounding in any supported format (detected from the content).

    Parameters
    ----------
    path : str or Path
        Sounding file.
    launch : int
        0-based launch of an IGRA2 file holding several; ignored by the other formats.

    Returns
    -------
    Sounding
        Usable levels, altitude strictly increasing (see the module rules).

    Raises
    ------
    InputError
        Unknown format, missing column, unknown unit, bad number, decreasing altitude,
        fewer than two usable levels, IGRA2 launch out of range or truncated; located.
    """
    lines = read_lines(path)
    fmt = detect_sounding_format(lines)
    if fmt == "igra2":
        return _read_igra2(path, lines, launch)
    if fmt == "wyoming-csv":
        return _read_wyoming_csv(path, lines)
    if fmt == "wyoming-list":
        return _read_wyoming_list(path, lines)
    if fmt == "plain-csv":
        return _read_plain_csv(path, lines)
    raise InputError(path, "not a recognised sounding: expected University of Wyoming "
                     "TEXT:CSV or TEXT:LIST, IGRA2 v2, or a plain CSV with header "
                     "'altitude_msl_m,pressure_pa,temperature_k,...'")


# ----------------------------------------------------------------------------- Wyoming CSV
_WYO_CSV = {  # quantity -> {unit: (scale, offset)} converting to SI
    "pressure": {"hPa": (100.0, 0.0), "Pa": (1.0, 0.0)},
    "geopotential height": {"m": (1.0, 0.0)},
    "temperature": {"C": (1.0, ZERO_C_K), "K": (1.0, 0.0)},
    "wind direction": {"degree": (1.0, 0.0), "deg": (1.0, 0.0)},
    "wind speed": {"m/s": (1.0, 0.0), "knot": (KNOT_MPS, 0.0)},
}


_WYO_DEWPOINT = "dew point temperature"


def _read_wyoming_csv(path: str | Path, lines: list[str]) -> Sounding:
    header = [h.strip() for h in lines[0].split(",")]
    quantity = {h.rsplit("_", 1)[0]: (k, h.rsplit("_", 1)[-1] if "_" in h else "")
                for k, h in enumerate(header)}
    body = [(k + 1, ln) for k, ln in enumerate(lines) if k > 0 and ln.strip()]
    numbers = np.array([n for n, _ in body], dtype=np.int64)
    rows = split_rows(path, [ln for _, ln in body], numbers, len(header))
    vals = {}
    for name, units in _WYO_CSV.items():
        if name not in quantity:
            raise InputError(path, f"required column '{name}_...' is missing", line=1,
                             field=name)
        k, unit = quantity[name]
        if unit not in units:
            raise InputError(path, f"unknown unit '{unit}' for {name}; expected one of "
                             f"{', '.join(units)}", line=1, field=header[k])
        scale, offset = units[unit]
        raw = parse_floats(path, [r[k] for r in rows], numbers, header[k], allow_empty=True)
        with np.errstate(over="ignore"):  # an overflow becomes inf, rejected in _finish
            vals[name] = raw * scale + offset
    wn, we = checked_wind(path, vals["wind direction"], np.nan_to_num(vals["wind speed"], nan=0.0),
                   numbers)
    missing_wind = np.isnan(vals["wind direction"]) | np.isnan(vals["wind speed"])
    wn[missing_wind] = np.nan
    cols = {"z": vals["geopotential height"], "p": vals["pressure"],
            "t": vals["temperature"], "wn": wn, "we": we}
    if _WYO_DEWPOINT in quantity:  # optional: humidity
        k, unit = quantity[_WYO_DEWPOINT]
        units = _WYO_CSV["temperature"]
        if unit not in units:
            raise InputError(path, f"unknown unit '{unit}' for {_WYO_DEWPOINT}; expected one of "
                             f"{', '.join(units)}", line=1, field=header[k])
        scale, offset = units[unit]
        raw = parse_floats(path, [r[k] for r in rows], numbers, header[k], allow_empty=True)
        with np.errstate(over="ignore"):
            cols["dew"] = raw * scale + offset
    desc = ""
    origin = wyoming_csv_origin(
        rows[0][header.index("time")], *(rows[0][header.index(c)] if c in header else None
                                         for c in ("latitude", "longitude")), int(numbers[0])) \
        if rows and "time" in header else NO_ORIGIN
    if rows and "time" in header:
        desc = rows[0][header.index("time")].strip()
        if "latitude" in header and "longitude" in header:
            desc += (f" at lat {rows[0][header.index('latitude')].strip()} lon "
                     f"{rows[0][header.index('longitude')].strip()}")
    return sounding_from_levels(path, "wyoming-csv", cols, numbers, desc, origin)


# ---------------------------------------------------------------------------- Wyoming LIST
_WYO_LIST_UNITS = {"PRES": {"hPa": 100.0}, "HGHT": {"m": 1.0}, "TEMP": {"C": 1.0}, "DWPT": {"C": 1.0},
                   "DRCT": {"deg": 1.0}, "SKNT": {"knot": KNOT_MPS}, "SPED": {"m/s": 1.0}}


def _list_spans(header: str) -> dict[str, tuple[int, int | None]]:
    spans: dict[str, tuple[int, int | None]] = {}
    start = 0
    matches = list(re.finditer(r"\S+", header))
    for k, m in enumerate(matches):
        spans[m.group()] = (start, m.end() if k < len(matches) - 1 else None)
        start = m.end()
    return spans


def _read_wyoming_list(path: str | Path, lines: list[str]) -> Sounding:
    hk = next(k for k, ln in enumerate(lines) if "PRES" in ln.split() and "HGHT" in ln.split())
    spans = _list_spans(lines[hk])
    if hk + 1 >= len(lines):
        raise InputError(path, "no units line under the column names", line=hk + 1)
    units_line = lines[hk + 1]
    speed = "SKNT" if "SKNT" in spans else "SPED"
    read = ("PRES", "HGHT", "TEMP", "DRCT", speed) + (("DWPT",) if "DWPT" in spans else ())  # DWPT optional
    for name in read:
        if name not in spans:
            raise InputError(path, f"required column '{name}' is missing", line=hk + 1,
                             field=name)
        a, b = spans[name]
        unit = units_line[a:b].strip()
        if unit not in _WYO_LIST_UNITS[name]:
            raise InputError(path, f"unknown unit '{unit}' for column {name}; expected "
                             f"{' or '.join(_WYO_LIST_UNITS[name])}", line=hk + 2, field=name)
    start = hk + 2
    if start < len(lines) and lines[start].strip().startswith("---"):
        start += 1
    body, numbers = [], []
    for k in range(start, len(lines)):
        text = lines[k]
        if not text.strip() or re.match(r"\s*[A-Za-z<]", text):
            break
        body.append(text)
        numbers.append(k + 1)
    numbers_a = np.array(numbers, dtype=np.int64)
    vals = {}
    for name in read:
        a, b = spans[name]
        unit = units_line[a:b].strip()
        raw = parse_floats(path, [ln[a:b] for ln in body], numbers_a, name, allow_empty=True)
        with np.errstate(over="ignore"):  # an overflow becomes inf, rejected in _finish
            vals[name] = raw * _WYO_LIST_UNITS[name][unit]
    wn, we = checked_wind(path, vals["DRCT"], np.nan_to_num(vals[speed], nan=0.0), numbers_a)
    wn[np.isnan(vals["DRCT"]) | np.isnan(vals[speed])] = np.nan
    cols = {"z": vals["HGHT"], "p": vals["PRES"], "t": vals["TEMP"] + ZERO_C_K,
            "wn": wn, "we": we}
    if "DWPT" in vals:
        cols["dew"] = vals["DWPT"] + ZERO_C_K
    desc = next((ln.strip() for ln in lines[:hk] if ln.strip() and "---" not in ln), "")
    return sounding_from_levels(path, "wyoming-list", cols, numbers_a, desc, wyoming_list_origin(lines))


# ----------------------------------------------------------------------------------- IGRA2
def igra2_launches(path: str | Path, lines: list[str] | None = None) -> list[Igra2Launch]:
    """List the launches of an IGRA2 v2 data file.

    Parameters
    ----------
    path : str or Path
        IGRA2 data file.
    lines : list of str, optional
        The file's lines if already read.

    Returns
    -------
    list of Igra2Launch
        One per ``#`` header line, in file order.

    Raises
    ------
    InputError
        If the file does not start with an IGRA2 header or a header is malformed.
    """
    lines = read_lines(path) if lines is None else lines
    heads = [k for k, ln in enumerate(lines) if ln.startswith("#")]
    if not heads or heads[0] != 0:
        raise InputError(path, "not an IGRA2 file: the first line must be a '#' header", line=1)
    out = []
    for j, k in enumerate(heads):
        h = lines[k]
        if not _IGRA_HEADER.match(h) or len(h) < 36:
            raise InputError(path, "malformed IGRA2 header line", line=k + 1)
        try:
            declared = int(h[32:36])
        except ValueError:
            raise InputError(path, f"bad NUMLEV '{h[32:36].strip()}' in IGRA2 header",
                             line=k + 1, field="NUMLEV") from None
        end = heads[j + 1] if j + 1 < len(heads) else len(lines)
        present = sum(1 for ln in lines[k + 1:end] if ln.strip())
        desc = f"IGRA2 {h[1:12]} {h[13:17]}-{h[18:20]}-{h[21:23]} {h[24:26]} UTC"
        out.append(Igra2Launch(k + 1, desc, declared, present))
    return out


def _read_igra2(path: str | Path, lines: list[str], launch: int) -> Sounding:
    launches = igra2_launches(path, lines)
    if not 0 <= launch < len(launches):
        raise InputError(path, f"launch {launch} requested but the file holds "
                         f"{len(launches)} launches (0 to {len(launches) - 1})",
                         field="launch")
    info = launches[launch]
    if info.present_levels != info.declared_levels:
        raise InputError(path, f"launch {launch} header declares {info.declared_levels} "
                         f"levels but {info.present_levels} follow (file truncated?)",
                         line=info.line)
    numbers = np.arange(info.line + 1, info.line + 1 + info.present_levels)
    body = [lines[n - 1] for n in numbers]
    for n, ln in zip(numbers, body, strict=True):
        if len(ln.rstrip()) < 51:
            raise InputError(path, f"truncated IGRA2 level ({len(ln.rstrip())} characters, "
                             "expected 51)", line=int(n))
    fields = {"PRESS": (9, 15), "GPH": (16, 21), "TEMP": (22, 27), "DPDP": (34, 39), "WDIR": (40, 45),
              "WSPD": (46, 51)}
    v = {}
    for name, (a, b) in fields.items():
        raw = parse_floats(path, [ln[a:b] for ln in body], numbers, name)
        v[name] = np.where((raw == -9999) | (raw == -8888), np.nan, raw)
    wn, we = checked_wind(path, v["WDIR"], np.nan_to_num(v["WSPD"], nan=0.0) / 10.0, numbers)
    wn[np.isnan(v["WDIR"]) | np.isnan(v["WSPD"])] = np.nan
    cols = {"z": v["GPH"], "p": v["PRESS"], "t": v["TEMP"] / 10.0 + ZERO_C_K, "wn": wn,
            "we": we, "dew": (v["TEMP"] - v["DPDP"]) / 10.0 + ZERO_C_K}
    desc = f"{info.description} (launch {launch} of {len(launches)})"
    return sounding_from_levels(path, "igra2", cols, numbers, desc,
                                igra2_origin(lines[info.line - 1], info.line))


# ------------------------------------------------------------------------------- plain CSV
def _read_plain_csv(path: str | Path, lines: list[str]) -> Sounding:
    comments = []
    hk = 0
    while hk < len(lines) and (lines[hk].startswith("#") or not lines[hk].strip()):
        comments.append(lines[hk].lstrip("#").strip())
        hk += 1
    if hk == len(lines):
        raise InputError(path, "no header line after the comments", line=hk)
    header = [h.strip() for h in lines[hk].split(",")]
    by_dir = "wind_dir_deg" in header or "wind_north_mps" not in header
    wind = ("wind_dir_deg", "wind_speed_mps") if by_dir else ("wind_north_mps", "wind_east_mps")
    wanted = [*_PLAIN_REQUIRED, *wind] + [c for c in ("density_kgm3", "dewpoint_k") if c in header]
    col = find_columns(path, header, wanted, line=hk + 1, kind="a plain CSV sounding")
    body = [(k + 1, ln) for k, ln in enumerate(lines) if k > hk and ln.strip()]
    numbers = np.array([n for n, _ in body], dtype=np.int64)
    rows = split_rows(path, [ln for _, ln in body], numbers, len(header))
    v = {name: parse_floats(path, [r[col[name]] for r in rows], numbers, name, allow_empty=True)
         for name in wanted}
    if by_dir:
        wn, we = checked_wind(path, v["wind_dir_deg"], np.nan_to_num(v["wind_speed_mps"], nan=0.0),
                       numbers)
        wn[np.isnan(v["wind_dir_deg"]) | np.isnan(v["wind_speed_mps"])] = np.nan
    else:
        wn, we = v["wind_north_mps"], v["wind_east_mps"]
    cols = {"z": v["altitude_msl_m"], "p": v["pressure_pa"], "t": v["temperature_k"],
            "wn": wn, "we": we}
    if "density_kgm3" in v:
        cols["rho"] = v["density_kgm3"]
    if "dewpoint_k" in v:
        cols["dew"] = v["dewpoint_k"]
    origin = next((o for o in (origin_from_text(c, k + 1) for k, c in enumerate(comments)) if o.known),
                  NO_ORIGIN)
    return sounding_from_levels(path, "plain-csv", cols, numbers, " ".join(c for c in comments if c), origin)


def write_sounding_csv(path: str | Path, s: Sounding) -> None:
    """Write a sounding as plain CSV (north/east wind components, SI, ``%.10g``).

    The description, if any, goes on a leading ``# `` comment line, which
    :func:`read_sounding` reads back. Columns: ``altitude_msl_m,pressure_pa,temperature_k,
    wind_north_mps,wind_east_mps``, ``density_kgm3`` when the sounding has density and
    ``dewpoint_k`` when it has dewpoints (blank at levels without one).

    Parameters
    ----------
    path : str or Path
        Output file (overwritten).
    s : Sounding
        Profile to write.
    """
    names = ["altitude_msl_m", "pressure_pa", "temperature_k", "wind_north_mps",
             "wind_east_mps"]
    cols = [s.altitude_msl_m, s.pressure_pa, s.temperature_k, s.wind_north_mps,
            s.wind_east_mps]
    if s.density_kgm3 is not None:
        names.append("density_kgm3")
        cols.append(s.density_kgm3)
    if s.dewpoint_k is not None:
        names.append("dewpoint_k")
        cols.append(s.dewpoint_k)
    out = [f"# {' '.join(s.description.split())}"] if s.description.strip() else []
    out.append(",".join(names))
    table = np.column_stack([np.asarray(c, dtype=np.float64) for c in cols])
    out.extend(",".join("" if np.isnan(x) else f"{x:.10g}" for x in row) for row in table)
    Path(path).write_text("\n".join(out) + "\n", encoding="utf-8")
