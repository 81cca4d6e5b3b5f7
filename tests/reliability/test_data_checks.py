"""The pre-solve data check (casrecon/estimation/validation/data_checks.py, casrecon/io/imu_checks.py): each bad
input built from shipped problem data (a copy of problems/ees-drop-2, or of the GPS-only
realdata-skyderby-411, with one thing corrupted) is refused before any NLP is built, with exit status
2, one located stderr line naming the file, no traceback, inputs unchanged, no results folder; the
check alone takes under 1 s. Also the cases the check must let through (every shipped problem, rows
without a fix that are dropped with a note), the inspect warnings and the error texts.

Its helpers are its own, but for ``edit_text`` (tests/reliability/conftest.py).
"""

from __future__ import annotations

import functools
import hashlib
import os
import shutil
import subprocess
import sys
import time
import warnings
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest

import casrecon
from casrecon.cli import main
from casrecon.estimation.pointmass.fit import fit_point_mass
from casrecon.estimation.validation.precheck import check_problem
from casrecon.io.errors import InputError
from casrecon.io.imu import ImuCsvSpec, read_imu_csv
from casrecon.io.inspect import inspect_file
from casrecon.io.pointmass_problem import load_point_mass
from casrecon.io.vehicle_files import load_aero

from .conftest import edit_text

REPO = Path(__file__).resolve().parents[2]
PROBLEMS = REPO / "problems"
SOUNDINGS = REPO / "tests/data/realdata/soundings"
DROP = "ees-drop-2"            # the shortest synthetic drop: release 17:05:41.700Z, IMU t = 2.0 s
POINT_MASS = "realdata-skyderby-411"
RELEASE_UTC = np.datetime64("2023-10-03T17:05:41.700")
CHECK_LIMIT_S = 1.0


# ----------------------------------------------------------------------------------- helpers
def tree_checksums(root: Path) -> dict[str, str]:
    """SHA-256 of every file under ``root``, by relative path."""
    return {str(p.relative_to(root)): hashlib.sha256(p.read_bytes()).hexdigest()
            for p in sorted(root.rglob("*")) if p.is_file()}


@pytest.fixture(scope="module")
def pristine(tmp_path_factory) -> Path:
    """The inputs of ees-drop-2 and realdata-skyderby-411 (with vehicles/ and aero/), copied once."""
    root = tmp_path_factory.mktemp("pristine") / "problems"
    (root / DROP / "data").mkdir(parents=True)
    for name in ("problem.toml", "sounding.csv", "data/imu.csv", "data/gps.csv"):
        shutil.copy(PROBLEMS / DROP / name, root / DROP / name)
    for name in ("vehicles", "aero", POINT_MASS):
        shutil.copytree(PROBLEMS / name, root / name)
    return root


@pytest.fixture()
def problems(pristine, tmp_path) -> Path:
    """A fresh copy of the pristine problems for one test."""
    root = tmp_path / "problems"
    shutil.copytree(pristine, root)
    return root


def add_estimation_key(folder: Path, line: str) -> None:
    toml = folder / "problem.toml"
    text = toml.read_text()
    toml.write_text(text.replace("[estimation]\n", f"[estimation]\n{line}\n", 1) if "[estimation]\n" in text
                    else text + f"\n[estimation]\n{line}\n")


@functools.cache
def shipped_imu_table() -> np.ndarray:
    """The shipped data/imu.csv of the drop, parsed once."""
    return np.loadtxt(PROBLEMS / DROP / "data/imu.csv", delimiter=",", skiprows=1)


def edit_imu(folder: Path, change: Callable[[np.ndarray], np.ndarray]) -> None:
    """Rewrite data/imu.csv (time_s, ax, ay, az, wx, wy, wz in the file's units; the shipped file's values)
    through ``change``."""
    path = folder / "data/imu.csv"
    header = path.read_text().split("\n", 1)[0]
    table = change(shipped_imu_table().copy())
    np.savetxt(path, table, delimiter=",", header=header, comments="", fmt=["%.15g"] + ["%.9g"] * 6)


