"""IMU CSV reader/writer: real rocket log (RocketPy-Team/RocketPy, MIT), unit conversions,
saturation flags on a hand case, speed, and malformed files written in tmp_path.
"""

from __future__ import annotations

import time
from pathlib import Path

import numpy as np
import pytest
from conftest import REALDATA_DIR

from casrecon.io.errors import InputError
from casrecon.io.imu import STANDARD_GRAVITY, ImuCsvSpec, read_imu_csv, write_imu_csv

ROCKET = (REALDATA_DIR / "rocket-drogue-descent-hedy/imu.csv")
ROCKET_SPEC = ImuCsvSpec(time_column="ts", accel_columns=("Ax", "Ay", "Az"),
                         gyro_columns=("Gx", "Gy", "Gz"), gyro_unit="deg/s")
HEADER = "time_s,ax,ay,az,wx,wy,wz"


def assert_located(err: InputError, path: Path, line: int | None = None,
                   field: str | None = None) -> None:
    text = str(err)
    assert "\n" not in text and path.name in text
    if line is not None:
        assert err.line == line and f"{path.name}:{line}:" in text
    if field is not None:
        assert err.field == field


def synthetic(n: int = 200, seed: int = 1):
    rng = np.random.default_rng(seed)
    t = 12.5 + 0.002 * np.arange(n)
    return t, rng.normal(0, 20, (n, 3)), rng.normal(0, 3, (n, 3))


def test_rocket_log_reads_with_text_id_column():
    m = read_imu_csv(ROCKET, ROCKET_SPEC)
    assert m.n == 24564
    # -0.756,IMU0,0.795146484375,-9.90580078125,-0.67060546875,-1.2605042016806722,...
    assert m.time_s[0] == -0.756
    np.testing.assert_allclose(m.accel_mps2[0], [0.795146484375, -9.90580078125,
                                                 -0.67060546875])
    assert m.gyro_radps[0, 0] == pytest.approx(np.radians(-1.2605042016806722))
    assert m.accel_saturated.shape == (m.n, 3) and not m.accel_saturated.any()


def test_round_trip_default_spec(tmp_path):
    t, a, w = synthetic()
    f = tmp_path / "imu.csv"
    write_imu_csv(f, t, a, w)
    assert f.read_text().splitlines()[0] == HEADER
    m = read_imu_csv(f)
    np.testing.assert_allclose(m.time_s, t, rtol=0, atol=1e-12)
    np.testing.assert_allclose(m.accel_mps2, a, rtol=1e-8)
    np.testing.assert_allclose(m.gyro_radps, w, rtol=1e-8)


def test_round_trip_g_degps_ms_and_custom_columns(tmp_path):
    spec = ImuCsvSpec(time_column="t_ms", accel_columns=("AX", "AY", "AZ"),
                      gyro_columns=("GX", "GY", "GZ"), time_unit="ms", accel_unit="g",
                      gyro_unit="deg/s")
    t, a, w = synthetic()
    f = tmp_path / "imu_g.csv"
    write_imu_csv(f, t, a, w, spec)
    first = f.read_text().splitlines()[1].split(",")
    assert float(first[0]) == pytest.approx(t[0] * 1000)
    assert float(first[1]) == pytest.approx(a[0, 0] / STANDARD_GRAVITY, rel=1e-8)
    assert float(first[4]) == pytest.approx(np.degrees(w[0, 0]), rel=1e-8)
    m = read_imu_csv(f, spec)
    np.testing.assert_allclose(m.time_s, t, atol=1e-12)
    np.testing.assert_allclose(m.accel_mps2, a, rtol=1e-8)
    np.testing.assert_allclose(m.gyro_radps, w, rtol=1e-8)


