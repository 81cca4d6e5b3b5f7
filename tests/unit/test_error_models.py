"""The error models' pieces: Kalman whitening of part-white, part-Gauss-Markov residuals, the
profile grid's geometry and interpolation, and their problem.toml keys."""

from __future__ import annotations

import numpy as np
import pytest

from casrecon.estimation.profile import PROFILE_PARAMETERS, ProfileGrid
from casrecon.physics.dynamics import PARAMETER_NAMES
from casrecon.physics.sensor_errors import GpsErrorModel, innovations


def part_correlated(n: int, dt: float, tau: float, f: float, rng: np.random.Generator) -> np.ndarray:
    """sqrt(1 - f) w + sqrt(f) e with e a stationary unit Gauss-Markov process."""
    phi = np.exp(-dt / tau)
    e = np.empty(n)
    e[0] = rng.normal()
    for k in range(1, n):
        e[k] = phi * e[k - 1] + np.sqrt(1 - phi**2) * rng.normal()
    return np.sqrt(1 - f) * rng.normal(size=n) + np.sqrt(f) * e


@pytest.mark.parametrize("tau, f", [(2.0, 0.9), (20.0, 0.99), (0.6, 0.5)])
def test_innovations_are_white_with_unit_variance(tau, f):
    n, dt = 20000, 0.2
    y = part_correlated(n, dt, tau, f, np.random.default_rng(1))
    t = dt * np.arange(n)
    nu = innovations(y, t, tau, f)
    se = 1 / np.sqrt(n)
    assert abs(np.corrcoef(y[:-1], y[1:])[0, 1]) > 0.3          # the input is far from white
    assert abs(np.corrcoef(nu[:-1], nu[1:])[0, 1]) < 5 * se
    assert abs(np.mean(nu**2) - 1) < 5 * np.sqrt(2) * se
    # the wrong model leaves them coloured
    assert abs(np.corrcoef(innovations(y, t, tau, 0.0)[:-1], y[1:])[0, 1]) > 0.3


def test_innovations_handle_gaps_between_fixes():
    rng = np.random.default_rng(2)
    dt, tau, f = 0.2, 5.0, 0.95
    y = part_correlated(30000, dt, tau, f, rng)
    t = dt * np.arange(y.size)
    keep = rng.uniform(size=y.size) > 0.3                         # drop 30 % of the fixes
    nu = innovations(y[keep], t[keep], tau, f)
    se = 1 / np.sqrt(keep.sum())
    assert abs(np.corrcoef(nu[:-1], nu[1:])[0, 1]) < 5 * se
    assert abs(np.mean(nu**2) - 1) < 5 * np.sqrt(2) * se


def test_white_model_and_defaults():
    white = GpsErrorModel.white()
    assert not white.enabled and white.active.size == 0 and "white" in white.describe()
    default = GpsErrorModel()
    np.testing.assert_array_equal(default.active, np.arange(6))
    assert default.transition(np.array([0.2]))[0, 0] == pytest.approx(np.exp(-0.2 / 100.0))
    with pytest.raises(ValueError, match="fraction"):
        GpsErrorModel(10.0, 1.0, 1.0, 0.5)


def test_profile_grid_covers_the_altitudes_with_a_margin_and_interpolates_linearly():
    grid = ProfileGrid.covering(np.array([1312.0, 2980.5]), 10.0, (0.5, 0.5, 0.005), 300.0)
    assert grid.altitudes_msl_m[0] <= 1312.0 - 20 and grid.altitudes_msl_m[-1] >= 2980.5 + 20
    assert grid.size == 3 * grid.n_levels and grid.phi == pytest.approx(np.exp(-10 / 300))
    cells = grid.cell_of(np.array([1312.0, 2000.0, 1e6, -1e6]))
    assert grid.altitudes_msl_m[cells[0]] <= 1312.0 < grid.altitudes_msl_m[cells[0] + 1]
    assert cells[2] == grid.n_levels - 2 and cells[3] == 0
    lower, upper = np.array([1.0, -2.0, 0.5]), np.array([3.0, 0.0, -0.5])
    base = grid.altitudes_msl_m[cells[1]]
    got = np.asarray(grid.correction(np.r_[lower, upper], base + 2.5, base)).ravel()
    np.testing.assert_allclose(got, (lower + 0.25 * (upper - lower)) * grid.sigma)
    p = np.asarray(grid.add_to_parameters(np.zeros(len(PARAMETER_NAMES)), got)).ravel()
    for c, name in enumerate(PROFILE_PARAMETERS):
        assert p[PARAMETER_NAMES.index(name)] == pytest.approx(got[c])
    assert ProfileGrid.covering(np.array([0.0, 1.0]), 10.0, (0.0, 0.0, 0.0), 300.0) is None


def test_density_only_grid_corrects_only_the_density_factor():
    grid = ProfileGrid.covering(np.array([100.0, 200.0]), 10.0, (0.0, 0.0, 0.01), 300.0)
    assert grid.components == (2,) and grid.n_components == 1
    p = np.asarray(grid.add_to_parameters(np.zeros(len(PARAMETER_NAMES)), np.array([0.002]))).ravel()
    assert p[PARAMETER_NAMES.index("density_factor")] == pytest.approx(0.002) and np.count_nonzero(p) == 1
