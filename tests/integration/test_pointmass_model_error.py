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
from pathlib import Path

import numpy as np
import pytest
from conftest import noisy_flysight_track, point_mass_toml

from casrecon.analysis.fit_adequacy import pointmass_adequacy
from casrecon.estimation.pointmass_fit import fit_point_mass
from casrecon.io.flysight import iso_utc, write_flysight1
from casrecon.io.pointmass_problem import ModelErrorConfig, load_point_mass
from casrecon.physics.atmosphere import Atmosphere
from casrecon.physics.dynamics import Site
from casrecon.physics.pointmass import PointMassModel

SITE = Site(lat_deg=40.0, lon_deg=-105.0, ground_alt_msl_m=1500.0)
MASS_KG, CDA, WIND = 80.0, 0.25, (2.0, -1.0)
SIGMA_M2, TAU_S = 0.03, 1.0
PERIOD_S, DESCENT_S, DT_S = 0.2, 40.0, 0.01
T0_UNIX = 1717243200.0
SEEDS = (5, 6)


def simulate(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(fix times from release, true states at them (K, 6), true areas CdA, AN, AE at them (K, 3))."""
    rng = np.random.default_rng(seed)
    model = PointMassModel(Atmosphere.standard(), SITE, MASS_KG)
    k = int(round(DESCENT_S / PERIOD_S)) + 1
    phi = np.exp(-PERIOD_S / TAU_S)
    u = np.empty((k, 3))  # unit-variance processes at the fixes, linear between them
    u[0] = rng.standard_normal(3)
    for i in range(1, k):
        u[i] = phi * u[i - 1] + np.sqrt(1 - phi * phi) * rng.standard_normal(3)
    t_fix = PERIOD_S * np.arange(k)

    def areas_of(uu):
        return np.array([CDA * np.exp(SIGMA_M2 / CDA * uu[0]), SIGMA_M2 * uu[1], SIGMA_M2 * uu[2]])

    def f(x, t):
        uu = [np.interp(t, t_fix, u[:, c]) for c in range(3)]
        return np.asarray(model.rhs(x, areas_of(uu), WIND)).ravel()

    x = np.array([0.0, 0.0, -4000.0, 40.0, 0.0, 0.0])
    every = int(round(PERIOD_S / DT_S))
    states = [x]
    for step in range(every * (k - 1)):
        t = step * DT_S
        k1 = f(x, t)
        k2 = f(x + DT_S / 2 * k1, t + DT_S / 2)
        k3 = f(x + DT_S / 2 * k2, t + DT_S / 2)
        k4 = f(x + DT_S * k3, t + DT_S)
        x = x + DT_S / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if (step + 1) % every == 0:
            states.append(x)
    return t_fix, np.array(states), np.array([areas_of(uu) for uu in u])


def write_problem(folder: Path, seed: int, sigma_m2: float) -> tuple[Path, np.ndarray, np.ndarray]:
    """problem.toml and FlySight 1 track of the seed's truth; also the true states and areas."""
    t_fix, truth, areas = simulate(seed)
    rng = np.random.default_rng(seed + 1000)
    track = noisy_flysight_track(T0_UNIX + t_fix, truth, SITE, rng)
    folder.mkdir(parents=True, exist_ok=True)
    write_flysight1(folder / "track.csv", track)
    (folder / "problem.toml").write_text(point_mass_toml("model-error-truth", SITE, MASS_KG, "constant", f"""
[segment]
start_utc = "{iso_utc(T0_UNIX)}"
end_utc = "{iso_utc(T0_UNIX + t_fix[-1])}"

[model_error]
drag_area_fraction = {sigma_m2 / CDA}
lift_area_sigma_m2 = {sigma_m2}
time_s = {TAU_S}
"""))
    return folder / "problem.toml", truth, areas


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
