"""The simulator's world-is-not-the-model error processes (casrecon.simulation.model_errors): the
drawn atmosphere-profile error has its stated sigma and correlation length, the flown atmosphere is
the sounding plus that error, the coloured GPS error factors have the stated lag-1 autocorrelation
and white fraction, and the [truth] keys are validated with located errors.

Statistical checks compare an estimate with its truth within 4 standard errors, each standard error
computed from the same sample (spread of independent replicates or batches); 4 SE is exceeded
with probability 6e-5 by chance, and the draws are seeded, so the tests are deterministic.
"""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.io.errors import InputError
from casrecon.io.problem import load_problem
from casrecon.io.truth_errors import TruthErrors
from casrecon.scenario import Scenario
from casrecon.simulation.model_errors import (
    PROFILE_STEP_M,
    ProfileError,
    draw_profile_error,
    flown_atmosphere,
    gps_error_factors,
    profile_grid,
    unit_gauss_markov,
)

N_SE = 4.0
PROFILE = TruthErrors(profile_wind_sigma_mps=0.5, profile_density_sigma=0.005, profile_length_m=300.0)


def _mean_and_se(samples: np.ndarray) -> tuple[float, float]:
    """Mean of independent replicates and its standard error."""
    return float(samples.mean()), float(samples.std(ddof=1) / np.sqrt(samples.size))


def _ratio_and_se(a: np.ndarray, b: np.ndarray) -> tuple[float, float]:
    """Ratio sum(a) / sum(b) of independent replicates (a_i, b_i) and its delta-method standard error
    sd(a_i - R b_i) / (sqrt(M) mean(b_i))."""
    r = float(a.sum() / b.sum())
    return r, float((a - r * b).std(ddof=1) / (np.sqrt(a.size) * b.mean()))


def _lag_correlation(x: np.ndarray, lag: int) -> tuple[float, float]:
    """Correlation at ``lag`` samples of replicates ``x`` (M, n), pooled over the replicates:
    sum x_k x_k+lag / sum x_k^2, with its standard error."""
    return _ratio_and_se((x[:, :-lag] * x[:, lag:]).sum(axis=1), (x[:, :-lag] ** 2).sum(axis=1))


@pytest.fixture(scope="module")
def drop3() -> Scenario:
    return Scenario.load(PROBLEMS / "ees-drop-3")


@pytest.fixture(scope="module")
def profiles(drop3):
    """400 drawn profiles (seeds 0..399) on ees-drop-3's grid, normalised by their sigmas: (seeds, n, 3)."""
    grid = profile_grid(drop3.atmosphere.altitude_range_m, drop3.config.site.ground_alt_msl_m,
                        drop3.release_alt_msl_m)
    sigma = np.array([PROFILE.profile_wind_sigma_mps] * 2 + [PROFILE.profile_density_sigma])
    draws = []
    for seed in range(400):
        e = draw_profile_error(PROFILE, grid, seed)
        draws.append(np.column_stack([e.wind_north_mps, e.wind_east_mps, e.density]) / sigma)
    return grid, np.array(draws)


def test_profile_grid_covers_the_flight_and_the_sounding(drop3):
    lo, hi = drop3.atmosphere.altitude_range_m
    grid = profile_grid((lo, hi), drop3.config.site.ground_alt_msl_m, drop3.release_alt_msl_m)
    assert grid[0] == lo and grid[-1] == pytest.approx(hi, abs=1e-9)
    assert np.diff(grid) == pytest.approx(np.diff(grid)[0], abs=1e-9) and np.diff(grid)[0] <= PROFILE_STEP_M
    short = profile_grid((1400.0, 2000.0), 1310.0, 2865.0)     # a sounding above the ground, below the release
    assert short[0] == 1210.0 and short[-1] == pytest.approx(2965.0, abs=1e-9)


def test_profile_error_has_its_sigma(profiles):
    """Mean square of each normalised error over altitudes and seeds is 1 (wind N, E, density), also
    at the first grid altitude (the process starts stationary)."""
    _, x = profiles
    for col in range(3):
        mean, se = _mean_and_se((x[:, :, col] ** 2).mean(axis=1))
        assert abs(mean - 1.0) < N_SE * se, (col, mean, se)
        first, se_first = _mean_and_se(x[:, 0, col] ** 2)
        assert abs(first - 1.0) < N_SE * se_first, (col, first, se_first)


def test_profile_error_has_its_correlation_length(profiles):
    """The correlation at lags of one grid step (10 m) and of one correlation length is
    exp(-|dh| / L), and the length recovered from each is L (standard errors by the delta method)."""
    grid, x = profiles
    step = grid[1] - grid[0]
    for lag in (1, int(round(PROFILE.profile_length_m / step))):
        for col in range(3):
            corr, se = _lag_correlation(x[:, :, col], lag)
            assert abs(corr - np.exp(-lag * step / PROFILE.profile_length_m)) < N_SE * se, (lag, col, corr, se)
            length = -lag * step / np.log(corr)
            se_length = lag * step / (corr * np.log(corr) ** 2) * se
            assert abs(length - PROFILE.profile_length_m) < N_SE * se_length, (lag, col, length, se_length)


