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
- a segment given by hand (``[segment] end_utc``) must end before the final drop: when a good fix
  after the segment's first fix faster than ``min_speed_mps`` is slower than it again (the fall has
  ended: a canopy or the ground), the final drop of the fixes up to that one (the rule above) must
  not have begun before ``end_utc``; otherwise the window holds the opening's deceleration, which no
  drag model of a falling body flies (on the shipped Chicago track a window 4 s past the opening
  gave a wind of -20.9 m/s, 21 sigma, and a drag area up to 8.2 m^2 at exit 0), and
  :func:`final_drop_before` names it for a located refusal.
- a segment that never reaches a steady fall (a hop-and-pop: the canopy opened 5 to 9 s after exit)
  is said so in a note (:func:`unsteady_note`): when the vertical acceleration over every
  :data:`STEADY_SPAN_S` of it (lines through the good fixes' vertical speed) stays above
  :data:`STEADY_ACCEL_MPS2`, the drag never balances more than 90 % of the weight, and the fitted
  drag area is dominated by the exit transient, not a terminal fall. (A speed skydive's segment
  crosses zero at its top speed: the shipped Chicago, Byron and skyderby segments' lowest are
  -17.1, -10.1 and -13.3 m/s^2.)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from casrecon.estimation.validation.data_checks import GPS_MAX_GAP_S
from casrecon.io.flysight import GpsTrack, iso_utc
from casrecon.io.gps_rules import GpsQuality, filter_note, good_fixes, no_fix_note
from casrecon.io.pointmass_problem import SegmentConfig

#: Window of the running maximum that finds the final drop, s.
DROP_WINDOW_S = 2.0
#: A fix belongs to the fall when its vertical speed grows by more than EXIT_ACCEL_MPS2 x
#: EXIT_WINDOW_S over the following EXIT_WINDOW_S (m/s^2, s): about 0.3 g, against nearly g just
#: after an exit, and 1 m/s^2 of noise from two fixes' speed errors (sAcc about 0.5 m/s) a second apart.
EXIT_ACCEL_MPS2 = 3.0
EXIT_WINDOW_S = 1.0
#: A segment whose vertical acceleration over every STEADY_SPAN_S (s) of it is above STEADY_ACCEL_MPS2
#: (m/s^2, a tenth of g: the drag holds less than 90 % of the weight) never reached a steady fall.
STEADY_ACCEL_MPS2 = 0.1 * 9.80665
STEADY_SPAN_S = 2.0


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


@dataclass(frozen=True)
class FinalDrop:
    """The end of a fall found in a track: the fix where its final drop began and the first good fix
    slower than ``min_speed_mps`` after it (UTC s, vertical speed m/s)."""

    onset_unix_s: float
    onset_speed_mps: float
    slow_unix_s: float
    slow_speed_mps: float


def final_drop_before(track: GpsTrack, good: np.ndarray, start_unix_s: float, end_unix_s: float,
                      cfg: SegmentConfig) -> FinalDrop | None:
    """The final drop (canopy opening or impact) of the fall that the segment ``start_unix_s`` to
    ``end_unix_s`` (UTC, s) holds, when it began before ``end_unix_s`` (module docstring); None when it
    did not, or the fall does not end in the track."""
    t, v = track.time_unix_s, track.vel_d_mps
    idx = np.flatnonzero(good & (t >= start_unix_s) & np.isfinite(v))
    fast = idx[(t[idx] <= end_unix_s) & (v[idx] > cfg.min_speed_mps)]
    if not fast.size:
        return None
    slow = idx[(idx > fast[0]) & (v[idx] <= cfg.min_speed_mps)]
    if not slow.size:
        return None
    run = idx[(idx >= fast[0]) & (idx <= slow[0])]
    onset = run[drop_onset(t[run], v[run], cfg.deploy_drop_mps)]
    if t[onset] >= end_unix_s:
        return None
    return FinalDrop(float(t[onset]), float(v[onset]), float(t[slow[0]]), float(v[slow[0]]))


def lowest_acceleration(track: GpsTrack, good: np.ndarray, start_unix_s: float,
                        end_unix_s: float) -> tuple[float, float] | None:
    """Lowest vertical acceleration (m/s^2, down positive) of the segment and the UTC time (s) at the end of
    its window: the slopes of lines through the good fixes' vertical speed over every
    :data:`STEADY_SPAN_S` of the segment (each window ending at a fix; None with fewer than 3 fixes)."""
    t, v = track.time_unix_s, track.vel_d_mps
    sel = good & np.isfinite(v) & (t >= start_unix_s) & (t <= end_unix_s)
    t, v = t[sel], v[sel]
    if t.size < 3:
        return None
    ends = np.flatnonzero(t >= min(t[0] + STEADY_SPAN_S, t[-1]) - 1e-6)
    best = None
    for k in ends:
        w = (t >= t[k] - STEADY_SPAN_S - 1e-6) & (t <= t[k])
        if w.sum() >= 3:
            slope = float(np.polyfit(t[w] - t[k], v[w], 1)[0])
            if best is None or slope < best[0]:
                best = (slope, float(t[k]))
    return best


def unsteady_note(track: GpsTrack, good: np.ndarray, start_unix_s: float, end_unix_s: float) -> str:
    """The note for a segment that never reaches a steady fall ("" when it does; module docstring)."""
    lowest = lowest_acceleration(track, good, start_unix_s, end_unix_s)
    if lowest is None or lowest[0] <= STEADY_ACCEL_MPS2:
        return ""
    accel, at = lowest
    return (f"the segment never reaches a steady fall: its vertical acceleration (over {STEADY_SPAN_S:g} s of "
            f"GPS vertical speed) is at least {accel:.2f} m/s^2 ({accel / 9.80665:.2f} g, lowest over the "
            f"{STEADY_SPAN_S:g} s up to {iso_utc(at)}; steady: at most {STEADY_ACCEL_MPS2:.2f} m/s^2), so the drag "
            f"never holds more than about {max(1.0 - accel / 9.80665, 0.0):.0%} of the weight: the drag area is "
            "dominated by the exit transient (low speed, changing body position), not a terminal fall")
