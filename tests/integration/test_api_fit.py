"""The public API on a real fit: a folder written by ``casrecon fit --out`` loads into the same kind
of object as ``casrecon.fit`` returns, with full-precision correlations, and saves back unchanged."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from conftest import chicago_kinematic_15s

import casrecon
from casrecon.cli import main
from casrecon.estimation.engine.covariance import fisher_and_jacobian
from casrecon.estimation.kinematic.covariance import gauge_matrix

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="module")
def cli_folder(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("api") / "ees-drop-1"
    assert main(["fit", str(ROOT / "problems" / "ees-drop-1"), "--out", str(out), "--no-figures", "--quiet"]) == 0
    return out


def test_cli_folder_loads_with_exact_parameters(cli_folder, tmp_path):
    result = casrecon.load_results(cli_folder)
    assert isinstance(result, casrecon.DropFit) and result.converged
    doc = json.loads((cli_folder / "parameters.json").read_text())
    matrix = np.array(doc["correlation"]["matrix"])
    assert np.array_equal(result.params.correlation, matrix)
    assert np.any(np.round(matrix, 6) != matrix), "correlations are stored at full precision"
    for name, entry in doc["parameters"].items():
        p = result.params[name]
        assert (p.value, p.stderr, p.stderr_scaled, p.unit) == (entry["value"], entry["sigma"],
                                                                entry["sigma_chi2_scaled"], entry["unit"])
    assert set(result.residuals) >= {"imu", "gps"}
    assert result.report() == (cli_folder / "report.txt").read_text().rstrip("\n")
    assert result.chi2.keys() >= {"imu", "gps"} and result.reduced_chi2 == doc_summary(cli_folder)["reduced_chi2"]
    s = result.sample(["alpha_t_deg", "qbar_pa"], [1.0, 3.0])
    assert s.shape == (2, 5) and np.all(s["qbar_pa_3sigma"] > 0)
    again = casrecon.load_results(result.save(tmp_path / "copy"))
    assert again.params == result.params and again.trajectory.equals(result.trajectory)


def doc_summary(folder: Path) -> dict:
    return json.loads((folder / "summary.json").read_text())


def test_point_mass_fit_saves_and_loads(tmp_path):
    result = casrecon.fit(ROOT / "problems" / "realdata-fs1-byron")
    assert isinstance(result, casrecon.PointMassFit) and result.converged
    assert "cda_m2" in result.columns and dict(result.params[next(iter(result.params))].correl) == {}
    s = result.sample("cda_m2", [1.0, 5.0])
    assert list(s.columns) == ["segment_time_s", "cda_m2", "cda_m2_3sigma"] and np.all(s["cda_m2_3sigma"] > 0)
    folder = result.save(tmp_path / "pm")
    assert (folder / "trajectory.csv").is_file() and not (folder / "figures").exists()
    again = casrecon.load_results(folder)
    assert isinstance(again, casrecon.PointMassFit)
    assert again.params == result.params and again.trajectory.equals(result.trajectory)
    assert again.report() == result.report() and set(again.residuals) == {"gps"}


def test_kinematic_fit_saves_and_loads(tmp_path):
    """The IMU-driven reconstruction through the API (15 s of the real Chicago jump): records with
    correlations, sampling with the Euler angles unwrapped, save and load back unchanged."""
    result = casrecon.fit(chicago_kinematic_15s(tmp_path))
    assert isinstance(result, casrecon.KinematicFit) and result.converged
    assert result.adequacy is not None and "gps" in result.chi2
    bias = result.params["gyro_bias_z"]
    assert bias.stderr > 0 and bias.correl and abs(bias.correl["gyro_scale_z"]) <= 1.0
    s = result.sample(["vel_d_mps", "yaw_deg"], [1.0, 5.0])
    assert list(s.columns) == ["segment_time_s", "vel_d_mps", "vel_d_mps_3sigma", "yaw_deg"]
    assert np.all(s["vel_d_mps_3sigma"] > 0) and np.all(np.abs(s["yaw_deg"]) <= 180.0)
    with pytest.raises(ValueError, match="available: "):
        result.sample("alpha_t_deg", 1.0)
    # the node blocks of the selected inverse equal those of column solves (a pair of nodes far
    # apart is outside the band, so covariance_of solves for it), to the accuracy the matrix allows:
    # both are backward-stable solves with H + Q Q^T, whose forward error is bounded by eps times
    # its condition at unit diagonal (4.4e11 here: the IMU scale factors against the states; the
    # measured difference is 3.4e-6 relative, a wrong block would differ by order one)
    cov, cols = result.fit.covariance, result.fit.state_columns
    far = cov.covariance_of(np.r_[cols[0], cols[-1]])
    near = cov.blocks([cols[0], cols[-1]])
    h, _ = fisher_and_jacobian(result.fit.nlp, result.fit.z)
    aug = (h + gauge_matrix(result.fit.z, cov.gauge_columns, h.shape[0])[0]).toarray()
    unit = np.sqrt(np.diag(aug))
    bound = np.finfo(float).eps * np.linalg.cond(aug / np.outer(unit, unit))
    assert bound < 1e-3
    for block, ref in zip(near, (far[:10, :10], far[10:, 10:])):
        assert np.abs(block - ref).max() <= bound * np.abs(ref).max()
    folder = result.save(tmp_path / "kin")
    again = casrecon.load_results(folder)
    assert isinstance(again, casrecon.KinematicFit) and again.fit is None
    assert again.params == result.params and again.trajectory.equals(result.trajectory)
    assert again.report() == result.report() and set(again.residuals) == {"imu", "gps"}
    assert again.save(tmp_path / "kin-copy") and (tmp_path / "kin-copy" / "summary.json").is_file()
