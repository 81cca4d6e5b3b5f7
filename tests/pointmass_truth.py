"""The area-process truth of the GPS-only fit's tests (integration and slow): a point mass whose
drag area is 0.25 m^2 times exp(0.12 u) and whose horizontal lift areas are 0.03 m^2 u (u unit
Gauss-Markov processes, 1 s), drawn at the 5 Hz fix epochs and linear between them (the fit's own
model of them), flown by RK4 on a 0.01 s grid for 40 s from 4000 m, and written as a FlySight 1
track with white noise and a problem.toml with the matching [model_error]."""

from __future__ import annotations

from pathlib import Path

import casadi as ca
import numpy as np
from conftest import noisy_flysight_track, point_mass_flight, point_mass_toml

from casrecon.io.flysight import iso_utc, write_flysight1
from casrecon.physics.atmosphere import Atmosphere
from casrecon.physics.dynamics import Site
from casrecon.physics.pointmass import PointMassModel
from casrecon.physics.sensor_errors import GpsErrorModel
from casrecon.simulation.model_errors import unit_gauss_markov

SITE = Site(lat_deg=40.0, lon_deg=-105.0, ground_alt_msl_m=1500.0)
MASS_KG, CDA, WIND = 80.0, 0.25, (2.0, -1.0)
SIGMA_M2, TAU_S = 0.03, 1.0
PERIOD_S, DESCENT_S, DT_S = 0.2, 40.0, 0.01
T0_UNIX = 1717243200.0


def simulate(seed: int) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(fix times from release, true states at them (K, 6), true areas CdA, AN, AE at them (K, 3))."""
    rng = np.random.default_rng(seed)
    model = PointMassModel(Atmosphere.standard(), SITE, MASS_KG)
    k = int(round(DESCENT_S / PERIOD_S)) + 1
    t_fix = PERIOD_S * np.arange(k)
    u = unit_gauss_markov(t_fix, TAU_S, rng.standard_normal((k, 3)))  # unit processes, linear between fixes
    u_of_t = [ca.interpolant(f"u{c}", "linear", [t_fix], u[:, c]) for c in range(3)]

    uu = ca.SX.sym("u", 3)
    areas_of = ca.Function("areas", [uu], [ca.vertcat(CDA * ca.exp(SIGMA_M2 / CDA * uu[0]), SIGMA_M2 * uu[1],
                                                      SIGMA_M2 * uu[2])])
    x0 = np.array([0.0, 0.0, -4000.0, 40.0, 0.0, 0.0])
    _, states = point_mass_flight(model, lambda tt: areas_of(ca.vertcat(*[f(tt) for f in u_of_t])), WIND, x0,
                                  t_fix[-1], DT_S)
    every = int(round(PERIOD_S / DT_S))
    return t_fix, states[::every], np.array(areas_of.map(k)(u.T)).T


def write_problem(folder: Path, seed: int, sigma_m2: float,
                  gps_errors: GpsErrorModel | None = None) -> tuple[Path, np.ndarray, np.ndarray]:
    """problem.toml and FlySight 1 track of the seed's truth, the GPS errors white or drawn from
    ``gps_errors`` (and the fit told so); also the true states and areas."""
    t_fix, truth, areas = simulate(seed)
    rng = np.random.default_rng(seed + 1000)
    track = noisy_flysight_track(T0_UNIX + t_fix, truth, SITE, rng, correlated=gps_errors)
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
""", gps_errors))
    return folder / "problem.toml", truth, areas
