"""Truth test of the GPS-only fit with an area process (``[model_error]``).

Truth: an 80 kg point mass (wind (2, -1) m/s, ICAO atmosphere) whose drag area is 0.25 m^2 times
exp(0.12 u) and whose horizontal lift areas north and east are 0.03 m^2 u (u first-order
Gauss-Markov processes of unit variance and correlation time 1 s: about 1.2 m/s^2 at its 80 m/s),
drawn at the 5 Hz fix epochs and linear between them (the fit's own model of them), RK4 on a 0.01 s grid, 40 s from
4000 m; FlySight 1 fixes with white noise from each fix's reported accuracy (about 1.5 m, 2.5 m,
0.3 m/s). The fit has a constant drag-area spline and no lift spline: the process carries all of it.

What is checked, on fixed seeds:
- the mean drag area, the wind and the node states against the truth (3 sigma);
- the fitted areas (constant plus process) against the drawn ones (3-sigma bands hold them at
  >= 97 % of node components; the process's own sigma is below its prior's, so the data did
  determine it);
- the adequacy tests run on the Kalman innovations (pointmass_innovations): for the right model
  each channel's reduced chi-square lies within 0.25 of 1 (about 5 sigma for 200 samples) and the
  verdict trusts the bands;
- the same data fitted without the area process (strong constraint): the verdict refuses
  its bands, which is what the process is there to fix.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from pointmass_truth import CDA, SIGMA_M2, TAU_S, WIND, write_problem

from casrecon.analysis.fit_adequacy import pointmass_adequacy
from casrecon.estimation.pointmass.fit import fit_point_mass
from casrecon.io.pointmass_problem import ModelErrorConfig, load_point_mass

SEEDS = (5, 6)


@pytest.fixture(scope="module", params=SEEDS)
def fitted(request, tmp_path_factory):
    path, truth, areas = write_problem(tmp_path_factory.mktemp(f"me{request.param}"), request.param, SIGMA_M2)
    cfg = load_point_mass(path)
    return cfg, fit_point_mass(cfg), truth, areas


def test_parameters_states_and_areas_within_their_sigmas(fitted):
    cfg, r, truth, areas = fitted
    assert cfg.model_error == ModelErrorConfig(SIGMA_M2 / CDA, SIGMA_M2, TAU_S)
    assert r.solver.converged, r.solver.status
    names = [s.name for s in r.params.specs]
    z = {k: (r.values[names.index(k)] - v) / r.sigma[names.index(k)]
         for k, v in (("CdA", CDA), ("wind_bias_n", WIND[0]), ("wind_bias_e", WIND[1]))}
    print("parameter z", {k: round(float(v), 2) for k, v in z.items()}, "sigma", np.round(r.sigma, 4))
    assert all(abs(v) < 3 for v in z.values()), z
    assert r.states.shape == truth.shape
    z_states = (r.states - truth) / r.state_sigma
    assert np.mean(np.abs(z_states) < 3) >= 0.98, np.mean(np.abs(z_states) < 3)
    assert r.areas.shape == areas.shape  # CdA and both lift areas, though the spline has no lift
    z_areas = (r.areas - areas) / r.area_sigma
    inside = np.mean(np.abs(z_areas) < 3, axis=0)
    print(f"areas inside 3 sigma at {np.round(inside, 3)} of nodes; median sigma "
          f"{np.round(np.median(r.area_sigma, axis=0), 4)} m^2; CdA RMS error "
          f"{np.sqrt(np.mean((r.cda - areas[:, 0]) ** 2)):.4f}")
    assert np.all(inside >= 0.97), inside
    np.testing.assert_allclose(r.areas[:, 0] - r.area_process[:, 0], r.values[names.index("CdA")])
    assert np.median(r.area_process_sigma) < 0.7 * SIGMA_M2


def test_innovations_are_white_and_the_verdict_trusts_the_right_model(fitted):
    _, r, _, _ = fitted
    verdict = pointmass_adequacy(r)
    for c in verdict.channels:
        print(f"{c.name}: reduced chi2 {c.reduced_chi2:.3f}, lag-1 {c.lag1:+.3f}, Ljung-Box p {c.ljung_box_p:.3g}")
        assert abs(c.reduced_chi2 - 1) < 0.25, c
    assert verdict.trusted, verdict.line


def test_strong_constraint_is_refused_on_the_same_data(tmp_path):
    path, _, _ = write_problem(tmp_path / "strong", SEEDS[0], SIGMA_M2)
    cfg = dataclasses.replace(load_point_mass(path), model_error=ModelErrorConfig())
    r = fit_point_mass(cfg)
    verdict = pointmass_adequacy(r)
    print(verdict.line)
    assert not verdict.trusted


def test_innovations_skip_missing_components_and_gaps(tmp_path, monkeypatch):
    """An NMEA-like track (no vertical velocity) with a 2 s run of fixes dropped by the quality rules:
    the filter predicts across the gap and leaves the missing values out; the verdict tests the five
    channels there are, and trusts the right model."""
    import casrecon.estimation.pointmass.fit as pmf
    from casrecon.io.flysight import read_flysight

    path, _, areas = write_problem(tmp_path / "nmea", SEEDS[0], SIGMA_M2)
    track = read_flysight(path.parent / "track.csv")
    h_acc = track.h_acc_m.copy()
    h_acc[50:60] = 50.0                      # above max_h_acc_m: dropped
    track = dataclasses.replace(track, vel_d_mps=np.full(track.n, np.nan), h_acc_m=h_acc)
    monkeypatch.setattr(pmf, "read_gps_track", lambda *args, **kw: track)
    r = fit_point_mass(load_point_mass(path))
    assert r.solver.converged, r.solver.status
    missing = np.isnan(r.whitened_residuals)
    assert missing[:, 5].all()                               # no vertical velocity anywhere
    assert missing[50:60, :5].all() and missing[0, :5].all()  # the gap, and the diffuse first fix
    # and the second fix's height: without a vertical velocity its prediction is still diffuse
    np.testing.assert_array_equal(missing[:, :5].sum(axis=0), [11, 11, 12, 11, 11])
    assert missing[1, 2]
    verdict = pointmass_adequacy(r)
    assert [c.name for c in verdict.channels] == ["GPS pos n", "GPS pos e", "GPS pos d", "GPS vel n", "GPS vel e"]
    assert verdict.trusted, verdict.line
    assert np.mean(np.abs((r.areas - areas) / r.area_sigma) < 3) >= 0.97
