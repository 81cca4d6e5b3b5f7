"""Gross input errors on ees-drop-3-model-error (both error models from the data, the default path;
issue 49): each ends in an error or a not-trusted verdict that names its cause, none is absorbed by
an error model. A 300 m ground-altitude error is refused by the pre-solve data check (exit 2, about
1 s); an IMU clock 1 s off (``utc_at_zero``) asks the error models for sizes beyond their
plausibility limits, which are not refitted with (about 90 s: slow)."""

from __future__ import annotations

import json
import shutil

import pytest
from conftest import PROBLEMS

from casrecon.cli import main


@pytest.fixture()
def drop_copy(tmp_path):
    """A copy of problems/ees-drop-3-model-error with the folders its relative paths name; returns
    the path of the copied problem.toml."""
    root = tmp_path / "problems"
    root.mkdir()
    for name in ("ees-drop-3-model-error", "vehicles", "aero"):
        shutil.copytree(PROBLEMS / name, root / name, ignore=shutil.ignore_patterns("summary.json", "trajectory.csv"))
    (root / "ees-drop-3").mkdir()
    shutil.copy(PROBLEMS / "ees-drop-3" / "sounding.csv", root / "ees-drop-3" / "sounding.csv")
    return root / "ees-drop-3-model-error" / "problem.toml"


def edited(toml, old: str, new: str):
    text = toml.read_text()
    assert text.count(old) == 1, old
    toml.write_text(text.replace(old, new))
    return toml


def test_a_300_m_ground_altitude_error_is_a_located_input_error(drop_copy, tmp_path, capsys):
    toml = edited(drop_copy, "ground_alt_msl_m = 1310.0", "ground_alt_msl_m = 1610.0")
    assert main(["fit", str(toml), "--out", str(tmp_path / "out"), "--no-figures", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "field 'site.ground_alt_msl_m'" in err and "-300 m from it" in err, err


@pytest.mark.slow
def test_an_imu_clock_1_s_off_is_named_and_not_absorbed(drop_copy, tmp_path, capsys):
    """Measured: without the limits the refit took a profile error of 1.62 m/s and 2.09 % over 3000 m and
    GPS velocity errors over 10 s at 2.79 times the accuracies; the verdict blamed the ground. With
    the error-model limits the fit stood and its verdict named the IMU clock; since the pre-solve
    check of the IMU's impact against the GPS's end of descent (issue 51) it is refused before the
    fit (0.88 s apart, 0.5 s allowed), naming the clock."""
    toml = edited(drop_copy, 'utc_at_zero = "2023-10-04T15:20:03.100Z"', 'utc_at_zero = "2023-10-04T15:20:04.100Z"')
    out = tmp_path / "out"
    assert main(["fit", str(toml), "--out", str(out), "--no-figures", "--quiet"]) == 2
    err = capsys.readouterr().err
    assert "imu.csv" in err and "utc_at_zero" in err and "its clock right?" in err, err
    assert not out.exists()


def test_a_sounding_of_another_day_is_named_and_not_absorbed(drop_copy, tmp_path):
    """ees-drop-1's sounding (another October day at the same site; a CSV sounding carries no date or
    place to compare) for ees-drop-3's: without the limits the refit took a profile error of 1.99 m/s
    and 1.5 % over 3000 m (the longest length then searched; now longer ones while the evidence rises)
    and its bands were trusted. One fit and one estimate (about 10 to 45 s)."""
    shutil.copytree(PROBLEMS / "ees-drop-1", drop_copy.parents[1] / "ees-drop-1",
                    ignore=shutil.ignore_patterns("data"))
    toml = edited(drop_copy, 'sounding = "../ees-drop-3/sounding.csv"', 'sounding = "../ees-drop-1/sounding.csv"')
    out = tmp_path / "out"
    assert main(["fit", str(toml), "--out", str(out), "--no-figures", "--quiet"]) == 0
    adequacy = json.loads((out / "summary.json").read_text())["adequacy"]
    assert not adequacy["trusted"]
    assert "10 or more times the configured 300 m" in adequacy["reasons"][0]
    assert "sounding of another day or place" in adequacy["reasons"][0]
