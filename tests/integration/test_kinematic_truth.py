"""Kinematic (IMU-driven) reconstruction of a synthetic EES drop against its truth (one case in the
default suite; the 10-case study at three IMU rates is tests/slow/test_kinematic_study.py), and the
`casrecon fit` command on a kinematic problem."""

import json
import re

import numpy as np
import pandas as pd
import pytest

from casrecon.analysis.estimator_mc import chi2_interval
from casrecon.analysis.kinematic_truth import truth_case
from casrecon.cli import main


def test_kinematic_fit_recovers_a_drawn_truth_at_100_hz():
    """ees-drop-1 with a truth drawn from the priors, its 500 Hz IMU decimated to 100 Hz: the fit
    converges, at least 95 % of the node values of position, velocity and attitude lie inside their
    3-sigma bands, so do the aerodynamic coefficients, alpha_T and qbar that acted (the truth
    database with the true dispersions and air) inside the implied ones' bands, and the NEES of the
    IMU biases and clock offset is below its 99.9 % quantile, and the adequacy verdict trusts the bands."""
    case = truth_case("problems/ees-drop-1", seed=7, index=0, steps=(5,))[5]
    assert "failed" not in case, case
    assert case["rate_hz"] == pytest.approx(100.0, rel=1e-6)
    for group, (inside, total) in case["coverage"].items():
        assert total > 500 and inside / total >= 0.95, (group, inside, total)
    # the aerodynamics the trajectory implies: the truth database's totals inside their bands
    assert set(case["aero_coverage"]) >= {"CA", "CN_crossflow", "Cm_crossflow", "alpha_t_deg", "qbar_pa"}
    for name, (inside, total) in case["aero_coverage"].items():
        assert total > 150 and inside / total >= 0.95, (name, inside, total)
    assert case["nees"] < chi2_interval(len(case["names"]), (0.001, 0.999))[1], case
    assert case["trusted"], "the adequacy verdict rejects an exact synthetic drop"
    assert 0.7 < case["reduced_chi2"] < 1.3


def test_cli_fits_the_chicago_skydive_kinematically(tmp_path):
    """The real FlySight 2 jump reconstructed from its own 13 Hz IMU: converges with the IMU, GPS
    and GPS error process residuals below their stated noise (reduced chi-square below 2), writes
    the folder; the canopy opening's samples, which the 13 Hz sampling does not resolve, are found
    and de-weighted with a note naming their times (issue 50), and with them every IMU bias and
    scale factor lies within 3 sigma of its prior (gyro scale z was at +5.9 sigma). The bands are
    still not called trustworthy: the GPS residuals stay correlated (the diver's manoeuvres)."""
    out = tmp_path / "out"
    assert main(["fit", "problems/realdata-fs2-chicago-kinematic", "--out", str(out), "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] and summary["kind"] == "kinematic"
    by_group = summary["reduced_chi2_by_group"]
    for group in ("imu", "gps", "gps_error"):
        assert by_group[group] < 2.0, (group, by_group)
    assert not summary["adequacy"]["trusted"]
    parameters = json.loads((out / "parameters.json").read_text())["parameters"]
    imu = {name: p["value"] / p["prior_sigma"] for name, p in parameters.items()
           if name.startswith(("gyro_bias", "accel_bias", "gyro_scale", "accel_scale"))}
    assert len(imu) == 12 and all(abs(z) <= 3.0 for z in imu.values()), imu
    report = (out / "report.txt").read_text()
    note = next(line for line in report.splitlines() if "whose rotation the sampling does not resolve" in line)
    times = [float(x) for x in re.findall(r"t = (\d+\.\d+) to (\d+\.\d+) s", note)[0]]
    assert 1726601160.0 < times[0] < times[1] < 1726601164.0, note  # the opening, 40 to 44 s into the span
    assert (out / "figures" / "kinematic.png").exists()
    tr = pd.read_csv(out / "trajectory.csv")
    assert np.all(np.isfinite(tr["vel_d_mps_3sigma"])) and tr["vel_d_mps"].max() > 120  # a 132 m/s dive


@pytest.mark.slow
def test_cli_fits_the_rocket_drogue_descent_kinematically(tmp_path):
    """The real rocket drogue descent (100 Hz IMU spinning at up to 20 rad/s, latitude/longitude
    fixes, barometer) reconstructed from its own IMU: converges, the IMU, GPS and barometer residuals
    are at their stated noise (reduced chi-square below 2 per group) and the descent rate is the
    drogue's 20 to 30 m/s."""
    out = tmp_path / "out"
    assert main(["fit", "problems/realdata-rocket-hedy-drogue", "--out", str(out), "--quiet", "--no-figures"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["converged"] and summary["kind"] == "kinematic"
    by_group = summary["reduced_chi2_by_group"]
    for group in ("imu", "gps", "baro"):
        assert by_group[group] < 2.0, (group, by_group)
    assert summary["reduced_chi2"] < 2.0
    tr = pd.read_csv(out / "trajectory.csv")
    late = tr[tr["segment_time_s"] > 70.0]
    assert late["vel_d_mps"].between(20.0, 30.0).all()
    assert np.all(np.isfinite(tr["att_d_deg_3sigma"]))
