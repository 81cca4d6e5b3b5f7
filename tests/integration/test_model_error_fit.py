"""A drop whose air differs from its sounding (0.5 m/s, 0.5 %, 300 m) and whose GPS errors are
time-correlated (problems/ees-drop-3-model-error): the fit with the error models converges, and the
wind and density it reconstructs (sounding + bias + profile correction) hold the flown truth within
3 sigma at the grid levels."""

from __future__ import annotations

import json

import numpy as np
import pandas as pd
import pytest
from conftest import PROBLEMS

from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.scenario import Scenario

FOLDER = PROBLEMS / "ees-drop-3-model-error"


@pytest.fixture(scope="module")
def fit():
    return fit_drop(Scenario.load(FOLDER))


def test_converges_with_the_error_models(fit):
    assert fit.converged and fit.part.profile is not None and fit.part.extra("gps") is not None
    assert 0.98 < fit.reduced_chi2 < 1.06
    assert any("atmosphere-profile corrections" in n for n in fit.notes)
    assert any("GPS errors Gauss-Markov" in n for n in fit.notes)
    # the profile sigmas the data say are the configured ones within 25 %; the GPS errors' white
    # part is smaller than the problem's 1 % (the truth has none; the refit's model has each size at
    # the largest the data allow: the velocity's white part 0.8 %, measured 2026-12-05): one
    # refit, whose estimate agrees
    estimates = [n for n in fit.notes if "GPS error model the data say" in n]
    assert len(estimates) == 2 and "refitted" in estimates[0] and estimates[1].endswith("; no refit"), estimates
    assert "wind 0.5" in estimates[0] and "density 0.4" in estimates[0]
    model = fit.scenario.config.gps.error_model
    assert model.position_fraction > 0.99 and model.velocity_fraction > 0.99, model
    assert (model.position_time_s, model.velocity_time_s) == (20.0, 2.0)
    assert abs(model.position_scale - 1) < 0.1 and abs(model.velocity_scale - 1) < 0.1, model
    # the GPS altitude at the start is 12 m off the truth, beyond the profile windows' 10 m
    # tolerance: the windows are placed again by the fitted altitudes (which hold the truth)
    assert fit.solver.profile_placements >= 1
    assert any("placed again by the fitted altitudes" in n for n in fit.notes)


def reconstructed_air(fit):
    """Per corrected quantity (wind N, wind E, density): the fitted bias + correction at the grid
    levels, its 1-sigma (the covariance of the two included) and the flown truth there."""
    truth = json.loads((FOLDER / "data" / "truth.json").read_text())["parameters"]
    error = pd.read_csv(FOLDER / "data" / "truth_atmosphere_error.csv")
    grid, cols = fit.part.profile, fit.part.extra("profile").cols
    out = []
    for c, (name, bias) in enumerate(zip(("wind_north_error_mps", "wind_east_error_mps", "density_error"),
                                         ("wind_bias_n", "wind_bias_e", "density_factor"))):
        i = fit.params.index(bias)
        coefficient_cols = cols.reshape(grid.n_levels, grid.n_components)[:, c]
        level = grid.level_matrix()  # spline coefficients -> corrections at the levels
        values, sigmas = [], []
        for j in range(grid.n_levels):
            near = np.flatnonzero(level[j])
            cov = fit.covariance.covariance_of(np.r_[fit.part.theta_cols[i], coefficient_cols[near]],
                                               np.r_[fit.params.scales[i], grid.sigma[c] * level[j, near]])
            values.append(fit.values[i] + level[j, near] @ fit.z[coefficient_cols[near]] * grid.sigma[c])
            sigmas.append(np.sqrt(cov.sum()))
        flown = np.interp(grid.altitudes_msl_m, error["altitude_msl_m"], error[name]) + truth[bias]
        out.append((name, np.array(values), np.array(sigmas), flown))
    return out


def test_reconstructed_air_is_closer_to_the_flown_truth_than_the_sounding(fit):
    for name, values, _, flown in reconstructed_air(fit):
        rms_fit = np.sqrt(np.mean((values - flown) ** 2))
        assert rms_fit < 0.8 * np.sqrt(np.mean(flown**2)), name


