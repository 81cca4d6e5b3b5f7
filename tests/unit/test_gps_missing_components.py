"""GPS fixes with missing components (NaN in the track): ``fixes_ned`` gives them an infinite sigma and
a position conversion without the height; the quality rules test only known accuracies; per-axis
velocity sigmas; the adequacy verdict leaves an empty channel out."""

from __future__ import annotations

import dataclasses

import numpy as np
import pymap3d
import pytest

from casrecon.analysis.adequacy import assess
from casrecon.io.flysight import GpsTrack
from casrecon.io.gps_rules import GpsQuality, fixes_ned, good_fixes, present
from casrecon.physics.dynamics import Site

SITE = Site(lat_deg=39.39, lon_deg=-8.29, ground_alt_msl_m=100.0)


def track(n: int = 4) -> GpsTrack:
    rng = np.random.default_rng(3)
    n_m, e_m, d_m = rng.uniform(-800, 800, n), rng.uniform(-800, 800, n), -rng.uniform(500, 5000, n)
    lat, lon, h = pymap3d.ned2geodetic(n_m, e_m, d_m, SITE.lat_deg, SITE.lon_deg, SITE.ground_alt_msl_m)
    ones = np.ones(n)
    return GpsTrack("t", "flysight1", 1.7e9 + np.arange(n), np.asarray(lat), np.asarray(lon), np.asarray(h),
                    rng.normal(size=n), rng.normal(size=n), 20 + rng.normal(size=n), 2 * ones, 3 * ones, 0.3 * ones,
                    np.full(n, 9))


def test_full_track_unchanged():
    g = track()
    pos, vel, sig = fixes_ned(g, SITE, np.arange(g.n))
    n, e, d = pymap3d.geodetic2ned(g.lat_deg, g.lon_deg, g.h_msl_m, SITE.lat_deg, SITE.lon_deg, SITE.ground_alt_msl_m)
    assert np.array_equal(pos, np.column_stack([n, e, d])) and np.isfinite(sig).all()
    assert np.array_equal(sig[:, 3:], np.column_stack([g.s_acc_mps] * 3))


def test_missing_vertical_velocity():
    g = track()
    nmea = dataclasses.replace(g, vel_d_mps=np.full(g.n, np.nan))
    pos, vel, sig = fixes_ned(nmea, SITE, np.arange(g.n))
    full = fixes_ned(g, SITE, np.arange(g.n))
    assert np.isnan(vel[:, 2]).all() and np.isinf(sig[:, 5]).all()
    assert np.array_equal(pos, full[0]) and np.array_equal(vel[:, :2], full[1][:, :2])
    assert np.array_equal(sig[:, :5], full[2][:, :5])
    assert present(sig).sum() == 5 * g.n


def test_latitude_longitude_only():
    g = track()
    nan = np.full(g.n, np.nan)
    flat = dataclasses.replace(g, h_msl_m=nan, vel_n_mps=nan, vel_e_mps=nan, vel_d_mps=nan, v_acc_m=nan, s_acc_mps=nan)
    pos, vel, sig = fixes_ned(flat, SITE, np.arange(g.n))
    assert np.isnan(pos[:, 2]).all() and np.isnan(vel).all()
    assert np.isfinite(sig[:, :2]).all() and np.isinf(sig[:, 2:]).all()
    # north and east from the latitude and longitude at the ground altitude: off by at most d * dh / R
    true = fixes_ned(g, SITE, np.arange(g.n))[0]
    bound = np.hypot(true[:, 0], true[:, 1]) * -true[:, 2] / 6.35e6
    assert (np.abs(pos[:, :2] - true[:, :2]).max(axis=1) <= bound).all() and bound.max() < 1.0
    # quality rules: the unknown vAcc and sAcc do not drop the fixes; a known poor hAcc does
    q = GpsQuality()
    assert good_fixes(flat, q).all()
    assert not good_fixes(dataclasses.replace(flat, h_acc_m=np.full(g.n, 20.0)), q).any()


def test_per_axis_velocity_sigma():
    g = track()
    _, _, sig = fixes_ned(g, SITE, np.arange(g.n), velocity_sigma_mps=(0.1, 0.2, 0.5))
    assert np.array_equal(sig[:, 3:], np.tile([0.1, 0.2, 0.5], (g.n, 1)))
    nmea = dataclasses.replace(g, vel_d_mps=np.full(g.n, np.nan))
    _, _, sig = fixes_ned(nmea, SITE, np.arange(g.n), velocity_sigma_mps=(0.1, 0.2, 0.5))
    assert np.isinf(sig[:, 5]).all()                  # a sigma does not make a missing value present


def test_adequacy_leaves_an_empty_channel_out():
    rng = np.random.default_rng(0)
    channels = {f"c{i}": rng.standard_normal(200) for i in range(5)}
    a = assess(channels, [], np.zeros(0), np.zeros(0), np.zeros((0, 0)))
    b = assess({**channels, "vel_d": np.full(200, np.nan)}, [], np.zeros(0), np.zeros(0), np.zeros((0, 0)))
    assert [t.name for t in b.channels] == [t.name for t in a.channels] and b.line == a.line


@pytest.mark.parametrize("idx", [np.arange(4), np.array([True, False, True, True])])
def test_index_or_mask(idx):
    assert fixes_ned(track(), SITE, idx)[2].shape[0] == np.arange(4)[idx].size