def edit_gps(folder: Path, change: Callable[[list[str], list[list[str]], np.ndarray], list[list[str]]],
             name: str = "data/gps.csv") -> None:
    """Rewrite a FlySight 1 track through ``change(header, rows, t_since_release_s)``."""
    path = folder / name
    lines = path.read_text().splitlines()
    header, units, rows = lines[0].split(","), lines[1], [ln.split(",") for ln in lines[2:]]
    t = np.array([np.datetime64(r[0].rstrip("Z")) for r in rows])
    rows = change(header, rows, (t - RELEASE_UTC) / np.timedelta64(1, "ms") / 1e3)
    path.write_text("\n".join([",".join(header), units, *(",".join(r) for r in rows)]) + "\n")


def set_cells(col: str, value: str, when: Callable[[np.ndarray], np.ndarray]):
    """A GPS edit writing ``value`` into column ``col`` of the rows where ``when(t)`` holds."""
    def change(header, rows, t):
        k = header.index(col)
        for i in np.flatnonzero(when(t)):
            rows[i][k] = value
        return rows
    return change


def no_fix(when: Callable[[np.ndarray], np.ndarray], acc: str | None = None):
    """Rows without a fix: gpsFix 0, latitude, longitude and height 0 (and optionally every accuracy)."""
    def change(header, rows, t):
        for i in np.flatnonzero(when(t)):
            for col, v in (("gpsFix", "0"), ("lat", "0.0000000"), ("lon", "0.0000000"), ("hMSL", "0.000")):
                rows[i][header.index(col)] = v
            if acc is not None:
                for col in ("hAcc", "vAcc", "sAcc"):
                    rows[i][header.index(col)] = acc
        return rows
    return change


def keep_rows(when: Callable[[np.ndarray], np.ndarray]):
    return lambda header, rows, t: [r for r, k in zip(rows, when(t), strict=True) if k]


def cut_sounding(folder: Path, top_m: float) -> None:
    path = folder / "sounding.csv"
    lines = path.read_text().splitlines()
    body = [ln for ln in lines[1:] if ln.startswith("#") or float(ln.split(",")[0]) <= top_m]
    path.write_text("\n".join([lines[0], *body]) + "\n")


def wyoming_list_sounding(folder: Path, top_m: float) -> None:
    """The OUN TEXT:LIST sounding cut after the level below ``top_m`` (as a download stopped early)."""
    lines = (SOUNDINGS / "20110522_OUN_12Z.txt").read_text().splitlines()
    head = next(k for k, ln in enumerate(lines) if "HGHT" in ln.split()) + 3
    keep = lines[:head] + [ln for ln in lines[head:] if float(ln.split()[1]) <= top_m]
    (folder / "oun.txt").write_text("\n".join(keep) + "\n")
    edit_text(folder / "problem.toml", 'sounding = "sounding.csv"', 'sounding = "oun.txt"')


def run_in_process(args: list[str], capsys) -> tuple[int, str]:
    code = main(args)
    out, err = capsys.readouterr()
    return code, err


def assert_refused(folder: Path, root: Path, tmp_path: Path, capsys, file_name: str, fragment: str,
                   command: str = "fit") -> InputError:
    """Time the check alone, then run the command in-process: exit 2, one located line, nothing written."""
    before = tree_checksums(root)
    t0 = time.perf_counter()
    with pytest.raises(InputError) as exc:
        check_problem(folder)
    elapsed = time.perf_counter() - t0
    assert elapsed < CHECK_LIMIT_S, f"the check took {elapsed:.2f} s"
    assert Path(exc.value.path).name == file_name and fragment in exc.value.message, str(exc.value)
    out = tmp_path / "out"
    code, err = run_in_process([command, str(folder), "--out", str(out), "--no-figures"], capsys)
    assert code == 2, err
    assert len(err.strip().splitlines()) == 1 and err.startswith("casrecon: ") and file_name in err, err
    assert fragment in err and "np.float64" not in err and "Traceback" not in err, err
    assert not out.exists() and sorted(p.name for p in tmp_path.iterdir()) == ["problems"]
    assert tree_checksums(root) == before
    return exc.value


