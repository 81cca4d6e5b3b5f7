"""Shared fixtures: paths, hand-made vehicles and atmospheres, and the shipped drops simulated once.

Simulations of whole drops are session-scoped so every test that needs one shares it; each takes
about 0.3 s at the problems' own 500 Hz settings.
"""

from __future__ import annotations

import dataclasses
import importlib.util
import json
import shutil
from pathlib import Path

import casadi as ca
import numpy as np
import pymap3d
import pytest

from casrecon.io.flysight import GpsTrack
from casrecon.physics.atmosphere import Atmosphere
from casrecon.physics.dynamics import Site
from casrecon.physics.pointmass import PointMassModel
from casrecon.physics.sensor_errors import GpsErrorModel
from casrecon.physics.vehicle import Vehicle
from casrecon.scenario import Scenario
from casrecon.simulation.model_errors import unit_gauss_markov
from casrecon.simulation.simulate import Simulator

REPO = Path(__file__).resolve().parents[1]
PROBLEMS = REPO / "problems"
#: Copies of ../shared/realdata (real measured files, licences and provenance README inside),
#: kept in the repository so the tests run on a fresh clone.
REALDATA_DIR = Path(__file__).resolve().parent / "data" / "realdata"
EES_DROPS = ("ees-drop-1", "ees-drop-2", "ees-drop-3", "ees-drop-4")
ALL_PROBLEMS = (*EES_DROPS, "davinci-ztu")

def short_window(name: str, start_s: float, length_s: float) -> Scenario:
    """A shipped EES drop fitted over ``length_s`` seconds from ``start_s`` after release."""
    sc = Scenario.load(PROBLEMS / name)
    flight = json.loads((PROBLEMS / name / "data" / "truth.json").read_text())["summary"]["flight_time_s"]
    est = dataclasses.replace(sc.config.estimation, start_after_release_s=start_s,
                              end_before_impact_s=flight - start_s - length_s)
    return Scenario.from_config(dataclasses.replace(sc.config, estimation=est))


#: A representative site (the UTTR point of the shipped problems).
UTTR = Site(lat_deg=40.19, lon_deg=-112.94, ground_alt_msl_m=1310.0)


def still_air(ground_msl_m: float = 1310.0, top_msl_m: float = 12000.0, **wind) -> Atmosphere:
    """An exponential-ish, windless (unless ``wind_north_mps``/``wind_east_mps`` given) atmosphere
    built directly from arrays: p falls 10 % per km from 86650 Pa, T falls 6.5 K/km from 284 K."""
    h = np.linspace(ground_msl_m, top_msl_m, 12)
    dz = (h - ground_msl_m) / 1000.0
    p = 86650.0 * 0.9**dz
    t = 284.0 - 6.5 * dz
    wn = np.full(h.size, float(wind.get("wind_north_mps", 0.0)))
    we = np.full(h.size, float(wind.get("wind_east_mps", 0.0)))
    return Atmosphere(h, p, t, wn, we)


def simple_vehicle(**kw) -> Vehicle:
    """A 100 kg axisymmetric body, everything on the x axis, IMU and GPS at the CM unless given."""
    base = dict(name="test body", mass_kg=100.0, inertia_kgm2=np.diag([10.0, 8.0, 8.0]),
                cm_m=(0.0, 0.0, 0.0), mrp_m=(0.0, 0.0, 0.0), ref_area_m2=1.2, ref_length_m=1.0)
    base.update(kw)
    return Vehicle(**base)


def sim_problem(scenario: Scenario, dt_s: float | None = None):
    """Simulate a scenario the way ``casrecon simulate`` does (its IMU rate and substeps)."""
    cfg = scenario.config
    dt = 1.0 / cfg.imu.rate_hz if dt_s is None else dt_s
    sim = Simulator(scenario.model, dt_s=dt, substeps=max(1, round(dt / cfg.simulation.dt_s)))
    return sim.run(scenario.release_state(), scenario.truth_parameters(), cfg.simulation.t_max_s)


@pytest.fixture(scope="session")
def ees_runs():
    """{drop name: (Scenario, Trajectory)} for the four EES drops, simulated once per session."""
    out = {}
    for name in EES_DROPS:
        sc = Scenario.load(PROBLEMS / name)
        out[name] = (sc, sim_problem(sc))
    return out


