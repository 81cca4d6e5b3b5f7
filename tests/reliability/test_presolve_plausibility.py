"""Pre-solve plausibility of the inputs against each other (issue 51, casrecon/estimation/validation/consistency.py
and the gyro-against-accelerometer rule of casrecon/io/imu_checks.py): inputs that pass every file's own
rules but cannot be right are refused before any NLP is built: exit status 2, one located stderr line
with the measured reason, no results folder, inputs unchanged. A sounding of another day and place is
warned about (once, naming both) and the fit goes on. No shipped problem or real track raises any of them.

Each bad input is built from shipped data: a barometer file in hPa under a ``pressure_pa`` header
(ees-drop-1-baro; the rocket Hedy's ``P`` column), gyros in rad/s declared as deg/s (ees-drop-2), the IMU
log of another drop (ees-drop-4's with ees-drop-1's GPS), a University of Wyoming sounding of Boise 2010
used for a drop in Utah in 2023 and for a skydive near Moscow in 2021.
"""

from __future__ import annotations

import logging
import shutil
import time
from pathlib import Path

import numpy as np
import pytest

from casrecon.estimation.validation.precheck import check_problem
from casrecon.io.errors import InputError
from casrecon.io.inspect import inspect_file

from .conftest import assert_clean_failure, call_cli, edit_text, leftover_temp_folders, tree_checksums

REPO = Path(__file__).resolve().parents[2]
PROBLEMS = REPO / "problems"
REALDATA = REPO / "tests/data/realdata"
BOISE = REALDATA / "soundings/BOI_72681_2010-12-09_12Z_wyoming.csv"
CHECK_LIMIT_S = 1.0
#: The loggers of the checks' warnings.
CONSISTENCY_LOGGER = "casrecon.estimation.validation.consistency"
#: Phrases only the new checks write (in errors, warnings and ``casrecon inspect`` lines).
NEW_PHRASES = ("specific force turned", "times the", "end of descent", "is it the sounding of this drop",
               "outside the standard atmosphere's")
COPIED = ("vehicles", "aero", "ees-drop-1", "ees-drop-1-baro", "ees-drop-2", "realdata-skyderby-411",
          "realdata-rocket-hedy-drogue")


@pytest.fixture(scope="module")
def pristine(tmp_path_factory) -> Path:
    """The shipped problems these tests corrupt, copied once."""
    root = tmp_path_factory.mktemp("pristine") / "problems"
    for name in COPIED:
        shutil.copytree(PROBLEMS / name, root / name)
    shutil.copy(PROBLEMS / "ees-drop-4/data/imu.csv", root / "ees-drop-4-imu.csv")
    return root


@pytest.fixture()
def problems(pristine, tmp_path) -> Path:
    root = tmp_path / "problems"
    shutil.copytree(pristine, root)
    return root


def pressure_in_hpa(path: Path) -> None:
    """Rewrite a barometer CSV's pressure column (the last) in hPa, its header unchanged."""
    lines = path.read_text().splitlines()
    out = [lines[0]]
    for ln in lines[1:]:
        *head, p = ln.split(",")
        out.append(",".join([*head, f"{float(p) / 100:.4f}"]))
    path.write_text("\n".join(out) + "\n")


def gyros_in_rad(path: Path) -> None:
    """Rewrite an EES IMU CSV's gyro columns (wx, wy, wz: deg/s) in rad/s, the declaration unchanged."""
    header = path.read_text().split("\n", 1)[0]
    table = np.loadtxt(path, delimiter=",", skiprows=1)
    table[:, 4:7] = np.radians(table[:, 4:7])
    np.savetxt(path, table, delimiter=",", header=header, comments="", fmt=["%.15g"] + ["%.9g"] * 6)