# ------------------------------------------------------------------------ 6-DOF: refused
def in_window(a: float, b: float) -> Callable[[np.ndarray], np.ndarray]:
    """Rows from a to b seconds after release (the fit window of drop 2 runs 3.5 to 30.5 s)."""
    return lambda t: (t >= a) & (t < b)


def gyro(fn):
    def change(x):
        x[:, 4:7] = fn(x[:, 4:7], x[:, 0])
        return x
    return change


def accel(fn):
    def change(x):
        x[:, 1:4] = fn(x[:, 1:4], x[:, 0])
        return x
    return change


def _column(k: int, value: float, a: float, b: float):
    def fn(v, t):
        v[(t >= a) & (t < b), k] = value
        return v
    return fn


DROP_CASES: dict[str, tuple[Callable[[Path], None], str, str]] = {
    # IMU (file columns, deg/s and m/s^2; release at IMU t = 2.0 s)
    "imu gap of 2 s": (lambda f: edit_imu(f, lambda x: x[(x[:, 0] < 12.0) | (x[:, 0] >= 14.0)]),
                       "imu.csv", "gap of 2.002 s after t = 11.998 s"),
    "imu one missing sample": (lambda f: edit_imu(f, lambda x: np.delete(x, 8000, axis=0)),
                               "imu.csv", "gap of 0.004 s"),
    "gyros in deg/s declared rad/s": (lambda f: edit_text(f / "problem.toml", 'gyro_unit = "deg/s"',
                                                          'gyro_unit = "rad/s"'),
                                      "imu.csv", 'probably in deg/s: declare gyro_unit = "deg/s"'),
    "accel in m/s^2 declared g": (lambda f: edit_text(f / "problem.toml", 'accel_unit = "m/s^2"',
                                                      'accel_unit = "g"'),
                                  "imu.csv", 'probably in m/s^2: declare accel_unit = "m/s^2"'),
    "accel in g declared m/s^2": (lambda f: edit_imu(f, accel(lambda v, t: v / 9.80665)),
                                  "imu.csv", 'probably in g: declare accel_unit = "g"'),
    "every gyro sample saturated": (lambda f: edit_imu(f, gyro(lambda v, t: np.full_like(v, 157.4))),
                                    "imu.csv", "100% of the gyro samples at or beyond the declared gyro limits"),
    "one gyro axis 40 % saturated": (lambda f: edit_imu(f, gyro(_column(1, 157.4, 8.0, 20.0))),
                                     "imu.csv", "of the gyro samples at or beyond the declared gyro limits"),
    # (a clipped accelerometer reads over 3 g, which the impact search would take for the impact: given here)
    "accelerometer axis 30 % saturated": (lambda f: (add_estimation_key(f, "impact_imu_s = 32.542"),
                                                     edit_imu(f, accel(_column(0, -49.03325, 6.0, 15.0)))),
                                          "imu.csv", "accelerometer samples at or beyond"),
    "gyro stuck for 5 s": (lambda f: edit_imu(f, gyro(_column(1, 12.3456, 10.0, 15.0))),
                           "imu.csv", "gyro reads 12.3456 deg/s for 4.998 s"),
    "gyro dead (zeros) the whole log": (lambda f: edit_imu(f, gyro(_column(2, 0.0, -1.0, 1e9))),
                                        "imu.csv", "gyro reads 0 deg/s"),
    "accelerometer stuck for 2 s": (lambda f: edit_imu(f, accel(_column(2, -9.5, 20.0, 22.0))),
                                    "imu.csv", "accelerometer reads -9.5 m/s^2 for 1.998 s"),
    # GPS accuracies (refused by the reader, located by line)
    "hAcc 0": (lambda f: edit_gps(f, set_cells("hAcc", "0.000", in_window(10.0, 10.2))), "gps.csv",
               "accuracy 0 m"),
    "hAcc negative": (lambda f: edit_gps(f, set_cells("hAcc", "-1.500", in_window(10.0, 10.2))), "gps.csv",
                      "accuracy -1.5 m"),
    "vAcc 0": (lambda f: edit_gps(f, set_cells("vAcc", "0", in_window(20.0, 20.2))), "gps.csv", "accuracy 0 m"),
    "sAcc negative": (lambda f: edit_gps(f, set_cells("sAcc", "-0.25", in_window(5.0, 5.2))), "gps.csv",
                      "accuracy -0.25 m/s"),
    "hAcc NaN": (lambda f: edit_gps(f, set_cells("hAcc", "NaN", in_window(10.0, 10.2))), "gps.csv",
                 "non-finite value 'NaN'"),
    "sAcc inf": (lambda f: edit_gps(f, set_cells("sAcc", "inf", in_window(10.0, 10.2))), "gps.csv",
                 "non-finite value 'inf'"),
    "vAcc blank": (lambda f: edit_gps(f, set_cells("vAcc", "", in_window(10.0, 10.2))), "gps.csv", "empty value"),
    "hAcc 0 before release": (lambda f: edit_gps(f, set_cells("hAcc", "0.000", in_window(-1.0, -0.8))), "gps.csv",
                              "accuracy 0 m"),
    # GPS coverage of the fit window (3.5 to 30.5 s after release)
    "gpsFix 0 rows for 5 s mid-window": (lambda f: edit_gps(f, no_fix(in_window(10.0, 15.0))), "gps.csv",
                                         "no good GPS fix for 5.2 s"),
    "track cut at half the window": (lambda f: edit_gps(f, keep_rows(lambda t: t < 16.0)), "gps.csv",
                                     "to its end"),
    "track starting 10 s late": (lambda f: edit_gps(f, keep_rows(lambda t: t > 13.5)), "gps.csv",
                                 "from the start of the fit window"),
    "5 s hole in the track": (lambda f: edit_gps(f, keep_rows(lambda t: (t < 10.0) | (t >= 15.0))), "gps.csv",
                              "no good GPS fix for 5.2 s"),
    "every fix poor (hAcc 50 m)": (lambda f: edit_gps(f, set_cells("hAcc", "50.000", lambda t: t > -1e9)), "gps.csv",
                                   "the track has no good fix"),
    # [release] time against the data
    "release time 3 h late": (lambda f: edit_text(f / "problem.toml", "2023-10-03T17:05:41.700Z",
                                                  "2023-10-03T20:05:41.700Z"),
                              "problem.toml", "3.0 h earlier"),
    "release time a day early": (lambda f: edit_text(f / "problem.toml", "2023-10-03T17:05:41.700Z",
                                                     "2023-10-02T17:05:41.700Z"),
                                 "problem.toml", "24.0 h later"),
    "release time 2 min late": (lambda f: edit_text(f / "problem.toml", "2023-10-03T17:05:41.700Z",
                                                    "2023-10-03T17:07:41.700Z"),
                                "problem.toml", "120 s earlier"),
    "release time in the wrong time zone": (lambda f: edit_text(f / "problem.toml", "2023-10-03T17:05:41.700Z",
                                                                "2023-10-03T17:05:41.700+02:00"),
                                            "problem.toml", "2.0 h later"),
    "IMU clock a day off": (lambda f: edit_text(f / "problem.toml", "2023-10-03T17:05:39.700Z",
                                                "2023-10-04T17:05:39.700Z"),
                            "problem.toml", "24.0 h later"),
    # release and impact against the GPS
    "release 300 m too high": (lambda f: edit_text(f / "problem.toml", "h_agl_m = 1189.42", "h_agl_m = 1489.42"),
                               "problem.toml", "expected them within 100 m"),
    "ground 300 m too low": (lambda f: edit_text(f / "problem.toml", "ground_alt_msl_m = 1310.0",
                                                 "ground_alt_msl_m = 1010.0"),
                             "problem.toml", "+30"),
    "ground 60 m too high": (lambda f: edit_text(f / "problem.toml", "ground_alt_msl_m = 1310.0",
                                                 "ground_alt_msl_m = 1370.0"),
                             "problem.toml", "expected within 50 m"),
    "release_imu_s 10 s late": (lambda f: add_estimation_key(f, "release_imu_s = 12.0"), "problem.toml",
                                "puts the release at"),
    "impact_imu_s 10 s early": (lambda f: add_estimation_key(f, "impact_imu_s = 22.5"), "problem.toml",
                                "puts the impact"),
    # the sounding against the release altitude (2499 m MSL)
    "sounding truncated at 2000 m": (lambda f: cut_sounding(f, 2000.0), "sounding.csv",
                                     "the sounding stops at 1960 m MSL"),
    "sounding 10 m short of the release": (lambda f: cut_sounding(f, 2490.0), "sounding.csv",
                                           "below the release altitude"),
    "Wyoming TEXT:LIST cut at 2200 m": (lambda f: wyoming_list_sounding(f, 2200.0), "oun.txt",
                                        "the sounding stops at 2134 m MSL"),
}


