"""The public FlySight tracks of the GPS-only error-description study (tests/data/realdata/flysight-tracks-*,
docs/studies/flysight-tracks.md): at least ten beyond the shipped three, each with its source and licence
recorded, each readable with a fall the point-mass fit finds; and the study benchmark's decimation."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import REALDATA_DIR, REPO, script_module

from casrecon.estimation.pointmass.segment import find_segment
from casrecon.io.flysight import read_flysight
from casrecon.io.gps_rules import GpsQuality
from casrecon.io.pointmass_problem import SegmentConfig

FOLDERS = {"flysight-tracks-ssscoring": "LICENSE.txt", "flysight-tracks-skyderby": "LICENSE"}
TRACKS = sorted(p for f in FOLDERS for p in (REALDATA_DIR / f).glob("*.csv"))
SHIPPED = ("fs1-byron-2019-05-25.CSV", "TRACK.CSV", "speed_skydiving_411.csv")

pytestmark = pytest.mark.skipif(not REALDATA_DIR.is_dir(), reason="real data not present")


def test_ten_tracks_beyond_the_shipped_ones_each_with_source_and_licence():
    readme = (REALDATA_DIR / "README.md").read_text()
    assert len(TRACKS) >= 10
    assert not {p.name for p in TRACKS} & set(SHIPPED)
    for folder, licence in FOLDERS.items():
        assert (REALDATA_DIR / folder / licence).is_file()
    for p in TRACKS:
        row = [line for line in readme.splitlines() if f"`{p.parent.name}/{p.name}`" in line]
        assert len(row) == 1, p.name
        cells = [c.strip() for c in row[0].strip("|").split("|")]
        assert len(cells) == 4, p.name
        source, licence = cells[2], cells[3]
        assert " @ " in source and ("BSD-3" in licence or "O'Saasy" in licence), p.name


@pytest.mark.parametrize("path", TRACKS, ids=lambda p: p.stem)
def test_track_reads_and_holds_a_fall(path):
    track = read_flysight(path)
    seg = find_segment(track, GpsQuality(10.0, 10.0, 1.0, 6), SegmentConfig())
    assert seg.end_unix_s - seg.start_unix_s > 10.0
    t = track.time_unix_s
    # the cut keeps at most 30 s before the fall (less where the source file begins later) and 20 s after it
    assert 0.0 < seg.start_unix_s - t[0] <= 30.5
    assert t[-1] - seg.end_unix_s == pytest.approx(20.0, abs=0.5)


def test_benchmark_decimates_a_10_hz_track_to_5_hz(tmp_path):
    bench = script_module(REPO / "benchmarks" / "fs_tracks_loo.py")
    for name in ("flysight-tracks-ssscoring/fs2-byron-2024-10-06-TRACK.csv",
                 "flysight-tracks-skyderby/fs1-10hz-2017-06-03.csv"):
        src = REALDATA_DIR / name
        full, cut = read_flysight(src), read_flysight(bench.decimated(src, tmp_path))
        assert np.median(np.diff(full.time_unix_s)) == pytest.approx(0.1, abs=1e-3)
        assert np.allclose(np.diff(cut.time_unix_s), 0.2, atol=1e-3)
        kept = np.isin(np.round(full.time_unix_s, 3), np.round(cut.time_unix_s, 3))
        assert kept.sum() == cut.time_unix_s.size >= full.time_unix_s.size // 2 - 1
        assert np.array_equal(full.h_msl_m[kept], cut.h_msl_m)
    five_hz = REALDATA_DIR / "flysight-tracks-ssscoring/fs1-eloy-2024-12-07.csv"
    assert bench.decimated(five_hz, tmp_path) == five_hz
