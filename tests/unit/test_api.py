"""The public Python API on small synthetic results folders (no fit): Parameter records, sample(),
save/load round trip, clear errors, figures returned without a folder, cheap import."""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from matplotlib.figure import Figure

import casrecon
from casrecon.io.units import IMU_CHANNEL_UNITS, imu_residual_column, imu_sigma_key, utc_text
from casrecon.output.columns import write_table
from casrecon.output.results import write_json

NAMES = ("CA_mult", "Cmq_mult", "wind_bias_n")


def _corr(n: int, seed: int = 1) -> np.ndarray:
    a = np.random.default_rng(seed).normal(size=(n, n + 2))
    c = a @ a.T
    d = np.sqrt(np.diag(c))
    return c / np.outer(d, d)


def make_folder(folder: Path, n: int = 50) -> Path:
    """A per-drop results folder with the files a fit writes, from simple formulas."""
    folder.mkdir(parents=True)
    rng = np.random.default_rng(0)
    t_imu = np.linspace(3.0, 13.0, n)
    ft = t_imu - 2.0
    t_unix = 1696347130.25 + ft
    traj = {"time_imu_s": t_imu, "flight_time_s": ft, "time_unix_s": t_unix, "utc": utc_text(t_unix)}
    for name, values in (("h_agl_m", 400.0 - 35.0 * ft), ("vel_n_mps", 0 * ft), ("vel_e_mps", 0 * ft),
                         ("vel_d_mps", 35.0 + 0 * ft), ("alpha_t_deg", 10 + np.sin(ft)), ("qbar_pa", 700 + ft),
                         ("p_dps", np.cos(ft))):
        traj[name], traj[f"{name}_3sigma"] = values, 0.01 + 0.001 * ft
    write_table(folder / "trajectory.csv", traj)
    imu = {"time_imu_s": t_imu}
    imu.update({imu_residual_column(c): rng.normal(0, 0.01, n) for c in IMU_CHANNEL_UNITS})
    imu.update({f"{c}_used": np.ones(n) for c in IMU_CHANNEL_UNITS})
    write_table(folder / "residuals_imu.csv", imu)
    write_json(folder / "imu_sigma.json", {imu_sigma_key(c): 0.01 for c in IMU_CHANNEL_UNITS})
    sigma = rng.uniform(0.01, 0.1, len(NAMES))
    red = 1.0371
    write_json(folder / "parameters.json", {
        "parameters": {k: {"value": float(rng.normal()), "sigma": float(s), "three_sigma": 3 * float(s),
                           "sigma_chi2_scaled": float(s * np.sqrt(red)), "unit": "-", "group": "aero",
                           "prior_sigma": 1 / 3} for k, s in zip(NAMES, sigma)},
        "correlation": {"names": list(NAMES), "matrix": _corr(len(NAMES)).tolist()}})
    write_json(folder / "summary.json", {"problem": "synthetic", "converged": True, "release_imu_s": 2.0,
                                         "chi2": {"imu": 100.0, "gps": 20.0}, "reduced_chi2": red})
    (folder / "report.txt").write_text("[[Fit: synthetic]]\n")
    return folder


@pytest.fixture
def loaded(tmp_path):
    return casrecon.load_results(make_folder(tmp_path / "res"))


def test_parameter_records(loaded):
    params = loaded.params
    assert params.names == NAMES and list(params)[:len(NAMES)] == list(NAMES)
    assert all(params[n].fixed for n in list(params)[len(NAMES):])  # the dispersion factors held at 0
    p = params["Cmq_mult"]
    doc = json.loads((loaded.source / "parameters.json").read_text())
    entry = doc["parameters"]["Cmq_mult"]
    assert (p.name, p.value, p.stderr, p.unit, p.group) == ("Cmq_mult", entry["value"], entry["sigma"], "-", "aero")
    assert p.stderr_scaled == entry["sigma_chi2_scaled"]
    assert p.prior_sigma == 1 / 3 and p.three_sigma == 3 * p.stderr
    matrix = np.array(doc["correlation"]["matrix"])
    assert set(p.correl) == {"CA_mult", "wind_bias_n"}
    assert p.correl["CA_mult"] == matrix[1, 0] and p.correl["wind_bias_n"] == matrix[1, 2]
    assert np.array_equal(params.correlation, matrix)
    frame = params.to_frame()
    assert list(frame.index[frame["vary"]]) == list(NAMES)
    assert frame.loc["CA_mult", "stderr"] == params["CA_mult"].stderr
    with pytest.raises(KeyError, match="CA_mult, Cmq_mult, wind_bias_n"):
        params["nope"]
    assert loaded.converged and loaded.reduced_chi2 == 1.0371 and loaded.chi2 == {"imu": 100.0, "gps": 20.0}
    assert loaded.report() == "[[Fit: synthetic]]"
    assert repr(loaded).startswith("<DropFit 'synthetic': converged") and len(repr(loaded)) < 200
    assert set(loaded.residuals) == {"imu"} and "ax_residual_mps2" in loaded.residuals["imu"]