@pytest.mark.parametrize("case", list(DROP_CASES), ids=list(DROP_CASES))
def test_drop_refused_before_solving(case, problems, tmp_path, capsys):
    corrupt, file_name, fragment = DROP_CASES[case]
    folder = problems / DROP
    corrupt(folder)
    assert_refused(folder, problems, tmp_path, capsys, file_name, fragment)


def test_located_lines(problems, tmp_path, capsys):
    """The IMU gap and a GPS accuracy name their line: the IMU sample after the gap (header on line 1)
    and the FlySight row (header and units on lines 1 and 2)."""
    folder = problems / DROP
    edit_imu(folder, lambda x: x[(x[:, 0] < 12.0) | (x[:, 0] >= 14.0)])
    with pytest.raises(InputError) as exc:
        check_problem(folder)
    assert exc.value.line == 6000 + 2 and exc.value.field == "time_s"  # t = 14.000 s is sample 6000
    shutil.copy(PROBLEMS / DROP / "data/imu.csv", folder / "data/imu.csv")
    edit_gps(folder, set_cells("hAcc", "0.000", in_window(10.0, 10.2)))
    rows = (folder / "data/gps.csv").read_text().splitlines()
    line = next(k + 1 for k, r in enumerate(rows) if r.split(",")[7] == "0.000")
    with pytest.raises(InputError) as exc:
        check_problem(folder)
    assert exc.value.line == line and exc.value.field == "hAcc"


