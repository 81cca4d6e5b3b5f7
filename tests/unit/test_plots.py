"""Figures of a results folder: drawn from a tiny synthetic folder (no fit), per-drop and joint; every
figure into PNG and PDF, each file checked (PNG signature and image shape, PDF header and trailer).
The input figures read the shipped ees-drop-1 data files the folder's config/resolved.json names."""

from __future__ import annotations

import json
import logging
from pathlib import Path

import numpy as np
import pytest
from conftest import PROBLEMS
from figure_files import AERO_FIGURES, DROP_FIGURES, assert_figure_file, assert_png

from casrecon.analysis import aero_columns as aero
from casrecon.io.errors import InputError
from casrecon.io.units import gps_residual_column, gps_sigma_column, imu_residual_column, imu_sigma_key
from casrecon.report import figure_style
from casrecon.report.joint_plots import JOINT_FIGURE_NAMES
from casrecon.report.plots import draw_figures

RELEASE_IMU_S = 2.0
TRAJ_NAMES = ("pos_n_m", "pos_e_m", "pos_d_m", "h_agl_m", "vel_n_mps", "vel_e_mps", "vel_d_mps",
              "roll_deg", "pitch_deg", "yaw_deg", "p_dps", "q_dps", "r_dps", "alpha_deg",
              "beta_deg", "alpha_t_deg", "qbar_pa", "mach")
PARAM_NAMES = ("CA_mult", "Cm_add", "Cmq_mult", "wind_bias_n")


def _write_csv(path: Path, columns: dict[str, np.ndarray]) -> None:
    np.savetxt(path, np.column_stack(list(columns.values())), delimiter=",",
               header=",".join(columns), comments="", fmt="%.9g")


def _parameters(names) -> dict:
    n = len(names)
    corr = 0.5 * np.eye(n) + 0.5 * np.ones((n, n)) * 0.3 + 0.35 * np.eye(n)
    np.fill_diagonal(corr, 1.0)
    return {"parameters": {k: {"value": 0.1, "sigma": 0.02, "three_sigma": 0.06, "unit": "-"}
                           for k in names},
            "correlation": {"names": list(names), "matrix": corr.tolist()}}


