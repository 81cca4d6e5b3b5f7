"""Report-ready results on real written folders (issue 15): every CSV column and JSON number names
its unit or is dimensionless by the stated list (:mod:`casrecon.io.units`); the trajectory's UTC,
latitude, longitude and h_MSL put the GPS antenna on the fixes the fit saw; the joint summary's
reduced chi-square is over the joint dof and each drop's over its own.

To stay cheap the 6-DOF fits use short windows (8 s of ees-drop-1, 6 s of ees-drop-1 and 6 s of
ees-drop-2 jointly): about 7 s and 17 s of solving here; the point-mass fit is FS1 Byron (~5 s).
"""

from __future__ import annotations

import json
import types
from pathlib import Path

import numpy as np
import pymap3d
import pytest
from conftest import PROBLEMS, short_window
from scipy.spatial.transform import Rotation

import casrecon
from casrecon.analysis.fit_products import fit_products
from casrecon.analysis.sensitivity_documents import design_document, fisher_document, profile_document
from casrecon.cli import main
from casrecon.cli_montecarlo import run_montecarlo_command
from casrecon.estimation.sixdof.joint import JointConfig, fit_joint
from casrecon.io.flysight import read_flysight
from casrecon.io.truth_trajectory import read_truth_trajectory
from casrecon.io.units import unit_of, unnamed_columns, unnamed_json_numbers
from casrecon.output.consistency import write_consistency
from casrecon.report.results_folder import read_csv
from casrecon.results.drop_fit import DropFit
from casrecon.results.joint_fit import JointFit
from casrecon.scenario import Scenario

#: Files ``casrecon simulate --data`` writes in the input formats the readers take (FlySight columns,
#: the problem's IMU column names, the sounding as given): their units are those formats'.
INPUT_FORMAT_FILES = {"imu.csv", "gps.csv", "baro.csv", "sounding.csv"}


@pytest.fixture(scope="module")
def drop_folder(tmp_path_factory) -> tuple[Path, DropFit]:
    fit = casrecon.fit(short_window("ees-drop-1", 3.0, 8.0))
    return fit.save(tmp_path_factory.mktemp("units") / "drop"), fit


@pytest.fixture(scope="module")
def joint_folder(tmp_path_factory) -> Path:
    drops = [short_window("ees-drop-1", 3.0, 6.0), short_window("ees-drop-2", 3.0, 6.0)]
    result = fit_joint(drops, JointConfig("pair", (PROBLEMS / "ees-drop-1", PROBLEMS / "ees-drop-2")))
    products = {d.scenario.config.name: fit_products(d) for d in result.drops}
    return JointFit.from_fit(result, products).save(tmp_path_factory.mktemp("units") / "joint")


@pytest.fixture(scope="module")
def pointmass_folder(tmp_path_factory) -> Path:
    return casrecon.fit(PROBLEMS / "realdata-fs1-byron").save(tmp_path_factory.mktemp("units") / "pm")


