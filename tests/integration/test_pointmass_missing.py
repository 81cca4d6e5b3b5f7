"""The GPS-only fit of a track without vertical velocity (what an NMEA log gives): it fits, it gives the
same answer as the full track with the vertical-velocity sigma set to infinity (zero weight), and it
counts 5 measurements per fix. Truth, noise and problem from :mod:`test_pointmass_truth` (constant CdA,
seed 11); the segment is given (the automatic one needs the vertical velocity, and says so)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
from test_pointmass_truth import SEEDS, T0_UNIX, make_track, simulate, write_problem

import casrecon.estimation.pointmass.fit as pmf
from casrecon.analysis.fit_adequacy import pointmass_adequacy
from casrecon.io.errors import InputError
from casrecon.io.flysight import iso_utc, read_flysight
from casrecon.io.pointmass_problem import load_point_mass

SEGMENT = (1.0, 38.0)  # s after the exit


@pytest.fixture(scope="module")
def tracks():
    full, _, _ = make_track(*simulate(lambda t: 0.25), seed=SEEDS[0])
    return full, dataclasses.replace(full, vel_d_mps=np.full(full.n, np.nan))


def problem(tmp_path, full, segment: bool = True):
    start, end = (iso_utc(T0_UNIX + s) for s in SEGMENT)
    extra = f'\n[segment]\nstart_utc = "{start}"\nend_utc = "{end}"\n' if segment else ""
    return load_point_mass(write_problem(tmp_path, full, "constant", extra))


def test_without_vertical_velocity_equals_zero_weight(tracks, tmp_path, monkeypatch):
    full, _ = tracks
    cfg = problem(tmp_path, full)
    prepare = pmf.prepare_data

    def zero_weight_vd(c):
        data = prepare(c)
        data.inv_sigma[:, 5] = 0.0
        return data

    with monkeypatch.context() as m:
        m.setattr(pmf, "prepare_data", zero_weight_vd)
        ref = pmf.fit_point_mass(cfg)
    as_written = read_flysight(cfg.gps_file)  # the same values as the reference reads (file precision)
    with monkeypatch.context() as m:
        m.setattr(pmf, "read_gps_track", lambda path, date=None: dataclasses.replace(
            as_written, vel_d_mps=np.full(as_written.n, np.nan)))
        got = pmf.fit_point_mass(cfg)
    assert got.solver.converged and ref.solver.converged
    n_fix = int((got.inv_sigma[:, 0] > 0).sum())
    assert got.n_measurements["gps"] == 5 * n_fix == ref.n_measurements["gps"]
    assert np.all(got.inv_sigma[:, 5] == 0) and np.isnan(got.normalized_residuals[:, 5]).all()
    print("no vel_d", dict(zip(got.params.names, got.values)), "ref", dict(zip(ref.params.names, ref.values)))
    assert got.values == pytest.approx(ref.values, rel=1e-6, abs=1e-9)
    assert got.sigma == pytest.approx(ref.sigma, rel=1e-6)
    assert got.reduced_chi2 == pytest.approx(ref.reduced_chi2, rel=1e-6)
    assert np.abs(got.states - ref.states).max() < 1e-4
    # the truth is still found, and the adequacy verdict tests five GPS channels, not six
    z = (got.values[0] - 0.25) / got.sigma[0]
    assert abs(z) < 3, z
    adequacy = pointmass_adequacy(got)
    assert sorted(t.name for t in adequacy.channels if t.name.startswith("gps")) == sorted(
        t.name for t in pointmass_adequacy(ref).channels if t.name.startswith("gps"))
    assert len(adequacy.channels) == 5
    stats = got.residual_stats()
    assert math.isnan(stats["vel_d"]["rms"]) and 0.7 < stats["vel_n"]["rms"] < 1.3


def test_automatic_segment_needs_vertical_velocity(tracks, tmp_path, monkeypatch):
    full, no_vd = tracks
    cfg = problem(tmp_path, full, segment=False)
    monkeypatch.setattr(pmf, "read_gps_track", lambda path, date=None: no_vd)
    with pytest.raises(InputError) as err:
        pmf.prepare_data(cfg)
    assert err.value.field == "segment.start_utc" and "no vertical velocity" in err.value.message
