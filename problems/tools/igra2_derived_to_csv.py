"""Write each launch of an IGRA2 v2 *derived* file (``*-drvd.txt``) as a plain CSV sounding that
:func:`casrecon.io.sounding.read_sounding` reads.

The derived files hold every level with all quantities (the data files give heights only at the
mandatory levels and winds and temperatures at different significant levels, so their complete
levels are few). Columns used (1-based character spans of NOAA's igra2-derived-format.txt):
PRESS 1-7 (Pa), CALCGPH 17-23 (m, the hydrostatic geopotential height, given at every level; the
reported one is not), TEMP 25-31 (K x 10), VAPPRESS 73-79 (hPa x 1000, written as the dewpoint of
that vapour pressure by Bolton's formula inverted), UWND 113-119 and VWND 129-135 (m/s x 10);
-99999 and -88888 are missing.

Run: python problems/tools/igra2_derived_to_csv.py DERIVED.txt OUT_PREFIX "STATION NAME" LAT LON
(one ``OUT_PREFIX_YYYY-MM-DD_HHZ.csv`` per launch; the description line carries the station, the
nominal time and the place, which :mod:`casrecon.io.sounding_origin` reads back).
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from casrecon.io.sounding import write_sounding_csv
from casrecon.io.sounding_levels import sounding_from_levels

SPANS = {"PRESS": (0, 7), "CALCGPH": (16, 23), "TEMP": (24, 31), "VAPPRESS": (72, 79), "UWND": (112, 119),
         "VWND": (128, 135)}


def dewpoint_k(vapour_pa: np.ndarray) -> np.ndarray:
    """Dewpoint (K) of a vapour pressure (Pa): Bolton's e = 611.2 exp(17.67 t / (t + 243.5)) inverted;
    NaN (no dewpoint) where the vapour pressure is missing or zero."""
    e = np.where(vapour_pa > 0, vapour_pa, np.nan)
    x = np.log(e / 611.2)
    return 243.5 * x / (17.67 - x) + 273.15


def main(path: str, prefix: str, station: str, lat: str, lon: str) -> None:
    lines = Path(path).read_text().splitlines()
    heads = [k for k, ln in enumerate(lines) if ln.startswith("#")] + [len(lines)]
    for a, b in zip(heads[:-1], heads[1:], strict=True):
        h = lines[a]
        date, hour = f"{h[13:17]}-{h[18:20]}-{h[21:23]}", h[24:26]
        body = lines[a + 1:b]
        if len(body) != int(h[32:36]):
            print(f"{path}:{a + 1}: {date} {hour}Z declares {int(h[32:36])} levels, {len(body)} follow: skipped")
            continue
        raw = {k: np.array([float(ln[i:j]) for ln in body]) for k, (i, j) in SPANS.items()}
        v = {k: np.where((x == -99999) | (x == -88888), np.nan, x) for k, x in raw.items()}
        cols = {"z": v["CALCGPH"], "p": v["PRESS"], "t": v["TEMP"] / 10.0, "wn": v["VWND"] / 10.0,
                "we": v["UWND"] / 10.0, "dew": dewpoint_k(v["VAPPRESS"] / 10.0)}
        desc = f"IGRA2 derived {h[1:12]} {station} {date} {hour}Z lat {lat} lon {lon} ({Path(path).name} line {a + 1})"
        s = sounding_from_levels(path, "igra2-derived", cols, np.arange(a + 2, b + 1), desc)
        out = Path(f"{prefix}_{date}_{hour}Z.csv")
        write_sounding_csv(out, s)
        print(f"{out}: {s.n} levels ({s.dropped_levels} dropped)")


if __name__ == "__main__":
    main(*sys.argv[1:6])
