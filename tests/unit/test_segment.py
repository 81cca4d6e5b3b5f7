"""Segment rules of the GPS-only fit (casrecon.estimation.pointmass.segment) on hand-made tracks.

Every track below is a 5 Hz sequence of fixes built from a vertical-speed profile: level flight,
an exit (vertical speed growing ~9.5 m/s per second), a fast run, and a deployment (vertical speed
falling to canopy speed). The expected start and end are computed from the rules by hand:
start = the first fix of the descent whose vertical speed exceeds 2 m/s (the run of good fixes
faster than min_speed_mps, extended back while above 2 m/s), end = end_margin_s before the final
drop began: the deployment ramp's fixes are each more than deploy_drop_mps (5 m/s) below the
fast run's 55 m/s, so the drop began at the last 55 m/s fix.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from casrecon.estimation.pointmass.segment import (
    STEADY_ACCEL_MPS2,
    SegmentError,
    final_drop_before,
    find_segment,
    unsteady_note,
)
from casrecon.io.flysight import GpsTrack, read_flysight
from casrecon.io.gps_rules import good_fixes
from casrecon.io.pointmass_problem import GpsQuality, SegmentConfig

T0 = 1_600_000_000.0
DT = 0.2


def track_from(vel_d: np.ndarray, h_acc=None, v_acc=None, s_acc=None, num_sv=None) -> GpsTrack:
    n = vel_d.size
    t = T0 + DT * np.arange(n)
    h = 4000.0 - np.cumsum(vel_d) * DT

    def full(v, default):
        return np.full(n, default, dtype=np.int64 if isinstance(default, int) else float) if v is None else \
            np.asarray(v, dtype=np.int64 if isinstance(default, int) else float)

    return GpsTrack("hand-made.csv", "flysight1", t, np.full(n, 40.0), np.full(n, -105.0), h, np.full(n, 30.0),
                    np.zeros(n), np.asarray(vel_d, float), full(h_acc, 1.5), full(v_acc, 2.5), full(s_acc, 0.3),
                    full(num_sv, 12))


def jump_profile(level_s=4.0, fast_s=40.0, canopy_s=6.0) -> np.ndarray:
    """Level (0 m/s) -> exit ramp 9.5 m/s^2 up to 55 m/s -> fast -> deployment ramp to 5 m/s."""
    level = np.zeros(int(level_s / DT))
    ramp = np.minimum(9.5 * DT * np.arange(1, 40), 55.0)      # 1.9, 3.8, ... 55
    fast = np.full(int(fast_s / DT), 55.0)
    deploy = np.linspace(55.0, 5.0, 8)[1:]                       # 47.9, 40.7, ..., 5
    canopy = np.full(int(canopy_s / DT), 5.0)
    return np.r_[level, ramp, fast, deploy, canopy]


Q = GpsQuality()
CFG = SegmentConfig()


def test_a_slow_descent_before_the_exit_is_left_out():
    """A body still in or on a descending aircraft (vertical speed 2.5 to 3.5 m/s for 3 s, hardly
    accelerating) is not falling: the segment starts at the exit, where the speed grows at ~g."""
    vd = jump_profile()
    exit_at = int(np.flatnonzero(vd > 0)[0])
    aircraft = np.linspace(2.5, 3.5, 15)                       # 3 s at 0.33 m/s^2
    vd = np.r_[vd[:exit_at], aircraft, 3.5 + vd[exit_at:]]
    seg = find_segment(track_from(vd), Q, CFG)
    # the aircraft fix 0.8 s before the ramp (3.29 m/s) reaches 7.3 m/s a second later (+4.0 > 3);
    # the one 1.0 s before (3.21 m/s) only 5.4 (+2.2): the segment starts at the first
    first_falling = exit_at + aircraft.size - 4
    assert vd[first_falling + 5] - vd[first_falling] > 3.0 > vd[first_falling + 4] - vd[first_falling - 1]
    assert seg.start_unix_s - T0 == pytest.approx(DT * first_falling, abs=1e-6)
    assert any("not yet falling" in n for n in seg.notes)


def test_a_draggy_body_near_its_terminal_speed_keeps_its_whole_fall():
    """A body whose terminal speed (24 m/s) is just above min_speed_mps hardly accelerates where it
    crosses 20 m/s: the segment still reaches back to its release, since the fall-onset test applies
    only below half of min_speed_mps."""
    t = DT * np.arange(150)
    vd = np.r_[np.zeros(20), 24.0 * np.tanh(9.5 * t[:130] / 24.0)]   # g at release, ~0.3 m/s^2 at 20 m/s
    vd = np.r_[vd, np.linspace(24.0, 5.0, 8)[1:], np.full(30, 5.0)]
    seg = find_segment(track_from(vd), Q, CFG)
    assert seg.start_unix_s - T0 == pytest.approx(DT * np.flatnonzero(vd > 2.0)[0], abs=1e-6)


def test_exit_and_deployment_found_from_the_data():
    vd = jump_profile()
    tr = track_from(vd)
    seg = find_segment(tr, Q, CFG)
    i_start = int(np.flatnonzero(vd > 2.0)[0])                 # second ramp fix (3.8 m/s): 1.9 is below 2
    assert vd[i_start - 1] <= 2.0 < vd[i_start]
    assert seg.start_unix_s == pytest.approx(tr.time_unix_s[i_start], abs=1e-6)
    i_last_fast = int(np.flatnonzero(vd > CFG.min_speed_mps)[-1])
    assert vd[i_last_fast + 1] < CFG.min_speed_mps
    i_onset = int(np.flatnonzero(vd == 55.0)[-1])               # the deployment ramp starts after it
    assert vd[i_onset + 1] < 55.0 - CFG.deploy_drop_mps
    assert seg.end_unix_s == pytest.approx(tr.time_unix_s[i_onset] - CFG.end_margin_s, abs=1e-6)
    assert seg.good.all() and seg.good.shape == (tr.n,)
    assert any("segment found from the data" in n for n in seg.notes)
    assert "0 of" in seg.notes[0]


def test_min_speed_and_end_margin_are_used():
    vd = jump_profile()
    tr = track_from(vd)
    cfg = SegmentConfig(min_speed_mps=45.0, end_margin_s=1.0)
    seg = find_segment(tr, Q, cfg)
    i_last = int(np.flatnonzero(vd > 45.0)[-1])               # the deployment ramp's 47.9 m/s fix
    assert vd[i_last] < 55.0 - cfg.deploy_drop_mps               # is in the final drop: the end is before it
    assert seg.end_unix_s == pytest.approx(tr.time_unix_s[i_last - 1] - 1.0, abs=1e-6)
    # the start is still where the descent began (back over the ramp to 2 m/s), not at 45 m/s
    assert seg.start_unix_s == pytest.approx(tr.time_unix_s[np.flatnonzero(vd > 2.0)[0]], abs=1e-6)


def test_cold_start_fixes_dropped_and_counted():
    vd = jump_profile(level_s=10.0)
    h_acc = np.full(vd.size, 1.5)
    h_acc[:20] = 100.0                                          # cold start: the first 4 s
    tr = track_from(vd, h_acc=h_acc)
    seg = find_segment(tr, Q, CFG)
    assert not seg.good[:20].any() and seg.good[20:].all()
    assert seg.notes[0].startswith(f"20 of {tr.n} fixes fail the quality rules")
    assert "dropped" in seg.notes[0]
    assert seg.start_unix_s == pytest.approx(tr.time_unix_s[np.flatnonzero(vd > 2.0)[0]], abs=1e-6)


@pytest.mark.parametrize("field, bad", [("h_acc", 10.01), ("v_acc", 10.01), ("s_acc", 1.01), ("num_sv", 5)])
def test_each_quality_rule_drops_a_fix(field, bad):
    vd = jump_profile()
    values = {"h_acc": 1.5, "v_acc": 2.5, "s_acc": 0.3, "num_sv": 12}
    arr = np.full(vd.size, values[field], dtype=np.int64 if field == "num_sv" else float)
    arr[100] = bad
    good = good_fixes(track_from(vd, **{field: arr}), Q)
    assert np.flatnonzero(~good).tolist() == [100]
    # at the limit itself the fix is kept
    arr[100] = {"h_acc": 10.0, "v_acc": 10.0, "s_acc": 1.0, "num_sv": 6}[field]
    assert good_fixes(track_from(vd, **{field: arr}), Q).all()


def test_num_sv_absent_is_not_tested():
    vd = jump_profile()
    tr = track_from(vd, num_sv=np.full(vd.size, -1))
    assert good_fixes(tr, Q).all()
    assert good_fixes(tr, GpsQuality(min_num_sv=30)).all()
    assert not good_fixes(track_from(vd, num_sv=np.full(vd.size, 12)), GpsQuality(min_num_sv=30)).any()


def test_bad_fix_on_the_exit_ramp_stops_the_back_extension():
    vd = jump_profile()
    i_ramp = np.flatnonzero(vd > 2.0)[0]
    s_acc = np.full(vd.size, 0.3)
    s_acc[i_ramp + 2] = 5.0                                     # a bad fix at ~7.6 m/s
    tr = track_from(vd, s_acc=s_acc)
    seg = find_segment(tr, Q, CFG)
    assert seg.start_unix_s == pytest.approx(tr.time_unix_s[i_ramp + 3], abs=1e-6)


def test_longest_fast_run_wins():
    # a short fast burst (2 s) before the real descent, separated by slow fixes
    vd = np.r_[np.zeros(10), np.full(10, 30.0), np.zeros(10), jump_profile(level_s=2.0)]
    tr = track_from(vd)
    seg = find_segment(tr, Q, CFG)
    assert seg.start_unix_s > tr.time_unix_s[20]
    assert seg.end_unix_s - seg.start_unix_s > 40.0


def test_bad_fixes_inside_the_fast_run_do_not_split_it():
    # a 2 s outage (10 fixes failing the rules) 10 s into the fast run: the run bridges it
    vd = jump_profile(fast_s=40.0)
    i_fast = np.flatnonzero(vd >= 55.0)
    h_acc = np.full(vd.size, 1.5)
    cut = i_fast[0] + 50                                        # 10 s into the fast run
    h_acc[cut:cut + 10] = 50.0
    tr = track_from(vd, h_acc=h_acc)
    whole = find_segment(track_from(vd), Q, CFG)
    seg = find_segment(tr, Q, CFG)
    assert (seg.start_unix_s, seg.end_unix_s) == (whole.start_unix_s, whole.end_unix_s)
    assert seg.end_unix_s - seg.start_unix_s > 40.0


def test_fast_run_split_by_a_gap_the_fit_refuses_keeps_the_longer_part():
    # 4 s without a good fix (over GPS_MAX_GAP_S = 3 s) 10 s into the fast run: the run splits
    vd = jump_profile(fast_s=40.0)
    i_fast = np.flatnonzero(vd >= 55.0)
    h_acc = np.full(vd.size, 1.5)
    cut = i_fast[0] + 50
    h_acc[cut:cut + 20] = 50.0
    tr = track_from(vd, h_acc=h_acc)
    seg = find_segment(tr, Q, CFG)
    # the part after the gap is longer; the back extension stops at the bad fix
    assert seg.start_unix_s == pytest.approx(tr.time_unix_s[cut + 20], abs=1e-6)


def test_no_fast_run_raises():
    with pytest.raises(SegmentError, match="no good fix descends faster than 20"):
        find_segment(track_from(np.full(200, 5.0)), Q, CFG)
    # fast fixes that are all bad do not count either; the message names the rule that removed them
    with pytest.raises(SegmentError, match=r"\[gps\] leaves 0 of \d+ fixes: max_h_acc_m = 10.0 removes"):
        find_segment(track_from(jump_profile(), h_acc=np.full(jump_profile().size, 50.0)), Q, CFG)


def test_too_short_descent_raises():
    vd = np.r_[np.zeros(10), np.full(15, 30.0), np.zeros(10)]  # 3 s fast
    with pytest.raises(SegmentError, match="only"):
        find_segment(track_from(vd), Q, CFG)


def test_explicit_start_and_end_override():
    vd = jump_profile()
    tr = track_from(vd)
    start, end = T0 + 10.0, T0 + 30.0
    seg = find_segment(tr, Q, SegmentConfig(start_unix_s=start, end_unix_s=end))
    assert (seg.start_unix_s, seg.end_unix_s) == (start, end)
    assert any("start_utc / end_utc" in n for n in seg.notes)
    # both given: no fast run needed at all
    seg = find_segment(track_from(np.full(200, 5.0)), Q, SegmentConfig(start_unix_s=start, end_unix_s=end))
    assert (seg.start_unix_s, seg.end_unix_s) == (start, end)


def test_explicit_start_only_or_end_only():
    vd = jump_profile()
    tr = track_from(vd)
    auto = find_segment(tr, Q, CFG)
    seg = find_segment(tr, Q, SegmentConfig(start_unix_s=T0 + 12.0))
    assert seg.start_unix_s == T0 + 12.0 and seg.end_unix_s == pytest.approx(auto.end_unix_s, abs=1e-6)
    seg = find_segment(tr, Q, SegmentConfig(end_unix_s=T0 + 30.0))
    assert seg.start_unix_s == pytest.approx(auto.start_unix_s, abs=1e-6) and seg.end_unix_s == T0 + 30.0
    # an explicit start 2 s before the end found: too short
    with pytest.raises(SegmentError, match="only 2.0 s long"):
        find_segment(tr, Q, SegmentConfig(start_unix_s=auto.end_unix_s - 2.0))


def test_slow_deceleration_is_not_a_drop():
    """A fall whose speed decays 0.5 m/s per second (faster than the air's density makes it) and
    then stops at once (impact): no final drop, the end is end_margin_s before the last fast fix."""
    vd = np.r_[np.zeros(10), np.minimum(9.5 * DT * np.arange(1, 40), 55.0), 55.0 - 0.5 * DT * np.arange(200),
               np.zeros(10)]
    tr = track_from(vd)
    seg = find_segment(tr, Q, CFG)
    i_last_fast = int(np.flatnonzero(vd > CFG.min_speed_mps)[-1])
    assert seg.end_unix_s == pytest.approx(tr.time_unix_s[i_last_fast] - CFG.end_margin_s, abs=1e-6)


@pytest.mark.parametrize("drop_s", [1.0, 2.0, 4.0])
def test_deployment_of_any_length_is_left_out(drop_s):
    """A deployment decelerating from 55 to 5 m/s over drop_s seconds, after a plateau with 0.5 m/s
    noise: the end is end_margin_s before the deceleration began, whatever its length."""
    rng = np.random.default_rng(3)
    plateau = 55.0 + rng.normal(0.0, 0.5, 150)
    n_drop = int(drop_s / DT)
    vd = np.r_[np.zeros(10), np.minimum(9.5 * DT * np.arange(1, 40), 55.0), plateau,
               np.linspace(55.0, 5.0, n_drop + 1)[1:], np.full(20, 5.0)]
    tr = track_from(vd)
    seg = find_segment(tr, Q, CFG)
    i_begin = 10 + 39 + 150 - 1                                  # the plateau's last fix
    # the end lies within 2 s (the running maximum's window) before the deceleration began
    assert tr.time_unix_s[i_begin] - 2.0 - CFG.end_margin_s <= seg.end_unix_s
    assert seg.end_unix_s <= tr.time_unix_s[i_begin] - CFG.end_margin_s + 1e-9
    assert np.all(vd[(tr.time_unix_s <= seg.end_unix_s) & (tr.time_unix_s > seg.start_unix_s + 10)] > 53.0)


REALDATA = Path(__file__).parents[1] / "data" / "realdata"
TRACKS = [REALDATA / "flysight-speed-ssscoring" / "fs1-byron-2019-05-25.CSV",
          REALDATA / "flysight-speed-ssscoring" / "fs2-chicago-2024-09-17" / "TRACK.CSV",
          REALDATA / "flysight-speed-skyderby" / "speed_skydiving_411.csv"]


@pytest.mark.parametrize("path", TRACKS, ids=lambda p: p.parent.name + "/" + p.name)
def test_real_tracks_end_before_the_canopy_opens(path):
    """On the three real speed skydives the canopy opening decelerates the diver by 12 to 22 m/s^2
    over the last second of the old segment (which ended 0.5 s before the speed fell below
    20 m/s); the segment now ends before it: less than 3 m/s^2 over its last second."""
    tr = read_flysight(path)
    good = good_fixes(tr, Q)

    def decel_last_second(cfg):
        e = find_segment(tr, Q, cfg).end_unix_s
        return float(np.interp(e - 1.0, tr.time_unix_s[good], tr.vel_d_mps[good])
                     - np.interp(e, tr.time_unix_s[good], tr.vel_d_mps[good]))

    assert decel_last_second(CFG) < 3.0
    assert decel_last_second(SegmentConfig(deploy_drop_mps=1e9)) > 10.0    # the old rule: inside the opening


def test_a_hand_window_past_the_deployment_names_the_final_drop():
    """jump_profile: exit at 4 s, 55 m/s from about 9.8 s to 44 s, then the deployment. A window ending
    after the last 55 m/s fix holds the final drop, which began at that fix; one ending before it does not."""
    v = jump_profile()
    tr = track_from(v)
    good = good_fixes(tr, GpsQuality())
    onset = int(np.flatnonzero(v >= 55.0)[-1])
    start, cfg = T0 + 5.0, SegmentConfig()
    drop = final_drop_before(tr, good, start, tr.time_unix_s[onset] + 4.0, cfg)
    assert drop is not None and drop.onset_unix_s == pytest.approx(tr.time_unix_s[onset])
    assert drop.slow_speed_mps <= cfg.min_speed_mps < drop.onset_speed_mps
    assert final_drop_before(tr, good, start, tr.time_unix_s[onset] - 0.5, cfg) is None
    assert final_drop_before(tr, good, start, tr.time_unix_s[onset], cfg) is None


def test_a_hop_and_pop_segment_is_said_to_be_the_exit_transient():
    """A body of terminal speed 55 m/s falling from rest (v = vt tanh(g t / vt)): over its first 7 s it
    accelerates at g (1 - tanh^2) = 3.7 m/s^2 or more (at 6 s, the middle of the last 2 s), so the note says
    the fall never got steady and gives that acceleration; the same body's 30 s fall gets there (below
    0.01 m/s^2 from 28 s) and has no note."""
    g, vt = 9.80665, 55.0
    t = DT * np.arange(int(40.0 / DT))
    tr = track_from(vt * np.tanh(g * t / vt))
    good = good_fixes(tr, GpsQuality())
    note = unsteady_note(tr, good, T0, T0 + 7.0)
    lowest = g * (1 - np.tanh(g * 6.0 / vt) ** 2)  # the slope of a line over 5 to 7 s: about the value at 6 s
    assert note.startswith("the segment never reaches a steady fall") and "exit transient" in note
    found = float(note.split("is at least ")[1].split(" m/s^2")[0])
    assert found == pytest.approx(lowest, rel=0.1) and found > STEADY_ACCEL_MPS2
    assert unsteady_note(tr, good, T0, T0 + 30.0) == ""
