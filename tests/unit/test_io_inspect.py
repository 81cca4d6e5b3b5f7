"""inspect_file on every real file kind, on hand-made IMU/plain files and on unknown kinds."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import REALDATA_DIR

from casrecon.io.errors import InputError
from casrecon.io.imu import write_imu_csv
from casrecon.io.inspect import inspect_file

REAL = REALDATA_DIR
FS1 = REAL / "flysight-speed-ssscoring/fs1-byron-2019-05-25.CSV"
FS2 = REAL / "flysight-speed-ssscoring/fs2-chicago-2024-09-17/TRACK.CSV"
SENSOR = REAL / "flysight-speed-ssscoring/fs2-chicago-2024-09-17/SENSOR.CSV"


def test_fs1_report_cold_start_and_columns():
    r = inspect_file(FS1)
    assert "FlySight 1 GPS track" in r and "rows: 5729" in r
    assert "2019-05-25T20:21:18.600Z" in r and "hMSL [m]" in r
    # hAcc 41.8, 30.4, 23.9, ... m at the start: 16 poor fixes, first good one 3.2 s later
    assert "cold start: 16 leading fixes poor" in r
    assert "good fixes start at 2019-05-25T20:21:21.800Z" in r


def test_fs2_report_gap_and_cold_start():
    r = inspect_file(FS2)
    assert "FlySight 2 GNSS track" in r and "rows: 16022" in r
    assert "cold start: 27 leading fixes poor" in r
    assert "largest 623.3 s" in r  # logging paused for about ten minutes on the ride up


def test_sensor_csv_report():
    r = inspect_file(SENSOR)
    assert "FlySight 2 sensor log" in r
    assert "IMU 29745" in r and "BARO 22937" in r and "TIME 1590" in r
    assert "skipped: MAG, HUM, VBAT" in r
    assert "1590 rows, drift +3.302 ppm, residual RMS 0.319 ms" in r
    assert "IMU time: 2024-09-17T18:56:26.143Z to 2024-09-17T19:34:23.933Z UTC" in r
    assert "12.99 Hz" in r and "10.1 Hz" in r


@pytest.mark.parametrize("name,kind", [
    ("20110522_OUN_12Z.txt", "TEXT:LIST"), ("may4_sounding.txt", "TEXT:LIST"),
    ("BOI_72681_2010-12-09_12Z_wyoming.csv", "TEXT:CSV"),
    ("OUN_72357_2023-05-22_12Z_wyoming.csv", "TEXT:CSV"),
    ("USM00070026-data.txt", "IGRA2")])
def test_soundings(name, kind):
    r = inspect_file(REAL / "soundings" / name)
    assert kind in r and "levels:" in r and "altitude MSL" in r


def test_igra2_lists_launches_and_truncation():
    r = inspect_file(REAL / "soundings/USM00070026-data.txt")
    assert "launch 2:" in r and "TRUNCATED: 0 of 147" in r


def test_rocket_imu():
    r = inspect_file(REAL / "rocket-drogue-descent-hedy/imu.csv")
    assert "IMU CSV" in r and "rows: 24564" in r and "100 Hz" in r and "deg/s" in r


def test_imu_saturation_and_gap(tmp_path):
    t = np.arange(100) * 0.01
    t[50:] += 0.5
    acc = np.zeros((100, 3))
    acc[:, 0] = np.linspace(-10, 40, 100)
    acc[90:, 0] = 49.0  # clipped: ten samples sit at the maximum
    f = tmp_path / "imu.csv"
    write_imu_csv(f, t, acc, np.zeros((100, 3)) + np.linspace(0, 1, 100)[:, None])
    r = inspect_file(f)
    assert "possible accelerometer saturation: 10 samples of ax at its max 49" in r
    assert "gaps: 1 steps" in r and "largest 0.51 s" in r


@pytest.mark.parametrize("name", ["LICENSE", "flightInfo.csv"])  # baro.csv: test_io_rocket_logs
def test_unknown_kind(name):
    path = REAL / "rocket-drogue-descent-hedy" / name
    with pytest.raises(InputError) as exc:
        inspect_file(path)
    text = str(exc.value)
    assert name in text and "supported:" in text and "FlySight 1" in text and "\n" not in text


@pytest.mark.parametrize("content", [b"", b"\x00\x01binary"])
def test_empty_and_binary(tmp_path, content):
    f = tmp_path / "x.bin"
    f.write_bytes(content)
    with pytest.raises(InputError, match="x.bin"):
        inspect_file(f)


def test_malformed_flysight_reports_reader_error(tmp_path):
    lines = FS1.read_text().splitlines()
    lines[99] = lines[99][:20]
    f = tmp_path / "cut.CSV"
    f.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError) as exc:
        inspect_file(f)
    assert exc.value.line == 100 and "cut.CSV:100:" in str(exc.value)


def test_random_corruptions_only_raise_input_error(tmp_path):
    """Deterministic fuzz: cut, delete, insert and replace bytes in copies of real files."""
    import random

    rng = random.Random(20240917)
    sources = [REAL / "flysight-speed-skyderby/speed_skydiving_411.csv",
               *(p for p in (REAL / "soundings").iterdir() if p.name != "LICENSE")]
    blobs = [(p.name, p.read_bytes()) for p in sources]
    imu_rows = (REAL / "rocket-drogue-descent-hedy/imu.csv").read_bytes().splitlines(True)
    blobs.append(("imu.csv", b"".join(imu_rows[:300])))
    alphabet = b",.-0123456789 \nabcZT:$#e\t\r+"
    for _ in range(150):
        name, raw = rng.choice(blobs)
        b = bytearray(raw)
        for _ in range(rng.randint(1, 3)):
            i = rng.randrange(len(b))
            op = rng.random()
            if op < 0.3:
                del b[i:i + rng.randint(1, 20)]
            elif op < 0.6:
                b[i] = rng.choice(alphabet)
            elif op < 0.8:
                b[i:i] = bytes([rng.choice(alphabet)])
            else:
                b = b[:i]
        f = tmp_path / name
        f.write_bytes(bytes(b))
        try:
            inspect_file(f)
        except InputError as err:
            assert "\n" not in str(err) and name in str(err)