def script_module(path: Path):
    """The module of a script that is not in a package (a benchmark, a problems/tools script),
    imported from ``path`` under its file name."""
    spec = importlib.util.spec_from_file_location(Path(path).stem, path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


def chicago_kinematic_15s(folder: Path) -> Path:
    """The shipped Chicago kinematic problem cut to its first 15 s (exit and dive), written into
    ``folder``/chicago-15s with absolute data paths; returns that problem folder."""
    src = PROBLEMS / "realdata-fs2-chicago-kinematic" / "problem.toml"
    data = (PROBLEMS / "realdata-fs2-chicago").as_posix()
    text = src.read_text().replace("../realdata-fs2-chicago", data).replace("end_s = 1726601170.0",
                                                                              "end_s = 1726601135.0")
    assert data in text and "1726601135.0" in text
    problem = Path(folder) / "chicago-15s"
    problem.mkdir()
    (problem / "problem.toml").write_text(text)
    return problem


@pytest.fixture()
def problem_copy(tmp_path):
    """Copy of problems/ees-drop-1 (with vehicles/ and aero/ beside it, so relative paths work);
    returns the path of the copied problem.toml."""
    root = tmp_path / "problems"
    root.mkdir()
    shutil.copytree(PROBLEMS / "ees-drop-1", root / "ees-drop-1")
    shutil.copytree(PROBLEMS / "vehicles", root / "vehicles")
    shutil.copytree(PROBLEMS / "aero", root / "aero")
    return root / "ees-drop-1" / "problem.toml"


def noisy_flysight_track(t_unix: np.ndarray, truth: np.ndarray, site: Site, rng: np.random.Generator,
                         noise: float = 1.0, correlated: GpsErrorModel | None = None) -> GpsTrack:
    """A FlySight 1 track of the true NED antenna states ``truth`` (n, 6) at ``t_unix``: reported
    accuracies about 1.5 m (hAcc), 2.5 m (vAcc) and 0.3 m/s (sAcc), each +-20 % from fix to fix and
    rounded as the file keeps them, and noise drawn from each fix's own values (times ``noise``):
    white, or with ``correlated`` part white, part Gauss-Markov as that model says."""
    n = t_unix.size
    h_acc = np.round(1.5 * rng.uniform(0.8, 1.2, n), 3)
    v_acc = np.round(2.5 * rng.uniform(0.8, 1.2, n), 3)
    s_acc = np.round(0.3 * rng.uniform(0.8, 1.2, n), 2)
    sig = np.column_stack([h_acc, h_acc, v_acc, s_acc, s_acc, s_acc])
    unit = rng.standard_normal((n, 6))
    if correlated is not None:
        e = rng.standard_normal((n, 6))
        for cols, tau in ((slice(0, 3), correlated.position_time_s), (slice(3, 6), correlated.velocity_time_s)):
            if tau > 0:  # (a white component has no correlated fraction)
                e[:, cols] = unit_gauss_markov(t_unix, tau, e[:, cols])
        f = correlated.fraction
        unit = np.sqrt(1 - f) * unit + np.sqrt(f) * e
    meas = truth + noise * sig * unit
    lat, lon, h = pymap3d.ned2geodetic(meas[:, 0], meas[:, 1], meas[:, 2], site.lat_deg, site.lon_deg,
                                       site.ground_alt_msl_m)
    return GpsTrack("synthetic", "flysight1", np.asarray(t_unix, float), np.asarray(lat), np.asarray(lon),
                    np.asarray(h), meas[:, 3], meas[:, 4], meas[:, 5], h_acc, v_acc, s_acc,
                    np.full(n, 12, dtype=np.int64))


def point_mass_toml(name: str, site: Site, mass_kg: float, model: str, extra: str = "",
                    gps_errors: GpsErrorModel | None = None) -> str:
    """problem.toml text of a point-mass problem on the ICAO atmosphere whose track ``track.csv``
    has white GPS errors (or those of ``gps_errors``), drag ``model`` ("constant" or "spline"), then
    ``extra`` (more tables)."""
    g = gps_errors or GpsErrorModel.white()
    return f"""\
[problem]
kind = "point-mass"
name = "{name}"

[site]
lat_deg = {site.lat_deg}
lon_deg = {site.lon_deg}
ground_alt_msl_m = {site.ground_alt_msl_m}

[atmosphere]
sounding = "standard"

[vehicle]
mass_kg = {mass_kg}

[drag]
model = "{model}"

[gps]
file = "track.csv"
position_error_time_s = {g.position_time_s}
velocity_error_time_s = {g.velocity_time_s}
position_correlated_fraction = {g.position_fraction}
velocity_correlated_fraction = {g.velocity_fraction}
{extra}"""


def point_mass_flight(model: PointMassModel, areas_of_t, wind_mps, x0: np.ndarray, duration_s: float,
                      dt_s: float = 0.01) -> tuple[np.ndarray, np.ndarray]:
    """(t, X): RK4 of the point-mass ``rhs`` from ``x0`` (NED position, velocity) at t = 0 over
    ``duration_s``, every step in one casadi ``mapaccum``; ``areas_of_t(t)`` gives (CdA, AN, AE) in
    m^2 as a casadi 3-vector of the symbolic time t (s), ``wind_mps`` the wind bias (north, east)."""
    x, t = ca.SX.sym("x", 6), ca.SX.sym("t")
    wind = ca.DM(wind_mps)

    def f(xx, tt):
        return model.rhs(xx, areas_of_t(tt), wind)

    k1 = f(x, t)
    k2 = f(x + dt_s / 2 * k1, t + dt_s / 2)
    k3 = f(x + dt_s / 2 * k2, t + dt_s / 2)
    k4 = f(x + dt_s * k3, t + dt_s)
    step = ca.Function("rk4_step", [x, t], [x + dt_s / 6 * (k1 + 2 * k2 + 2 * k3 + k4)])
    n = int(round(duration_s / dt_s))
    states = np.array(step.mapaccum("flight", n)(x0, ca.DM(np.arange(n) * dt_s).T))
    return np.arange(n + 1) * dt_s, np.column_stack([x0, states]).T