def assert_refused(folder: Path, root: Path, tmp_path: Path, capsys, located: str, *fragments: str) -> InputError:
    """The check alone under 1 s, then ``casrecon fit`` in-process: exit 2, one line starting with
    ``casrecon: `` + ``located`` (file, line, field) with every fragment, no results folder, inputs unchanged."""
    before = tree_checksums(root)
    t0 = time.perf_counter()
    with pytest.raises(InputError) as exc:
        check_problem(folder)
    assert time.perf_counter() - t0 < CHECK_LIMIT_S
    out = tmp_path / "out"
    proc = call_cli(capsys, "fit", folder, "--out", out, "--no-figures")
    line = assert_clean_failure(proc, 2, *fragments)
    assert line.startswith(f"casrecon: {located}"), line
    assert not out.exists() and not leftover_temp_folders(tmp_path)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["problems"]
    assert tree_checksums(root) == before
    return exc.value


# ------------------------------------------------------------------------------ refused
def test_barometer_in_hpa_refused(problems, tmp_path, capsys):
    """712 to 867 hPa written under pressure_pa: 0.01 times the sounding's pressure at the GPS altitude;
    located at the first sample of the fit window (line 60: 2.3 s after the file's start at 25 Hz)."""
    folder = problems / "ees-drop-1-baro"
    baro = folder / "data/baro.csv"
    pressure_in_hpa(baro)
    err = assert_refused(folder, problems, tmp_path, capsys, f"{baro}:60: field 'pressure_pa': measured pressure",
                         "is 0.01 times the 78172 Pa of the sounding", "at the GPS altitude (1317 to 2931 m MSL)",
                         "expected a ratio of 0.5 to 2", "probably in hPa (mbar) (x 100): name its column pressure_hpa")
    assert (err.line, err.field) == (60, "pressure_pa")


def test_kinematic_barometer_in_hpa_refused(problems):
    """The rocket's barometer (column P) in hPa, against the standard atmosphere at the ground (its GNSS
    gives no height): refused by the kinematic problem's data preparation, named on its first sample."""
    folder = problems / "realdata-rocket-hedy-drogue"
    pressure_in_hpa(folder / "baro.csv")
    t0 = time.perf_counter()
    with pytest.raises(InputError) as exc:
        check_problem(folder)
    assert time.perf_counter() - t0 < CHECK_LIMIT_S
    err = exc.value
    assert Path(err.path).name == "baro.csv" and err.field == "P" and err.line is not None
    assert "of the standard atmosphere at the ground altitude 144 m MSL" in err.message
    assert "is 0.00738 times" in err.message and "probably in hPa (mbar) (x 100): name its column pressure_hpa" \
        in err.message, err.message


def test_gyros_in_rad_declared_deg_refused(problems, tmp_path, capsys):
    """Gyros in rad/s declared as deg/s read 57.3 times too slow: the specific force turns 414 deg in IMU
    axes over drop 2's window while the gyros turn 25 deg."""
    folder = problems / "ees-drop-2"
    imu = folder / "data/imu.csv"
    gyros_in_rad(imu)
    err = assert_refused(folder, problems, tmp_path, capsys, f"{imu}: field 'wx,wy,wz': the specific force turned",
                         "414 deg in IMU axes", "read as deg/s, turned 25 deg", "expected at most 3 x 25 + 90",
                         'the file is probably in rad/s, declare gyro_unit = "rad/s"')
    assert err.field == "wx,wy,wz"


def test_imu_of_another_drop_refused(problems, tmp_path, capsys):
    """ees-drop-4's IMU log with ees-drop-1's GPS: its impact is 0.63 s before the GPS stops descending
    (the impact-altitude check, 50 m at 41 m/s, lets it through)."""
    folder = problems / "ees-drop-1"
    shutil.copy(problems / "ees-drop-4-imu.csv", folder / "data/imu.csv")
    err = assert_refused(folder, problems, tmp_path, capsys, f"{folder / 'data/imu.csv'}: the IMU's impact",
                         "t = 41.520 s", "0.63 s before the GPS's end of descent", "41.4 m/s down at",
                         "expected within 0.5 s: is the IMU log of this drop")
    assert err.line is None


