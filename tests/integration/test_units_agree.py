"""Issue 52: one shipped problem of each kind fitted and saved (8 s of the EES drop 1 in 6-DOF, the
FS1 Byron track as a point mass, 15 s of the Chicago jump kinematically): every angle and rate,
column and parameter, leaves in degrees; every kind names its time columns alike (``time_unix_s``
and ``utc`` on UTC clocks, ``flight_time_s`` since release where there is one, ``segment_time_s``
since the first row where there is none) and they agree with each other; latitude, longitude and
h_MSL carry 3-sigma bands; the 6-DOF trajectory has airspeed and speed with 3-sigma.

About 5 s (6-DOF), 5 s (point mass) and 15 s (kinematic) of fitting on the 2-core machine.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from conftest import PROBLEMS, chicago_kinematic_15s, short_window

import casrecon
from casrecon.io.units import OUTPUT_UNITS, unit_of

#: The time columns a results table may have, the same names in every kind (:mod:`casrecon.io.units`).
TIME_NAMES = {"time_imu_s", "flight_time_s", "segment_time_s", "time_unix_s", "utc"}
#: Column names that hold an angle or an angular rate (Euler and flow angles, attitude bands,
#: body rates, latitude and longitude, gyro residuals and noise).
ANGLE_WORDS = ("roll", "pitch", "yaw", "alpha", "beta", "att_", "latitude", "longitude", "p_", "q_", "r_", "wx_",
               "wy_", "wz_")
#: Mean meridian and equatorial radius (m): latitude and longitude bands against the NED ones.
RADIUS_M = 6_371_000.0


@pytest.fixture(scope="module")
def folders(tmp_path_factory) -> dict[str, tuple[Path, object]]:
    tmp = tmp_path_factory.mktemp("units-agree")
    fits = {"6-DOF": casrecon.fit(short_window("ees-drop-1", 3.0, 8.0)),
            "point-mass": casrecon.fit(PROBLEMS / "realdata-fs1-byron"),
            "kinematic": casrecon.fit(chicago_kinematic_15s(tmp))}
    return {kind: (fit.save(tmp / kind.replace("-", "")), fit) for kind, fit in fits.items()}


def csv_headers(folder: Path) -> dict[str, list[str]]:
    return {p.name: p.read_text().split("\n", 1)[0].split(",") for p in sorted(folder.glob("*.csv"))}


@pytest.mark.parametrize("kind", ["6-DOF", "point-mass", "kinematic"])
def test_every_angle_and_rate_column_and_parameter_is_in_degrees(folders, kind):
    folder, fit = folders[kind]
    for name, header in csv_headers(folder).items():
        for column in header:
            base = column.removesuffix("_3sigma")
            if base.startswith(ANGLE_WORDS):  # in degrees, or normalised (``_z``) or a flag (``_used``)
                assert unit_of(column) in ("deg", "deg/s", "-"), (name, column)
    params = json.loads((folder / "parameters.json").read_text())["parameters"]
    assert params
    for name, record in params.items():
        assert record["unit"] not in OUTPUT_UNITS, (kind, name, record["unit"])  # no rad, no rad/s
        if name.startswith("gyro_bias"):
            assert record["unit"] == "deg/s"
        if "misalignment" in name:
            assert record["unit"] == "deg"
    for name in fit.params:
        assert fit.params[name].unit not in OUTPUT_UNITS, (kind, name)
    if kind == "kinematic":
        # the values themselves: the estimator's rad/s in deg/s, in the file, the API and the report
        raw = fit.fit
        i = raw.params.names.index("gyro_bias_z")
        assert params["gyro_bias_z"]["value"] == pytest.approx(np.degrees(raw.values[i]), rel=1e-12)
        assert params["gyro_bias_z"]["sigma"] == pytest.approx(np.degrees(raw.sigma[i]), rel=1e-12)
        assert fit.params["gyro_bias_z"].value == params["gyro_bias_z"]["value"]
        assert fit.params["gyro_bias_z"].unit == "deg/s"
        line = next(ln for ln in fit.report().splitlines() if ln.startswith("    gyro_bias_z:"))
        assert "[deg/s]" in line and f"{np.degrees(raw.values[i]): .6g}" in line


@pytest.mark.parametrize("kind", ["6-DOF", "point-mass", "kinematic"])
def test_time_columns_have_one_name_per_quantity_and_agree(folders, kind):
    folder, fit = folders[kind]
    for name, header in csv_headers(folder).items():
        times = [c for c in header if c.endswith("time_s") or c in ("utc", "clock_s")]
        assert set(times) <= TIME_NAMES, (kind, name, times)
    tr = pd.read_csv(folder / "trajectory.csv", parse_dates=["utc"])
    # every kind here is on a UTC clock: time_unix_s and utc are there and are the same instants
    seconds = (tr["utc"] - pd.Timestamp("1970-01-01", tz="UTC")).dt.total_seconds()
    np.testing.assert_allclose(seconds, tr["time_unix_s"], rtol=0, atol=1e-6)
    if kind == "6-DOF":
        release = json.loads((folder / "summary.json").read_text())["clock"]["release_time_unix_s"]
        np.testing.assert_allclose(tr["flight_time_s"], tr["time_unix_s"] - release, rtol=0, atol=2e-6)
        assert "segment_time_s" not in tr
    else:
        assert "flight_time_s" not in tr and tr["segment_time_s"].iloc[0] == 0.0
        np.testing.assert_allclose(tr["segment_time_s"], tr["time_unix_s"] - tr["time_unix_s"].iloc[0], rtol=0,
                                   atol=2e-6)
        # the old name samples the same axis
        t = float(tr["segment_time_s"].iloc[-1]) / 2
        column = "vel_d_mps"
        assert fit.sample(column, t, time="time_s")[column].equals(fit.sample(column, t)[column])
    for name, table in fit.tables.items() if hasattr(fit, "tables") else ():
        assert not {"time_s", "clock_s"} & set(table.columns), name


@pytest.mark.parametrize("kind", ["6-DOF", "point-mass", "kinematic"])
def test_every_kind_writes_one_report_style_and_fit_report_is_report_txt(folders, kind):
    """Issue 52: report.txt of every kind starts with [[Fit Statistics]], [[Variables]] (value, 1- and
    3-sigma named) and [[Correlations]], then the kind's own sections and the verdict last; the API's
    fit_report() is that text, fresh and loaded."""
    folder, fit = folders[kind]
    text = (folder / "report.txt").read_text().rstrip("\n")
    loaded = casrecon.load_results(folder)
    assert fit.fit_report() == fit.report() == text == loaded.fit_report() == loaded.report()
    lines = text.splitlines()
    titles = [ln.split("]]")[0] + "]]" for ln in lines if ln.startswith("[[")]
    assert titles[:3] == ["[[Fit Statistics]]", "[[Variables]]", "[[Correlations]]"]
    assert titles[-1] == "[[Model adequacy]]" and lines[-1] == f"    VERDICT: {fit.adequacy.line}"
    assert len(titles) > 4  # the kind's own sections
    assert f"    reduced chi-square = {fit.redchi:.6g}" in lines and f"    iterations         = {fit.nfev}" in lines
    variables = lines[lines.index(next(ln for ln in lines if ln.startswith("[[Variables]]"))) + 1:]
    for name in fit.params:
        p = fit.params[name]
        line = next(ln for ln in variables if ln.startswith(f"    {name}:"))
        if p.fixed:
            assert line.endswith(f" {p.value: .6g} (fixed) [{p.unit}]"), line
        else:
            assert f" {p.value: .6g} +/- {p.stderr:.4g} (1-sigma), +/- {3 * p.stderr:.4g} (3-sigma) [{p.unit}]" in line
    # other correlation limits change the list, not the rest
    fewer = fit.fit_report(min_correl=0.999, max_correl=1)
    assert fewer.split("[[Correlations]]")[0] == text.split("[[Correlations]]")[0]
    assert fewer.split("\n[[", 3)[-1] == text.split("\n[[", 3)[-1]


def test_kinematic_residual_files_have_the_time_columns_of_the_other_kinds(folders):
    """Issue 52: residuals_gps.csv of a kinematic fit had no time column; now both residual files
    have the clock (``time_unix_s`` here, a UTC clock) and ``segment_time_s``, as a point-mass fit's."""
    folder, fit = folders["kinematic"]
    tr = pd.read_csv(folder / "trajectory.csv")
    for name in ("residuals_imu.csv", "residuals_gps.csv"):
        res = pd.read_csv(folder / name)
        assert [c for c in res.columns if c in TIME_NAMES] == ["time_unix_s", "segment_time_s"], name
        np.testing.assert_allclose(res["segment_time_s"], res["time_unix_s"] - tr["time_unix_s"].iloc[0], rtol=0,
                                   atol=2e-6)
        assert res["segment_time_s"].is_monotonic_increasing and res["segment_time_s"].iloc[0] >= 0.0
    # every interval residual is at its start node; the nodes sit on the fixes: every fix residual at a node
    imu = pd.read_csv(folder / "residuals_imu.csv")
    np.testing.assert_allclose(imu["segment_time_s"], tr["segment_time_s"].iloc[:-1], rtol=0, atol=1e-6)
    gps = pd.read_csv(folder / "residuals_gps.csv")
    gap = np.abs(gps["segment_time_s"].to_numpy()[:, None] - tr["segment_time_s"].to_numpy()[None, :]).min(axis=1)
    assert gap.max() < 1e-6 and len(gps) > 100
    assert {"time_unix_s", "segment_time_s"} <= set(fit.residuals["gps"].columns)


