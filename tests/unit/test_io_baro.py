"""Barometer files: the plain CSV (UTC or IMU clock, Pa or hPa), FlySight 2 SENSOR.CSV's BARO rows,
the [sensors.baro] table, and located errors on bad input."""

from __future__ import annotations

import numpy as np
import pytest
from test_io_sensor import SENSOR

from casrecon.io.baro import BaroConfig, parse_baro, read_baro, write_baro_csv
from casrecon.io.errors import InputError
from casrecon.io.sensor import read_flysight2_sensor
from casrecon.io.toml_fields import Fields


def test_plain_csv_round_trip(tmp_path):
    t = 1696347128.28 + 0.04 * np.arange(5)
    p = np.array([71226.209, 71232.287, 71230.0, 71229.5, 71228.125])
    write_baro_csv(tmp_path / "baro.csv", t, p)
    log = read_baro(tmp_path / "baro.csv")
    assert log.clock == "utc"
    assert log.time_s == pytest.approx(t, abs=5e-4) and log.pressure_pa == pytest.approx(p, abs=5e-4)


def test_imu_clock_and_hpa(tmp_path):
    f = tmp_path / "baro.csv"
    f.write_text("time_s,temperature_c,pressure_hpa\n0.0,20,1013.25\n0.1,20,1013.20\n")
    log = read_baro(f)
    assert log.clock == "imu" and log.pressure_pa == pytest.approx([101325.0, 101320.0])


@pytest.mark.parametrize("text, line, what", [
    ("time_s,pressure_pa\n0.0,101325\n0.1,-5\n", 3, "outside"),
    ("time_s,pressure_pa\n0.0,101325\n0.0,101320\n", 3, "repeats"),
    ("time_s,pressure_pa\n0.0,101325\n0.1,abc\n", 3, "pressure_pa"),
    ("time_s,pressure_pa\n0.0,101325\n0.1\n", 3, "truncated"),
    ("t,p\n0.0,101325\n0.1,101320\n", 1, "time column"),
    ("time_s,pressure_pa\n0.0,101325\n", None, "at least 2"),
    ("time_s,pressure_pa\n0.0,1013.25\n0.1,1013.2\n", None, None),
])
def test_bad_files_are_located(tmp_path, text, line, what):
    f = tmp_path / "baro.csv"
    f.write_text(text)
    if what is None:  # 1013 "Pa" is a valid (if high-altitude) pressure: accepted, not silently rescaled
        assert read_baro(f).pressure_pa[0] == pytest.approx(1013.25)
        return
    with pytest.raises(InputError) as info:
        read_baro(f)
    assert what in str(info.value) and str(f) in str(info.value)
    if line is not None:
        assert f":{line}:" in str(info.value)


def test_flysight2_sensor_baro_rows():
    log = read_baro(SENSOR)
    ref = read_flysight2_sensor(SENSOR)
    assert log.clock == "utc" and log.time_s.size == ref.baro_time_unix_s.size > 100
    assert np.array_equal(log.pressure_pa, ref.baro_pressure_pa)


def test_config_defaults_and_validation(tmp_path):
    path = tmp_path / "problem.toml"
    assert parse_baro(None) is None
    cfg = parse_baro(Fields({"file": "baro.csv"}, path, "sensors.baro."))
    assert cfg == BaroConfig(file=(tmp_path / "baro.csv"))
    with pytest.raises(InputError, match="noise_pa"):
        parse_baro(Fields({"noise_pa": -1.0}, path, "sensors.baro."))
    with pytest.raises(InputError, match="nois_pa"):
        parse_baro(Fields({"nois_pa": 1.0}, path, "sensors.baro."))