@pytest.fixture(scope="module")
def simulate_folder(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("units") / "sim"
    assert main(["simulate", str(PROBLEMS / "ees-drop-2"), "--out", str(out), "--data", "--every", "5"]) == 0
    return out


def unnamed(folder: Path) -> dict[str, list[str]]:
    """File (relative) -> its CSV columns or JSON numbers that name no unit; ``config/`` (the inputs
    and their resolved settings, named as in problem.toml) and the input-format files are left out."""
    out = {}
    for path in sorted(folder.rglob("*")):
        rel = path.relative_to(folder)
        if "config" in rel.parts or path.name in INPUT_FORMAT_FILES:
            continue
        if path.suffix == ".csv":
            bad = unnamed_columns(path.read_text().splitlines()[0].split(","))
        elif path.suffix == ".json":
            bad = unnamed_json_numbers(json.loads(path.read_text()))
        else:
            continue
        if bad:
            out[str(rel)] = bad
    return out


def test_the_rules_catch_names_without_units():
    # the pre-issue-15 names fail, so the folder tests below can fail
    assert unnamed_columns(["pos_n_residual", "wx_residual", "pos_n_sigma", "wind_bias_n", "time"]) == [
        "pos_n_residual", "wx_residual", "pos_n_sigma", "wind_bias_n", "time"]
    assert unnamed_json_numbers({"ax": 0.05, "mesh": {"intervals": 3}, "p": {"value": 1.0}}) == [
        "ax", "mesh.intervals", "p.value"]
    assert [unit_of(n) for n in ("wx_residual_dps", "pos_n_m_3sigma", "force_error_x_n", "cases_per_s", "CA_mult",
                                 "vel_d_mps", "qbar_pa")] == ["deg/s", "m", "N", "1/s", "-", "m/s", "Pa"]
    assert unit_of("wind_bias_n") is None and unit_of("utc").startswith("UTC")
    assert unit_of("Cm_best_fit_3sigma") == unit_of("CN_crossflow_reconstructed") == "-"  # aero_coefficients.csv
    # a record's unit names its numbers, a key on the path names the numbers below it, a units map its keys
    assert unnamed_json_numbers({"p": {"value": 1.0, "unit": "m/s"}, "flight_time_s": {"mean": 1.0},
                                 "parameters": {"wind_bias_n": 1.0}, "units": {"wind_bias_n": "m/s"}}) == []


def test_every_column_and_number_of_a_fit_names_its_unit(drop_folder):
    folder, fit = drop_folder
    names = {p.name for p in folder.iterdir()}
    assert {"trajectory.csv", "residuals_imu.csv", "residuals_gps.csv", "imu_sigma.json", "parameters.json",
            "summary.json", "gps_fixes.csv", "pitching_moment.csv", "cm_curves.csv", "reconciled.csv",
            "aero_coefficients.csv"} <= names
    assert unnamed(folder) == {}
    # the API holds the same names as the files
    for name, table in fit.tables.items():
        assert unnamed_columns(table.columns) == [], name
    # deg/s in, deg/s out: gyro noise (problem: 0.10 deg/s), gyro residuals and gyro biases
    sigma = json.loads((folder / "imu_sigma.json").read_text())
    assert sigma["wx_sigma_dps"] == pytest.approx(0.10) and sigma["ax_sigma_mps2"] == pytest.approx(0.05)
    gyro = read_csv(folder / "residuals_imu.csv")["wy_residual_dps"]
    assert 0.7 < np.std(gyro) / 0.10 < 1.3
    p = json.loads((folder / "parameters.json").read_text())["parameters"]["gyro_bias_y"]
    assert p["unit"] == "deg/s" and p["prior_sigma"] == pytest.approx(0.10)
    assert abs(p["value"] - 0.1061) < 3 * p["sigma"]  # [truth] gyro_bias_dps of ees-drop-1
    assert fit.params["gyro_bias_y"].unit == "deg/s" and "[deg/s]" in fit.report()


def test_every_column_and_number_of_a_joint_folder_names_its_unit(joint_folder):
    assert sorted(p.name for p in (joint_folder / "drops").iterdir()) == ["ees-drop-1", "ees-drop-2"]
    assert unnamed(joint_folder) == {}
    params = json.loads((joint_folder / "parameters.json").read_text())["parameters"]
    assert params["ees-drop-2.gyro_bias_x"]["unit"] == "deg/s" and params["CA_mult"]["shared"] is True


def test_every_column_and_number_of_a_point_mass_fit_names_its_unit(pointmass_folder):
    assert unnamed(pointmass_folder) == {}
    loaded = casrecon.load_results(pointmass_folder)
    assert loaded.sample("cda_m2", loaded.trajectory["time_unix_s"][3], time="time_unix_s")["cda_m2"][0] == \
        loaded.trajectory["cda_m2"][3]


def test_every_column_and_number_of_a_simulation_names_its_unit(simulate_folder):
    assert {"trajectory.csv", "summary.json", "truth.json"} <= {p.name for p in simulate_folder.iterdir()}
    assert unnamed(simulate_folder) == {}
    truth = json.loads((simulate_folder / "truth.json").read_text())
    assert truth["units"]["gyro_bias_z"] == "deg/s"
    assert truth["parameters"]["gyro_bias_z"] == pytest.approx(-0.1942)  # [truth] gyro_bias_dps of ees-drop-2


def test_simulated_trajectory_is_on_the_release_utc_and_site(simulate_folder):
    import pandas as pd

    tr = pd.read_csv(simulate_folder / "trajectory.csv", parse_dates=["utc"])
    # issue 52: the flight time has the name every kind gives it (casrecon/io/units.py), no alias
    assert [c for c in tr.columns if "time" in c] == ["flight_time_s", "time_unix_s"]
    pd.testing.assert_frame_equal(read_truth_trajectory(simulate_folder / "trajectory.csv"), tr)
    cfg = Scenario.load(PROBLEMS / "ees-drop-2").config
    assert tr["utc"].iloc[0] == pd.Timestamp(cfg.release.time_utc)
    np.testing.assert_allclose(tr["time_unix_s"] - tr["flight_time_s"], cfg.release.time_utc.timestamp(), atol=1e-6)
    lat, lon, h = pymap3d.ned2geodetic(tr["pos_n_m"], tr["pos_e_m"], tr["pos_d_m"], cfg.site.lat_deg,
                                       cfg.site.lon_deg, cfg.site.ground_alt_msl_m)
    np.testing.assert_allclose(tr["latitude_deg"], lat, rtol=0, atol=1e-8)
    np.testing.assert_allclose(tr["longitude_deg"], lon, rtol=0, atol=1e-8)
    np.testing.assert_allclose(tr["h_msl_m"], h, rtol=0, atol=1e-3)
    # within a few km of the site h_MSL is the ground altitude plus h_AGL, less the curvature drop
    assert np.all(np.abs(tr["h_msl_m"] - cfg.site.ground_alt_msl_m - tr["h_agl_m"]) < 0.1)


def test_monte_carlo_and_sensitivity_documents_name_their_units(tmp_path, drop_folder):
    out = tmp_path / "mc"
    assert run_montecarlo_command(PROBLEMS / "ees-drop-2", out, 3, 0, 1, None, figures=False, progress=False) == 0
    assert unnamed(out) == {}
    names = ("CA_mult", "wind_bias_n", "gyro_bias_x")
    cases = [{"index": i, "nees": 2.0 + i, "reduced_chi2": 1.0, "names": list(names), "error": [0.1, 0.2, 0.3],
              "sigma": [0.1, 0.1, 0.1]} for i in range(2)] + [{"index": 2, "failed": "did not converge"}]
    res = types.SimpleNamespace(cases=cases, n_params=3, nees_sum=5.0, interval=(1.2, 14.4), consistent=True,
                                failed=cases[2:])
    (tmp_path / "nees").mkdir()
    write_consistency(tmp_path / "nees", res, 12.5)
    assert unnamed(tmp_path / "nees") == {}
    fit = drop_folder[1].fit
    from casrecon.analysis.observability import Profile, fisher_directions

    fisher = fisher_document(fit.scenario.config.name, fisher_directions(fit), fit.params.specs)
    assert unnamed_json_numbers(fisher) == []
    profile = Profile("gyro_bias_x", np.linspace(0.001, 0.002, 3), np.array([9.0, 0.0, 9.0]), 0.0015, 0.0005,
                      (0.001, 0.002))
    doc = profile_document(profile, "rad/s")
    assert unnamed_json_numbers(doc) == [] and doc["unit"] == "deg/s"
    assert doc["estimate"] == pytest.approx(np.degrees(0.0015))
    design = {"parameter": "Cmq_mult", "pitch_rate": [(0.0, 0.1)], "altitude": [(800.0, 0.2)], "n_drops": [(1, 0.3)]}
    assert unnamed_json_numbers(design_document(design, "-")) == []


def interpolate(t: np.ndarray, grid: np.ndarray, values: np.ndarray) -> np.ndarray:
    return np.column_stack([np.interp(t, grid, values[:, k]) for k in range(values.shape[1])])


def check_geodetic_against_fixes(folder: Path, problem: str) -> float:
    """The written centre-of-mass latitude, longitude and h_MSL at each used fix's UTC, moved to the
    antenna by the written attitude, against the antenna the fit compared with that fix (the fix's
    own lat/lon/hMSL, converted by pymap3d here, minus its residual). Returns the largest miss, m."""
    cfg = Scenario.load(PROBLEMS / problem).config
    site, veh = cfg.site, cfg.vehicle
    tr = read_csv(folder / "trajectory.csv")
    res = read_csv(folder / "residuals_gps.csv")
    track = read_flysight(cfg.gps.file)
    idx = np.array([np.argmin(np.abs(track.time_unix_s - u)) for u in res["time_unix_s"]])
    assert np.all(np.abs(track.time_unix_s[idx] - res["time_unix_s"]) < 1e-3)  # each residual's own fix
    fix = np.column_stack(pymap3d.geodetic2ned(track.lat_deg[idx], track.lon_deg[idx], track.h_msl_m[idx],
                                               site.lat_deg, site.lon_deg, site.ground_alt_msl_m))
    model_antenna = fix - np.column_stack([res[f"pos_{c}_residual_m"] for c in "ned"])
    # the trajectory at the fixes' UTC: geodetic centre of mass, and the antenna lever arm rotated by
    # the attitude at the neighbouring nodes (interpolated as a vector: no Euler angles near gimbal lock)
    t = res["time_unix_s"]
    geo = interpolate(t, tr["time_unix_s"], np.column_stack([tr["latitude_deg"], tr["longitude_deg"], tr["h_msl_m"]]))
    cm = np.column_stack(pymap3d.geodetic2ned(geo[:, 0], geo[:, 1], geo[:, 2], site.lat_deg, site.lon_deg,
                                              site.ground_alt_msl_m))
    c_nb = Rotation.from_euler("ZYX", np.column_stack([tr["yaw_deg"], tr["pitch_deg"], tr["roll_deg"]]),
                               degrees=True).as_matrix()
    lever = c_nb @ veh.lever(veh.gps_position_m)
    antenna = cm + interpolate(t, tr["time_unix_s"], lever)
    miss = np.linalg.norm(antenna - model_antenna, axis=1)
    assert np.linalg.norm(veh.lever(veh.gps_position_m)) > 0.3  # the lever arm matters at 0.1 m
    assert np.median(np.linalg.norm(fix - model_antenna, axis=1)) > 0.5  # GPS noise: residuals are not ~0
    return float(miss.max())


def test_trajectory_geodetic_puts_the_antenna_on_the_fixes(drop_folder):
    miss = check_geodetic_against_fixes(drop_folder[0], "ees-drop-1")
    print(f"largest antenna miss {miss * 1000:.2f} mm")
    assert miss < 0.1


@pytest.mark.parametrize("drop", ["ees-drop-1", "ees-drop-2"])
def test_joint_drop_trajectory_geodetic_puts_the_antenna_on_the_fixes(joint_folder, drop):
    assert check_geodetic_against_fixes(joint_folder / "drops" / drop, drop) < 0.1


def test_trajectory_utc_is_the_gps_receiver_clock(drop_folder):
    import pandas as pd

    folder, fit = drop_folder
    summary = json.loads((folder / "summary.json").read_text())
    clock = summary["clock"]
    assert clock["clock_offset_s"] == fit.params["clock_offset_s"].value and clock["clock_offset_estimated"]
    tr = pd.read_csv(folder / "trajectory.csv", parse_dates=["utc"])
    utc0 = pd.Timestamp(clock["utc_at_imu_zero"]).timestamp()
    np.testing.assert_allclose(tr["time_unix_s"], utc0 + tr["time_imu_s"] + clock["clock_offset_s"], rtol=0,
                               atol=1e-6)
    seconds = (tr["utc"] - pd.Timestamp("1970-01-01", tz="UTC")).dt.total_seconds()
    np.testing.assert_allclose(seconds, tr["time_unix_s"], rtol=0, atol=1e-6)
    assert (fit.trajectory["utc"] == casrecon.load_results(folder).trajectory["utc"]).all()


def test_joint_folder_has_a_report_in_the_one_style(joint_folder):
    """Issue 52: a joint folder has report.txt (it had only the Markdown tables.md) in the report style of
    every kind, which the API's fit_report() gives back; so has each drop's folder."""
    text = (joint_folder / "report.txt").read_text().rstrip("\n")
    loaded = casrecon.load_results(joint_folder)
    assert loaded.fit_report() == loaded.report() == text
    lines = text.splitlines()
    titles = [ln.split("]]")[0] + "]]" for ln in lines if ln.startswith("[[")]
    assert titles == ["[[Fit Statistics]]", "[[Variables]]", "[[Correlations]]", "[[Solver]]", "[[Drops]]",
                      "[[Joint vs single-drop sigma]]", "[[Model adequacy]]"]
    assert lines[1] == "    fit                = pair (joint 6-DOF of 2 drops)"
    assert lines[-1] == f"    VERDICT: {loaded.adequacy.line}"
    p = loaded.params["CA_mult"]
    line = next(ln for ln in lines if ln.startswith("    CA_mult:"))
    assert f" {p.value: .6g} +/- {p.stderr:.4g} (1-sigma), +/- {3 * p.stderr:.4g} (3-sigma) [-]" in line
    assert any(ln.startswith("    ees-drop-2.gyro_bias_x:") and "[deg/s]" in ln for ln in lines)
    for name, drop in loaded.drops.items():
        assert drop.fit_report() == drop.report() == (joint_folder / "drops" / name / "report.txt").read_text().rstrip()
        assert drop.report().startswith(f"[[Fit Statistics]]\n    fit                = {name} (6-DOF)")


def test_joint_summary_reduced_chi2_is_over_the_joint_dof(joint_folder):
    s = json.loads((joint_folder / "summary.json").read_text())
    assert s["reduced_chi2"] == pytest.approx(s["chi2"] / s["dof"], rel=1e-12)
    drops = {name: json.loads((joint_folder / "drops" / name / "summary.json").read_text()) for name in s["drops"]}
    # the shared factors count once in the joint dof and in each drop's own
    assert s["dof"] == sum(d["dof"] for d in drops.values()) + (len(drops) - 1) * len(s["shared"])
    for name, d in drops.items():
        own = sum(d["chi2"].values())
        assert d["reduced_chi2"] == pytest.approx(own / d["dof"], rel=1e-12)
        assert d["chi2"] == s["chi2_per_drop"][name] and d["dof"] == s["dof_per_drop"][name]
        assert d["reduced_chi2"] == s["reduced_chi2_per_drop"][name]
    reduced = [d["reduced_chi2"] for d in drops.values()]
    assert reduced[0] != reduced[1] and s["reduced_chi2"] not in reduced
    # every residual is some drop's: the drops' chi-squares add up to the joint one
    assert sum(sum(d["chi2"].values()) for d in drops.values()) == pytest.approx(s["chi2"], rel=1e-9)
    loaded = casrecon.load_results(joint_folder)
    assert loaded.reduced_chi2 == s["reduced_chi2"] and set(loaded.drops) == set(drops)
    for name, drop in loaded.drops.items():
        assert drop.reduced_chi2 == drops[name]["reduced_chi2"]
