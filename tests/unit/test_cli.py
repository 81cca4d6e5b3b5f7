"""``casrecon simulate``: outputs of a good run, and an untouched --out folder after a bad one."""

from __future__ import annotations

import json
import shutil

import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.cli import main
from casrecon.report.results_folder import read_csv


def test_simulate_writes_trajectory_and_summary(tmp_path, capsys):
    out = tmp_path / "run"
    assert main(["simulate", str(PROBLEMS / "ees-drop-2"), "--out", str(out)]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["problem"] == "ees-drop-2" and summary["impacted"] is True
    assert isinstance(summary["flight_time_s"], float) and isinstance(summary["impact_speed_mps"], float)
    assert len(summary["impact_euler_deg"]) == 3 and len(summary["max_abs_rate_dps"]) == 3
    header = (out / "trajectory.csv").read_text().splitlines()[0].split(",")
    assert header[:6] == ["flight_time_s", "time_unix_s", "utc", "latitude_deg", "longitude_deg", "h_msl_m"]
    tr = read_csv(out / "trajectory.csv")
    # 500 Hz samples, the last one at impact with the summary's time and speed
    assert np.diff(tr["flight_time_s"][1:-1]) == pytest.approx(0.002, abs=1e-9)
    assert tr["flight_time_s"][-1] == pytest.approx(summary["flight_time_s"], abs=1e-6)
    speed = np.linalg.norm([tr[f"vel_{c}_mps"][-1] for c in "ned"])
    assert speed == pytest.approx(summary["impact_speed_mps"], rel=1e-6)
    assert abs(tr["h_agl_m"][-1]) < 1e-6
    assert "ees-drop-2: flight time" in capsys.readouterr().out


def test_failed_simulate_leaves_existing_out_untouched(tmp_path, capsys, problem_copy):
    out = tmp_path / "run"
    out.mkdir()
    (out / "keep.txt").write_text("previous result")
    (out / ".casrecon-results.json").write_text("{}")  # a casrecon results folder (else --out is refused)
    text = problem_copy.read_text().replace("h_agl_m = 1618.04", "h_agl_m = -5.0")
    problem_copy.write_text(text)
    assert main(["simulate", str(problem_copy.parent), "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "release.h_agl_m" in err[0] and str(problem_copy) in err[0]
    assert sorted(p.name for p in out.iterdir()) == [".casrecon-results.json", "keep.txt"]
    assert (out / "keep.txt").read_text() == "previous result"
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".run")]


def test_every_thins_the_history_but_keeps_impact(tmp_path):
    src = tmp_path / "p"
    shutil.copytree(PROBLEMS, src)
    out = tmp_path / "thin"
    assert main(["simulate", str(src / "ees-drop-2"), "--out", str(out), "--every", "50"]) == 0
    tr = read_csv(out / "trajectory.csv")
    assert abs(tr["h_agl_m"][-1]) < 1e-6  # impact row kept
    assert np.diff(tr["flight_time_s"][1:-1]) == pytest.approx(0.1, abs=1e-9)