def test_parameters_is_a_mapping_whose_values_are_the_records(loaded):
    """Issue 52: ``values()`` is the Mapping's method (every record, the fixed ones included), not an
    ndarray property hiding it; the estimated values in fit order are ``var_values``."""
    params = loaded.params
    assert list(params.values()) == [params[n] for n in params]
    assert list(params.items()) == [(n, params[n]) for n in params] and list(params.keys()) == list(params)
    assert dict(params) == {n: params[n] for n in params}
    np.testing.assert_array_equal(params.var_values, [params[n].value for n in params.var_names])
    assert params.var_values.shape == (len(NAMES),)


def test_sample_interpolates_values_and_3sigma(loaded):
    t = [1.0, 1.5, 10.99]
    out = loaded.sample(["h_agl_m", "alpha_t_deg"], t)
    assert list(out.columns) == ["flight_time_s", "h_agl_m", "h_agl_m_3sigma", "alpha_t_deg", "alpha_t_deg_3sigma"]
    np.testing.assert_allclose(out["h_agl_m"], 400 - 35 * np.array(t), rtol=1e-8)
    np.testing.assert_allclose(out["h_agl_m_3sigma"], 0.01 + 0.001 * np.array(t), rtol=1e-8)
    tr = loaded.trajectory
    np.testing.assert_array_equal(out["alpha_t_deg"], np.interp(t, tr["flight_time_s"], tr["alpha_t_deg"]))
    imu = loaded.sample("qbar_pa", 5.0, time="time_imu_s")
    np.testing.assert_allclose(imu["qbar_pa"], 703.0, rtol=1e-8)
    utc = loaded.sample("qbar_pa", 1696347130.25 + 3.0, time="time_unix_s")
    np.testing.assert_allclose(utc["qbar_pa"], 703.0, rtol=1e-8)


def test_utc_column_reads_as_timestamps(loaded):
    import pandas as pd

    tr = loaded.trajectory
    assert isinstance(tr["utc"].dtype, pd.DatetimeTZDtype) and str(tr["utc"].dt.tz) == "UTC"
    # the ISO text and the Unix seconds name the same instants (to the microsecond they are written in)
    seconds = (tr["utc"] - pd.Timestamp("1970-01-01", tz="UTC")).dt.total_seconds().to_numpy()
    np.testing.assert_allclose(seconds, tr["time_unix_s"].to_numpy(), rtol=0, atol=1e-6)
    assert "utc" not in loaded.columns and "time_unix_s" not in loaded.columns
    again = pd.read_csv(loaded.source / "trajectory.csv", parse_dates=["utc"])
    assert again["utc"].iloc[0] == tr["utc"].iloc[0]


def test_sample_errors_name_what_is_available(loaded):
    with pytest.raises(ValueError, match=r"no time-history column 'alpha_tt'.*available: h_agl_m, .*alpha_t_deg"):
        loaded.sample("alpha_tt", [2.0])
    with pytest.raises(ValueError, match="outside the fit window"):
        loaded.sample("h_agl_m", [0.5])
    with pytest.raises(ValueError, match="time must be one of"):
        loaded.sample("h_agl_m", [2.0], time="utc")


def test_save_load_round_trip_is_exact(loaded, tmp_path):
    again = casrecon.load_results(loaded.save(tmp_path / "copy"))
    assert again.params == loaded.params
    for name in NAMES:
        a, b = again.params[name], loaded.params[name]
        assert (a.value, a.stderr, a.stderr_scaled, dict(a.correl)) == (b.value, b.stderr, b.stderr_scaled,
                                                                        dict(b.correl))
    assert again.trajectory.equals(loaded.trajectory)
    assert again.residuals["imu"].equals(loaded.residuals["imu"])


def test_json_floats_round_trip_exactly(tmp_path):
    x = np.random.default_rng(3).normal(size=(7, 7)) * 10.0 ** np.arange(-3, 4)
    write_json(tmp_path / "x.json", {"matrix": x.tolist()})
    assert np.array_equal(np.array(json.loads((tmp_path / "x.json").read_text())["matrix"]), x)


