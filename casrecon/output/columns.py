"""CSV tables of named columns with units in their names (:mod:`casrecon.io.units`): numbers to 9
significant digits (Unix times to the microsecond), text columns (``utc``) as they are."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from casrecon.io.gps_rules import geodetic_sigmas, ned_to_geodetic
from casrecon.io.units import GEODETIC, column_format


def column_cells(name: str, values) -> np.ndarray:
    """The CSV cells of one column: text as it is, numbers in :func:`~casrecon.io.units.column_format`."""
    v = np.asarray(values)
    if v.dtype.kind in "US":
        return v.astype(str)
    return np.char.mod(column_format(name), v.astype(float))


def write_table(path: str | Path, columns: dict[str, np.ndarray], every: int = 1) -> None:
    """Write named columns (1-D arrays of one length, numbers or text) as CSV with a header row,
    keeping every ``every``-th row (the cells of :func:`column_cells`, one format per row)."""
    arrays = [np.asarray(values)[::every] for values in columns.values()]
    text = [a.dtype.kind in "US" for a in arrays]
    row = ",".join("%s" if t else column_format(name) for name, t in zip(columns, text))
    cells = [a.astype(str).tolist() if t else a.astype(float).tolist() for a, t in zip(arrays, text)]
    lines = [",".join(columns)] + [row % r for r in zip(*cells)]
    Path(path).write_text("\n".join(lines) + "\n")


def geodetic_columns(pos_ned: np.ndarray, three_sigma_ned: np.ndarray, site) -> dict[str, np.ndarray]:
    """``latitude_deg``, ``longitude_deg`` (WGS-84, deg) and ``h_msl_m`` (m) of NED positions (n, 3;
    m from the site's ground point; :func:`~casrecon.io.gps_rules.ned_to_geodetic`), each followed
    by its ``_3sigma`` from the positions' 3-sigma (n, 3; m; :func:`~casrecon.io.gps_rules.geodetic_sigmas`:
    north sigma over the meridian radius, east sigma over the parallel's radius, down sigma)."""
    geo = ned_to_geodetic(pos_ned, site)
    sig = geodetic_sigmas(geo[0], geo[2], three_sigma_ned)
    out: dict[str, np.ndarray] = {}
    for name, value, three in zip(GEODETIC, geo, sig):
        out[name], out[f"{name}_3sigma"] = value, three
    return out
