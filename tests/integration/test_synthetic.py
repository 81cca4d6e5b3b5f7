"""Synthetic data of ees-drop-1: clock grid, GPS noise against its reported accuracies, gyro
clipping, determinism and the truth file's parameter names."""

from __future__ import annotations

import json

import numpy as np
import pymap3d
import pytest
from conftest import PROBLEMS

from casrecon.cli import main
from casrecon.physics.aero import DISPERSION_NAMES
from casrecon.physics.rotations import dcm_body_to_ned
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import make_synthetic


def dcm_numpy(q: np.ndarray) -> np.ndarray:
    """(N, 3, 3) body-to-NED matrices of unit scalar-first quaternions (textbook formula)."""
    q0, q1, q2, q3 = q.T
    return np.stack([
        np.stack([1 - 2 * (q2**2 + q3**2), 2 * (q1 * q2 - q0 * q3), 2 * (q1 * q3 + q0 * q2)], -1),
        np.stack([2 * (q1 * q2 + q0 * q3), 1 - 2 * (q1**2 + q3**2), 2 * (q2 * q3 - q0 * q1)], -1),
        np.stack([2 * (q1 * q3 - q0 * q2), 2 * (q2 * q3 + q0 * q1), 1 - 2 * (q1**2 + q2**2)], -1)], 1)


@pytest.fixture(scope="module")
def drop1():
    sc = Scenario.load(PROBLEMS / "ees-drop-1")
    return sc, make_synthetic(sc)


def test_imu_on_its_500_hz_clock(drop1):
    sc, data = drop1
    t = data.imu_time_s
    assert t[0] == 0.0
    assert np.diff(t) == pytest.approx(0.002, abs=1e-12)
    assert data.imu_accel_mps2.shape == data.imu_gyro_radps.shape == (t.size, 3)
    # in-flight trajectory samples sit on the IMU grid: t_imu = t_flight + t_zero = k * 2 ms
    t_zero = data.truth["release_imu_time_s"]
    k = (data.trajectory.time_s[1:-1] + t_zero) / 0.002
    assert np.abs(k - np.round(k)).max() < 1e-6
    # the log spans pre-release (2.011 s), the flight and 2 s after impact
    assert t[-1] == pytest.approx(t_zero + data.trajectory.flight_time_s + 2.0, abs=0.005)


def test_gps_errors_match_reported_accuracies(drop1):
    sc, data = drop1
    cfg, traj, g = sc.config, data.trajectory, data.gps
    # truth antenna from the states: p_cm + C_nb r, v_cm + C_nb (w x r), r = antenna - CM
    r = np.asarray(cfg.vehicle.gps_position_m) - np.asarray(cfg.vehicle.cm_m)
    c = dcm_numpy(traj.states[:, 6:10])
    ant = np.hstack([traj.states[:, 0:3] + c @ r,
                     traj.states[:, 3:6] + np.einsum("nij,nj->ni", c, np.cross(traj.states[:, 10:13], r))])
    k = traj.time_s.size // 2  # the vectorised DCM agrees with the library's
    assert c[k] == pytest.approx(np.asarray(dcm_body_to_ned(traj.states[k, 6:10]), float), abs=1e-12)
    t = g.time_unix_s - cfg.release.time_utc.timestamp()
    fly = (t > 0) & (t < traj.flight_time_s)
    assert fly.sum() >= 195  # 40 s at 5 Hz
    truth = np.column_stack([np.interp(t[fly], traj.time_s, ant[:, i]) for i in range(6)])
    site = cfg.site
    n, e, d = pymap3d.geodetic2ned(g.lat_deg[fly], g.lon_deg[fly], g.h_msl_m[fly], site.lat_deg,
                                   site.lon_deg, site.ground_alt_msl_m)
    meas = np.column_stack([n, e, d, g.vel_n_mps[fly], g.vel_e_mps[fly], g.vel_d_mps[fly]])
    sigma = np.column_stack([g.h_acc_m, g.h_acc_m, g.v_acc_m, g.s_acc_mps, g.s_acc_mps, g.s_acc_mps])[fly]
    z = (meas - truth) / sigma
    # ~200 samples per axis: the sample std of unit normals has sd 1/sqrt(400) = 0.05, so
    # [0.8, 1.2] is a 4-sigma band; the mean (sd 0.07) must be within 0.3.
    std = z.std(axis=0)
    assert np.all((std > 0.8) & (std < 1.2)), std
    assert np.all(np.abs(z.mean(axis=0)) < 0.3), z.mean(axis=0)
    # in-flight accuracies are the nominal ones (+-10 % jitter), not the cold-start values
    assert np.all(np.abs(g.h_acc_m[fly] / cfg.gps.h_acc_m - 1) < 0.11)


def test_gps_fixes_on_whole_utc_multiples(drop1):
    _, data = drop1
    ms = np.round(data.gps.time_unix_s * 1000).astype(np.int64)
    assert np.all(ms % 200 == 0) and np.all(np.diff(ms) == 200)


def test_gyro_clipped_at_declared_limits(drop1):
    sc, data = drop1
    lo, hi = np.radians(np.array(sc.config.imu.spec.gyro_limits)).T
    w = data.imu_gyro_radps
    assert np.all(w >= lo - 1e-15) and np.all(w <= hi + 1e-15)
    clipped = np.isclose(w, hi, rtol=0, atol=1e-12) | np.isclose(w, lo, rtol=0, atol=1e-12)
    assert clipped[:, 1].sum() > 10  # drop 1's pitch rate reaches 167 deg/s > 157.4 deg/s
    # the truth did exceed the limit there (the clipping is not noise at the limit)
    assert np.degrees(np.abs(data.trajectory.outputs[:, 14]).max()) > 160.0


def test_truth_parameter_names(drop1):
    sc, data = drop1
    p = data.truth["parameters"]
    expected = {*DISPERSION_NAMES, "wind_bias_n", "wind_bias_e", "density_factor", "clock_offset_s", "downwash_mps",
                "sounding_shift_m", *(f"{s}_bias_{a}" for s in ("accel", "gyro") for a in "xyz")}
    assert set(p) == expected
    t = sc.config.truth
    assert p["CA_mult"] == 0.1641 and p["wind_bias_e"] == -0.6782 and p["clock_offset_s"] == -0.011
    # the truth file keeps the problem's units: gyro biases in deg/s, as [truth] gyro_bias_dps gives them
    assert p["gyro_bias_y"] == pytest.approx(0.1061) and data.truth["units"]["gyro_bias_y"] == "deg/s"
    assert data.truth["units"]["accel_bias_z"] == "m/s^2" and data.truth["units"]["CA_mult"] == "-"
    assert p["accel_bias_z"] == t.accel_bias_mps2[2]


def test_deterministic_files(tmp_path):
    # same seed -> byte-identical files; another seed -> different noise
    outs = [tmp_path / "a", tmp_path / "b", tmp_path / "c"]
    for out, seed in zip(outs, (None, None, 99), strict=True):
        args = ["simulate", str(PROBLEMS / "ees-drop-2"), "--out", str(out), "--data"]
        assert main(args + ([] if seed is None else ["--seed", str(seed)])) == 0
    for name in ("imu.csv", "gps.csv", "truth.json", "trajectory.csv", "sounding.csv"):
        assert (outs[0] / name).read_bytes() == (outs[1] / name).read_bytes(), name
    assert (outs[0] / "imu.csv").read_bytes() != (outs[2] / "imu.csv").read_bytes()
    assert json.loads((outs[2] / "truth.json").read_text())["seed"] == 99
