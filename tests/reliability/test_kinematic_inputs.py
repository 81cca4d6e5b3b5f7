"""The IMU record of a kinematic problem (issue 50): ``[imu] accel_limits`` / ``gyro_limits`` read and
saturated samples masked with a note, gaps reported or refused with their line, an IMU rate too low
for the body's rotation refused as bad input (exit 2, the file named), and a SENSOR.CSV's dropped
``$TIME`` row said once. On copies of the shipped Skydive Chicago FlySight 2 files."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from casrecon.estimation.kinematic.imu_record import MAX_IMU_GAP_S
from casrecon.estimation.kinematic.inputs import inputs_from_config
from casrecon.io.errors import InputError
from casrecon.io.imu import write_imu_csv
from casrecon.io.kinematic_problem import load_kinematic
from casrecon.io.sensor import read_flysight2_sensor

from .conftest import PROBLEMS, assert_clean_failure, call_cli

FILES = PROBLEMS / "realdata-fs2-chicago"
SHIPPED = (PROBLEMS / "realdata-fs2-chicago-kinematic" / "problem.toml").read_text()
SPAN = (1726601120.0, 1726601170.0)  # the shipped problem's [segment], UTC s


def problem(tmp_path: Path, imu_lines: str = "", sensor: Path | None = None, imu_file: Path | None = None,
            segment: tuple[float, float] = SPAN) -> Path:
    """A copy of the shipped kinematic problem in tmp_path, with extra [imu] lines, another IMU file
    and another [segment]."""
    text = SHIPPED.replace('"../realdata-fs2-chicago/SENSOR.CSV"', f'"{imu_file or sensor or FILES / "SENSOR.CSV"}"')
    text = text.replace('"../realdata-fs2-chicago/TRACK.CSV"', f'"{FILES / "TRACK.CSV"}"')
    text = text.replace("[imu]\n", "[imu]\n" + imu_lines)
    text = re.sub(r"start_s = .*\nend_s = .*\n", f"start_s = {segment[0]}\nend_s = {segment[1]}\n", text)
    (tmp_path / "problem.toml").write_text(text)
    return tmp_path


def sensor_copy(tmp_path: Path, drop_imu_rows: range = range(0), shift_first_time_s: float = 0.0) -> Path:
    """A copy of the shipped SENSOR.CSV without the $IMU rows of ``drop_imu_rows`` (0-based among the
    $IMU rows) and with the first $TIME row's tow moved by ``shift_first_time_s``."""
    lines = (FILES / "SENSOR.CSV").read_text().splitlines(keepends=True)
    imu = [i for i, ln in enumerate(lines) if ln.startswith("$IMU")]
    first_time = next(i for i, ln in enumerate(lines) if ln.startswith("$TIME"))
    f = lines[first_time].rstrip("\r\n").split(",")
    f[2] = f"{float(f[2]) + shift_first_time_s:.3f}"
    lines[first_time] = ",".join(f) + "\r\n"
    gone = {imu[k] for k in drop_imu_rows}
    out = tmp_path / "SENSOR.CSV"
    out.write_text("".join(ln for i, ln in enumerate(lines) if i not in gone), newline="")
    return out


@pytest.fixture(scope="module")
def sensor():
    return read_flysight2_sensor(FILES / "SENSOR.CSV")


def test_limits_are_read_and_checked(tmp_path):
    cfg = load_kinematic(problem(tmp_path, "gyro_limits = [[-250, 250], [-250, 250], [-250, 250]]\n"
                                           "accel_limits = [[-16, 16], [-16, 16], [-16, 16]]\n"))
    assert cfg.imu.gyro_limits == ((-250.0, 250.0),) * 3 and cfg.imu.accel_limits == ((-16.0, 16.0),) * 3
    with pytest.raises(InputError, match="low < high") as err:
        load_kinematic(problem(tmp_path, "gyro_limits = [[250, -250], [-250, 250], [-250, 250]]\n"))
    assert err.value.field == "imu.gyro_limits"


def test_limits_of_an_imu_csv_go_to_its_spec(tmp_path):
    rocket = PROBLEMS / "realdata-rocket-hedy-drogue"
    text = (rocket / "problem.toml").read_text()
    text = re.sub(r'file = "([^"]+)"', lambda m: f'file = "{rocket / m.group(1)}"', text)
    text = text.replace("[imu]\n", "[imu]\ngyro_limits = [[-2000, 2000], [-2000, 2000], [-2000, 2000]]\n")
    (tmp_path / "problem.toml").write_text(text)
    cfg = load_kinematic(tmp_path)
    assert cfg.imu.spec.gyro_limits == ((-2000.0, 2000.0),) * 3 and cfg.imu.spec.accel_limits is None


