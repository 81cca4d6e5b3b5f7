"""The error families the fit's models do not contain (issue 49): each draws what its docstring
says, from its own seeded stream."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from casrecon.io.sounding import read_sounding
from casrecon.physics.atmosphere import Atmosphere
from casrecon.simulation.error_families import (
    FAMILIES,
    SOUNDING_DIR,
    SOUNDING_PAIRS,
    SoundingPair,
    Span,
    family_world,
    pair_difference,
    sounding_pair,
    von_karman_series,
)

SPAN = Span(lo_msl_m=1210.0, hi_msl_m=3000.0, ground_msl_m=1310.0, release_msl_m=2900.0, flight_s=40.0)


def test_von_karman_series_has_unit_variance_and_the_kolmogorov_structure_function():
    x = np.concatenate([von_karman_series(1.0, 100_000, 300.0, np.random.default_rng(i), 1) for i in range(8)], 1)
    assert abs(x.var() - 1.0) < 0.1
    # D(r) ~ r^(2/3) well inside the scale L (a Gauss-Markov process would give r^1)
    d = {lag: np.mean((x[lag:] - x[:-lag]) ** 2) for lag in (4, 16)}
    slope = np.log(d[16] / d[4]) / np.log(4)
    assert 0.6 < slope < 0.8, slope


@pytest.mark.parametrize("name", list(FAMILIES))
def test_family_worlds_are_seeded_and_differ_between_seeds(name):
    a, b, c = family_world(name, SPAN, 1), family_world(name, SPAN, 1), family_world(name, SPAN, 2)
    assert a.name == name
    utc = 1.7e9 + 0.2 * np.arange(300)
    white = np.random.default_rng(0).normal(size=(300, 6))
    sigma = np.tile([1.5, 1.5, 2.5, 0.25, 0.25, 0.25], (300, 1))
    for world in (a, b, c):
        if world.profile_error is not None:
            p = world.profile_error
            assert p.altitude_msl_m[0] <= SPAN.ground_msl_m and p.altitude_msl_m[-1] >= SPAN.release_msl_m
            assert np.all(np.diff(p.altitude_msl_m) > 0)
    if a.profile_error is not None and name != "density-ramp":
        assert np.array_equal(a.profile_error.wind_north_mps, b.profile_error.wind_north_mps)
        assert not np.array_equal(a.profile_error.wind_north_mps, c.profile_error.wind_north_mps)
    if a.gps_factors is not None and name != "none":
        fa, fb, fc = (w.gps_factors(utc, white, sigma) for w in (a, b, c))
        assert fa.shape == (300, 6) and np.array_equal(fa, fb) and not np.array_equal(fa, fc)


def test_gps_families_have_their_shapes():
    utc = 1.7e9 + 0.2 * np.arange(2000)
    zero = np.zeros((2000, 6))
    sigma = np.tile([1.5, 1.5, 2.5, 0.25, 0.25, 0.25], (2000, 1))
    steps = family_world("gps-steps", SPAN, 3).gps_factors(utc, zero, sigma)
    jumps = np.flatnonzero(np.any(np.diff(steps[:, :3], axis=0) != 0, axis=1))
    assert 25 < jumps.size < 100  # 400 s at one change per 8 s on average
    assert np.all(steps[:, 3:] == 0)  # velocity errors white (here zero)
    walk = family_world("gps-random-walk", SPAN, 3).gps_factors(utc, zero, sigma)[:, 0] * 1.5  # metres
    increments = np.diff(walk)
    assert abs(increments.std() / (0.15 * np.sqrt(0.2)) - 1) < 0.1
    long = family_world("gps-long-time", SPAN, 3).gps_factors(utc, zero, sigma)
    lag1 = np.corrcoef(long[:-1, 0], long[1:, 0])[0, 1]
    assert lag1 > 0.95


def test_atmosphere_families_have_their_shapes():
    ramp = family_world("density-ramp", SPAN, 0).profile_error
    at = np.interp([SPAN.ground_msl_m, SPAN.release_msl_m], ramp.altitude_msl_m, ramp.density)
    assert np.allclose(at, [-0.015, 0.015]) and not ramp.wind_north_mps.any()
    jet = family_world("wind-jet", SPAN, 0).profile_error
    speed = np.hypot(jet.wind_north_mps, jet.wind_east_mps)
    assert abs(speed.max() - 2.5) < 0.01 and speed[0] < 0.01
    coarse = family_world("coarse-grid", SPAN, 0).profile_error
    assert np.unique(coarse.wind_north_mps).size <= int((SPAN.hi_msl_m - SPAN.lo_msl_m) / 250) + 2
    turbulence = family_world("turbulence", SPAN, 0)
    assert np.median(np.diff(turbulence.profile_error.altitude_msl_m)) == pytest.approx(1.0)
    gust = turbulence.gusts(np.linspace(0, 40, 4001))
    assert gust.shape == (4001, 3) and 0.1 < gust[:, 0].std() < 0.6


def test_unknown_family_is_refused():
    with pytest.raises(ValueError, match="unknown error family 'gusty'"):
        family_world("gusty", SPAN, 0)


def test_sounding_pairs_are_one_site_hours_apart():
    assert len(SOUNDING_PAIRS) >= 3
    for pair in SOUNDING_PAIRS:
        a = read_sounding(SOUNDING_DIR / pair.first, pair.first_launch)
        b = read_sounding(SOUNDING_DIR / pair.second, pair.second_launch)
        assert 3 * 3600 <= b.origin.time_unix_s - a.origin.time_unix_s <= 24 * 3600, pair.name
        assert abs(a.altitude_msl_m[0] - b.altitude_msl_m[0]) < 20.0, pair.name  # one launch site
        if a.origin.lat_deg is not None:
            assert (a.origin.lat_deg, a.origin.lon_deg) == (b.origin.lat_deg, b.origin.lon_deg), pair.name


def _real_difference(pair: SoundingPair, agl_m: np.ndarray) -> np.ndarray:
    """Later minus earlier at heights above each sounding's lowest level, straight from their levels."""
    out = []
    for name, launch in ((pair.second, pair.second_launch), (pair.first, pair.first_launch)):
        s = read_sounding(SOUNDING_DIR / name, launch)
        rho = Atmosphere.from_sounding(s).levels["density_kgm3"]
        h = s.altitude_msl_m - s.altitude_msl_m[0]
        out.append([np.interp(agl_m, h, v) for v in (s.wind_north_mps, s.wind_east_mps, np.log(rho))])
    d = np.array(out[0]) - np.array(out[1])
    return np.vstack([d[:2], np.expm1(d[2])])