def test_load_results_on_a_folder_that_is_not_a_results_folder(tmp_path):
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "summary.json").write_text("{}")
    with pytest.raises(casrecon.InputError, match=r"junk: not a casrecon per-drop results folder: "
                                                  r"parameters.json, trajectory.csv missing"):
        casrecon.load_results(tmp_path / "junk")
    with pytest.raises(casrecon.InputError, match="nowhere: results folder not found"):
        casrecon.load_results(tmp_path / "nowhere")
    folder = make_folder(tmp_path / "bad")
    (folder / "parameters.json").write_text('{"correlation": {}}')
    with pytest.raises(casrecon.InputError,
                       match=r"bad/parameters.json: field .parameters.: expected an object \{name: \{value, sigma"):
        casrecon.load_results(folder)


def test_plot_functions_return_figures_without_a_folder(loaded, tmp_path):
    for fig in (casrecon.plot_trajectory(loaded), casrecon.plot_qbar_alpha_t(loaded),
                casrecon.plot_residuals(loaded, "imu"), casrecon.plot_correlation(loaded)):
        assert isinstance(fig, Figure)
    assert not (loaded.source / "figures").exists()
    with pytest.raises(ValueError, match="available: imu, gps"):
        casrecon.plot_residuals(loaded, "baro-typo")


def test_import_is_cheap_and_all_is_complete():
    code = ("import sys, casrecon; heavy = [m for m in ('casadi', 'pandas', 'matplotlib') if m in sys.modules]; "
            "print(heavy); assert not heavy")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert proc.returncode == 0, proc.stdout + proc.stderr
    for name in casrecon.__all__:
        assert getattr(casrecon, name) is not None, name
    assert isinstance(casrecon.__version__, str)


def make_joint_folder(folder: Path) -> Path:
    for drop in ("drop-a", "drop-b"):
        make_folder(folder / "drops" / drop)
        summary = json.loads((folder / "drops" / drop / "summary.json").read_text())
        write_json(folder / "drops" / drop / "summary.json", {**summary, "problem": drop})
    names = ["CA_mult", "drop-a.wind_bias_n", "drop-b.wind_bias_n"]
    write_json(folder / "parameters.json", {
        "parameters": {n: {"value": 0.1 * k, "sigma": 0.01 * (k + 1), "three_sigma": 0.03 * (k + 1),
                           "sigma_chi2_scaled": 0.011 * (k + 1), "shared": "." not in n} for k, n in enumerate(names)},
        "correlation": {"names": names, "matrix": _corr(3, seed=4).tolist()}})
    write_json(folder / "summary.json", {"name": "pair", "converged": True, "shared": ["CA_mult"], "chi2": 240.0,
                                         "dof": 230, "reduced_chi2": 240 / 230,
                                         "chi2_per_drop": {"drop-a": {"imu": 100.0}, "drop-b": {"imu": 140.0}}})
    (folder / "tables.md").write_text("### Shared aero dispersions\n")
    return folder


def test_joint_folder_loads_and_round_trips(tmp_path):
    joint = casrecon.load_results(make_joint_folder(tmp_path / "joint"))
    assert isinstance(joint, casrecon.JointFit)
    assert list(joint.drops) == ["drop-a", "drop-b"] and isinstance(joint.drops["drop-a"], casrecon.DropFit)
    assert joint.shared == ("CA_mult",) and joint.params["CA_mult"].shared is True
    assert joint.params["drop-b.wind_bias_n"].shared is False
    assert joint.params["CA_mult"].correl["drop-a.wind_bias_n"] == joint.params.correlation[0, 1]
    assert joint.chi2 == {"drop-a": {"imu": 100.0}, "drop-b": {"imu": 140.0}}
    assert "Shared aero dispersions" in joint.report()
    assert repr(joint).startswith("<JointFit 'pair': 2 drops, 1 shared factors")
    assert isinstance(casrecon.plot_correlation(joint), Figure)
    again = casrecon.load_results(joint.save(tmp_path / "copy"))
    assert again.params == joint.params and again.drops["drop-b"].params == joint.drops["drop-b"].params
    (tmp_path / "joint" / "parameters.json").unlink()
    with pytest.raises(casrecon.InputError, match="not a casrecon joint results folder: parameters.json missing"):
        casrecon.load_results(tmp_path / "joint")


def test_save_with_figures_and_plots_from_a_path(loaded, tmp_path):
    folder = loaded.save(tmp_path / "with-figures", figures=True)
    assert (folder / "figures" / "altitude_velocity.png").stat().st_size > 1000
    assert isinstance(casrecon.plot_trajectory(folder), Figure)
    with pytest.raises(TypeError, match="expected a per-drop result"):
        casrecon.plot_trajectory(42)