# ------------------------------------------------------------------------------ warned
def sounding_warnings(caplog) -> list[str]:
    return [r.getMessage() for r in caplog.records if r.name == CONSISTENCY_LOGGER]


def test_far_sounding_warned_before_the_solve(problems, caplog):
    """A Boise 2010 sounding for drop 2 (Utah, 2023): one warning on the sounding file's line 2 naming
    both dates and places; the check goes on (the sounding covers the drop)."""
    folder = problems / "ees-drop-2"
    shutil.copy(BOISE, folder / "boise.csv")
    edit_text(folder / "problem.toml", 'sounding = "sounding.csv"', 'sounding = "boise.csv"')
    with caplog.at_level(logging.WARNING, logger="casrecon"):
        check_problem(folder)
        check_problem(folder)  # once per process
    (warning,) = sounding_warnings(caplog)
    assert warning.startswith(f"{folder / 'boise.csv'}:2: WARNING: the sounding was launched "
                              "2010-12-09T11:06:00.000Z at lat 43.5600 lon -116.2100 and the drop is "), warning
    assert "4681.2 days after its launch and 462 km from it (2023-10-03T17:05:41.700Z at lat 40.1900 lon " \
           "-112.9400, [release] time_utc and [site]); expected within 1 day and 100 km" in warning, warning


def test_far_sounding_fit_warns_once_and_writes_whole_results(problems, tmp_path, capsys):
    """The point-mass fit of the Moscow-area skyderby track with the Boise sounding: exit 0, the warning
    once on stderr (located), and a complete results folder (no temporary folder left)."""
    folder = problems / "realdata-skyderby-411"
    shutil.copy(BOISE, folder / "boise.csv")
    edit_text(folder / "problem.toml", 'sounding = "standard"', 'sounding = "boise.csv"')
    out = tmp_path / "out"
    proc = call_cli(capsys, "fit", folder, "--out", out, "--no-figures")
    assert proc.returncode == 0, proc.stderr[-2000:]
    warned = [ln for ln in proc.stderr.splitlines() if "is it the sounding of this drop" in ln]
    assert warned == [f"{folder / 'boise.csv'}:2: WARNING: the sounding was launched 2010-12-09T11:06:00.000Z at "
                      "lat 43.5600 lon -116.2100 and the drop is 3863.1 days after its launch and 8803 km from it "
                      "(2021-07-07T13:30:38.600Z at lat 54.7880 lon 37.6443, the segment's start and [site]); "
                      "expected within 1 day and 100 km: is it the sounding of this drop? (used as given)"], warned
    assert {"summary.json", "trajectory.csv", "report.txt"} <= {p.name for p in out.iterdir()}
    assert not leftover_temp_folders(tmp_path)


# ------------------------------------------------------------------------------ no false alarm
@pytest.mark.parametrize("name", sorted(p.parent.name for p in PROBLEMS.glob("*/problem.toml")))
def test_shipped_problem_raises_no_plausibility_finding(name, caplog):
    """Every shipped problem passes the pre-solve check with no warning of the new checks (its time:
    benchmarks/bench_prechecks.py)."""
    with caplog.at_level(logging.WARNING, logger="casrecon"):
        notes = check_problem(PROBLEMS / name)
    assert not sounding_warnings(caplog)
    assert not [n for n in notes if any(p in n for p in NEW_PHRASES)]


def realdata_files() -> list[Path]:
    return sorted(p for p in REALDATA.rglob("*") if p.is_file() and p.suffix.lower() in (".csv", ".txt")
                  and p.name not in ("flightInfo.csv", "LICENSE.txt"))


@pytest.mark.parametrize("path", realdata_files(), ids=lambda p: p.name)
def test_real_tracks_raise_no_plausibility_warning(path):
    """``casrecon inspect`` of every real file under tests/data/realdata writes none of the new checks'
    warnings (the rocket's IMU: its force turns within its gyros'; its barometer: within the standard
    atmosphere's range of flight)."""
    text = inspect_file(path)
    assert not [ln for ln in text.splitlines() if any(p in ln for p in NEW_PHRASES)], text
