"""The GPS-only fit's GPS error model from the data ([gps] error_model_from_data;
casrecon.estimation.error_models.pointmass_gps_sigma): a synthetic track whose receiver reports accuracies twice
the errors it makes (Gauss-Markov errors at half the reported sizes), fitted with the right
correlation times and fractions at the reported sizes. The estimate must find the smaller sizes, the
refit must weigh the fixes accordingly, and its bands must still hold the truth."""

from __future__ import annotations

import dataclasses

import casadi as ca
import numpy as np
import pytest
from conftest import noisy_flysight_track, point_mass_flight, point_mass_toml

from casrecon.estimation.pointmass.fit import fit_point_mass
from casrecon.io.flysight import write_flysight1
from casrecon.io.pointmass_problem import load_point_mass
from casrecon.physics.atmosphere import Atmosphere
from casrecon.physics.dynamics import Site
from casrecon.physics.pointmass import PointMassModel
from casrecon.physics.sensor_errors import GpsErrorModel

SITE = Site(lat_deg=40.0, lon_deg=-105.0, ground_alt_msl_m=1500.0)
MASS_KG, CDA_M2, WIND = 80.0, 0.25, (2.0, -1.0)
RATE_HZ, DESCENT_S, T0_UNIX = 5.0, 30.0, 1717243200.0
#: The receiver's errors: Gauss-Markov as configured, at this fraction of its reported accuracies.
ERROR_SIZE = 0.5
MODEL = GpsErrorModel(position_time_s=20.0, velocity_time_s=1.0, position_fraction=0.9, velocity_fraction=0.7)


@pytest.fixture(scope="module")
def fits(tmp_path_factory):
    """(the fit with the configured model, the fit with the model from the data, the true states at
    the fit's nodes, the problem's configuration)."""
    model = PointMassModel(Atmosphere.standard(), SITE, MASS_KG)
    x0 = np.array([0.0, 0.0, -4000.0, 40.0, 0.0, 0.0])
    t_sim, x_sim = point_mass_flight(model, lambda t: ca.vertcat(CDA_M2, 0, 0), WIND, x0, DESCENT_S)
    every = int(round(1.0 / RATE_HZ / (t_sim[1] - t_sim[0])))
    t_desc, x_desc = t_sim[::every], x_sim[::every]
    # level flight before the exit, canopy after: the segment is found from the data
    t_pre = -np.arange(10, 0, -1) / RATE_HZ
    x_pre = x_desc[0] + t_pre[:, None] * np.r_[x_desc[0, 3:], 0, 0, 0][None, :]
    t_post = t_desc[-1] + np.arange(1, 11) / RATE_HZ
    v_post = np.array([2.0, -1.0, 8.0])
    x_post = np.column_stack([x_desc[-1, :3] + (t_post - t_desc[-1])[:, None] * v_post, np.tile(v_post, (10, 1))])
    t_rel, truth = np.r_[t_pre, t_desc, t_post], np.vstack([x_pre, x_desc, x_post])
    track = noisy_flysight_track(T0_UNIX + t_rel, truth, SITE, np.random.default_rng(5), ERROR_SIZE, MODEL)
    folder = tmp_path_factory.mktemp("pm-gps-sigma")
    write_flysight1(folder / "track.csv", track)
    text = point_mass_toml("gps-sigma", SITE, MASS_KG, "constant", "error_model_from_data = true\n", MODEL)
    (folder / "problem.toml").write_text(text)
    cfg = load_point_mass(folder)
    estimated = fit_point_mass(cfg)
    configured = fit_point_mass(dataclasses.replace(cfg, gps_error_model_from_data=False))
    idx = np.round((estimated.t_unix - T0_UNIX - t_rel[0]) * RATE_HZ).astype(int)
    return configured, estimated, truth[idx], cfg


def test_the_estimate_finds_the_receivers_smaller_errors_and_refits(fits):
    configured, estimated, _, _ = fits
    assert configured.config.gps_errors == MODEL
    final = estimated.config.gps_errors
    assert final != MODEL, "no refit was made"
    assert any("GPS error model the data say" in n for n in estimated.notes)
    # the velocity errors (150 fixes, 1 s correlation) size well; the position errors, correlated over 20 s
    # of a 30 s track, within a factor 1.6
    assert 0.35 < final.velocity_scale < 0.7
    assert ERROR_SIZE / 1.6 < final.position_scale < ERROR_SIZE * 1.6
    # the fixes weigh more: the wind bias and the drag area are determined better
    assert estimated.sigma[-1] < configured.sigma[-1]
    assert estimated.cda_sigma.mean() < configured.cda_sigma.mean()


def test_the_refits_bands_hold_the_truth(fits):
    _, estimated, truth, _ = fits
    z = np.abs(estimated.states - truth) / estimated.state_sigma
    assert np.mean(z < 3.0) >= 0.95, np.mean(z < 3.0, axis=0)
    z_wind = np.abs(estimated.values[-2:] - np.array(WIND)) / estimated.sigma[-2:]
    assert np.all(z_wind < 3.0), z_wind
    z_cda = abs(estimated.values[0] - CDA_M2) / estimated.sigma[0]
    assert z_cda < 3.0


def test_an_estimate_that_fails_leaves_the_configured_fit_and_says_why(fits, monkeypatch):
    from casrecon.estimation.error_models import pointmass_gps_sigma

    configured, _, _, cfg = fits

    def failing(result, times, search):
        raise ValueError("the fit's GPS error prior rows are not the Gauss-Markov chains rebuilt here")

    monkeypatch.setattr(pointmass_gps_sigma, "estimate_gps_model", failing)
    result = fit_point_mass(cfg)
    assert result.config.gps_errors == MODEL
    np.testing.assert_allclose(result.values, configured.values, rtol=1e-9, atol=1e-12)
    assert any("GPS error model not estimated from the data (the fit's GPS error prior rows" in n and
               "fitted with the configured one" in n for n in result.notes), result.notes
    assert result.timings["error_model_s"] == 0.0