def test_saturated_samples_are_masked_and_counted_in_a_note(tmp_path, sensor):
    """Chicago's gyros reach 473 deg/s in the span: declared clipped at +-200 deg/s, the samples at or beyond
    the limit (counted here from the file's values) are the masked ones, and a note counts them."""
    data, _ = inputs_from_config(load_kinematic(problem(
        tmp_path, "gyro_limits = [[-200, 200], [-200, 200], [-200, 200]]\n")))
    t = sensor.imu_time_unix_s
    sel = (t >= SPAN[0] - 1.0) & (t <= SPAN[1] + 1.0)
    clipped = np.abs(np.degrees(sensor.imu_gyro_radps[sel])) >= 200.0
    assert clipped.sum() >= 10
    np.testing.assert_array_equal(~data.gyro_valid, clipped)
    assert data.accel_valid.all()
    assert any(f"{clipped.sum()} saturated gyro axis-samples in the span" in n for n in data.notes), data.notes


def test_an_axis_mostly_at_its_limit_is_refused(tmp_path):
    with pytest.raises(InputError, match="at or beyond the declared gyro limits") as err:
        inputs_from_config(load_kinematic(problem(tmp_path, "gyro_limits = [[-1, 1], [-1, 1], [-1, 1]]\n")))
    assert err.value.path.endswith("SENSOR.CSV") and err.value.line is not None


def test_short_gaps_are_reported_and_a_long_one_refused_with_its_line(tmp_path, sensor):
    t = sensor.imu_time_unix_s
    first = int(np.searchsorted(t, SPAN[0] + 10.0))  # 10 s into the span
    short = sensor_copy(tmp_path, range(first, first + 2))  # 3 periods of 77 ms: 0.23 s
    data, _ = inputs_from_config(load_kinematic(problem(tmp_path, sensor=short)))
    note = next(n for n in data.notes if "gap" in n)
    assert note.startswith("1 gap in the IMU record") and f"after t = {t[first - 1]:.3f} s" in note, note
    n_long = int(np.ceil(MAX_IMU_GAP_S / 0.077)) + 1
    long = sensor_copy(tmp_path, range(first, first + n_long))
    after = [i + 1 for i, ln in enumerate(long.read_text().splitlines()) if ln.startswith("$IMU")][first]
    with pytest.raises(InputError, match="gap of 0.[5-9]") as err:
        inputs_from_config(load_kinematic(problem(tmp_path, sensor=long)))
    assert err.value.line == after and err.value.path == str(long)


def test_an_imu_rate_too_low_for_the_rotation_is_bad_input(tmp_path, capsys, sensor):
    """Every 8th sample of Chicago's IMU (1.6 Hz) in an IMU CSV: the diver turns more than 57 deg between
    samples. Exit 2 naming the file and the line of the sample, not a failed fit (exit 3)."""
    keep = slice(None, None, 8)
    csv = tmp_path / "imu.csv"
    write_imu_csv(csv, sensor.imu_time_unix_s[keep], sensor.imu_accel_mps2[keep], sensor.imu_gyro_radps[keep])
    folder = problem(tmp_path, 'gyro_unit = "rad/s"\naccel_unit = "m/s^2"\n', imu_file=csv)
    proc = call_cli(capsys, "fit", folder, "--out", tmp_path / "out", "--no-figures")
    line = assert_clean_failure(proc, 2, str(csv), "turns", "its rate is too low")
    number = int(re.search(r"imu\.csv:(\d+):", line).group(1))
    t = float(csv.read_text().splitlines()[number - 1].split(",")[0])
    assert SPAN[0] - 1.0 <= t <= SPAN[1] + 1.0 and f"at t = {t:.3f} s" in line, line


def test_a_dropped_time_row_is_said_once(tmp_path, capsys):
    """A SENSOR.CSV whose first $TIME row is 0.9 s off (as in many real files): its note is printed once
    and is in the report."""
    shifted = sensor_copy(tmp_path, shift_first_time_s=0.9)
    folder = problem(tmp_path, sensor=shifted, segment=(SPAN[0] + 5.0, SPAN[0] + 15.0))
    proc = call_cli(capsys, "fit", folder, "--out", tmp_path / "out", "--no-figures")
    assert proc.returncode == 0, proc.stderr[-2000:]
    note = "'$TIME' row(s) off the clock line"
    assert (proc.stdout + proc.stderr).count(note) == 1, proc.stdout + proc.stderr
    assert note in (tmp_path / "out" / "report.txt").read_text()