def make_drop_folder(folder: Path, name: str = "synthetic-drop", n: int = 200) -> Path:
    """A per-drop results folder with every file casrecon fit writes, from simple formulas."""
    folder.mkdir(parents=True)
    rng = np.random.default_rng(0)
    t_imu = np.linspace(RELEASE_IMU_S + 1.0, RELEASE_IMU_S + 11.0, n)
    ft = t_imu - RELEASE_IMU_S
    alpha = 20.0 * np.exp(-ft / 8.0) * np.sin(2 * np.pi * ft)
    cols = {"time_imu_s": t_imu, "flight_time_s": ft}
    values = {name: np.sin(ft + k) for k, name in enumerate(TRAJ_NAMES)}
    values.update(h_agl_m=400.0 - 35.0 * ft, pos_d_m=-(400.0 - 35.0 * ft), vel_d_mps=35.0 + 0 * ft,
                  alpha_deg=alpha, alpha_t_deg=np.abs(alpha), qbar_pa=700.0 + 10 * ft)
    for key in TRAJ_NAMES:
        cols[key], cols[f"{key}_3sigma"] = values[key], 0.01 + 0.001 * ft
    _write_csv(folder / "trajectory.csv", cols)
    tg = t_imu[::10]
    _write_csv(folder / "gps_fixes.csv", {
        "time_imu_s": tg, "pos_n_m": 0 * tg, "pos_e_m": 0 * tg, "pos_d_m": -(400 - 35 * (tg - 2)),
        "vel_n_mps": 0 * tg, "vel_e_mps": 0 * tg, "vel_d_mps": 35 + rng.normal(0, 0.2, tg.size)})
    gps = {"time_imu_s": tg}
    gps.update({gps_residual_column(c): rng.normal(0, 1, tg.size) for c in
                ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")})
    gps.update({gps_sigma_column(c): np.full(tg.size, 1.5) for c in
                ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")})
    _write_csv(folder / "residuals_gps.csv", gps)
    imu = {"time_imu_s": t_imu}
    chans = ("ax", "ay", "az", "wx", "wy", "wz")
    imu.update({imu_residual_column(c): rng.normal(0, 0.05 if c[0] == "a" else 0.1, n) for c in chans})
    imu.update({f"{c}_used": (np.arange(n) > 5).astype(float) for c in chans})
    _write_csv(folder / "residuals_imu.csv", imu)
    (folder / "imu_sigma.json").write_text(json.dumps(
        {imu_sigma_key(c): 0.05 if c[0] == "a" else 0.1 for c in chans}))
    _write_csv(folder / "pitching_moment.csv", {
        "time_imu_s": t_imu, "alpha_deg": alpha, "qbar_pa": values["qbar_pa"],
        "cm_recon": -0.002 * alpha + rng.normal(0, 1e-3, n)})
    a = np.linspace(-20, 20, 81)
    _write_csv(folder / "cm_curves.csv", {"alpha_deg": a, "cm_nominal": -0.0025 * a,
                                          "cm_fitted": -0.002 * a})
    ts = np.linspace(ft[0], ft[-1] + 0.1, 3 * n)
    sim = {"flight_time_s": ts, "h_agl_m": 400 - 35 * ts, "speed_mps": 35 + 0 * ts,
           "alpha_t_deg": np.interp(ts, ft, np.abs(alpha)), "p_dps": np.sin(ts)}
    _write_csv(folder / "reconciled.csv", sim)
    _write_csv(folder / "nominal.csv", {**sim, "speed_mps": 36 + 0 * ts})
    coefficients = {aero.TIME_IMU: t_imu, aero.FLIGHT_TIME: ft, aero.ALPHA_T: np.abs(alpha),
                    aero.QBAR: values["qbar_pa"]}
    for k, c in enumerate(aero.COEFFICIENTS):
        base = 0.01 * (k + 1) * np.sin(ft + k)
        for j, variant in enumerate((aero.RECONSTRUCTED, aero.BEST_FIT, aero.NOMINAL)):
            coefficients[aero.column(c, variant)] = base + 0.001 * j + (rng.normal(0, 1e-3, n) if j == 0 else 0)
            if variant != aero.NOMINAL:
                coefficients[aero.sigma_column(c, variant)] = np.full(n, 3e-3 / (j + 1))
    coefficients[aero.column("CA", aero.RECONSTRUCTED)][:4] = np.nan  # next to a saturated sample
    _write_csv(folder / "aero_coefficients.csv", {c: coefficients[c] for c in aero.all_columns()})
    data = PROBLEMS / "ees-drop-1"
    (folder / "config").mkdir()
    (folder / "config" / "resolved.json").write_text(json.dumps({
        "site": {"lat_deg": 40.19, "lon_deg": -112.94, "ground_alt_msl_m": 1310.0},
        "inputs": {"imu": {"file": str(data / "data" / "imu.csv"), "utc_at_zero_unix_s": 1696347128.25,
                           "spec": {"gyro_unit": "deg/s", "gyro_limits": [[-183.65, 157.4]]}},
                   "gps": {"file": str(data / "data" / "gps.csv")},
                   "sounding": {"file": str(data / "sounding.csv"), "launch": 0}}}))
    (folder / "summary.json").write_text(json.dumps({
        "problem": name, "release_imu_s": RELEASE_IMU_S, "impact_imu_s": RELEASE_IMU_S + 12.0,
        "window_imu_s": [t_imu[0], t_imu[-1]],
        "reconciled": {"flight_time_difference_s": 0.1, "impact_speed_difference_mps": -0.2}}))
    (folder / "parameters.json").write_text(json.dumps(_parameters(PARAM_NAMES)))
    return folder


@pytest.fixture
def no_render(monkeypatch):
    """Build the figures but skip the ~1 s of rendering each (the plumbing tests only need the
    files); a figure saved under a folder in the returned list is still rendered for real."""
    real_save = figure_style.save_figure
    rendered: list[Path] = []

    def fast_save(fig, path: Path, formats=("png",)) -> list[Path]:
        if path.parent in rendered:
            return real_save(fig, path, formats)
        path.parent.mkdir(parents=True, exist_ok=True)
        paths = [path.with_suffix(f".{f}") for f in formats]
        for p in paths:
            p.write_bytes(b"not rendered")
        fig.clear()
        return paths

    monkeypatch.setattr(figure_style, "save_figure", fast_save)
    return rendered


def test_every_figure_of_a_drop_is_a_png_and_a_pdf(tmp_path):
    folder = make_drop_folder(tmp_path / "fit")
    notes: list[str] = []
    paths = draw_figures(folder, notes, formats=("png", "pdf"))
    assert notes == []
    assert sorted(p.name for p in paths) == sorted(f"{f}.{x}" for f in DROP_FIGURES for x in ("png", "pdf"))
    for path in paths:
        assert path.parent == folder / "figures"
        assert_figure_file(path)


def test_missing_aero_table_and_moved_inputs_skip_only_their_figures(tmp_path, no_render):
    folder = make_drop_folder(tmp_path / "fit")
    (folder / "aero_coefficients.csv").unlink()
    resolved = json.loads((folder / "config" / "resolved.json").read_text())
    resolved["inputs"]["gps"]["file"] = str(tmp_path / "moved.csv")
    (folder / "config" / "resolved.json").write_text(json.dumps(resolved))
    notes: list[str] = []
    paths = draw_figures(folder, notes)
    assert {p.stem for p in paths} == set(DROP_FIGURES) - {*AERO_FIGURES, "inputs_gps"}
    assert len(notes) == 4
    assert sum("aero_coefficients.csv" in n for n in notes) == 3
    assert any("inputs_gps" in n and "moved.csv" in n for n in notes)


OPTIONAL = {"reconciled.csv": "reconciled", "pitching_moment.csv": "pitching_moment",
            "residuals_imu.csv": "residuals_imu", "residuals_gps.csv": "residuals_gps",
            "parameters.json": "correlation"}


def test_missing_optional_file_skips_only_its_figure(tmp_path, caplog, no_render):
    folder = make_drop_folder(tmp_path / "fit")
    (folder / "reconciled.csv").unlink()
    notes: list[str] = []
    with caplog.at_level(logging.WARNING):
        paths = draw_figures(folder, notes)
    assert {p.stem for p in paths} == set(DROP_FIGURES) - {"reconciled"}
    assert len(notes) == 1 and "reconciled.csv" in notes[0] and "reconciled" in notes[0]
    assert "reconciled.csv" in caplog.text


def test_each_missing_optional_file_is_noted(tmp_path, no_render):
    folder = make_drop_folder(tmp_path / "fit")
    for name in OPTIONAL:
        (folder / name).unlink()
    notes: list[str] = []
    paths = draw_figures(folder, notes)
    assert {p.stem for p in paths} == set(DROP_FIGURES) - set(OPTIONAL.values())
    assert len(notes) == len(OPTIONAL)
    for (name, figure), note in zip(OPTIONAL.items(), sorted(notes, key=_note_order), strict=True):
        assert name in note and figure in note


def _note_order(note: str) -> int:
    return next(k for k, name in enumerate(OPTIONAL) if name in note)


def test_missing_decorations_still_draw(tmp_path, no_render):
    """Files that only decorate a figure (GPS dots, C_m curves, sigma lines, nominal simulation)
    do not skip it."""
    folder = make_drop_folder(tmp_path / "fit")
    for name in ("gps_fixes.csv", "cm_curves.csv", "imu_sigma.json", "nominal.csv"):
        (folder / name).unlink()
    notes: list[str] = []
    assert len(draw_figures(folder, notes)) == len(DROP_FIGURES) and notes == []


@pytest.mark.parametrize("required", ["summary.json", "trajectory.csv"])
def test_not_a_results_folder_names_the_missing_file(tmp_path, required):
    folder = make_drop_folder(tmp_path / "fit")
    (folder / required).unlink()
    with pytest.raises(InputError, match=f"not a casrecon results folder: {required} missing"):
        draw_figures(folder)


def test_empty_or_absent_folder_raises(tmp_path):
    with pytest.raises(InputError, match="summary.json"):
        draw_figures(tmp_path)
    with pytest.raises(InputError, match="results folder not found"):
        draw_figures(tmp_path / "nowhere")


def test_joint_folder_draws_each_drop_and_the_top_correlation(tmp_path, no_render):
    top = tmp_path / "joint"
    no_render.append(top / "figures")
    for name in ("ees-drop-1", "ees-drop-3"):
        make_drop_folder(top / "drops" / name, name=name, n=120)
    shared = ["CA_mult", "Cm_add"] + [f"{d}.wind_bias_n" for d in ("ees-drop-1", "ees-drop-3")]
    (top / "parameters.json").write_text(json.dumps(_parameters(shared)))
    (top / "summary.json").write_text(json.dumps({"drops": ["ees-drop-1", "ees-drop-3"]}))
    notes: list[str] = []
    paths = draw_figures(top, notes)
    assert notes == []
    for name in ("ees-drop-1", "ees-drop-3"):
        figs = {p.stem for p in paths if p.parent == top / "drops" / name / "figures"}
        assert figs == set(DROP_FIGURES) - {"correlation"}
    assert {p.name for p in paths if p.parent == top / "figures"} == {f"{n}.png" for n in JOINT_FIGURE_NAMES}
    for path in paths:
        assert path.is_file()
    assert_png(top / "figures" / "correlation.png")