def test_profile_errors_are_independent(profiles):
    _, x = profiles
    for a, b in ((0, 1), (0, 2), (1, 2)):
        cross, se = _mean_and_se((x[:, :, a] * x[:, :, b]).mean(axis=1))
        assert abs(cross) < N_SE * se, (a, b, cross, se)


def test_profile_error_is_seeded_on_its_own_stream(drop3):
    grid = profile_grid(drop3.atmosphere.altitude_range_m, 1310.0, drop3.release_alt_msl_m)
    a, b = draw_profile_error(PROFILE, grid, 7), draw_profile_error(PROFILE, grid, 7)
    other = draw_profile_error(PROFILE, grid, 8)
    assert np.array_equal(a.wind_north_mps, b.wind_north_mps) and np.array_equal(a.density, b.density)
    assert not np.allclose(a.wind_north_mps, other.wind_north_mps)
    unit = np.random.default_rng((7, 3)).normal(size=(grid.size, 3))[:, 0]   # the stream (seed, 3)
    assert a.wind_north_mps[0] == pytest.approx(0.5 * unit[0], rel=1e-12)
    assert draw_profile_error(TruthErrors(), grid, 7) is None


def _air(atmosphere, h: np.ndarray) -> np.ndarray:
    sym = ca.SX.sym("h")
    a = atmosphere.at(sym)
    f = ca.Function("air", [sym], [ca.vertcat(a.pressure, a.temperature, a.density, a.wind_ned[0], a.wind_ned[1])])
    return np.asarray(f.map(h.size)(h[None, :]))


def test_flown_atmosphere_is_the_sounding_plus_the_error(drop3):
    sounding = drop3.atmosphere
    grid = profile_grid(sounding.altitude_range_m, 1310.0, drop3.release_alt_msl_m)
    error = draw_profile_error(PROFILE, grid, 3)
    flown = flown_atmosphere(sounding, error)
    snd, fl = _air(sounding, grid), _air(flown, grid)
    assert fl[0] == pytest.approx(snd[0], rel=1e-12)                     # pressure
    assert fl[1] == pytest.approx(snd[1], rel=1e-12)                     # temperature
    assert fl[2] == pytest.approx(snd[2] * (1 + error.density), rel=1e-12)
    assert fl[3] == pytest.approx(snd[3] + error.wind_north_mps, abs=1e-10)
    assert fl[4] == pytest.approx(snd[4] + error.wind_east_mps, abs=1e-10)
    zero = ProfileError(grid, 0 * grid, 0 * grid, 0 * grid)
    between = np.linspace(grid[0] - 50.0, grid[-1] + 50.0, 7777)         # off the nodes, and beyond both ends
    assert _air(flown_atmosphere(sounding, zero), between) == pytest.approx(_air(sounding, between), rel=1e-10)


def test_unit_gauss_markov_is_stationary_with_its_lag_correlation():
    """A 0.2 s grid, tau = 2 s: variance 1 at every time and lag-1 correlation exp(-0.1), over 4000
    independent columns."""
    t = 0.2 * np.arange(50)
    x = unit_gauss_markov(t, 2.0, np.random.default_rng(11).normal(size=(t.size, 4000)))
    for k in (0, 25, 49):
        var, se = _mean_and_se(x[k] ** 2)
        assert abs(var - 1.0) < N_SE * se, (k, var, se)
    corr, se = _mean_and_se((x[:-1] * x[1:]).mean(axis=0))
    assert abs(corr - np.exp(-0.1)) < N_SE * se, (corr, se)


@pytest.mark.parametrize("uniform", [True, False])
def test_unit_gauss_markov_is_the_exact_recursion(uniform):
    """x_0 = e_0, x_k = phi_k x_k-1 + sqrt(1 - phi_k^2) e_k with phi_k from each step, on a uniform grid
    (computed by a filter) and on an uneven one (a loop)."""
    rng = np.random.default_rng(4)
    c = np.cumsum(np.r_[0.0, np.full(99, 0.2) if uniform else rng.uniform(0.05, 0.5, 99)])
    e = rng.normal(size=(100, 2))
    expected = np.empty_like(e)
    expected[0] = e[0]
    for k in range(1, 100):
        phi = np.exp(-(c[k] - c[k - 1]) / 1.5)
        expected[k] = phi * expected[k - 1] + np.sqrt(1 - phi**2) * e[k]
    assert unit_gauss_markov(c, 1.5, e) == pytest.approx(expected, abs=1e-12)
    assert unit_gauss_markov(c, 1.5, e[:, 1]) == pytest.approx(expected[:, 1], abs=1e-12)


