"""Every figure of a joint fit, a Monte Carlo and a sensitivity study drawn into PNG and PDF, each
file checked to be a valid image or document, plus the tables beside them (envelopes.csv,
fisher.json). Cheap inputs: a synthetic four-drop joint folder (49 parameters, as the EES joint
fit), a 50-case Monte Carlo of ees-drop-1, and ``sensitivity fisher`` on ees-drop-2 cut to a 3.4 s
window."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from conftest import PROBLEMS
from matplotlib.figure import Figure
from matplotlib.image import imread

import casrecon
from casrecon.analysis.mc_envelopes import PERCENTILES, envelope_column
from casrecon.analysis.montecarlo import run_montecarlo
from casrecon.analysis.observability import Profile
from casrecon.cli import main
from casrecon.output.fit_results import write_table
from casrecon.output.montecarlo_results import write_envelopes_csv
from casrecon.output.results import write_json
from casrecon.report import (
    figure_style,
    joint_correlation,
    joint_figures,
    joint_plots,
    montecarlo_plots,
    sensitivity_plots,
)
from casrecon.report.results_folder import read_csv
from casrecon.simulation.batch import HISTORY_CHANNELS

FORMATS = ("png", "pdf")
DROPS = ("drop-a", "drop-b", "drop-c", "drop-d")
SHARED = ("CA_mult", "CN_add", "CNY_mult", "CY_add", "Cm_add", "Cmn_mult", "Cn_add", "Cmq_mult", "Cl_add")
LOCAL = ("wind_bias_n", "wind_bias_e", "density_factor", "accel_bias_x", "accel_bias_y", "accel_bias_z",
         "gyro_bias_x", "gyro_bias_y", "gyro_bias_z", "clock_offset_s")
TRAJECTORY = ("h_agl_m", "vel_n_mps", "vel_e_mps", "vel_d_mps", "qbar_pa", "alpha_t_deg", "alpha_deg", "beta_deg",
              "p_dps", "q_dps", "r_dps")


def assert_valid(path: Path) -> None:
    """A PNG with its signature that matplotlib reads back, or a PDF from %PDF to %%EOF."""
    data = path.read_bytes()
    if path.suffix == ".png":
        assert data[:8] == b"\x89PNG\r\n\x1a\n", path
        image = imread(path)
        assert image.ndim == 3 and min(image.shape[:2]) > 300, (path, image.shape)
    else:
        assert path.suffix == ".pdf" and data.startswith(b"%PDF-") and data.rstrip().endswith(b"%%EOF"), path
        assert len(data) > 5000, path


def save_all(fig: Figure, stem: Path) -> list[Path]:
    """Save one figure in every format of FORMATS."""
    return figure_style.save_figure(fig, stem, FORMATS)


def _correlation(n: int, seed: int) -> np.ndarray:
    a = np.random.default_rng(seed).normal(size=(n, n + 3))
    c = a @ a.T
    d = np.sqrt(np.diag(c))
    return c / np.outer(d, d)


def make_joint_folder(folder: Path) -> Path:
    """A joint results folder as ``casrecon joint`` writes it, from simple formulas: four drops with
    trajectory, pitching-moment points and database curves; 9 shared + 4 x 10 own parameters."""
    rng = np.random.default_rng(7)
    for k, drop in enumerate(DROPS):
        sub = folder / "drops" / drop
        sub.mkdir(parents=True)
        ft = np.linspace(3.5, 38.0 - 2 * k, 400)
        traj = {"time_imu_s": ft + 2.0, "flight_time_s": ft}
        for j, name in enumerate(TRAJECTORY):
            traj[name], traj[f"{name}_3sigma"] = 10 * np.sin(ft + j + k), 0.01 + 0.001 * ft
        traj["h_agl_m"] = 1500.0 - 40.0 * (ft - 3.5) - 50 * k
        traj["vel_d_mps"] = 40.0 + np.exp(-ft) + 0 * ft
        alpha = 15 * np.exp(-ft / 20) * np.sin(3 * ft)
        traj["alpha_deg"], traj["qbar_pa"] = alpha, 900 - 500 * np.exp(-ft / 3)
        write_table(sub / "trajectory.csv", traj)
        write_table(sub / "pitching_moment.csv", {
            "time_imu_s": ft + 2.0, "alpha_deg": alpha, "qbar_pa": traj["qbar_pa"],
            "cm_recon": -0.0022 * alpha + rng.normal(0, 2e-4, ft.size)})
        a = np.linspace(-20, 20, 81)
        write_table(sub / "cm_curves.csv", {"alpha_deg": a, "cm_nominal": -0.0025 * a, "cm_fitted": -0.0022 * a})
        write_json(sub / "summary.json", {"problem": drop, "converged": True, "release_imu_s": 2.0,
                                          "reduced_chi2": 1.0})
        write_json(sub / "parameters.json", {
            "parameters": {n: {"value": 0.0, "sigma": 0.1} for n in SHARED},
            "correlation": {"names": list(SHARED), "matrix": np.eye(len(SHARED)).tolist()}})
    names = list(SHARED) + [f"{d}.{n}" for d in DROPS for n in LOCAL]
    write_json(folder / "parameters.json", {
        "parameters": {n: {"value": 0.0, "sigma": 0.01, "shared": "." not in n} for n in names},
        "correlation": {"names": names, "matrix": _correlation(len(names), 3).tolist()}})
    write_json(folder / "summary.json", {"name": "quad", "converged": True, "shared": list(SHARED), "chi2": 100.0,
                                         "dof": 100, "reduced_chi2": 1.0})
    return folder


@pytest.fixture(scope="module")
def joint_folder(tmp_path_factory):
    return make_joint_folder(tmp_path_factory.mktemp("joint") / "quad")


def test_every_joint_figure_is_a_valid_png_and_pdf(joint_folder):
    drops = sorted((joint_folder / "drops").iterdir())
    notes: list[str] = []
    paths = joint_plots.draw_joint_figures(joint_folder, drops, "quad", notes, formats=FORMATS)
    assert notes == []
    assert sorted(p.name for p in paths) == sorted(f"{n}.{s}" for n in joint_plots.JOINT_FIGURE_NAMES for s in FORMATS)
    assert {"joint_altitude_speed", "joint_qbar_alpha_t", "joint_rates", "correlation"} <= set(
        joint_plots.JOINT_FIGURE_NAMES)
    for p in paths:
        assert p.parent == joint_folder / "figures"
        assert_valid(p)


def test_joint_plot_api_takes_a_joint_fit_or_a_folder(joint_folder, tmp_path):
    joint = casrecon.load_results(joint_folder)
    assert isinstance(joint, casrecon.JointFit)
    draws = (casrecon.plot_joint_altitude_speed, casrecon.plot_joint_qbar_alpha_t, casrecon.plot_joint_flow_angles,
             casrecon.plot_joint_rates, casrecon.plot_joint_pitching_moment, casrecon.plot_shared_correlation,
             casrecon.plot_correlation)
    for k, draw in enumerate(draws):  # building a figure is cheap, rendering is not: none is saved here
        assert isinstance(draw((joint, joint_folder)[k % 2]), Figure), draw.__name__
    fig = casrecon.plot_joint_rates(joint)
    assert len(fig.axes) == 6 and fig.legends and not any(ax.get_legend() for ax in fig.axes)
    assert [line.get_color() for line in fig.axes[0].lines] == list(joint_figures.DROP_COLORS[:4])
    assert casrecon.plot_correlation(joint_folder).axes[0].get_xticklabels()[0].get_text() == "$C_A$ mult"
    with pytest.raises(TypeError, match="joint"):
        casrecon.plot_joint_rates(joint.drops["drop-a"])


def test_joint_correlation_is_blocked_and_prints_the_values_that_fit(joint_folder):
    doc = json.loads((joint_folder / "parameters.json").read_text())
    names, mat = joint_correlation.correlation_matrix(doc)
    assert len(names) == 49
    parts = joint_correlation.blocks(names[::-1])  # any order in: shared block first, then drops
    assert [b for b, _ in parts][0] == "shared" and sorted(b for b, _ in parts[1:]) == sorted(DROPS)
    fig = joint_correlation.joint_correlation_figure(doc, "quad")
    ax = fig.axes[0]
    off = np.abs(mat[~np.eye(49, dtype=bool)])
    texts = [t.get_text() for t in ax.texts]
    assert len(texts) == int((off >= joint_correlation.MIN_PRINTED).sum())  # every |r| >= 0.1, as 100 r
    assert all(t.lstrip("-").isdigit() for t in texts)
    labels = [t.get_text() for t in ax.get_xticklabels()]
    assert labels[0] == "$C_A$ mult" and labels.count(r"$\Delta\rho/\rho$") == 4  # short, drop prefix dropped
    small = {"correlation": {"names": list(SHARED[:4]), "matrix": _correlation(4, 1).tolist()}}
    decimals = [t.get_text() for t in joint_correlation.joint_correlation_figure(small, "s").axes[0].texts]
    assert decimals and all("." in t for t in decimals)  # big cells: r with two decimals


@pytest.fixture(scope="module")
def montecarlo():
    return run_montecarlo(PROBLEMS / "ees-drop-1", 50, seed=4, workers=1)


def test_every_montecarlo_figure_is_a_valid_png_and_pdf(montecarlo, tmp_path):
    paths = montecarlo_plots.plot_montecarlo(montecarlo, tmp_path / "figures", FORMATS)
    assert sorted(p.name for p in paths) == sorted(f"{n}.{s}" for n in ("histograms", "speed_vs_time", "envelopes")
                                                   for s in FORMATS)
    for p in paths:
        assert_valid(p)
    # the envelopes as written, read back and drawn again
    write_envelopes_csv(tmp_path / "envelopes.csv", montecarlo.histories.envelopes())
    table = read_csv(tmp_path / "envelopes.csv")
    assert list(table)[:2] == ["flight_time_s", "n_in_flight"]
    assert {envelope_column(c, p) for c in HISTORY_CHANNELS for p in PERCENTILES} <= set(table)
    assert table["n_in_flight"][0] == 50 and np.diff(table["flight_time_s"]) == pytest.approx(0.1)
    ok = table["n_in_flight"] == 50
    for c in HISTORY_CHANNELS:
        lo, mid, hi = (table[envelope_column(c, p)][ok] for p in PERCENTILES)
        assert np.all(lo <= mid) and np.all(mid <= hi), c
    h = table[envelope_column("h_agl_m", 50)]
    # the grid runs to the last case's touchdown; the landed cases count at 0 m
    assert h[0] > 1600 and h[-1] == 0.0 and table["n_in_flight"][-1] >= 1
    fig = montecarlo_plots.envelope_figure(table, "again", 50)
    for p in save_all(fig, tmp_path / "envelopes_again"):
        assert_valid(p)
    assert montecarlo.histories.nbytes == 50 * table["flight_time_s"].size * 16


@pytest.fixture(scope="module")
def short_problem(tmp_path_factory):
    """ees-drop-2 fitted from 3.5 to about 6.9 s after release only (a fit of a few seconds)."""
    root = tmp_path_factory.mktemp("problems")
    for name in ("ees-drop-2", "vehicles", "aero"):
        shutil.copytree(PROBLEMS / name, root / name)
    toml = root / "ees-drop-2" / "problem.toml"
    toml.write_text(toml.read_text() + "\n[estimation]\nend_before_impact_s = 24.0\n")
    return root / "ees-drop-2"


def test_every_sensitivity_figure_is_a_valid_png_and_pdf(short_problem, tmp_path, capsys):
    out = tmp_path / "fisher"
    assert main(["sensitivity", "fisher", str(short_problem), "--out", str(out)]) == 0
    doc = json.loads((out / "fisher.json").read_text())
    assert set(doc) == {"problem", "order", "units", "parameters", "directions"}
    first = doc["directions"][0]
    assert set(first) == {"rank", "eigenvalue", "sigma_normalised", "three_sigma_normalised", "largest_loading",
                          "loadings"}
    assert first["sigma_normalised"] == pytest.approx(first["eigenvalue"] ** -0.5)
    for d in doc["directions"]:
        assert sum(w * w for w in d["loadings"].values()) == pytest.approx(1.0)
    paths = [out / "fisher.png", sensitivity_plots.plot_fisher(doc, tmp_path, ("pdf",))]
    x = -0.3 + 0.01 * np.linspace(-4, 4, 9)
    profile = Profile("Cmq_mult", x, ((x + 0.3) / 0.01) ** 2, -0.3, 0.03, (-0.33, -0.27))
    design = {"parameter": "Cmq_mult", "pitch_rate": [(0.0, 0.01), (30.0, 0.005)], "altitude": [(800.0, 0.01)],
              "n_drops": [(1, 0.006), (2, 0.004), (4, 0.003)]}
    for draw, what in ((sensitivity_plots.plot_profile, profile), (sensitivity_plots.plot_design, design)):
        first = draw(what, tmp_path, FORMATS)  # one call writes every format, returns the first
        assert first.suffix == ".png"
        paths += [first.with_suffix(f".{s}") for s in FORMATS]
    assert len(paths) == 6
    for p in paths:
        assert_valid(p)