@pytest.mark.parametrize("kind", ["6-DOF", "point-mass", "kinematic"])
def test_geodetic_columns_have_three_sigma_bands(folders, kind):
    tr = pd.read_csv(folders[kind][0] / "trajectory.csv")
    np.testing.assert_array_equal(tr["h_msl_m_3sigma"], tr["pos_d_m_3sigma"])
    lat = np.radians(tr["latitude_deg"])
    np.testing.assert_allclose(np.radians(tr["latitude_deg_3sigma"]) * RADIUS_M, tr["pos_n_m_3sigma"], rtol=1e-2)
    np.testing.assert_allclose(np.radians(tr["longitude_deg_3sigma"]) * RADIUS_M * np.cos(lat),
                               tr["pos_e_m_3sigma"], rtol=1e-2)
    assert np.all(tr["latitude_deg_3sigma"] > 0)


def test_sixdof_trajectory_has_airspeed_and_speed_with_bands(folders):
    folder, fit = folders["6-DOF"]
    tr = pd.read_csv(folder / "trajectory.csv")
    speed = np.sqrt(tr["vel_n_mps"] ** 2 + tr["vel_e_mps"] ** 2 + tr["vel_d_mps"] ** 2)
    np.testing.assert_allclose(tr["speed_mps"], speed, rtol=1e-8)
    # the model's airspeed: the speed relative to the wind (a few m/s here) and the gusts
    assert 0.0 < np.max(np.abs(tr["airspeed_mps"] - tr["speed_mps"])) < 20.0
    for column in ("airspeed_mps", "speed_mps"):
        band = tr[f"{column}_3sigma"]
        assert np.all(np.isfinite(band)) and np.all(band > 0)
    # |v|'s band is the velocity's along v: between the smallest and largest component band
    vel = np.column_stack([tr[f"vel_{a}_mps_3sigma"] for a in "ned"])
    assert np.all(tr["speed_mps_3sigma"] <= vel.max(axis=1) * (1 + 1e-6))
    assert np.all(tr["speed_mps_3sigma"] >= vel.min(axis=1) * (1 - 1e-6) * 0.5)
    assert fit.sample("airspeed_mps", 5.0)["airspeed_mps_3sigma"].iloc[0] > 0


def test_sixdof_tables_name_the_body_rates_as_the_trajectory_does(folders):
    # tables.md labels the body rates p, q, r (trajectory.csv: p_dps, q_dps, r_dps), not the gyro's wx
    head = next(ln for ln in (folders["6-DOF"][0] / "tables.md").read_text().splitlines() if "phi, deg" in ln)
    assert "p, deg/s | q, deg/s | r, deg/s" in head and "wx" not in head
