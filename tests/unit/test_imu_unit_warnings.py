"""Unit plausibility of IMU logs (casrecon.io.imu_checks.peak_findings / unit_warnings): one line naming
the column, the value and the likely unit when a declared or assumed unit gives an implausible value,
in ``casrecon inspect`` and, as a logged warning, in the 6-DOF pre-solve check.

The case of issue 14: a log in deg/s that rests most of the time (so the gyro-unit rule's 95th
percentile stays low) read as rad/s showed +-11,000 deg/s with no warning.
"""

from __future__ import annotations

import logging
import shutil
from pathlib import Path

import numpy as np
import pytest

from casrecon.estimation.validation.precheck import check_problem
from casrecon.io.imu import ImuCsvSpec, read_imu_csv, write_imu_csv
from casrecon.io.imu_checks import gyro_unit_finding, peak_findings, unit_warnings
from casrecon.io.inspect import inspect_file

REPO = Path(__file__).resolve().parents[2]


def rest_then_tumble(path: Path, gyro_in_file: str = "deg/s", accel_spike_mps2: float = 0.0) -> Path:
    """5 min at rest (0.3 deg/s gyro noise, 1 g), then 10 s tumbling at up to 200 deg/s; gyros written in
    ``gyro_in_file`` under the default header (time_s, ax..az in m/s^2, wx..wz), which inspect reads as rad/s."""
    rng = np.random.default_rng(1)
    t = np.arange(0.0, 300.0, 0.01)
    w = rng.normal(0.0, 0.3, (t.size, 3))
    tumble = t > 290.0
    w[tumble] = 200.0 * np.sin(2 * np.pi * np.c_[t[tumble], 1.3 * t[tumble], 0.7 * t[tumble]])
    a = rng.normal(0.0, 0.05, (t.size, 3))
    a[:, 2] -= 9.81
    a[15000, 0] = accel_spike_mps2 or a[15000, 0]
    gyro = w if gyro_in_file == "deg/s" else np.radians(w)
    write_imu_csv(path, t, a, gyro)                  # writes the numbers as given, header time_s,ax,...,wz
    return path


def test_resting_log_in_degrees_read_as_radians_is_warned(tmp_path):
    f = rest_then_tumble(tmp_path / "imu.csv")
    m = read_imu_csv(f)                              # default spec: rad/s
    assert gyro_unit_finding(m, ImuCsvSpec()) is None   # the percentile rule misses it (the case)
    r = inspect_file(f)
    assert "11459.16 deg/s" in r                     # what inspect reports as the range
    lines = [ln for ln in r.splitlines() if ln.startswith("WARNING")]
    assert len(lines) == 1, r
    w = lines[0]
    assert w.startswith("WARNING: line ") and ": wx: gyro reads 200 rad/s (11459 deg/s)" in w
    assert 'probably in deg/s, declare gyro_unit = "deg/s"' in w and "beyond 50 rad/s" in w


def test_same_log_declared_in_degrees_has_no_warning(tmp_path):
    f = rest_then_tumble(tmp_path / "imu.csv")
    spec = ImuCsvSpec(gyro_unit="deg/s")
    assert unit_warnings(read_imu_csv(f, spec), spec) == []
    g = rest_then_tumble(tmp_path / "imu_rad.csv", gyro_in_file="rad/s")
    assert "WARNING" not in inspect_file(g)


def test_accelerometer_peak_is_warned(tmp_path):
    f = rest_then_tumble(tmp_path / "imu.csv", gyro_in_file="rad/s", accel_spike_mps2=-2500.0)
    r = inspect_file(f)
    w = [ln for ln in r.splitlines() if ln.startswith("WARNING")]
    assert len(w) == 1 and "line 15002: ax: accelerometer reads -2500 m/s^2 (-255 g)" in w[0]
    assert "beyond 2000 m/s^2" in w[0] and "check accel_unit" in w[0]
    # declared g: the peak would be 24,500 m/s^2; the median rule already flags the unit, no second line
    spec = ImuCsvSpec(accel_unit="g")
    m = read_imu_csv(f, spec)
    assert "accelerometer" in peak_findings(m, spec) and unit_warnings(m, spec) == []


def test_real_rocket_log_has_no_peak_warning():
    """The real Hedy rocket IMU (deg/s, m/s^2; up to 1757 deg/s = 30.7 rad/s and 77 m/s^2) is plausible."""
    from casrecon.io.inspect import ROCKET_SPEC

    m = read_imu_csv(REPO / "tests/data/realdata/rocket-drogue-descent-hedy/imu.csv", ROCKET_SPEC)
    assert peak_findings(m, ROCKET_SPEC) == {}


@pytest.fixture()
def drop2(tmp_path) -> Path:
    root = tmp_path / "problems"
    (root / "ees-drop-2" / "data").mkdir(parents=True)
    for name in ("problem.toml", "sounding.csv", "data/imu.csv", "data/gps.csv"):
        shutil.copy(REPO / "problems" / "ees-drop-2" / name, root / "ees-drop-2" / name)
    for name in ("vehicles", "aero"):
        shutil.copytree(REPO / "problems" / name, root / name)
    return root / "ees-drop-2"


def test_six_dof_check_logs_a_gyro_spike_and_lets_it_through(drop2, caplog):
    """One gyro sample of 3000 deg/s (52 rad/s) in the fit window of ees-drop-2 (gyros in deg/s):
    warned, not refused."""
    path = drop2 / "data" / "imu.csv"
    lines = path.read_text().splitlines(keepends=True)
    k = next(i for i, ln in enumerate(lines[1:], 1) if float(ln.split(",")[0]) >= 10.0)
    f = lines[k].rstrip("\n").split(",")
    f[5] = "3000"                                    # wy
    lines[k] = ",".join(f) + "\n"
    path.write_text("".join(lines))
    with caplog.at_level(logging.WARNING, logger="casrecon.estimation.validation.data_checks"):
        check_problem(drop2)
    assert f"imu.csv:{k + 1}: field 'wy': gyro reads 3000 deg/s (52.4 rad/s)" in caplog.text