def test_sounding_pair_world_is_a_real_pairs_difference_without_its_mean():
    drawn = set()
    for seed in range(12):
        p = family_world("sounding-pair", SPAN, seed).profile_error
        flown = (p.altitude_msl_m >= SPAN.ground_msl_m) & (p.altitude_msl_m <= SPAN.release_msl_m)
        got = np.array([p.wind_north_mps, p.wind_east_mps, p.density])
        agl = np.clip(p.altitude_msl_m - SPAN.ground_msl_m, 0.0, None)
        matches = []
        for k, pair in enumerate(SOUNDING_PAIRS):
            real = _real_difference(pair, agl)
            for sign in (1, -1):
                want = sign * real - sign * real[:, flown].mean(axis=1, keepdims=True)
                if np.allclose(got, want, rtol=0, atol=1e-9):
                    matches.append((k, sign))
        assert len(matches) == 1, (seed, matches)
        drawn.add(matches[0])
        assert np.allclose(got[:, flown].mean(axis=1), 0.0, atol=1e-12)
        assert np.all(got[:, agl == 0] == got[:, agl == 0][:, :1])  # held below the ground
    assert len({k for k, _ in drawn}) == len(SOUNDING_PAIRS) and {s for _, s in drawn} == {1, -1}


def test_sounding_pair_differences_have_real_size():
    d = pair_difference(SOUNDING_PAIRS[1])  # Utqiagvik 2014-09-10, 00Z to 12Z
    assert d.hours == 12.0 and d.height_agl_m[0] == 0.0 and np.all(np.diff(d.height_agl_m) == 5.0)
    low = d.height_agl_m <= 1600.0
    assert 0.3 < d.wind_east_mps[low].std() < 5.0 and 0.0005 < d.density[low].std() < 0.02


def test_a_pair_of_other_days_or_sites_is_refused(tmp_path):
    days = SoundingPair("Norman 2011-05-22 and 2023-05-22", "soundings/20110522_OUN_12Z.txt",
                        "soundings/OUN_72357_2023-05-22_12Z_wyoming.csv")
    with pytest.raises(ValueError, match="h apart; expected the later 3 to 24 h after the earlier"):
        pair_difference(days, Path(__file__).resolve().parents[1] / "data" / "realdata")
    first, second = SOUNDING_PAIRS[1].first, SOUNDING_PAIRS[1].second  # Utqiagvik, 12 h apart
    (tmp_path / first).write_text((SOUNDING_DIR / first).read_text())
    (tmp_path / second).write_text((SOUNDING_DIR / second).read_text().replace("lat 71.2889", "lat 40.19", 1))
    with pytest.raises(ValueError, match="the two files give different places"):
        pair_difference(SOUNDING_PAIRS[1], tmp_path)
    short = Span(lo_msl_m=1210.0, hi_msl_m=40_000.0, ground_msl_m=1310.0, release_msl_m=39_900.0, flight_s=40.0)
    with pytest.raises(ValueError, match="reaches .* m above its surface; the drop needs"):
        sounding_pair(short, np.random.default_rng(0))


def test_the_air_scaled_twice_is_twice_the_departure_and_the_same_gps():
    from casrecon.simulation.error_families import with_air_scaled

    span = Span(lo_msl_m=1210.0, hi_msl_m=4000.0, ground_msl_m=1310.0, release_msl_m=2900.0, flight_s=40.0)
    world = family_world("turbulence", span, 3)
    twice = with_air_scaled(world, 2.0)
    np.testing.assert_allclose(twice.profile_error.wind_north_mps, 2 * world.profile_error.wind_north_mps)
    np.testing.assert_allclose(twice.profile_error.density, 2 * world.profile_error.density)
    t = np.linspace(0.0, 40.0, 81)
    np.testing.assert_allclose(twice.gusts(t), 2 * world.gusts(t))
    assert twice.gps_factors is world.gps_factors and twice.name == "turbulence x2"
    assert with_air_scaled(world, 1.0).name == "turbulence"
