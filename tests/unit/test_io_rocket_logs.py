"""The rocket "Hedy" CATS flight-computer logs (tests/data/realdata/rocket-drogue-descent-hedy, MIT,
RocketPy-Team/RocketPy data/rockets/hedy/cats_tust/): gnssInfo.csv (latitude/longitude only, on the
flight computer clock), baro.csv (ts,id,T,P) and imu.csv (deg/s gyros) read, recognised by
``input_kind`` and ``inspect``; broken copies give one located line and exit 2."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from casrecon.cli import main
from casrecon.io.baro import read_baro
from casrecon.io.errors import InputError
from casrecon.io.gnss_csv import DEFAULT_H_ACC_M, read_gnss_csv
from casrecon.io.gps_files import read_gps_track
from casrecon.io.imu import read_imu_csv
from casrecon.io.input_kind import input_kind
from casrecon.io.inspect import ROCKET_SPEC, inspect_file

HEDY = Path(__file__).resolve().parents[1] / "data" / "realdata" / "rocket-drogue-descent-hedy"


def test_gnss_log():
    raw = np.genfromtxt(HEDY / "gnssInfo.csv", delimiter=",", names=True)
    track = read_gnss_csv(HEDY / "gnssInfo.csv")
    assert track.format == "gnss-csv"
    # stale rows (the position of the previous row repeated) dropped: each kept fix is a new position
    moved = np.r_[True, (np.diff(raw["latitude"]) != 0) | (np.diff(raw["longitude"]) != 0)]
    assert track.n == int(moved.sum()) and track.n < raw.size
    assert np.array_equal(track.time_unix_s, raw["ts"][moved])     # time base: the flight computer clock
    assert np.array_equal(track.lat_deg, raw["latitude"][moved])
    for missing in (track.h_msl_m, track.vel_n_mps, track.vel_e_mps, track.vel_d_mps, track.v_acc_m,
                    track.s_acc_mps):
        assert np.isnan(missing).all()
    assert (track.h_acc_m == DEFAULT_H_ACC_M).all()
    sats = raw["satellites"][moved]
    assert np.array_equal(track.gps_fix == 0, sats == 0)
    assert np.array_equal(track.num_sv == -1, sats > 99)            # 193 is not a satellite count
    shifted = read_gnss_csv(HEDY / "gnssInfo.csv", utc_at_zero_s=1.7e9)
    assert shifted.time_unix_s == pytest.approx(track.time_unix_s + 1.7e9)
    assert "stale" in track.notes[0]
    assert read_gps_track(HEDY / "gnssInfo.csv").n == track.n


def test_baro_and_imu_logs():
    baro = read_baro(HEDY / "baro.csv")
    raw = np.genfromtxt(HEDY / "baro.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert baro.clock == "imu" and np.array_equal(baro.time_s, raw["ts"]) and np.array_equal(baro.pressure_pa, raw["P"])
    imu = read_imu_csv(HEDY / "imu.csv", ROCKET_SPEC)
    raw = np.genfromtxt(HEDY / "imu.csv", delimiter=",", names=True, dtype=None, encoding="utf-8")
    assert np.allclose(np.degrees(imu.gyro_radps[:, 1]), raw["Gy"])  # deg/s in the file, rad/s read
    assert np.array_equal(imu.accel_mps2[:, 2], raw["Az"])
    assert np.array_equal(imu.time_s, baro.time_s)                   # one clock for IMU and barometer


@pytest.mark.parametrize("name, kind, words", [
    ("gnssInfo.csv", "gnss-csv", ("GNSS CSV", "altitude hMSL: not in the file", "stale")),
    ("baro.csv", "baro", ("barometer CSV (IMU clock)", "pressure: 51343 to 99644 Pa", "100 Hz")),
    ("imu.csv", "imu", ("IMU CSV", "Gx, Gy, Gz [deg/s]", "100 Hz")),
])
def test_recognised(name, kind, words):
    assert input_kind(HEDY / name)[0] == kind
    text = inspect_file(HEDY / name)
    for w in words:
        assert w in text, (w, text)


@pytest.mark.parametrize("text, line, field", [
    ("ts,latitude,longitude,satellites\n0.0,39.39,-8.28,10\n0.2,39.39,abc,10\n", 3, "longitude"),
    ("ts,latitude,longitude,satellites\n0.2,39.39,-8.28,10\n0.2,39.391,-8.28,10\n", 3, "ts"),
    ("ts,latitude,longitude,satellites\n0.0,139.39,-8.28,10\n", 2, "latitude"),
    ("ts,latitude,longitude,satellites\n0.0,39.39,-8.28\n", 2, None),
    ("ts,latitude,longitude,satellites\n", 1, None),
])
def test_broken_gnss_csv(tmp_path, capsys, text, line, field):
    f = tmp_path / "gnssInfo.csv"
    f.write_text(text)
    with pytest.raises(InputError) as err:
        read_gnss_csv(f)
    assert err.value.line == line and (field is None or err.value.field == field)
    assert main(["inspect", str(f)]) == 2
    out = capsys.readouterr().err
    assert out.startswith(f"casrecon: {f}:{line}:") and out.strip().count("\n") == 0


@pytest.mark.parametrize("text, line, field", [
    ("ts,id,T,P\n0.0,BARO0,20,99600\n0.01,BARO1,20,99600\n", 3, "id"),
    ("ts,id,T,P\n0.0,BARO0,20,99600\n0.01,BARO0,20,9.96e6\n", 3, "P"),
    ("ts,id,T,P\n0.0,BARO0,20,99600\n0.0,BARO0,20,99600\n", 3, "ts"),
])
def test_broken_baro_csv(tmp_path, capsys, text, line, field):
    f = tmp_path / "baro.csv"
    f.write_text(text)
    with pytest.raises(InputError) as err:
        read_baro(f)
    assert err.value.line == line and err.value.field == field
    assert main(["inspect", str(f)]) == 2
    out = capsys.readouterr().err
    assert out.startswith(f"casrecon: {f}:{line}: field '{field}'") and out.strip().count("\n") == 0
