"""The error models' pieces: Kalman whitening of part-white, part-Gauss-Markov residuals, the
profile grid's geometry and interpolation, and their problem.toml keys."""

from __future__ import annotations

import casadi as ca
import numpy as np
import pytest

from casrecon.estimation.error_models.profile import PROFILE_PARAMETERS, ProfileGrid
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
    np.testing.assert_array_equal(default.scale, np.ones(6))
    scaled = GpsErrorModel(position_scale=0.5, velocity_scale=2.0)
    np.testing.assert_array_equal(scaled.scale, [0.5] * 3 + [2.0] * 3)
    assert "position accuracies x 0.5, velocity accuracies x 2" in scaled.describe()
    assert "accuracies" not in default.describe()
    for bad in (0.0, -1.0, np.inf):
        with pytest.raises(ValueError, match="scales"):
            GpsErrorModel(position_scale=bad)


def test_gps_accuracy_scale_sizes_the_fix_errors(problem_copy):
    """``position_accuracy_scale`` and ``velocity_accuracy_scale`` multiply the file's accuracies in
    the fit's GPS rows (a fit's reported GPS sigma) and in the kinematic fit's inputs."""
    from test_problem_config import edit

    from casrecon.estimation.kinds.gps import fix_sigma
    from casrecon.estimation.sixdof.fitdata import load_fit_data
    from casrecon.io.problem import load_problem

    edit(problem_copy, "position_error_time_s = 0.0", "position_error_time_s = 0.0\n"
         "position_accuracy_scale = 0.5\nvelocity_accuracy_scale = 3.0")
    cfg = load_problem(problem_copy)
    model = cfg.gps.error_model
    assert (model.position_scale, model.velocity_scale) == (0.5, 3.0)
    data = load_fit_data(cfg)
    sigma = fix_sigma(data, model)
    np.testing.assert_allclose(sigma[:, :3], 0.5 * data.gps_sigma[:, :3])
    np.testing.assert_allclose(sigma[:, 3:], 3.0 * data.gps_sigma[:, 3:])


def test_profile_grid_covers_the_altitudes_with_a_margin():
    grid = ProfileGrid.covering(np.array([1312.0, 2980.5]), 10.0, (0.5, 0.5, 0.005), 300.0)
    assert grid.altitudes_msl_m[0] <= 1312.0 - 30 and grid.altitudes_msl_m[-1] >= 2980.5 + 30
    assert grid.size == 3 * grid.n_levels and grid.phi == pytest.approx(np.exp(-10 / 300))
    cells = grid.cell_of(np.array([1312.0, 2000.0, 1e6, -1e6]))
    assert grid.altitudes_msl_m[cells[0]] <= 1312.0 < grid.altitudes_msl_m[cells[0] + 1]
    assert cells[2] == grid.n_levels - 2 and cells[3] == 0
    assert ProfileGrid.covering(np.array([0.0, 1.0]), 10.0, (0.0, 0.0, 0.0), 300.0) is None


def whole_grid_spline(grid, coefficients, alt):
    """sum_j g_j B((h - h_j) / step) over every level (numpy; coefficients (n_levels, n_c) SI)."""
    x = (alt - grid.altitudes_msl_m) / grid.step_m
    d = np.abs(x)
    b = (np.maximum(0, 2 - d) ** 3 - 4 * np.maximum(0, 1 - d) ** 3) / 6
    return b @ coefficients