def test_saturation_hand_case(tmp_path):
    f = tmp_path / "sat.csv"
    f.write_text("time_s,ax,ay,az,wx,wy,wz,extra\n"
                 "0.0,5.0,0,0,157.4,0,0,x\n"          # ax at +5 g: saturated; wx at limit
                 "0.1,4.999999996,0,-3,0,0,-183.65,y\n"  # within 1e-9 rel of 5: saturated
                 "0.2,4.9999,0,-3.5,0,0,-183.6,z\n"   # 4.9999 not; az beyond -3: saturated
                 "0.3,-5.2,3.0,0,200,0,0,w\n")
    spec = ImuCsvSpec(accel_unit="g", gyro_unit="deg/s",
                      accel_limits=((-5, 5), (-3, 3), (-3, 3)),
                      gyro_limits=((-150, 150), (-150, 150), (-183.65, 157.4)))
    m = read_imu_csv(f, spec)
    np.testing.assert_array_equal(m.accel_saturated, [[1, 0, 0], [1, 0, 1], [0, 0, 1],
                                                      [1, 1, 0]])
    np.testing.assert_array_equal(m.gyro_saturated, [[1, 0, 0], [0, 0, 1], [0, 0, 0],
                                                     [1, 0, 0]])
    assert m.accel_mps2[0, 0] == pytest.approx(5 * STANDARD_GRAVITY)  # value kept, flagged
    assert not read_imu_csv(f, ImuCsvSpec(accel_unit="g")).accel_saturated.any()


def test_single_limit_pair_applies_to_all_axes(tmp_path):
    f = tmp_path / "one.csv"
    f.write_text(HEADER + "\n0,1,2,3,0,0,0\n")
    m = read_imu_csv(f, ImuCsvSpec(accel_limits=((-2, 2),)))
    np.testing.assert_array_equal(m.accel_saturated, [[0, 1, 1]])


@pytest.mark.parametrize("kwargs,match", [
    ({"time_unit": "min"}, "time_unit"), ({"accel_unit": "ft/s^2"}, "accel_unit"),
    ({"gyro_unit": "rpm"}, "gyro_unit"), ({"accel_limits": ((1, -1),) * 3}, "low < high"),
    ({"gyro_limits": ((-1, 1),) * 2}, "3"), ({"accel_columns": ("a", "b")}, "3"),
    ({"gyro_columns": ("ax", "q", "r")}, "distinct")])
def test_spec_validation(kwargs, match):
    with pytest.raises(ValueError, match=match):
        ImuCsvSpec(**kwargs)


def test_twenty_thousand_rows_fast(tmp_path):
    t, a, w = synthetic(20000)
    f = tmp_path / "big.csv"
    write_imu_csv(f, t, a, w)
    t0 = time.perf_counter()
    m = read_imu_csv(f)
    assert time.perf_counter() - t0 < 0.5
    assert m.n == 20000


GOOD = [HEADER, "0.0,1,2,3,4,5,6", "0.1,1,2,3,4,5,6", "0.2,1,2,3,4,5,6", "0.3,1,2,3,4,5,6"]
BREAKS = {
    "truncated row": (lambda L: L[:2] + ["0.1,1,2"] + L[3:], 3, None),
    "unparseable": (lambda L: L[:3] + ["0.2,1,2,3,4,5x,6"] + L[4:], 4, "wy"),
    "nan": (lambda L: L[:3] + ["0.2,1,nan,3,4,5,6"] + L[4:], 4, "ay"),
    "inf": (lambda L: L[:4] + ["0.3,1,2,3,-inf,5,6"], 5, "wx"),
    "empty cell": (lambda L: L[:2] + ["0.1,1,2,,4,5,6"] + L[3:], 3, "az"),
    "time backwards": (lambda L: L[:3] + ["0.05,1,2,3,4,5,6"] + L[4:], 4, "time_s"),
    "duplicate time": (lambda L: L[:3] + ["0.1,1,2,3,4,5,6"] + L[4:], 4, "time_s"),
    "missing column": (lambda L: ["time_s,ax,ay,az,wx,wy,gz"] + L[1:], 1, "wz"),
    "blank line inside": (lambda L: L[:2] + [""] + L[2:], 3, None),
    "header only": (lambda L: L[:1], 1, None),
}


