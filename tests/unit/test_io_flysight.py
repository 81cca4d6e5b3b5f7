"""FlySight reader and writer: real tracks, round trip, malformed copies (never the originals).

Real tracks: pr3d4t0r/SSScoring (BSD-3) and skyderby/skyderby (O'Saasy), see
tests/data/realdata (copies of ../shared/realdata)/README.md.
"""

from __future__ import annotations

from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest
from conftest import REALDATA_DIR

from casrecon.io.errors import InputError
from casrecon.io.flysight import read_flysight, write_flysight1

REAL = REALDATA_DIR
FS1 = REAL / "flysight-speed-ssscoring/fs1-byron-2019-05-25.CSV"
FS1B = REAL / "flysight-speed-skyderby/speed_skydiving_411.csv"
FS2 = REAL / "flysight-speed-ssscoring/fs2-chicago-2024-09-17/TRACK.CSV"
SENSOR = REAL / "flysight-speed-ssscoring/fs2-chicago-2024-09-17/SENSOR.CSV"


def unix(*args: int) -> float:
    return datetime(*args, tzinfo=UTC).timestamp()


def assert_located(err: InputError, path: Path, line: int | None = None,
                   field: str | None = None) -> None:
    text = str(err)
    assert "\n" not in text
    assert path.name in text
    if line is not None:
        assert err.line == line
        assert f"{path.name}:{line}:" in text
    if field is not None:
        assert err.field == field
        assert f"'{field}'" in text


def broken_copy(tmp_path: Path, src: Path, edit, newline: str = "\n") -> Path:
    """Copy ``src`` to tmp_path, apply ``edit`` to its list of lines, write it back."""
    lines = src.read_text().splitlines()
    out = tmp_path / src.name
    text = edit(lines)
    out.write_bytes(text.encode() if isinstance(text, str)
                    else (newline.join(text) + newline).encode())
    return out


def test_fs1_byron_reads_with_hand_checked_first_fix():
    g = read_flysight(FS1)
    assert g.format == "flysight1"
    assert g.n == 5731 - 2
    # first row: 2019-05-25T20:21:18.60Z,37.8128243,-121.5854839,402.489,-19.82,49.51,-3.29,
    #            41.832,53.707,0.82,...,3,6
    assert g.time_unix_s[0] == pytest.approx(unix(2019, 5, 25, 20, 21, 18) + 0.6, abs=1e-6)
    assert g.lat_deg[0] == 37.8128243 and g.lon_deg[0] == -121.5854839
    assert g.h_msl_m[0] == 402.489 and g.vel_d_mps[0] == -3.29 and g.h_acc_m[0] == 41.832
    assert g.num_sv[0] == 6 and g.num_sv.dtype.kind == "i"
    assert np.all(np.diff(g.time_unix_s) > 0)
    assert g.vel_d_mps.max() == pytest.approx(104.53)


def test_fs1_skyderby_reads():
    g = read_flysight(FS1B)
    assert g.n == 1177 and g.format == "flysight1"
    assert g.time_unix_s[0] == pytest.approx(unix(2021, 7, 7, 13, 30, 8) + 0.6, abs=1e-6)
    assert g.vel_d_mps.max() == pytest.approx(117.87)


def test_fs2_track_reads_crlf():
    g = read_flysight(FS2)
    assert g.format == "flysight2"
    assert g.n == 16022
    # $GNSS,2024-09-17T18:56:32.200Z,41.3995911,-88.7909127,137.122,-2.503,-0.573,0.448,
    #       635.066,651.242,36.417,4
    assert g.time_unix_s[0] == pytest.approx(unix(2024, 9, 17, 18, 56, 32) + 0.2, abs=1e-6)
    assert g.lat_deg[0] == 41.3995911 and g.vel_d_mps[0] == 0.448 and g.num_sv[0] == 4
    assert g.vel_d_mps.max() == pytest.approx(132.08)


def test_fs2_sensor_file_refused_as_not_a_track():
    with pytest.raises(InputError, match="SENSOR.CSV holds no GNSS track") as exc:
        read_flysight(SENSOR)
    assert_located(exc.value, SENSOR)


def test_round_trip_fs1(tmp_path):
    g = read_flysight(FS2)
    out = tmp_path / "out.csv"
    write_flysight1(out, g)
    lines = out.read_text().splitlines()
    assert lines[0] == "time,lat,lon,hMSL,velN,velE,velD,hAcc,vAcc,sAcc,heading,cAcc,gpsFix,numSV"
    assert lines[1] == ",(deg),(deg),(m),(m/s),(m/s),(m/s),(m),(m),(m/s),(deg),(deg),,"
    assert lines[2].startswith("2024-09-17T18:56:32.20Z,41.3995911,-88.7909127,137.122,")
    h = read_flysight(out)
    assert h.format == "flysight1" and h.n == g.n
    np.testing.assert_allclose(h.time_unix_s, g.time_unix_s, atol=1e-6)
    np.testing.assert_allclose(h.lat_deg, g.lat_deg, atol=1e-7)
    np.testing.assert_allclose(h.h_msl_m, g.h_msl_m, atol=1e-3)
    np.testing.assert_allclose(h.vel_n_mps, g.vel_n_mps, atol=0.006)
    np.testing.assert_array_equal(h.num_sv, g.num_sv)