@pytest.mark.parametrize("step", [10.0, 5.0, 30.0])
def test_profile_window_equals_the_whole_grid_spline_within_its_tolerance(step):
    grid = ProfileGrid.covering(np.array([1312.0, 1480.0]), step, (0.5, 0.5, 0.005), 300.0, tolerance_m=10.0)
    assert grid.window_levels == 4 + 2 * int(np.ceil(10.0 / step))
    z = np.random.default_rng(1).normal(size=grid.size)
    g = grid.coefficients(z)
    for guess in (1312.0, 1317.5, 1400.2, 1480.0, grid.altitudes_msl_m[0] + 1, grid.altitudes_msl_m[-1] - 1):
        cell = grid.cell_of(np.array([guess]))
        cols = grid.window_columns(0, cell)[0]
        base = grid.window_base_msl_m(cell)[0]
        for alt in np.linspace(guess - 9.9, guess + 9.9, 7):
            assert not grid.outside_windows(np.array([alt]), cell)[0]
            got = np.asarray(grid.correction(z[cols], alt, base)).ravel()
            np.testing.assert_allclose(got, whole_grid_spline(grid, g, alt), rtol=1e-12, atol=1e-15)
    # an altitude a step beyond the window's reach is flagged (inside the grid, away from its ends)
    cell = grid.cell_of(np.array([1400.0]))
    reach = step * ((grid.window_levels - 4) // 2)
    far = np.array([1400.0 - reach - step - 0.5, 1400.0 + reach + step + 0.5])
    assert grid.outside_windows(far, np.r_[cell, cell]).all()
    # the level values are the spline at the levels, and a correction is added to its parameter
    np.testing.assert_allclose(grid.level_values(z), whole_grid_spline(grid, g, grid.altitudes_msl_m[:, None]),
                               rtol=1e-12, atol=1e-15)
    got = np.array([0.1, -0.2, 0.003])
    p = np.asarray(grid.add_to_parameters(np.zeros(len(PARAMETER_NAMES)), got)).ravel()
    for c, name in enumerate(PROFILE_PARAMETERS):
        assert p[PARAMETER_NAMES.index(name)] == pytest.approx(got[c])


def test_profile_correction_is_twice_differentiable_across_levels():
    grid = ProfileGrid.covering(np.array([100.0, 300.0]), 10.0, (0.5, 0.0, 0.0), 300.0)
    h = ca.SX.sym("h")
    cell = grid.cell_of(np.array([200.0]))
    w = ca.SX.sym("w", 6)
    c = grid.correction(w, h, float(grid.window_base_msl_m(cell)[0]))
    d2 = ca.Function("d2", [h, w], [ca.hessian(c, h)[0]])
    values = np.random.default_rng(2).normal(size=6)
    level = float(grid.altitudes_msl_m[cell[0]])
    left, right = float(d2(level - 1e-9, values)), float(d2(level + 1e-9, values))
    assert left == pytest.approx(right, rel=1e-6, abs=1e-9)


def test_density_only_grid_corrects_only_the_density_factor():
    grid = ProfileGrid.covering(np.array([100.0, 200.0]), 10.0, (0.0, 0.0, 0.01), 300.0)
    assert grid.components == (2,) and grid.n_components == 1
    p = np.asarray(grid.add_to_parameters(np.zeros(len(PARAMETER_NAMES)), np.array([0.002]))).ravel()
    assert p[PARAMETER_NAMES.index("density_factor")] == pytest.approx(0.002) and np.count_nonzero(p) == 1


def test_profile_common_columns_match_levels_by_altitude():
    a = ProfileGrid.covering(np.array([1312.0, 1480.0]), 10.0, (0.5, 0.5, 0.005), 300.0)
    b = ProfileGrid.covering(np.array([1295.0, 1470.0]), 10.0, (0.5, 0.5, 0.005), 300.0)
    to, frm = b.common_columns(100, a, 7)
    assert to.size == frm.size > 0
    level_b, level_a = (to - 100) // 3, (frm - 7) // 3
    np.testing.assert_array_equal(b.altitudes_msl_m[level_b], a.altitudes_msl_m[level_a])
    np.testing.assert_array_equal((to - 100) % 3, (frm - 7) % 3)
    coarse = ProfileGrid.covering(np.array([1312.0, 1480.0]), 20.0, (0.5, 0.5, 0.005), 300.0)
    assert coarse.common_columns(0, a, 0)[0].size == 0


def test_model_error_study_worlds_switch_the_truth_errors_off():
    """The model-error study's worlds: exact air drops the drawn profile error only (the fit's profile
    model stays on); white GPS drops the correlated GPS errors and tells the fit."""
    from conftest import PROBLEMS

    from casrecon.analysis.model_error_mc import World, in_world
    from casrecon.scenario import Scenario

    sc = Scenario.load(PROBLEMS / "ees-drop-3-model-error")
    assert sc.config.truth.errors.profile and sc.config.truth.errors.coloured_gps
    air = in_world(sc, World(exact_air=True)).config
    assert not air.truth.errors.profile and air.truth.errors.coloured_gps
    assert air.atmosphere.profile_wind_sigma_mps == sc.config.atmosphere.profile_wind_sigma_mps > 0
    assert air.gps.error_model == sc.config.gps.error_model
    white = in_world(sc, World(white_gps=True)).config
    assert white.truth.errors.profile and not white.truth.errors.coloured_gps
    assert white.gps.error_model == GpsErrorModel.white()
    matched = in_world(sc, World(matched_gps=True)).config
    model = sc.config.gps.error_model
    assert matched.gps.error_model == model and matched.truth.errors.profile
    assert matched.truth.errors.gps_position_time_s == model.position_time_s
    assert matched.truth.errors.gps_velocity_time_s == model.velocity_time_s
    assert matched.truth.errors.gps_white_fraction == pytest.approx(1.0 - model.position_fraction)
    default = in_world(sc, World(default_gps_model=True)).config
    assert default.gps.error_model == GpsErrorModel() != model
    assert default.truth.errors == sc.config.truth.errors
    with pytest.raises(ValueError, match="different GPS worlds"):
        in_world(sc, World(white_gps=True, matched_gps=True))
    with pytest.raises(ValueError, match="different GPS worlds"):
        in_world(sc, World(matched_gps=True, default_gps_model=True))


@pytest.mark.parametrize("n_levels", [3, 4, 9])
def test_profile_prior_whitens_the_level_values(n_levels):
    """The profile prior's rows are v_0 and (v_k - phi v_k-1) / sqrt(1 - phi^2) of the spline's
    values at the levels, v = (g_k-1 + 4 g_k + g_k+1) / 6, so the values (not the coefficients)
    are the Gauss-Markov process: their implied covariance is phi^|i-j|."""
    from casrecon.estimation.kinds.disturbance import spline_level_prior_terms

    n, phi = 3, 0.967
    cols = np.arange(n_levels * n).reshape(n_levels, n)
    terms = spline_level_prior_terms(cols, phi, "profile_start", "profile")
    rows = []  # the prior's (linear) rows as a matrix over z
    for term in terms:
        for bs in term.sets:
            f = bs.kind.values
            for b in range(bs.n_blocks):
                data = [np.asarray(d)[:, b] for d in bs.data]
                # linear rows: the column of local unknown j is their value at the unit vector e_j
                jac = np.column_stack([np.asarray(f(e, *data)).ravel() for e in np.eye(bs.kind.n_local)])
                block = np.zeros((jac.shape[0], cols.size))
                block[:, bs.cols[b]] = jac
                rows.append(block)
    r = np.vstack(rows)
    assert r.shape == (n_levels * n, n_levels * n)
    m = (4 * np.eye(n_levels) + np.eye(n_levels, k=1) + np.eye(n_levels, k=-1)) / 6
    values = np.kron(m, np.eye(n))  # v = values @ g (levels major, processes minor)
    cov_g = np.linalg.inv(r.T @ r)
    cov_v = values @ cov_g @ values.T
    k = np.arange(n_levels)
    want = np.kron(phi ** np.abs(k[:, None] - k[None, :]), np.eye(n))
    np.testing.assert_allclose(cov_v, want, atol=1e-10)


def test_gps_model_from_estimated_ratios():
    """The refit's GPS error model keeps the estimated white and correlated variances (fraction
    capped at 0.999); a correlated share below 1 % makes a group white; models differing only by a
    white part below the cap do not ask for a refit."""
    from casrecon.estimation.error_models.gps_error_sigma import model_from, models_differ

    fitted = GpsErrorModel(20.0, 2.0, 0.99, 0.99)
    m = model_from(fitted, {"gps position white": 2.0, "gps position correlated": 0.5,
                            "gps velocity white": 1.0, "gps velocity correlated": 1.0})
    total = 4.0 * 0.01 + 0.25 * 0.99
    assert m.position_scale == pytest.approx(np.sqrt(total))
    assert m.position_fraction == pytest.approx(0.25 * 0.99 / total)
    assert (m.velocity_scale, m.velocity_fraction) == pytest.approx((1.0, 0.99))
    assert models_differ(fitted, m) and not models_differ(fitted, fitted)
    capped = model_from(fitted, {"gps position white": 0.02, "gps velocity white": 0.02})
    assert capped.position_fraction == capped.velocity_fraction == 0.999
    again = model_from(capped, {"gps position white": 0.02, "gps velocity white": 0.3})
    assert again.position_fraction == 0.999 and not models_differ(capped, again)
    white = model_from(GpsErrorModel(), {"gps position correlated": 0.005, "gps velocity correlated": 0.05})
    assert (white.position_time_s, white.position_fraction, white.velocity_time_s) == (0.0, 0.0, 0.0)
    assert not white.enabled and models_differ(GpsErrorModel(), white)
    assert model_from(fitted, {}, (4.0, 10.0)).velocity_time_s == 10.0


@pytest.mark.parametrize("peak_s, expected_s", [(75.0, 75.0), (15.0, 15.0), (1000.0, 75.0), (0.6, 0.6)])
def test_the_time_search_goes_past_its_longest_time_while_the_evidence_rises(monkeypatch, peak_s, expected_s):
    """The velocity correlation time of the most evident candidate, the evidence peaked at ``peak_s``
    (base 0.6 s): the fixed candidates (0.12, 0.6, 3 s), then 15, 75 s (5 times at a time, up to
    125 times the base) while the longest is the most evident and the evidence rises."""
    from types import SimpleNamespace

    from casrecon.estimation.error_models import error_model_sigma as ems
    from casrecon.estimation.error_models.gps_error_sigma import GROUPS

    tried = []

    def fake_evaluated(build, candidates, start=None):
        out = []
        for length, times in candidates:
            tried.append(times[1])
            fun = np.log(times[1] / peak_s) ** 2 + np.log(times[0] / 100.0) ** 2  # -log Z
            out.append((fun, times, length, None, SimpleNamespace(x=np.zeros(len(GROUPS))), list(GROUPS)))
        return out

    monkeypatch.setattr(ems, "evaluated", fake_evaluated)
    errors = GpsErrorModel()
    own = (errors.position_time_s, errors.velocity_time_s)
    start = ems.most_evident(None, [(None, own)])
    tried.clear()
    best = ems.time_search(None, start, errors, own, own)
    assert best[1][0] == pytest.approx(100.0) and best[1][1] == pytest.approx(expected_s)
    # the longer times are searched (side by side) only where the longest fixed one wins
    longer = sorted(t for t in tried if t > 3.0 + 1e-9)
    assert longer == pytest.approx({75.0: [15.0, 75.0], 15.0: [15.0, 75.0], 1000.0: [15.0, 75.0], 0.6: []}[peak_s])
    from casrecon.estimation.error_models.profile_sigma import extension

    assert extension(5.0, 5.0, 125.0) == pytest.approx([25.0, 125.0])
    assert extension(10.0, 10 ** 0.5, 100.0) == pytest.approx([10 ** 1.5, 100.0])
    assert extension(10.0, 10.0, 50.0) == []


def test_a_refit_is_made_with_the_bounded_model_and_capped_at_the_configured_sizes():
    """The refit's GPS model is the bounded one (each size at the largest the data allow, at most
    the configured model's unless the most likely one is larger); whether a refit is needed is
    judged on it, so a fit made at the bounds whose bounds agree stands even though its most
    likely model (white) differs."""
    from casrecon.estimation.error_models.error_model_sigma import configured_caps
    from casrecon.estimation.error_models.gps_error_sigma import GpsErrorEstimate, model_from, part_sigmas

    configured = GpsErrorModel()  # 99 % of the position variance correlated over 100 s, 70 % of the velocity's
    caps = configured_caps(configured, configured)
    assert caps == pytest.approx({g: 1.0 for g in caps})
    fitted = model_from(configured, {"gps position white": 10.0, "gps position correlated": 0.6})
    caps = configured_caps(configured, fitted)
    for g, (i, j) in {"gps position white": (0, 1), "gps position correlated": (0, 2)}.items():
        assert caps[g] == pytest.approx(part_sigmas(configured)[i, j] / part_sigmas(fitted)[i, j])
    assert configured_caps(configured, GpsErrorModel.white())["gps position correlated"] == np.inf
    white = model_from(fitted, {"gps position correlated": 0.005, "gps velocity correlated": 0.005})
    estimate = GpsErrorEstimate(fitted, white, {"gps position correlated": 0.005}, (), fitted,
                                {"gps position correlated": 1.0})
    assert estimate.refit_model is fitted and not estimate.refit
    assert "upper bounds" in estimate.text() and "position correlated x 1" in estimate.text()
    unbounded = GpsErrorEstimate(fitted, white, {"gps position correlated": 0.005})
    assert unbounded.refit_model is white and unbounded.refit