@pytest.mark.parametrize("case", sorted(BREAKS))
def test_malformed_is_located(tmp_path, case):
    edit, line, field = BREAKS[case]
    f = tmp_path / "bad_imu.csv"
    f.write_text("\n".join(edit(list(GOOD))) + "\n")
    with pytest.raises(InputError) as exc:
        read_imu_csv(f)
    assert_located(exc.value, f, line, field)


def test_malformed_big_file_still_located(tmp_path):
    t, a, w = synthetic(5000)
    f = tmp_path / "big_bad.csv"
    write_imu_csv(f, t, a, w)
    lines = f.read_text().splitlines()
    lines[4321] = lines[4321].replace(",", ",NaN,", 1).rsplit(",", 1)[0]
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError) as exc:
        read_imu_csv(f)
    assert_located(exc.value, f, 4322, "ax")


def test_rocket_copy_with_bad_id_row_only_in_ignored_column(tmp_path):
    lines = ROCKET.read_text().splitlines()[:50]
    lines[10] = lines[10].replace("IMU0", "???")
    f = tmp_path / "imu.csv"
    f.write_text("\n".join(lines) + "\n")
    assert read_imu_csv(f, ROCKET_SPEC).n == 49
    lines[20] = lines[20][:25]
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError) as exc:
        read_imu_csv(f, ROCKET_SPEC)
    assert_located(exc.value, f, 21)


@pytest.mark.parametrize("content", [b"", b"\x00" * 100, b"\xff\xd8\xff\xe0 jpeg\n",
                                     bytes(range(256))])
def test_garbage(tmp_path, content):
    f = tmp_path / "junk.csv"
    f.write_bytes(content)
    with pytest.raises(InputError) as exc:
        read_imu_csv(f)
    assert_located(exc.value, f)


# ---------------------------------------------------------------- axes, blocks, large files
@pytest.mark.parametrize("axes,expected", [
    ("x,-z,y", [[1, 0, 0], [0, 0, -1], [0, 1, 0]]),
    ("-y,x,z", [[0, -1, 0], [1, 0, 0], [0, 0, 1]]),
    (((0, 1, 0), (-1, 0, 0), (0, 0, 1)), [[0, 1, 0], [-1, 0, 0], [0, 0, 1]])])
def test_axes_rotation_applied_on_read(tmp_path, axes, expected):
    f = tmp_path / "imu.csv"
    f.write_text(HEADER + "\n0,1,2,3,4,5,6\n0.1,1,2,3,4,5,6\n")
    spec = ImuCsvSpec(axes=axes, accel_limits=((-2.5, 2.5), (-10, 10), (-10, 10)))
    m = read_imu_csv(f, spec)
    R = np.array(expected, dtype=float)
    np.testing.assert_allclose(m.accel_mps2[0], R @ [1, 2, 3])
    np.testing.assert_allclose(m.gyro_radps[0], R @ [4, 5, 6])
    # file ay = 2 is within limits, file ax = 1 too: no flags; file column 'ay' saturated
    # moves to the IMU axis the rotation puts it on
    assert not m.accel_saturated.any()
    m2 = read_imu_csv(f, ImuCsvSpec(axes=axes, accel_limits=((-5, 5), (-2, 2), (-5, 5))))
    np.testing.assert_array_equal(m2.accel_saturated[0], np.abs(R[:, 1]) > 0)


@pytest.mark.parametrize("axes,match", [("x,y", "three"), ("x,x,z", "once"), ("x,y,-z", "reflection"),
                                        ("x,y,w", "three"), (((1, 0), (0, 1)), "3x3"),
                                        (((1, 0.1, 0), (0, 1, 0), (0, 0, 1)), "orthonormal"),
                                        (((-1, 0, 0), (0, 1, 0), (0, 0, 1)), "reflection")])
