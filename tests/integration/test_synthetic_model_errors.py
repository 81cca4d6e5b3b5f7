"""Synthetic data with the world not the model (issue 18): the truth flies the sounding plus a drawn
profile error while the fit keeps the sounding, the GPS errors are time-correlated with the stated
lag-1 autocorrelation, the default keys reproduce the data of the code before these errors existed
bit for bit, seeds are reproducible, and `simulate --data` records the drawn error.

Statistical checks: estimate within 4 of its standard errors (computed from the same sample).
"""

from __future__ import annotations

import dataclasses
import hashlib
import json

import casadi as ca
import numpy as np
import pandas as pd
import pymap3d
import pytest
from conftest import PROBLEMS

from casrecon.cli import main
from casrecon.io.truth_errors import TruthErrors
from casrecon.physics.dynamics import OUTPUT_NAMES
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import (
    COLD_START_FIXES,
    flown_scenario,
    make_synthetic,
    synthetic_scenario,
    truth_profile_error,
    with_synthetic_data,
)

N_SE = 4.0
MODEL_ERROR = PROBLEMS / "ees-drop-3-model-error"
#: sha256 of gps.csv and imu.csv that with_synthetic_data wrote for ees-drop-3 (seeds 3 and 0) and
#: ees-drop-1 (seed 1) on main at 4325714, before the model errors existed.
MAIN_SHA256 = {
    ("ees-drop-3", 3, "gps.csv"): "364e1038c900e6caf41930c4d1ae1842b2c351bfbd323b9543610a89ad04f640",
    ("ees-drop-3", 3, "imu.csv"): "1835f93edb62e8c02a0ca84404578c859f4a4c1b8f764bbc4df6b8ed899f06fd",
    ("ees-drop-3", 0, "gps.csv"): "ecb1856eb0564bb2071699fe9276200f57a4aedf359038d086260d0eac02f527",
    ("ees-drop-3", 0, "imu.csv"): "a0f971305bb704f30e1bd348743a9de33ef37296dc08d25f89422eb94b69e338",
    ("ees-drop-1", 1, "gps.csv"): "5f96cb9c7fd35209bdffcc176695defe8bc189a0c54fcee152d2e7982f75fb2b",
    ("ees-drop-1", 1, "imu.csv"): "a723ed981367740d8851ef4d705b1bba706ace510c7f351a3f5d03328136ed83",
}


def _with_errors(scenario: Scenario, **keys) -> Scenario:
    cfg = scenario.config
    truth = dataclasses.replace(cfg.truth, errors=dataclasses.replace(cfg.truth.errors, **keys))
    return Scenario.from_config(dataclasses.replace(cfg, truth=truth))