@pytest.mark.parametrize("case", ["imu gap of 2 s", "release time 3 h late"])
def test_drop_refused_subprocess(case, problems, tmp_path):
    """The command line itself (a new interpreter): exit 2, one line, nothing written."""
    corrupt, file_name, fragment = DROP_CASES[case]
    folder = problems / DROP
    corrupt(folder)
    before = tree_checksums(problems)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": os.pathsep.join([str(REPO), os.environ.get("PYTHONPATH", "")])}
    res = subprocess.run([sys.executable, "-m", "casrecon", "fit", str(folder), "--out", str(out)],
                         capture_output=True, text=True, timeout=120, env=env)
    assert res.returncode == 2, res.stderr
    assert len(res.stderr.strip().splitlines()) == 1 and file_name in res.stderr and fragment in res.stderr
    assert "Traceback" not in res.stderr and not out.exists() and tree_checksums(problems) == before


def test_joint_refuses_a_bad_drop(problems, tmp_path, capsys):
    """`casrecon joint` checks every drop before building its NLP."""
    good, bad = problems / DROP, problems / "bad-drop"
    shutil.copytree(good, bad)
    edit_text(bad / "problem.toml", 'name = "ees-drop-2"', 'name = "bad-drop"')
    edit_text(bad / "problem.toml", 'gyro_unit = "deg/s"', 'gyro_unit = "rad/s"')
    before = tree_checksums(problems)
    out = tmp_path / "out"
    code, err = run_in_process(["joint", str(good), str(bad), "--out", str(out), "--no-single", "--no-figures"],
                               capsys)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "imu.csv" in err and "deg/s" in err, err
    assert not out.exists() and tree_checksums(problems) == before