def test_round_trip_keeps_milliseconds_and_missing_numsv(tmp_path):
    g = read_flysight(FS1B)
    t = g.time_unix_s + 0.003
    g2 = type(g)(**{**g.__dict__, "time_unix_s": t, "num_sv": np.full(g.n, -1)})
    out = tmp_path / "ms.csv"
    write_flysight1(out, g2)
    assert ".603Z," in out.read_text().splitlines()[2]
    h = read_flysight(out)
    np.testing.assert_allclose(h.time_unix_s, t, atol=1e-6)
    assert np.all(h.num_sv == -1)


def _set(lines, lineno, col, value):
    f = lines[lineno - 1].split(",")
    f[col] = value
    lines[lineno - 1] = ",".join(f)
    return lines


FS1_BREAKS = {
    "truncated row": (lambda L: _cut(L, 10), 10, None),
    "unparseable number": (lambda L: _set(L, 7, 1, "37.8x"), 7, "lat"),
    "nan": (lambda L: _set(L, 8, 6, "nan"), 8, "velD"),
    "inf": (lambda L: _set(L, 9, 3, "inf"), 9, "hMSL"),
    "blank value": (lambda L: _set(L, 9, 7, ""), 9, "hAcc"),
    "bad time": (lambda L: _set(L, 12, 0, "2019-05-25 20:21:20.60"), 12, "time"),
    "time backwards": (lambda L: L[:19] + [L[20], L[19]] + L[21:], 21, "time"),
    "duplicate time": (lambda L: L[:30] + [L[29]] + L[30:], 31, "time"),
    "unknown unit": (lambda L: _set(L, 2, 3, "(ft)"), 2, "hMSL"),
    "missing column": (lambda L: _set(L, 1, 7, "hAccuracy"), 1, "hAcc"),
    "extra fields": (lambda L: _set(L, 15, 13, "6,7"), 15, None),
    "blank line inside": (lambda L: L[:40] + [""] + L[40:], 41, None),
    "satellite count inf": (lambda L: _set(L, 16, 13, "inf"), 16, "numSV"),
    "satellite count 1e300": (lambda L: _set(L, 17, 13, "1e300"), 17, "numSV"),
    "fractional fix type": (lambda L: _set(L, 18, 12, "2.5"), 18, "gpsFix"),
    "negative satellite count": (lambda L: _set(L, 19, 13, "-3"), 19, "numSV"),
}


def _cut(lines, lineno):
    lines[lineno - 1] = ",".join(lines[lineno - 1].split(",")[:5])
    return lines


@pytest.mark.parametrize("case", sorted(FS1_BREAKS))
def test_fs1_malformed_is_located(tmp_path, case):
    edit, line, field = FS1_BREAKS[case]
    bad = broken_copy(tmp_path, FS1, edit)
    with pytest.raises(InputError) as exc:
        read_flysight(bad)
    assert_located(exc.value, bad, line, field)


def test_fs1_cut_mid_write_is_an_error_not_dropped(tmp_path):
    text = FS1.read_text()
    bad = tmp_path / "cut.CSV"
    bad.write_text(text[:-20])  # last row loses its tail and its newline
    with pytest.raises(InputError) as exc:
        read_flysight(bad)
    assert_located(exc.value, bad, 5731)
    bad.write_text(text[:-1])  # complete fields but no final newline: still a partial write
    with pytest.raises(InputError, match="mid-write") as exc:
        read_flysight(bad)
    assert_located(exc.value, bad, 5731)


FS2_BREAKS = {
    "unknown unit": (lambda L: [ln.replace("$UNIT,GNSS,,deg,deg,m,", "$UNIT,GNSS,,deg,deg,ft,")
                                for ln in L], 6, "hMSL"),
    "truncated row": (lambda L: L[:99] + [L[99][:30]] + L[100:], 100, None),
    "missing column": (lambda L: [ln.replace(",velD,", ",vD,") for ln in L], 5, "velD"),
    "nan": (lambda L: _set(L, 50, 4, "NaN"), 50, "hMSL"),
    "not a $ line": (lambda L: L[:200] + ["garbage"] + L[200:], 201, None),
}


@pytest.mark.parametrize("case", sorted(FS2_BREAKS))
def test_fs2_malformed_is_located(tmp_path, case):
    edit, line, field = FS2_BREAKS[case]
    bad = broken_copy(tmp_path, FS2, edit, newline="\r\n")
    with pytest.raises(InputError) as exc:
        read_flysight(bad)
    assert_located(exc.value, bad, line, field)


@pytest.mark.parametrize("content", [b"", b"\n\n", b"\x00\x01\x02garbage\xff\xfe" * 50,
                                     b"\xff\xfe\xfa not utf8\n", b"hello,world\n1,2\n"])
def test_garbage_files(tmp_path, content):
    bad = tmp_path / "junk.csv"
    bad.write_bytes(content)
    with pytest.raises(InputError) as exc:
        read_flysight(bad)
    assert_located(exc.value, bad)


def test_missing_file(tmp_path):
    with pytest.raises(InputError) as exc:
        read_flysight(tmp_path / "nope.csv")
    assert_located(exc.value, tmp_path / "nope.csv")
