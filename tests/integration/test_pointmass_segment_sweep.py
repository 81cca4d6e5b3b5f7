"""No segment start or end crashes the GPS-only fit on the real FlySight tracks (issue 14).

The three real speed-skydive tracks in tests/data/realdata (SSScoring FlySight 1 and 2, BSD-3;
Skyderby FlySight 1, O'Saasy: see tests/data/realdata/README.md) are fitted with the shipped
problems' settings over 20 start offsets and 20 end offsets around the automatic segment (paired,
so that the node counts take many values modulo the knot spacing, among them those that crashed:
the old midpoint basis had one coefficient fewer when (nodes - 1) * period was a whole multiple of
the 2 s knot spacing), plus starts and ends outside the track. The default test builds each NLP
and evaluates it once at its start point (residuals, constraint Jacobian, Gauss-Newton matrix: the
old crash was there); the slow test runs the fits. Either may refuse a segment, but only with a
one-line FitError (exit 3) or InputError (exit 2).
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from casrecon.estimation.engine.checks import FitError
from casrecon.estimation.pointmass.fit import build_point_mass, fit_point_mass
from casrecon.estimation.pointmass.segment import find_segment
from casrecon.io.errors import InputError
from casrecon.io.flysight import read_flysight
from casrecon.io.pointmass_problem import PointMassConfig, load_point_mass

ROOT = Path(__file__).parents[2]
REALDATA = ROOT / "tests" / "data" / "realdata"
TRACKS = {
    "realdata-fs1-byron": REALDATA / "flysight-speed-ssscoring" / "fs1-byron-2019-05-25.CSV",
    "realdata-fs2-chicago": REALDATA / "flysight-speed-ssscoring" / "fs2-chicago-2024-09-17" / "TRACK.CSV",
    "realdata-skyderby-411": REALDATA / "flysight-speed-skyderby" / "speed_skydiving_411.csv",
}
N_OFFSETS = 20
START_OFFSETS_S = np.linspace(-3.0, 12.0, N_OFFSETS)              # around the automatic start
END_OFFSETS_S = np.linspace(3.0, -12.0, N_OFFSETS)[(7 * np.arange(N_OFFSETS)) % N_OFFSETS]


def _base(problem: str) -> PointMassConfig:
    return replace(load_point_mass(ROOT / "problems" / problem), gps_file=TRACKS[problem])


def sweep(problem: str, whole_track: bool = False) -> list[PointMassConfig]:
    """The shipped problem on the real track with the paired start/end offsets, a segment of whole
    knot spacings from a fix, then segments reaching outside the track (before its first fix,
    after its last) and, with ``whole_track``, all of it (minutes of nodes: slow to build)."""
    cfg = _base(problem)
    track = read_flysight(cfg.gps_file)
    seg = find_segment(track, cfg.quality, cfg.segment)
    t0, t1 = float(track.time_unix_s[0]), float(track.time_unix_s[-1])
    pairs = [(seg.start_unix_s + a, seg.end_unix_s + b) for a, b in zip(START_OFFSETS_S, END_OFFSETS_S)]
    whole = cfg.drag.knot_spacing_s * np.floor((seg.end_unix_s - seg.start_unix_s - 2.0) / cfg.drag.knot_spacing_s)
    pairs += [(seg.start_unix_s + 2.0, seg.start_unix_s + 2.0 + whole)]
    pairs += [(t0 - 60.0, seg.end_unix_s), (seg.start_unix_s, t1 + 60.0), (t1 + 1.0, t1 + 30.0)]
    pairs += [(t0, t1)] if whole_track else []
    return [replace(cfg, segment=replace(cfg.segment, start_unix_s=a, end_unix_s=b)) for a, b in pairs]


def _refusal_is_clean(err: Exception) -> None:
    assert isinstance(err, (FitError, InputError)), f"{type(err).__name__}: {err}"
    assert "\n" not in str(err) and str(err)


@pytest.mark.parametrize("problem", sorted(TRACKS))
def test_every_segment_builds_and_evaluates(problem):
    knots_per_node = {}
    for cfg in sweep(problem):
        try:
            built = build_point_mass(cfg)                 # evaluates derivatives in check_determined
        except (FitError, InputError) as err:
            _refusal_is_clean(err)
            continue
        r = built.nlp.residual_vector(built.z0)
        g = built.nlp.derivatives.constraints(built.z0)
        assert np.all(np.isfinite(r)) and np.all(np.isfinite(g))
        t = built.data.t_unix
        period = float(t[1] - t[0])
        steps = int(round(cfg.drag.knot_spacing_s / period))
        knots_per_node[(t.size - 1) % steps] = True
    # the sweep reached the node counts of the old crash ((nodes - 1) a whole multiple of the knot
    # spacing in periods) and many others
    assert 0 in knots_per_node and len(knots_per_node) >= 8


def test_issue_segment_of_the_chicago_track(tmp_path):
    """The segment of the issue (302 nodes at 10 Hz: 30.1 s, a whole multiple of the 2 s knots),
    through problem.toml; it crashed with a CasADi shape error."""
    text = (ROOT / "problems" / "realdata-fs2-chicago" / "problem.toml").read_text()
    text = text.replace('file = "TRACK.CSV"', f"file = {str(TRACKS['realdata-fs2-chicago'])!r}")
    (tmp_path / "problem.toml").write_text(text + '\n[segment]\nstart_utc = "2024-09-17T19:25:25.0Z"\n'
                                           'end_utc = "2024-09-17T19:25:55.1Z"\n')
    built = build_point_mass(load_point_mass(tmp_path))
    assert built.data.t_unix.size == 302
    assert np.all(np.isfinite(built.nlp.residual_vector(built.z0)))


@pytest.mark.slow
@pytest.mark.parametrize("problem", sorted(TRACKS))
def test_every_segment_fits_or_fails_cleanly(problem):
    converged = 0
    for cfg in sweep(problem, whole_track=True):
        try:
            result = fit_point_mass(cfg)
        except Exception as err:  # noqa: BLE001 - the test is that only the two clean errors occur
            _refusal_is_clean(err)
            continue
        assert result.solver.converged
        converged += 1
    assert converged >= N_OFFSETS // 2
