"""A user's own GPS quality filter that removes every fix, or nearly all (issue 51): the message names the
filter's keys in the problem's [gps] table, their values and how many fixes each removed, where it used to
say only "no good fix descends faster than 20 m/s". realdata-fs1-byron, a real FlySight 1 track."""

from __future__ import annotations

import numpy as np
import pytest

from casrecon.estimation.pointmass.segment import SegmentError, find_segment
from casrecon.io.flysight import GpsTrack
from casrecon.io.gps_rules import GpsQuality, filter_note
from casrecon.io.pointmass_problem import SegmentConfig

from .conftest import assert_clean_failure, call_cli, tree_checksums


def set_gps_key(problem, key: str, value) -> None:
    toml = problem / "problem.toml"
    text = toml.read_text()
    old = next(line for line in text.splitlines() if line.startswith(f"{key} ="))
    toml.write_text(text.replace(old, f"{key} = {value}", 1))


@pytest.mark.parametrize(("key", "value", "what"), [("max_h_acc_m", 0.01, "hAcc above it"),
                                                    ("min_num_sv", 40, "numSV below it")])
def test_a_filter_that_removes_every_fix_is_named(realdata_problem, tmp_path, capsys, key, value, what):
    set_gps_key(realdata_problem, key, value)
    before = tree_checksums(realdata_problem)
    proc = call_cli(capsys, "fit", realdata_problem, "--out", tmp_path / "out", "--quiet", "--no-figures")
    line = assert_clean_failure(proc, 3, "[gps] leaves 0 of", f"{key} = {value} removes", what)
    n = int(line.split("leaves 0 of ")[1].split()[0])
    assert f"{key} = {value} removes {n} of {n} fixes" in line and n > 1000
    assert not (tmp_path / "out").exists() and tree_checksums(realdata_problem) == before


def hand_track(n: int, h_acc: np.ndarray, num_sv: np.ndarray) -> GpsTrack:
    t = 1.6e9 + 0.2 * np.arange(n)
    vel_d = np.full(n, 50.0)
    return GpsTrack("hand.csv", "flysight1", t, np.full(n, 40.0), np.full(n, -105.0), 4000.0 - 10.0 * np.arange(n),
                    np.zeros(n), np.zeros(n), vel_d, h_acc, np.full(n, 2.5), np.full(n, 0.3), num_sv)


def test_nearly_all_fixes_removed_names_each_rule_with_its_count():
    """3 of 200 fixes pass (under 5 %): too few for a segment; both rules are named with their counts,
    the one that removes more first; the untouched rules are not named."""
    h_acc = np.full(200, 3.0)
    h_acc[::2] = 0.5                       # hAcc <= 1 m on 100 fixes
    num_sv = np.full(200, 7, dtype=np.int64)
    num_sv[[0, 60, 140]] = 12              # numSV >= 10 on 3 of those
    track = hand_track(200, h_acc, num_sv)
    q = GpsQuality(max_h_acc_m=1.0, min_num_sv=10)
    note = filter_note(track, q)
    assert note == ("the GPS quality filter of [gps] leaves 3 of 200 fixes: min_num_sv = 10 removes 197 of 200 fixes "
                    "(numSV below it); max_h_acc_m = 1.0 removes 100 of 200 fixes (hAcc above it, m)")
    with pytest.raises(SegmentError, match="min_num_sv = 10 removes 197 of 200 fixes"):
        find_segment(track, q, SegmentConfig())
    assert filter_note(track, GpsQuality(max_h_acc_m=1.0)) is None  # half the fixes pass: not "nearly all"