def test_api_fit_raises_input_error(problems):
    folder = problems / DROP
    edit_text(folder / "problem.toml", "2023-10-03T17:05:41.700Z", "2023-10-03T20:05:41.700Z")
    with pytest.raises(InputError, match="release.time_utc"):
        casrecon.fit(folder)


# ------------------------------------------------------------------- 6-DOF: let through
def test_every_shipped_problem_passes():
    """No shipped problem trips a check; each check runs in well under a second."""
    folders = sorted(p.parent for p in PROBLEMS.glob("*/problem.toml"))
    assert len(folders) >= 10
    for folder in folders:
        t0 = time.perf_counter()
        notes = check_problem(folder)
        assert time.perf_counter() - t0 < CHECK_LIMIT_S, folder
        assert not any("without a 3D fix" in n for n in notes), folder


PASS_CASES: dict[str, Callable[[Path], None]] = {
    "release time 30 s off": lambda f: edit_text(f / "problem.toml", "2023-10-03T17:05:41.700Z",
                                                 "2023-10-03T17:06:11.700Z"),
    "imu gap before release": lambda f: edit_imu(f, lambda x: x[(x[:, 0] < 0.5) | (x[:, 0] >= 1.0)]),
    "sounding just above the release": lambda f: cut_sounding(f, 2510.0),
    "hAcc 0 on a row without a fix": lambda f: edit_gps(f, no_fix(in_window(10.0, 10.2), acc="0.000")),
    "gyro stuck for 0.8 s": lambda f: edit_imu(f, gyro(_column(1, 12.3456, 10.0, 10.8))),
}


@pytest.mark.parametrize("case", list(PASS_CASES), ids=list(PASS_CASES))
def test_drop_let_through(case, problems):
    folder = problems / DROP
    PASS_CASES[case](folder)
    check_problem(folder)


def test_rows_without_fix_dropped_with_a_note(problems):
    """gpsFix 0 rows (latitude, longitude, height 0) mid-track: dropped, said in the notes, never at the
    origin of the Earth in the data the fit sees."""
    folder = problems / DROP
    edit_gps(folder, no_fix(in_window(10.0, 11.0)))
    notes = check_problem(folder)
    assert "5 GPS rows without a 3D fix (gpsFix 0) dropped (in the window)" in notes
    from casrecon.estimation.sixdof.fitdata import load_fit_data
    from casrecon.io.problem import load_problem
    data = load_fit_data(load_problem(folder))
    assert np.abs(data.gps_pos_ned[:, 2]).max() < 1500.0  # no fix 1310 m below the ground (h = 0)


# ---------------------------------------------------------------- point-mass (GPS only)
def in_dive(a: float, b: float):
    """Rows of the skyderby track from a to b seconds after its first fix faster than 50 m/s down."""
    def when(t):
        return (t >= t[DIVE[0]] + a) & (t < t[DIVE[0]] + b)
    return when


DIVE = [0]


@pytest.fixture()
def skyderby(problems) -> Path:
    folder = problems / POINT_MASS
    rows = [ln.split(",") for ln in (folder / "speed_skydiving_411.csv").read_text().splitlines()[2:]]
    DIVE[0] = next(k for k, r in enumerate(rows) if float(r[6]) > 50.0)
    return folder


def pm_gps(fn):
    return lambda f: edit_gps(f, fn, name="speed_skydiving_411.csv")


