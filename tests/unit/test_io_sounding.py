"""Sounding readers on the real profiles (Unidata siphon/MetPy fixtures, BSD-3), wind
convention, plain-CSV round trip and malformed copies written in tmp_path.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import REALDATA_DIR

from casrecon.io.errors import InputError
from casrecon.io.sounding import (
    KNOT_MPS,
    igra2_launches,
    read_sounding,
    write_sounding_csv,
)
from casrecon.io.sounding_levels import wind_from_direction

SND = (REALDATA_DIR / "soundings")
LIST = SND / "20110522_OUN_12Z.txt"
MAY4 = SND / "may4_sounding.txt"
BOI = SND / "BOI_72681_2010-12-09_12Z_wyoming.csv"
OUN = SND / "OUN_72357_2023-05-22_12Z_wyoming.csv"
IGRA = SND / "USM00070026-data.txt"


def assert_located(err: InputError, path: Path, line: int | None = None,
                   field: str | None = None) -> None:
    text = str(err)
    assert "\n" not in text and path.name in text
    if line is not None:
        assert err.line == line and f"{path.name}:{line}:" in text
    if field is not None:
        assert err.field == field


def edited(tmp_path: Path, src: Path, edit) -> Path:
    out = tmp_path / src.name
    out.write_text("\n".join(edit(src.read_text().splitlines())) + "\n")
    return out


def test_every_real_sounding_reads():
    names = sorted(p.name for p in SND.iterdir() if p.name != "LICENSE")
    assert len(names) == 5
    for name in names:
        s = read_sounding(SND / name)
        assert s.n >= 2 and np.all(np.diff(s.altitude_msl_m) > 0)
        # pressure never rises (BOI repeats 20 hPa at 26210 m and 26213 m, as the file says)
        assert np.all(s.pressure_pa > 0) and np.all(np.diff(s.pressure_pa) <= 0)
        assert np.all((s.temperature_k > 150) & (s.temperature_k < 320))


@pytest.mark.parametrize("direction,north,east", [(0, -1, 0), (90, 0, -1), (180, 1, 0),
                                                  (270, 0, 1)])
def test_wind_from_direction_hand_cases(direction, north, east):
    n, e = wind_from_direction(direction, 2.0)
    assert n == pytest.approx(2.0 * north, abs=1e-12)
    assert e == pytest.approx(2.0 * east, abs=1e-12)


def test_wind_from_direction_vectorised():
    n, e = wind_from_direction(np.array([45.0, 225.0]), np.array([np.sqrt(2), np.sqrt(2)]))
    np.testing.assert_allclose(n, [-1, 1], atol=1e-12)
    np.testing.assert_allclose(e, [-1, 1], atol=1e-12)


def test_wyoming_list_with_station_line():
    s = read_sounding(LIST)
    assert s.format == "wyoming-list" and s.n == 70 and s.dropped_levels == 1
    assert s.description == "72357 OUN Norman Observations at 12Z 22 May 2011"
    # 1000.0 hPa / 36 m has blank TEMP (below ground): dropped. First good level:
    # 966.0 hPa 345 m 22.2 C, 180 deg 7 kt: from the south, so it blows north: +7 kt north.
    assert s.pressure_pa[0] == pytest.approx(96600.0)
    assert s.temperature_k[0] == pytest.approx(295.35)
    assert s.altitude_msl_m[0] == 345.0
    assert s.wind_north_mps[0] == pytest.approx(7 * KNOT_MPS)
    assert s.wind_east_mps[0] == pytest.approx(0.0, abs=1e-12)
    assert s.altitude_msl_m[-1] == 16410.0


def test_wyoming_list_without_station_line():
    s = read_sounding(MAY4)
    assert s.format == "wyoming-list" and s.n == 30 and s.dropped_levels == 1
    # 959.0 hPa 345 m 22.2 C, 160 deg 18 kt: from SSE, blows NNW:
    # north = -18 kt cos 160 = +16.91 kt, east = -18 kt sin 160 = -6.156 kt
    assert s.pressure_pa[0] == pytest.approx(95900.0)
    assert s.wind_north_mps[0] == pytest.approx(16.914 * KNOT_MPS, rel=1e-4)
    assert s.wind_east_mps[0] == pytest.approx(-6.1564 * KNOT_MPS, rel=1e-4)


def test_wyoming_csv_boise():
    s = read_sounding(BOI)
    assert s.format == "wyoming-csv" and s.n == 131 and s.dropped_levels == 1
    assert s.description.startswith("2010-12-09 11:06:00")
    # 919.0 hPa 874 m -0.1 C, from 240 deg at 1.5 m/s (WSW): blows to ENE:
    # north = -1.5 cos 240 = +0.75, east = -1.5 sin 240 = +1.299
    assert s.pressure_pa[0] == pytest.approx(91900.0)
    assert s.temperature_k[0] == pytest.approx(273.05)
    assert s.wind_north_mps[0] == pytest.approx(0.75)
    assert s.wind_east_mps[0] == pytest.approx(1.2990381)
    assert s.altitude_msl_m[-1] == 32309.0  # the 32485 m level has no wind: dropped
    assert s.density_kgm3 is None


def test_wyoming_csv_norman():
    s = read_sounding(OUN)
    assert s.n == 255 and s.pressure_pa[0] == pytest.approx(97700.0)
    # level 2: 971 hPa, from 145 deg at 5.2 m/s: north = +4.2596, east = -2.9826
    assert s.wind_north_mps[1] == pytest.approx(4.2596, abs=1e-4)
    assert s.wind_east_mps[1] == pytest.approx(-2.9826, abs=1e-4)


def test_igra2_launches_and_levels():
    launches = igra2_launches(IGRA)
    assert len(launches) == 3
    assert [x.declared_levels for x in launches] == [158, 157, 147]
    assert [x.present_levels for x in launches] == [158, 157, 0]
    s = read_sounding(IGRA)
    assert s.format == "igra2" and s.n + s.dropped_levels == 158
    assert "USM00070026 2010-06-01 00" in s.description
    # surface: PRESS 100980 Pa, GPH 12 m, TEMP 0 (0.1 C), WDIR 20, WSPD 51 (0.1 m/s):
    # from NNE, blows SSW: north = -5.1 cos 20 = -4.7924, east = -5.1 sin 20 = -1.7443
    assert s.pressure_pa[0] == 100980.0 and s.altitude_msl_m[0] == 12.0
    assert s.temperature_k[0] == pytest.approx(273.15)
    assert s.wind_north_mps[0] == pytest.approx(-4.7924, abs=1e-4)
    assert s.wind_east_mps[0] == pytest.approx(-1.7443, abs=1e-4)
    s1 = read_sounding(IGRA, launch=1)
    assert "2010-06-01 12" in s1.description and s1.n + s1.dropped_levels == 157


def test_igra2_truncated_and_out_of_range_launch():
    with pytest.raises(InputError, match="declares 147 levels but 0") as exc:
        read_sounding(IGRA, launch=2)
    assert_located(exc.value, IGRA, 318)
    with pytest.raises(InputError, match="holds 3 launches") as exc:
        read_sounding(IGRA, launch=3)
    assert_located(exc.value, IGRA, field="launch")


@pytest.mark.parametrize("src", [LIST, BOI, IGRA])
def test_round_trip_plain_csv(tmp_path, src):
    s = read_sounding(src)
    out = tmp_path / "s.csv"
    write_sounding_csv(out, s)
    r = read_sounding(out)
    assert r.format == "plain-csv" and r.n == s.n and r.dropped_levels == 0
    assert r.description == s.description
    for name in ("altitude_msl_m", "pressure_pa", "temperature_k", "wind_north_mps",
                 "wind_east_mps"):
        np.testing.assert_allclose(getattr(r, name), getattr(s, name), rtol=1e-9, atol=1e-9)


def test_plain_csv_direction_density_any_order_and_drop_rules(tmp_path):
    f = tmp_path / "p.csv"
    f.write_text("wind_speed_mps,temperature_k,altitude_msl_m,density_kgm3,pressure_pa,"
                 "wind_dir_deg\n"
                 "4,288,1000,1.1,90000,270\n"
                 "4,287,1000,1.1,89999,270\n"     # same altitude: dropped, first kept
                 ",286,1500,1.05,85000,270\n"      # missing speed: dropped
                 "5,280,2000,1.0,80000,0\n")
    s = read_sounding(f)
    assert s.n == 2 and s.dropped_levels == 2
    np.testing.assert_allclose(s.wind_east_mps, [4, 0], atol=1e-12)
    np.testing.assert_allclose(s.wind_north_mps, [0, -5], atol=1e-12)
    np.testing.assert_allclose(s.density_kgm3, [1.1, 1.0])
    out = tmp_path / "q.csv"
    write_sounding_csv(out, s)
    np.testing.assert_allclose(read_sounding(out).density_kgm3, [1.1, 1.0])


PLAIN_HEADER = "altitude_msl_m,pressure_pa,temperature_k,wind_north_mps,wind_east_mps"
PLAIN_BREAKS = {
    "decreasing altitude": ("100,1e5,288,0,0\n300,9.7e4,287,0,0\n200,9.8e4,287,0,0\n", 4, None),
    "nan": ("100,1e5,288,0,0\n300,nan,287,0,0\n", 3, "pressure_pa"),
    "unparseable": ("100,1e5,288,0,0\n300,9.7e4,28x7,0,0\n", 3, "temperature_k"),
    "truncated row": ("100,1e5,288,0,0\n300,9.7e4\n", 3, None),
    "one level": ("100,1e5,288,0,0\n200,,288,0,0\n", None, None),
    "negative pressure": ("100,1e5,288,0,0\n200,-5,288,0,0\n", 3, "pressure"),
    "temperature in C": ("100,1e5,288,0,0\n200,9.8e4,15,0,0\n", 3, "temperature"),
    "pressure in mPa": ("100,1e5,288,0,0\n200,9.8e7,287,0,0\n", 3, "pressure"),
    "wind in mm/s": ("100,1e5,288,0,0\n200,9.8e4,287,3000,4000\n", 3, "wind speed"),
    "altitude in ft x 1000": ("100,1e5,288,0,0\n2e5,9.8e4,287,0,0\n", 3, "altitude"),
}


@pytest.mark.parametrize("case", sorted(PLAIN_BREAKS))
def test_plain_csv_malformed(tmp_path, case):
    body, line, field = PLAIN_BREAKS[case]
    f = tmp_path / "bad.csv"
    f.write_text(PLAIN_HEADER + "\n" + body)
    with pytest.raises(InputError) as exc:
        read_sounding(f)
    assert_located(exc.value, f, line, field)


def test_plain_csv_missing_column(tmp_path):
    f = tmp_path / "bad.csv"
    f.write_text("altitude_msl_m,pressure_pa,wind_dir_deg,wind_speed_mps\n1,2,3,4\n")
    with pytest.raises(InputError, match="temperature_k") as exc:
        read_sounding(f)
    assert_located(exc.value, f, 1, "temperature_k")


def test_wyoming_list_unknown_unit(tmp_path):
    bad = edited(tmp_path, LIST, lambda L: L[:4] + [L[4].replace("knot", " mph")] + L[5:])
    with pytest.raises(InputError, match="unknown unit 'mph'") as exc:
        read_sounding(bad)
    assert_located(exc.value, bad, 5, "SKNT")


def test_wyoming_list_bad_number(tmp_path):
    # line 8 is the 966.0 hPa level, TEMP 22.2
    bad = edited(tmp_path, LIST, lambda L: L[:7] + [L[7].replace("22.2", "2x.2")] + L[8:])
    with pytest.raises(InputError, match="2x.2") as exc:
        read_sounding(bad)
    assert_located(exc.value, bad, 8, "TEMP")


def test_wyoming_list_overflow_in_unit_conversion(tmp_path):
    # 1e307 hPa is a finite number whose conversion to Pa overflows: an error, not a level
    # silently dropped as missing (line 8 is the 966.0 hPa level)
    bad = edited(tmp_path, LIST, lambda L: L[:7] + [L[7].replace(" 966.0", " 1e307")] + L[8:])
    with pytest.raises(InputError, match="plausible range") as exc:
        read_sounding(bad)
    assert_located(exc.value, bad, 8, "pressure")


def test_wyoming_csv_unknown_unit_and_missing_column(tmp_path):
    bad = edited(tmp_path, BOI, lambda L: [L[0].replace("temperature_C", "temperature_F")]
                 + L[1:])
    with pytest.raises(InputError, match="unknown unit 'F'") as exc:
        read_sounding(bad)
    assert_located(exc.value, bad, 1, "temperature_F")
    bad = edited(tmp_path, BOI, lambda L: [L[0].replace("wind speed_m/s", "gust_m/s")] + L[1:])
    with pytest.raises(InputError, match="wind speed") as exc:
        read_sounding(bad)
    assert_located(exc.value, bad, 1, "wind speed")


def test_wyoming_csv_bad_rows(tmp_path):
    # line 4 is the 890.0 hPa level
    bad = edited(tmp_path, BOI, lambda L: L[:3] + [L[3].replace(" 890.0", " 89O.0")] + L[4:])
    with pytest.raises(InputError, match="89O.0") as exc:
        read_sounding(bad)
    assert_located(exc.value, bad, 4, "pressure_hPa")
    bad = edited(tmp_path, BOI, lambda L: L[:-1] + [L[-1][:40]])
    with pytest.raises(InputError, match="truncated") as exc:
        read_sounding(bad)
    assert_located(exc.value, bad, 133)
    bad = edited(tmp_path, BOI, lambda L: L[:5] + [L[3]] + L[5:])  # altitude goes back
    with pytest.raises(InputError, match="decreases") as exc:
        read_sounding(bad)
    assert_located(exc.value, bad, 6)


def test_igra2_truncated_level(tmp_path):
    bad = edited(tmp_path, IGRA, lambda L: L[:9] + [L[9][:30]] + L[10:])
    with pytest.raises(InputError, match="truncated") as exc:
        read_sounding(bad)
    assert_located(exc.value, bad, 10)
    bad = edited(tmp_path, IGRA, lambda L: L[:4] + [L[4][:10] + "9x" + L[4][12:]] + L[5:])
    with pytest.raises(InputError) as exc:
        read_sounding(bad)
    assert_located(exc.value, bad, 5, "PRESS")


@pytest.mark.parametrize("content", [b"", b"   \n", b"\x89PNG\r\n\x1a\n\x00\x00" * 20,
                                     b"\xfe\xff\xc3\x28\n", b"just,some,csv\n1,2,3\n"])
def test_garbage(tmp_path, content):
    f = tmp_path / "junk.txt"
    f.write_bytes(content)
    with pytest.raises(InputError) as exc:
        read_sounding(f)
    assert_located(exc.value, f)