def test_reconstructed_air_holds_the_flown_truth_within_3_sigma(fit):
    # was a strict xfail (3 to 5 sigma off at the lowest levels) while the corrections were linear
    # between levels on cells chosen by the guessed altitude (docs/design.md)
    for name, values, sigmas, flown in reconstructed_air(fit):
        z = (values - flown) / sigmas
        assert np.mean(np.abs(z) <= 3) >= 0.95, (name, np.abs(z).max())


def test_aero_factors_hold_the_truth_within_3_sigma(fit):
    truth = json.loads((FOLDER / "data" / "truth.json").read_text())["parameters"]
    for i, name in enumerate(fit.params.names):
        if name.endswith(("_mult", "_add")):
            assert abs(fit.values[i] - truth[name]) <= 3 * fit.sigma[i], name


def test_verdict_trusts_the_bands_with_the_gps_error_model_from_the_data(fit):
    """The simulated GPS errors are wholly Gauss-Markov while the problem's model keeps 1 % of each
    variance white. With the model as configured the whitened position innovations came out near
    half their sigma (a caution: "conservative"); with the GPS error model estimated from the data
    (the default) the white part goes and every test passes, no caution left."""
    from casrecon.analysis.fit_products import result_adequacy

    a = result_adequacy(fit)
    assert a.trusted and not a.reasons and not a.cautions, a.line
    assert a.line.startswith("bands can be trusted: all "), a.line
    for name in ("GPS pos n", "GPS pos e", "GPS pos d"):
        assert 0.7 < a.channel(name).reduced_chi2 < 1.4, a.channel(name)
    # the profile error the data say is the one flown (0.5 m/s, 0.5 m/s, 0.5 %), within a quarter
    names = [t.name for t in a.processes]
    assert names == ["profile wind n", "profile wind e", "profile density"]
    for t in a.processes:
        assert not (t.too_large or t.too_small), t
        assert 0.75 < t.estimated_sigma / 0.5 < 1.25, t


def test_profile_fit_of_exact_air_with_correlated_gps_converges(tmp_path):
    """A drop that flies its sounding exactly, with time-correlated GPS errors, fitted with the
    default error models (case 5 of an estimator study): with the Gauss-Newton Hessian Ipopt cycled
    for 200 iterations between objectives 14434 and 14444 without converging (it then continued
    with the exact Hessian after 80 iterations). The full-space Gauss-Newton solver, the default
    for profile fits since, converges on it by itself."""
    from dataclasses import replace

    from casrecon.analysis.estimator_mc import draw_truth, parameter_errors
    from casrecon.simulation.synthetic import synthetic_scenario, truth_parameters_by_name

    rng = np.random.default_rng([0, 5])
    cfg = draw_truth(Scenario.load(FOLDER), rng).config
    errors = replace(cfg.truth.errors, profile_wind_sigma_mps=0.0, profile_density_sigma=0.0)
    # the fit at the configured profile sigmas, as it was: no refit with the sizes the data say
    atmosphere = replace(cfg.atmosphere, profile_sigma_from_data=False)
    scenario = Scenario.from_config(replace(cfg, truth=replace(cfg.truth, errors=errors), atmosphere=atmosphere))
    scenario, _ = synthetic_scenario(scenario, tmp_path, seed=int(rng.integers(2**31)))
    r = fit_drop(scenario)
    assert r.converged and r.solver.method == "gauss-newton (full space)", (r.solver.method, r.solver.status)
    assert r.solver.iterations <= 30
    errors, _ = parameter_errors(r, truth_parameters_by_name(scenario))
    assert np.all(np.abs(errors / r.sigma) < 3.0), dict(zip(r.params.names, errors / r.sigma))
    # the air flown is the sounding: the verdict says the profile model is larger than the data show
    from casrecon.analysis.fit_products import result_adequacy

    a = result_adequacy(r)
    assert [t.too_small for t in a.processes] == [True, True, True], a.processes
    assert all(t.estimated_sigma < 0.5 * t.assumed_sigma for t in a.processes), a.processes
    assert "atmosphere profile smaller than assumed" in a.line