def plain_sounding_to(folder: Path, top_m: float) -> None:
    h = np.arange(0.0, top_m + 1.0, 100.0)
    rows = [f"{z:.1f},{101325 * (1 - 2.25577e-5 * z) ** 5.25588:.2f},{288.15 - 0.0065 * z:.2f},270,3" for z in h]
    (folder / "sounding.csv").write_text("altitude_msl_m,pressure_pa,temperature_k,wind_dir_deg,wind_speed_mps\n"
                                         + "\n".join(rows) + "\n")
    edit_text(folder / "problem.toml", 'sounding = "standard"', 'sounding = "sounding.csv"')


PM_CASES: dict[str, tuple[Callable[[Path], None], str, str]] = {
    "hAcc 0 mid-dive": (pm_gps(set_cells("hAcc", "0.000", in_dive(5.0, 5.2))), "speed_skydiving_411.csv",
                        "accuracy 0 m"),
    "sAcc negative mid-dive": (pm_gps(set_cells("sAcc", "-0.50", in_dive(5.0, 5.2))), "speed_skydiving_411.csv",
                               "accuracy -0.5 m/s"),
    "vAcc NaN mid-dive": (pm_gps(set_cells("vAcc", "nan", in_dive(5.0, 5.2))), "speed_skydiving_411.csv",
                          "non-finite value 'nan'"),
    "sounding below the exit": (lambda f: plain_sounding_to(f, 3000.0), "sounding.csv",
                                "below the segment's highest good fix"),
    "segment beyond the track": (lambda f: (f / "problem.toml").write_text(
        (f / "problem.toml").read_text() + '\n[segment]\nstart_utc = "2021-07-07T13:40:00Z"\n'
        'end_utc = "2021-07-07T13:41:00Z"\n'), "speed_skydiving_411.csv", "no good GPS fix for 60.0 s"),
}


@pytest.mark.parametrize("case", list(PM_CASES), ids=list(PM_CASES))
def test_point_mass_refused_before_solving(case, skyderby, problems, tmp_path, capsys):
    corrupt, file_name, fragment = PM_CASES[case]
    corrupt(skyderby)
    assert_refused(skyderby, problems, tmp_path, capsys, file_name, fragment)


def test_point_mass_fix0_rows_dropped_and_fit_converges(skyderby):
    """gpsFix 0 rows mid-dive used to end in a numpy overflow and a singular KKT matrix: now they are
    dropped (said in the notes) and the fit converges without an overflow."""
    edit_gps(skyderby, no_fix(in_dive(5.0, 6.0)), name="speed_skydiving_411.csv")
    assert "of which 5 GPS rows without a 3D fix (gpsFix 0) dropped" in check_problem(skyderby)
    with warnings.catch_warnings():
        warnings.simplefilter("error", RuntimeWarning)
        result = fit_point_mass(load_point_mass(skyderby), "constant")
    assert result.solver.converged and np.isfinite(result.values).all()


# ---------------------------------------------------------------------- inspect warnings
def test_inspect_warns_gyros_in_degrees_read_as_radians():
    r = inspect_file(PROBLEMS / DROP / "data/imu.csv")  # inspect assumes rad/s for time_s,ax,...,wz
    assert 'WARNING: w' in r and 'probably in deg/s' in r


@pytest.mark.parametrize("case,edit,fragment", [
    ("stuck gyro", gyro(_column(1, 0.123, 10.0, 15.0)), "gyro reads 0.123 rad/s for 4.998 s"),
    ("every gyro sample saturated", gyro(lambda v, t: np.full_like(v, 157.4)), "gyro reads 157.4 rad/s"),
    ("accelerometers in g", lambda x: np.c_[x[:, :1], x[:, 1:4] / 9.80665, np.radians(x[:, 4:7])],
     "probably in g"),
    ("2 s gap", lambda x: np.c_[x[:, :4], np.radians(x[:, 4:7])][(x[:, 0] < 12.0) | (x[:, 0] >= 14.0)],
     "gap of 2.002 s"),
])
def test_inspect_warns_imu(case, edit, fragment, problems):
    folder = problems / DROP
    edit_imu(folder, edit)
    r = inspect_file(folder / "data/imu.csv")
    assert "WARNING: " in r and fragment in r, r


