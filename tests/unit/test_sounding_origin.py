"""A sounding's own launch time and place (casrecon/io/sounding_origin.py), read from the real
soundings of tests/data/realdata/soundings (sources in its README), and what ``casrecon inspect``
says of them and of a barometer file in the wrong unit."""

from __future__ import annotations

import calendar
from pathlib import Path

import pytest

from casrecon.estimation.validation.consistency import distance_km, sounding_origin_warning
from casrecon.io.inspect import inspect_file
from casrecon.io.sounding import read_sounding, write_sounding_csv

REPO = Path(__file__).resolve().parents[2]
SND = REPO / "tests/data/realdata/soundings"


def utc(*fields: int) -> float:
    return float(calendar.timegm((*fields, 0, 0, 0, 0)))


@pytest.mark.parametrize(("name", "launch", "when", "lat", "lon", "line"), [
    ("BOI_72681_2010-12-09_12Z_wyoming.csv", 0, (2010, 12, 9, 11, 6), 43.56, -116.21, 2),
    ("OUN_72357_2023-05-22_12Z_wyoming.csv", 0, (2023, 5, 22, 11, 4), 35.18, -97.44, 2),
    ("20110522_OUN_12Z.txt", 0, (2011, 5, 22, 12, 0), None, None, 1),
    ("USM00070026-data.txt", 1, (2010, 6, 1, 12, 0), 71.2889, -156.7833, 160),
])
def test_origin_of_real_soundings(name, launch, when, lat, lon, line):
    o = read_sounding(SND / name, launch=launch).origin
    assert o.time_unix_s == utc(*when)
    assert (o.lat_deg, o.lon_deg, o.line) == (lat, lon, line)


def test_origin_absent_and_kept_through_plain_csv(tmp_path):
    """The shipped soundings and a TEXT:LIST without its title say nothing; a Wyoming sounding written as
    a plain CSV keeps its origin on the description line."""
    assert not read_sounding(REPO / "problems/ees-drop-1/sounding.csv").origin.known
    assert not read_sounding(SND / "may4_sounding.txt").origin.known
    boise = read_sounding(SND / "BOI_72681_2010-12-09_12Z_wyoming.csv")
    write_sounding_csv(tmp_path / "b.csv", boise)
    back = read_sounding(tmp_path / "b.csv").origin
    assert (back.time_unix_s, back.lat_deg, back.lon_deg, back.line) == (
        boise.origin.time_unix_s, boise.origin.lat_deg, boise.origin.lon_deg, 1)


def test_warning_thresholds():
    """Within a day and 100 km: no warning; one day and one hour, or 101 km: a warning naming both."""
    s = read_sounding(SND / "BOI_72681_2010-12-09_12Z_wyoming.csv")
    t0, lat, lon = s.origin.time_unix_s, s.origin.lat_deg, s.origin.lon_deg
    assert sounding_origin_warning(s, t0 + 23 * 3600, lat + 0.5, lon, "x") is None
    late = sounding_origin_warning(s, t0 + 25 * 3600, lat, lon, "x")
    assert late is not None and "1.0 days after its launch (2010-12-10T12:06:00.000Z at lat 43.5600" in late
    dlat = 101.0 / distance_km(0.0, 0.0, 1.0, 0.0)
    far = sounding_origin_warning(s, None, lat + dlat, lon, "x")
    assert far is not None and "101 km from it (lat " in far and "days" not in far
    assert abs(distance_km(lat, lon, lat + dlat, lon) - 101.0) < 1e-9


def test_inspect_names_the_origin_and_a_barometer_in_hpa(tmp_path):
    text = inspect_file(SND / "USM00070026-data.txt")
    assert "launch: 2010-06-01T00:00:00.000Z, lat 71.2889 lon -156.7833 (line 1)" in text
    assert "launch date and place: not in the file" in inspect_file(REPO / "problems/ees-drop-1/sounding.csv")
    src = (REPO / "problems/ees-drop-1-baro/data/baro.csv").read_text().splitlines()
    rows = [src[0]] + [f"{r.split(',')[0]},{float(r.split(',')[1]) / 100:.3f}" for r in src[1:]]
    (tmp_path / "baro.csv").write_text("\n".join(rows) + "\n")
    warning = [ln for ln in inspect_file(tmp_path / "baro.csv").splitlines() if ln.startswith("WARNING")]
    assert warning == ["WARNING: pressure_pa: median pressure 781.813 Pa, outside the standard atmosphere's 19284 "
                       "to 107478 Pa from -500 to 12000 m MSL; the file is probably in hPa (mbar) (x 100): name its "
                       "column pressure_hpa"]
    assert "WARNING" not in inspect_file(REPO / "problems/ees-drop-1-baro/data/baro.csv")
