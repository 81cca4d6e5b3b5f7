"""Which GPS fixes a GPS-only fit uses: quality rules, and the descent segment found in the data.

Rules (also in the results' notes):
- a fix is *good* when hAcc <= max_h_acc_m, vAcc <= max_v_acc_m, sAcc <= max_s_acc_mps and numSV >=
  min_num_sv (numSV absent: not tested); other fixes are dropped, never down-weighted twice (their
  own accuracies already weight the good ones);
- without explicit times, the segment is the longest run of consecutive good fixes whose vertical
  speed exceeds ``min_speed_mps`` (fixes that fail the quality rules are skipped, not a break: a
  run breaks at a good fix not fast enough, or where good fixes are more than
  :data:`~casrecon.estimation.validation.data_checks.GPS_MAX_GAP_S` apart, which the fit would refuse; a 2 s
  no-fix outage 10 s into a 45 s speed skydive otherwise cut the fit to its last 30 s), extended
  backwards over good fixes while the vertical speed is above 2 m/s (exit or release: the descent
  starts from near zero) and, below half of ``min_speed_mps``, the fix is already falling: its
  vertical speed grows by more than ``EXIT_ACCEL_MPS2`` over the next ``EXIT_WINDOW_S`` (a body
  let go falls at nearly g; one still in or on a descending aircraft does not: a speed skydive's
  track held 2 to 4 m/s for 2.6 s before the exit, which a free-fall model cannot fly; a draggy
  body near a terminal speed just above ``min_speed_mps`` hardly accelerates, hence only below
  half of it). It ends ``end_margin_s`` before the final drop (canopy opening or impact) began:
  the final drop is the stretch of fixes up to the run's last fix whose vertical speed is each
  more than ``deploy_drop_mps`` below its running maximum over the preceding ``DROP_WINDOW_S``; it
  began at that maximum of its first fix (no such stretch, as at an impact: at the run's last
  fix). A canopy decelerates the body from the fall's speed to below ``min_speed_mps`` in about
  two seconds, and the fixes of the opening are left out; a slow change of speed (the air's
  density, 0.2 m/s per second) never reaches the margin. A deceleration that runs into the opening
  (a speed skydiver's flare) is left out with it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from casrecon.estimation.validation.data_checks import GPS_MAX_GAP_S
from casrecon.io.flysight import GpsTrack
from casrecon.io.gps_rules import GpsQuality, filter_note, good_fixes, no_fix_note
from casrecon.io.pointmass_problem import SegmentConfig

#: Window of the running maximum that finds the final drop, s.
DROP_WINDOW_S = 2.0
#: A fix belongs to the fall when its vertical speed grows by more than EXIT_ACCEL_MPS2 x
#: EXIT_WINDOW_S over the following EXIT_WINDOW_S (m/s^2, s): about 0.3 g, against nearly g just
#: after an exit, and 1 m/s^2 of noise from two fixes' speed errors (sAcc about 0.5 m/s) a second apart.
EXIT_ACCEL_MPS2 = 3.0
EXIT_WINDOW_S = 1.0


class SegmentError(ValueError):
    """No usable descent segment in the track."""


@dataclass(frozen=True)
class Segment:
    """Start and end (UTC, s since 1970), the good-fix mask of the whole track, and notes."""

    start_unix_s: float
    end_unix_s: float
    good: np.ndarray
    notes: tuple[str, ...]


def _runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.flatnonzero(np.diff(np.r_[0, mask.astype(int), 0]))
    return list(zip(edges[::2], edges[1::2]))


def longest_fast_run(t: np.ndarray, vel_d: np.ndarray, good: np.ndarray, min_speed_mps: float) -> tuple[int, int]:
    """(first, last + 1) fix index of the longest (in time) run of good fixes faster than
    ``min_speed_mps`` (m/s, down positive; times ``t``, s), bad fixes skipped and a run broken by a
    good slow fix or a gap between good fixes over GPS_MAX_GAP_S; (0, 0) when there is none."""
    idx = np.flatnonzero(good)
    if not idx.size:
        return 0, 0
    fast = vel_d[idx] > min_speed_mps
    gap = np.r_[np.diff(t[idx]) > GPS_MAX_GAP_S, False]  # a gap after good fix k
    runs = []
    for a, b in _runs(fast):  # split each run of fast good fixes at its gaps
        cuts = a + 1 + np.flatnonzero(gap[a:b - 1])
        runs += list(zip(np.r_[a, cuts], np.r_[cuts, b]))
    if not runs:
        return 0, 0
    a, b = max(runs, key=lambda r: t[idx[r[1] - 1]] - t[idx[r[0]]])
    return int(idx[a]), int(idx[b - 1]) + 1


def drop_onset(t: np.ndarray, vel_d: np.ndarray, drop_mps: float) -> int:
    """Index of the fix where the final drop of ``vel_d`` (m/s, down positive; times ``t``, s) began:
    walking back from the last fix over those more than ``drop_mps`` below the maximum of the
    preceding :data:`DROP_WINDOW_S`, the fix of that maximum (the last fix when there is none)."""
    lo = np.searchsorted(t, t - DROP_WINDOW_S - 1e-6)
    i, onset = t.size - 1, t.size - 1
    while i >= 0:
        window = vel_d[lo[i]:i + 1]
        j = i - int(np.argmax(window[::-1]))          # the latest fix of the window's maximum
        if vel_d[i] >= vel_d[j] - drop_mps:
            break
        onset, i = j, i - 1
    return onset


def find_segment(track: GpsTrack, q: GpsQuality, cfg: SegmentConfig) -> Segment:
    """The descent segment of ``track`` per the module's rules (or the configured times)."""
    good = good_fixes(track, q)
    notes = [f"{int((~good).sum())} of {track.n} fixes fail the quality rules ({q.describe()}) and are dropped"]
    no_fix = no_fix_note(track)
    if no_fix:
        notes.append(f"of which {no_fix}")
    t = track.time_unix_s
    if cfg.start_unix_s is not None and cfg.end_unix_s is not None:
        notes.append("segment from [segment] start_utc / end_utc")
        return Segment(cfg.start_unix_s, cfg.end_unix_s, good, tuple(notes))
    i0, i1 = longest_fast_run(t, track.vel_d_mps, good, cfg.min_speed_mps)
    if i1 == i0:
        filtered = filter_note(track, q)
        if filtered:
            raise SegmentError(f"{track.path}: {filtered}; no fix left descends faster than {cfg.min_speed_mps} m/s "
                               "(relax the filter)")
        raise SegmentError(f"{track.path}: no good fix descends faster than {cfg.min_speed_mps} m/s")
    t_good, vd_good = t[good], track.vel_d_mps[good]

    def in_fall(i: int) -> bool:
        """Fix i is past the exit: fast already, or its vertical speed growing at a fall's rate."""
        growth = np.interp(t[i] + EXIT_WINDOW_S, t_good, vd_good) - track.vel_d_mps[i]
        return track.vel_d_mps[i] > 0.5 * cfg.min_speed_mps or growth > EXIT_ACCEL_MPS2 * EXIT_WINDOW_S

    while i0 > 0 and good[i0 - 1] and track.vel_d_mps[i0 - 1] > 2.0 and in_fall(i0 - 1):
        i0 -= 1
    start = cfg.start_unix_s if cfg.start_unix_s is not None else float(t[i0])
    run = np.arange(i0, i1)[good[i0:i1]]
    onset = run[drop_onset(t[run], track.vel_d_mps[run], cfg.deploy_drop_mps)]
    end = cfg.end_unix_s if cfg.end_unix_s is not None else float(t[onset]) - cfg.end_margin_s
    if end - start < 5.0:
        filtered = filter_note(track, q)
        why = f" ({filtered})" if filtered else ""
        raise SegmentError(f"{track.path}: the descent segment found is only {end - start:.1f} s long{why}")
    notes.append(f"segment found from the data: {end - start:.1f} s, vertical speed up to "
                 f"{track.vel_d_mps[run].max():.1f} m/s (rule: longest run faster than {cfg.min_speed_mps} m/s, "
                 f"back to 2 m/s or to a fix not yet falling, ending {cfg.end_margin_s} s before the final drop "
                 f"began at {track.vel_d_mps[onset]:.1f} m/s, {t[i1 - 1] - t[onset]:.1f} s before the last fix "
                 f"faster than {cfg.min_speed_mps} m/s)")
    return Segment(start, end, good, tuple(notes))