def test_gps_error_factors_white_by_default():
    white = np.random.default_rng(1).normal(size=(50, 6))
    t = 0.2 * np.arange(50)
    assert gps_error_factors(t, TruthErrors(), white, 0) is white
    assert gps_error_factors(t, TruthErrors(gps_white_fraction=0.7), white, 0) is white
    velocity_only = gps_error_factors(t, TruthErrors(gps_velocity_time_s=2.0), white, 0)
    assert np.array_equal(velocity_only[:, :3], white[:, :3]) and not np.allclose(velocity_only[:, 3:], white[:, 3:])


def _batch_stats(z: np.ndarray, batches: int) -> tuple[np.ndarray, ...]:
    """Mean square and lag-1 autocorrelation of each column of ``z`` (n, m) with their standard errors
    from ``batches`` consecutive batches (treated as independent replicates)."""
    n = z.shape[0] // batches * batches
    zb = z[:n].reshape(batches, -1, z.shape[1])
    square = (zb**2).mean(axis=1)
    corr = [_lag_correlation(zb[:, :, c], 1) for c in range(z.shape[1])]
    return (square.mean(0), square.std(0, ddof=1) / np.sqrt(batches), np.array([c[0] for c in corr]),
            np.array([c[1] for c in corr]))


@pytest.mark.parametrize("white_fraction", [0.0, 0.3])
def test_gps_error_factors_lag1_autocorrelation(white_fraction):
    """200 000 fixes at 5 Hz, position tau 20 s, velocity tau 2 s: unit variance and lag-1
    autocorrelation (1 - f) phi, phi = exp(-0.2 s / tau); batch standard errors (100 batches of 400 s,
    20 position correlation times each); the white part is the noise passed in, the rest the
    Gauss-Markov process of the stream (seed, 4)."""
    n, dt = 200_000, 0.2
    t = 1.7e9 + dt * np.arange(n)
    errors = TruthErrors(gps_position_time_s=20.0, gps_velocity_time_s=2.0, gps_white_fraction=white_fraction)
    white = np.random.default_rng(5).normal(size=(n, 6))
    z = gps_error_factors(t, errors, white, 12)
    var, se_var, corr, se_corr = _batch_stats(z, 100)
    phi = np.exp(-dt / np.array([20.0] * 3 + [2.0] * 3))
    assert np.all(np.abs(var - 1.0) < N_SE * se_var), (var, se_var)
    expected = (1 - white_fraction) * phi
    assert np.all(np.abs(corr - expected) < N_SE * se_corr), (corr, expected, se_corr)
    e = np.random.default_rng((12, 4)).normal(size=(n, 6))                 # the correlated part's stream
    coloured = np.column_stack([unit_gauss_markov(t, 20.0, e[:, :3]), unit_gauss_markov(t, 2.0, e[:, 3:])])
    assert np.abs(z - (np.sqrt(1 - white_fraction) * coloured + np.sqrt(white_fraction) * white)).max() < 1e-12
    assert np.array_equal(z, gps_error_factors(t, errors, white, 12))


def _problem_with_truth(tmp_path, extra: str):
    src = (PROBLEMS / "ees-drop-3" / "problem.toml").read_text()
    text = src.replace("[truth]\n", "[truth]\n" + extra + "\n", 1)
    text = text.replace('sounding = "sounding.csv"', f'sounding = "{PROBLEMS / "ees-drop-3" / "sounding.csv"}"')
    text = text.replace('"../', f'"{PROBLEMS}/')
    (tmp_path / "problem.toml").write_text(text)
    return tmp_path


def test_truth_error_keys_parsed(tmp_path):
    folder = _problem_with_truth(tmp_path, "profile_wind_sigma_mps = 0.4\nprofile_density_sigma = 0.003\n"
                                           "profile_length_m = 250\ngps_position_time_s = 20\n"
                                           "gps_velocity_time_s = 2\ngps_white_fraction = 0.25")
    errors = load_problem(folder).truth.errors
    assert errors == TruthErrors(0.4, 0.003, 250.0, 20.0, 2.0, 0.25)
    assert errors.profile and errors.coloured_gps
    assert load_problem(PROBLEMS / "ees-drop-3").truth.errors == TruthErrors()


@pytest.mark.parametrize("line, field", [
    ("profile_wind_sigma_mps = -0.1", "profile_wind_sigma_mps"),
    ("profile_density_sigma = -1e-3", "profile_density_sigma"),
    ("profile_length_m = 0", "profile_length_m"),
    ("gps_position_time_s = -2", "gps_position_time_s"),
    ("gps_velocity_time_s = \"fast\"", "gps_velocity_time_s"),
    ("gps_white_fraction = 1.5", "gps_white_fraction"),
])
def test_truth_error_keys_validated_with_located_errors(tmp_path, line, field):
    folder = _problem_with_truth(tmp_path, line)
    with pytest.raises(InputError) as err:
        load_problem(folder)
    text = str(err.value)
    assert f"problem.toml: field 'truth.{field}': expected" in text and "\n" not in text, text