def test_axes_validation(axes, match):
    with pytest.raises(ValueError, match=match):
        ImuCsvSpec(axes=axes)


def test_rocket_log_with_axes_spec():
    spec = ImuCsvSpec(time_column="ts", accel_columns=("Ax", "Ay", "Az"),
                      gyro_columns=("Gx", "Gy", "Gz"), gyro_unit="deg/s", axes="-y,x,z")
    m, ref = read_imu_csv(ROCKET, spec), read_imu_csv(ROCKET, ROCKET_SPEC)
    np.testing.assert_allclose(m.accel_mps2[:, 0], -ref.accel_mps2[:, 1])
    np.testing.assert_allclose(m.gyro_radps[:, 1], ref.gyro_radps[:, 0])


@pytest.mark.parametrize("chunk", [17, 64, 1000])
@pytest.mark.parametrize("case", sorted(BREAKS))
def test_small_blocks_give_the_same_errors(tmp_path, case, chunk):
    edit, line, field = BREAKS[case]
    f = tmp_path / "bad_imu.csv"
    f.write_text("\n".join(edit(list(GOOD))) + "\n")
    with pytest.raises(InputError) as exc:
        read_imu_csv(f, chunk_bytes=chunk)
    assert_located(exc.value, f, line, field)


def test_two_hundred_thousand_rows_blockwise(tmp_path):
    n = 200_000
    rng = np.random.default_rng(7)
    t = np.arange(n) / 50_000.0
    a, w = rng.normal(0, 20, (n, 3)), rng.normal(0, 3, (n, 3))
    f = tmp_path / "raw.csv"
    write_imu_csv(f, t, a, w)
    text = f.read_text().splitlines()
    text[12345] = text[12345].replace(",", ",+", 1)  # a '+' sign: still the fast path
    f.write_text("\r\n".join(text) + "\r\n")          # CRLF
    m = read_imu_csv(f, chunk_bytes=1 << 16)
    assert m.n == n
    np.testing.assert_array_equal(m.time_s, np.array([float(f"{x:.15g}") for x in t]))
    np.testing.assert_allclose(m.accel_mps2, a, rtol=1e-8)
    np.testing.assert_allclose(m.gyro_radps, w, rtol=1e-8)
    text[150000] = text[150000].replace(",", ",nan", 1)
    f.write_text("\n".join(text) + "\n")
    with pytest.raises(InputError) as exc:
        read_imu_csv(f, chunk_bytes=1 << 16)
    assert_located(exc.value, f, 150001, "ax")


def test_fast_parser_matches_python_float():
    from casrecon.io._csvtools import parse_numeric_block

    cells = ["1", "-2.5", "+3e2", "4.e-3", ".5", "-0", "123456789012345", "1E22", "9.99e-20",
             "0.1", "6.02214076e+23", "1.7976931348623157e308"]
    rows = [cells[k:k + 3] for k in range(0, len(cells), 3)]
    block = "".join(",".join(r) + "\n" for r in rows).encode()
    got = parse_numeric_block(block, 3)
    assert got is None  # 17 significant digits / exponent beyond 22: slow path
    block = "".join(",".join(r) + "\n" for r in rows[:3]).encode()
    got = parse_numeric_block(block, 3)
    np.testing.assert_array_equal(got, [[float(c) for c in r] for r in rows[:3]])
    for bad in [b"1,2,1.2.3\n", b"1,2,e5\n", b"1,2,1e\n", b"1,2,1-2\n", b"1,2,-\n", b"1,2,.\n",
                b"1,2,1e5.3\n", b"1,2,\n", b"1,2\n", b"1,2,--1\n", b"1,2,nan\n", b"1,2,0x1\n"]:
        assert parse_numeric_block(bad, 3) is None, bad