def _sha(path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.fixture(scope="module")
def model_error():
    """ees-drop-3-model-error simulated with its own seed, and the same without the profile error."""
    sc = Scenario.load(MODEL_ERROR)
    off = _with_errors(sc, profile_wind_sigma_mps=0.0, profile_density_sigma=0.0)
    return sc, make_synthetic(sc), make_synthetic(off)


@pytest.mark.parametrize("name, seed", [("ees-drop-3", 3), ("ees-drop-3", 0), ("ees-drop-1", 1)])
def test_default_keys_reproduce_the_data_of_main(tmp_path, name, seed):
    """White GPS noise and no profile error by default: gps.csv and imu.csv identical to those main
    wrote (its stored hashes; for the shipped seeds also the shipped files main wrote), and unchanged
    by the keys that only matter when a time or a sigma is non-zero."""
    sc = Scenario.load(PROBLEMS / name)
    assert sc.config.truth.errors == TruthErrors()
    variants = {"default": sc, "inert keys": _with_errors(sc, gps_white_fraction=0.5, profile_length_m=100.0)}
    for label, scenario in variants.items():
        out = tmp_path / label.replace(" ", "-")
        out.mkdir()
        with_synthetic_data(scenario, out, seed=seed)
        for file in ("gps.csv", "imu.csv"):
            assert _sha(out / file) == MAIN_SHA256[(name, seed, file)], (label, file)
            if seed == sc.config.truth.seed:
                assert (out / file).read_bytes() == (PROBLEMS / name / "data" / file).read_bytes(), (label, file)
        assert not (out / "truth_atmosphere_error.csv").exists()


def _outputs(model, traj, params: np.ndarray) -> np.ndarray:
    n = traj.states.shape[0]
    return np.asarray(model.outputs.map(n)(traj.states.T, np.tile(params[:, None], (1, n)))).T


def _wind(atmosphere, h: np.ndarray) -> np.ndarray:
    sym = ca.SX.sym("h")
    f = ca.Function("wind", [sym], [atmosphere.at(sym).wind_ned[:2]])
    return np.asarray(f.map(h.size)(h[None, :])).T


def test_truth_flies_the_perturbed_atmosphere(model_error):
    """The truth's outputs are those of the flown atmosphere (sounding plus the drawn error), not of
    the sounding: at the truth's own states the density it flew relative to the sounding's is 1 + e(h),
    and its airspeed is |v - (sounding wind + wind bias + wind error(h))|, with e and the wind error
    linearly interpolated from the recorded profile; both within a tenth of the error's own RMS
    (what remains is the flown interpolant's curvature between 10 m nodes against straight lines)."""
    sc, data, _ = model_error
    traj, err = data.trajectory, data.profile_error
    params = sc.truth_parameters()
    flown = _outputs(flown_scenario(sc, err).model, traj, params)
    sounding = _outputs(sc.model, traj, params)
    assert np.array_equal(flown, traj.outputs)
    col = OUTPUT_NAMES.index
    h = sc.config.site.ground_alt_msl_m + traj.output("h_agl")

    def rho(y):
        return 2 * y[:, col("qbar")] / y[:, col("airspeed")] ** 2

    e = np.interp(h, err.altitude_msl_m, err.density)
    mismatch = rho(flown) / rho(sounding) - 1 - e
    assert np.sqrt(np.mean(mismatch**2)) < 0.1 * np.sqrt(np.mean(e**2))
    bias = np.array(sc.config.truth.wind_bias_mps)
    wind_error = np.column_stack([np.interp(h, err.altitude_msl_m, err.wind_north_mps),
                                  np.interp(h, err.altitude_msl_m, err.wind_east_mps)])
    v = traj.states[:, 3:6].copy()
    v[:, :2] -= _wind(sc.atmosphere, h) + bias
    without = np.linalg.norm(v, axis=1)
    v[:, :2] -= wind_error
    predicted = np.linalg.norm(v, axis=1)
    airspeed = traj.output("airspeed")
    assert np.allclose(without, sounding[:, col("airspeed")], rtol=1e-12, atol=1e-9)
    rms = np.sqrt(np.mean((predicted - airspeed) ** 2))
    assert rms < 0.1 * np.sqrt(np.mean((without - airspeed) ** 2))


def test_imu_data_follow_the_flown_truth(model_error):
    """The accelerometer data in flight are the flown truth's specific force plus bias and white noise
    (mean square of the normalised residual 1 within 4 SE), not the sounding's at the same states
    (residual mean square larger by more than 4 SE); against the data of the same drop and seed
    without the profile error they differ by exactly the change of the true specific force (the
    accelerometer noise, drawn first, is the same)."""
    sc, data, off = model_error
    traj = data.trajectory
    dt_s = 1.0 / sc.config.imu.rate_hz
    t_zero = data.truth["release_imu_time_s"]
    k_fly = int(round((t_zero + traj.time_s[1]) / dt_s))
    rows = np.arange(k_fly, k_fly + traj.time_s.size - 2)
    assert data.imu_time_s[rows] - t_zero == pytest.approx(traj.time_s[1:-1], abs=1e-9)
    col = OUTPUT_NAMES.index
    meas = data.imu_accel_mps2[rows] - np.array(sc.config.truth.accel_bias_mps2)
    noise = sc.config.imu.accel_noise_mps2
    limits = np.array(sc.config.imu.spec.accel_limits)
    inside = np.all((data.imu_accel_mps2[rows] > limits[:, 0]) & (data.imu_accel_mps2[rows] < limits[:, 1]), axis=1)
    params = sc.truth_parameters()
    stats = {}
    for label, model in (("flown", flown_scenario(sc, data.profile_error).model), ("sounding", sc.model)):
        f = _outputs(model, traj, params)[1:-1, col("imu_fx"):col("imu_fz") + 1]
        z2 = (((meas - f) / noise) ** 2)[inside].ravel()
        stats[label] = (z2.mean(), z2.std(ddof=1) / np.sqrt(z2.size))
    mean, se = stats["flown"]
    assert abs(mean - 1.0) < N_SE * se, stats
    assert stats["sounding"][0] - 1.0 > N_SE * stats["sounding"][1], stats
    common = min(traj.time_s.size, off.trajectory.time_s.size) - 2      # in flight in both
    unclipped = inside[:common] & np.all((off.imu_accel_mps2[rows[:common]] > limits[:, 0])
                                         & (off.imu_accel_mps2[rows[:common]] < limits[:, 1]), axis=1)
    both = rows[:common][unclipped]
    fx = slice(col("imu_fx"), col("imu_fz") + 1)
    change = (traj.outputs[1:common + 1, fx] - off.trajectory.outputs[1:common + 1, fx])[unclipped]
    assert data.imu_accel_mps2[both] - off.imu_accel_mps2[both] == pytest.approx(change, abs=1e-12)
    assert np.sqrt(np.mean(change**2)) > 0.0


def test_fit_data_keep_the_sounding(model_error, tmp_path):
    sc, _, _ = model_error
    new, data = synthetic_scenario(sc, tmp_path, seed=4)
    assert new.config.atmosphere == sc.config.atmosphere
    for key, values in sc.atmosphere.levels.items():
        assert np.array_equal(new.atmosphere.levels[key], values), key
    assert data.profile_error is not None and new.config.gps.file == tmp_path / "gps.csv"


def test_seeds_reproducible(model_error):
    sc, data, _ = model_error
    again, other = make_synthetic(sc), make_synthetic(sc, seed=sc.config.truth.seed + 1)
    for a, b in ((data, again),):
        assert np.array_equal(a.imu_accel_mps2, b.imu_accel_mps2) and np.array_equal(a.imu_gyro_radps, b.imu_gyro_radps)
        assert np.array_equal(a.gps.lat_deg, b.gps.lat_deg) and np.array_equal(a.gps.vel_d_mps, b.gps.vel_d_mps)
        for f in ("altitude_msl_m", "wind_north_mps", "wind_east_mps", "density"):
            assert np.array_equal(getattr(a.profile_error, f), getattr(b.profile_error, f))
    assert not np.allclose(data.profile_error.wind_north_mps, other.profile_error.wind_north_mps)
    assert not np.array_equal(data.gps.lat_deg, other.gps.lat_deg)
    profile = truth_profile_error(sc)
    assert np.array_equal(profile.density, data.profile_error.density)


def test_coloured_gps_leaves_the_imu_and_accuracies_alone():
    """The correlated GPS part has its own stream: the IMU data and the reported accuracies of a seed
    do not change when the GPS errors are coloured, the GPS errors do."""
    sc = Scenario.load(PROBLEMS / "ees-drop-3")
    white, coloured = make_synthetic(sc), make_synthetic(_with_errors(sc, gps_position_time_s=20.0,
                                                                         gps_velocity_time_s=2.0))
    assert np.array_equal(white.imu_accel_mps2, coloured.imu_accel_mps2)
    assert np.array_equal(white.imu_gyro_radps, coloured.imu_gyro_radps)
    assert np.array_equal(white.gps.h_acc_m, coloured.gps.h_acc_m) and np.array_equal(white.gps.s_acc_mps,
                                                                                        coloured.gps.s_acc_mps)
    assert not np.array_equal(white.gps.lat_deg, coloured.gps.lat_deg)


@pytest.fixture(scope="module")
def long_track():
    """ees-drop-3 with 20 000 s of GPS fixes before release (100 000 fixes at 5 Hz with the helicopter at the
    release velocity), position errors correlated over 20 s and velocity errors over 2 s."""
    sc = Scenario.load(MODEL_ERROR)
    cfg = sc.config
    sc = Scenario.from_config(dataclasses.replace(cfg, simulation=dataclasses.replace(cfg.simulation,
                                                                                      pre_release_s=20000.0)))
    return sc, make_synthetic(sc)


def _normalised_gps_errors(sc: Scenario, data) -> tuple[np.ndarray, float]:
    """(written fix - true antenna) / stated sigma, N, E, D position and velocity, of the fixes before
    release; and their spacing, s."""
    cfg, gps, traj = sc.config, data.gps, data.trajectory
    t = gps.time_unix_s - cfg.release.time_utc.timestamp()
    before = t < 0
    col = OUTPUT_NAMES.index
    ant = traj.outputs[0, col("gps_n"):col("gps_vd") + 1]
    truth = np.column_stack([ant[:3] + np.outer(t[before], ant[3:]), np.tile(ant[3:], (before.sum(), 1))])
    site = cfg.site
    n, e, d = pymap3d.geodetic2ned(gps.lat_deg[before], gps.lon_deg[before], gps.h_msl_m[before], site.lat_deg,
                                   site.lon_deg, site.ground_alt_msl_m)
    meas = np.column_stack([n, e, d, gps.vel_n_mps[before], gps.vel_e_mps[before], gps.vel_d_mps[before]])
    sigma = np.column_stack([gps.h_acc_m, gps.h_acc_m, gps.v_acc_m, gps.s_acc_mps, gps.s_acc_mps,
                             gps.s_acc_mps])[before]
    return (meas - truth) / sigma, float(np.median(np.diff(t[before])))


def test_gps_errors_have_the_stated_lag1_autocorrelation(long_track):
    """Over 100 000 pre-release fixes the normalised errors of each group (position N, E, D pooled;
    velocity pooled) have lag-1 autocorrelation phi = exp(-0.2 s / tau) (least squares of z_k+1 on
    z_k, standard error sqrt((1 - phi^2) / sum z_k^2)) and unit mean square (AR(1) standard error
    sqrt(2 (1 + phi^2) / ((1 - phi^2) N)))."""
    sc, data = long_track
    z, dt_s = _normalised_gps_errors(sc, data)
    assert z.shape[0] == 100_000 + COLD_START_FIXES and dt_s == pytest.approx(0.2, abs=1e-6)
    errors = sc.config.truth.errors
    for cols, tau in ((slice(0, 3), errors.gps_position_time_s), (slice(3, 6), errors.gps_velocity_time_s)):
        phi = np.exp(-dt_s / tau)
        x = z[:, cols]
        r1 = np.sum(x[:-1] * x[1:]) / np.sum(x[:-1] ** 2)
        assert abs(r1 - phi) < N_SE * np.sqrt((1 - phi**2) / np.sum(x[:-1] ** 2)), (tau, r1, phi)
        mean_square = np.mean(x**2)
        assert abs(mean_square - 1.0) < N_SE * np.sqrt(2 * (1 + phi**2) / ((1 - phi**2) * x.size)), (tau, mean_square)


def test_simulate_data_records_the_drawn_error(tmp_path, model_error):
    """`casrecon simulate --data` writes truth_atmosphere_error.csv (the drawn error, 9 significant
    digits) beside truth.json, the original sounding as sounding.csv, and the shipped example's data
    are what the current code makes."""
    sc, data, _ = model_error
    out = tmp_path / "sim"
    assert main(["simulate", str(MODEL_ERROR), "--data", "--every", "10", "--quiet", "--out", str(out)]) == 0
    table = pd.read_csv(out / "truth_atmosphere_error.csv")
    assert list(table.columns) == ["altitude_msl_m", "wind_north_error_mps", "wind_east_error_mps", "density_error"]
    err = data.profile_error
    for column, values in zip(table.columns, (err.altitude_msl_m, err.wind_north_mps, err.wind_east_mps,
                                              err.density), strict=True):
        assert table[column].to_numpy() == pytest.approx(values, rel=1e-8, abs=1e-12), column
    assert (out / "sounding.csv").read_bytes() == (PROBLEMS / "ees-drop-3" / "sounding.csv").read_bytes()
    truth = json.loads((out / "truth.json").read_text())
    assert truth["model_errors"] == dataclasses.asdict(sc.config.truth.errors)
    for file in ("gps.csv", "imu.csv", "truth_atmosphere_error.csv", "truth.json"):
        assert (out / file).read_bytes() == (MODEL_ERROR / "data" / file).read_bytes(), file