def test_inspect_clean_imu_has_no_warning(problems):
    folder = problems / DROP
    edit_imu(folder, gyro(lambda v, t: np.radians(v)))
    assert "WARNING" not in inspect_file(folder / "data/imu.csv")


def test_inspect_warns_rows_without_fix(problems, capsys):
    folder = problems / DROP
    edit_gps(folder, no_fix(in_window(10.0, 11.0)))
    assert main(["inspect", str(folder / "data/gps.csv")]) == 0
    out, err = capsys.readouterr()
    assert err == "" and "WARNING: 5 rows without a 3D fix (gpsFix 0), the first at 2023-10-03T17:05:51" in out


def test_inspect_refuses_zero_accuracy(problems, capsys):
    folder = problems / DROP
    edit_gps(folder, set_cells("hAcc", "0.000", in_window(10.0, 10.2)))
    assert main(["inspect", str(folder / "data/gps.csv")]) == 2
    err = capsys.readouterr().err
    assert len(err.strip().splitlines()) == 1 and "gps.csv:" in err and "field 'hAcc'" in err


@pytest.mark.parametrize("cut", ["at a level", "mid-line"])
def test_inspect_warns_truncated_wyoming_list(cut, tmp_path):
    text = (SOUNDINGS / "20110522_OUN_12Z.txt").read_text()
    lines = text.splitlines()
    part = "\n".join(lines[:40]) + "\n" if cut == "at a level" else "\n".join(lines[:40])[:-30]
    path = tmp_path / "oun.txt"
    path.write_text(part)
    r = inspect_file(path)
    assert "TEXT:LIST" in r and "possibly TRUNCATED: the levels stop at" in r
    assert ("no line terminator" in r) == (cut == "mid-line")
    assert "TRUNCATED" not in inspect_file(SOUNDINGS / "20110522_OUN_12Z.txt")


# ---------------------------------------------------------------------------- error texts
def test_no_numpy_repr_in_time_errors(tmp_path):
    path = tmp_path / "imu.csv"
    path.write_text("time_s,ax,ay,az,wx,wy,wz\n20.000,0,0,9.8,0,0,0\n20.002,0,0,9.8,0,0,0\n"
                    "20.001,0,0,9.8,0,0,0\n")
    with pytest.raises(InputError) as exc:
        read_imu_csv(path)
    assert "(20.002 then 20.001)" in str(exc.value) and "np.float64" not in str(exc.value)


@pytest.mark.parametrize("wrong", [SOUNDINGS / "20110522_OUN_12Z.txt", PROBLEMS / DROP / "data/gps.csv"],
                         ids=["sounding", "flysight"])
def test_wrong_file_kind_says_what_was_expected(wrong):
    with pytest.raises(InputError) as exc:
        read_imu_csv(wrong, ImuCsvSpec())
    text = str(exc.value)
    assert "not an IMU CSV: expected a header line naming the columns time_s, ax, ay, az, wx, wy, wz" in text
    assert "Norman" not in text and "lat" not in text and exc.value.line == 1


def test_numpy_values_shown_as_plain_numbers():
    with pytest.raises(ValueError) as exc:
        ImuCsvSpec(gyro_limits=np.float64(3.5))
    assert "got 3.5" in str(exc.value) and "np." not in str(exc.value)
    with pytest.raises(ValueError) as exc:
        ImuCsvSpec(gyro_columns=(np.str_("wx"), "wy"))
    assert "got ('wx', 'wy')" in str(exc.value)


def test_wrong_aero_table_says_what_was_expected(problems):
    aero = problems / "aero"
    shutil.copy(PROBLEMS / DROP / "data/gps.csv", aero / "ees-sphere-cone.csv")
    with pytest.raises(InputError) as exc:
        load_aero(aero / "ees-sphere-cone.toml")
    text = str(exc.value)
    assert "not an aero table CSV: expected the header line mach,alpha_t_deg,CA,CN,Cm,Cmq" in text
    assert "lat" not in text and exc.value.line == 1
