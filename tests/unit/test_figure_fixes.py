"""What the figures show, read off the Axes the figure functions return (issue 52): the
reconstruction drawn on top of the best fit, a band narrower than its line said to be there, plain
tick labels on the point-mass residual axes, one legend entry per line style, no offset label on
reconciled.png's difference axes."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from matplotlib.collections import PolyCollection
from matplotlib.lines import Line2D
from test_plots import make_drop_folder

from casrecon.analysis import aero_columns as aero
from casrecon.report.aero_figures import aero_coefficients_figure
from casrecon.report.pointmass_plots import track_fit_figure
from casrecon.report.results_folder import DropFolder
from casrecon.report.trajectory_figures import reconciled_figure


@pytest.fixture(scope="module")
def drop(tmp_path_factory) -> Path:
    return make_drop_folder(tmp_path_factory.mktemp("fixes") / "drop")


def line_of(ax, label: str) -> Line2D:
    (line,) = [ln for ln in ax.get_lines() if ln.get_label() == label]
    return line


def test_the_reconstruction_is_drawn_on_top_of_the_best_fit_and_visible(drop):
    fig = aero_coefficients_figure(DropFolder(drop))
    for ax in fig.axes:
        recon, best = line_of(ax, "reconstructed from the IMU"), line_of(ax, "best-fit database")
        assert recon.get_zorder() > best.get_zorder()          # on top, whatever the drawing order
        assert recon.get_alpha() in (None, 1.0) and recon.get_linewidth() >= 0.8
        assert best.get_alpha() is not None and best.get_alpha() < 1.0   # the black line shows through
        assert all(recon.get_zorder() > c.get_zorder() for c in ax.collections if isinstance(c, PolyCollection))


def test_a_band_narrower_than_its_line_is_said_to_be_there(tmp_path, drop):
    import pandas as pd

    folder = make_drop_folder(tmp_path / "narrow")
    table = pd.read_csv(folder / "aero_coefficients.csv")
    table[aero.sigma_column("Cl", aero.BEST_FIT)] = 1e-9       # far narrower than any line
    table.to_csv(folder / "aero_coefficients.csv", index=False, na_rep="nan")
    fig = aero_coefficients_figure(DropFolder(folder))
    notes = {ax.get_ylabel(): " ".join(t.get_text() for t in ax.texts) for ax in fig.axes}
    (cl,) = [k for k in notes if "C_l" in k]
    assert "best-fit database" in notes[cl] and "narrower than" in notes[cl]
    assert "reconstructed" not in notes[cl]                    # its band is wide enough to see
    wide = aero_coefficients_figure(DropFolder(drop))
    assert not any(ax.texts for ax in wide.axes)               # visible bands: no note


def test_reconciled_difference_axes_have_no_offset_label(drop):
    fig = reconciled_figure(DropFolder(drop))
    fig.canvas.draw()
    differences = [ax for ax in fig.axes if ax.get_ylabel().startswith("difference")]
    assert differences
    for ax in differences:
        assert not ax.yaxis.get_major_formatter().get_useOffset()
        assert ax.yaxis.get_offset_text().get_text() == ""


def tiny_scale_reconciled(drop: Path, tmp_path: Path) -> Path:
    """``drop`` with a best-fit simulation at the reconstruction's nodes, 3e-6 (m, m/s, deg, deg/s)
    from it (which made matplotlib write "1e-6" above the difference axes)."""
    import shutil

    import pandas as pd


    folder = tmp_path / "tiny"
    shutil.copytree(drop, folder)
    traj = pd.read_csv(folder / "trajectory.csv")
    t = traj["flight_time_s"].to_numpy()
    speed = np.sqrt(traj["vel_n_mps"] ** 2 + traj["vel_e_mps"] ** 2 + traj["vel_d_mps"] ** 2)
    wiggle = 3e-6 * np.sin(3 * t)
    sim = pd.DataFrame({"flight_time_s": t, "h_agl_m": traj["h_agl_m"] + wiggle, "speed_mps": speed + wiggle,
                        "alpha_t_deg": traj["alpha_t_deg"] + wiggle, "p_dps": traj["p_dps"] + wiggle})
    sim.to_csv(folder / "reconciled.csv", index=False, na_rep="nan")
    return folder


def test_a_tiny_difference_is_labelled_in_plain_numbers(drop, tmp_path):
    fig = reconciled_figure(DropFolder(tiny_scale_reconciled(drop, tmp_path)))
    fig.canvas.draw()
    differences = [ax for ax in fig.axes if ax.get_ylabel().startswith("difference")]
    assert len(differences) == 4
    for ax in differences:
        assert ax.yaxis.get_offset_text().get_text() == ""
        labels = [t.get_text() for t in ax.get_yticklabels() if t.get_text()]
        assert labels and all("e" not in s for s in labels)


def point_mass_folder(folder: Path, n: int = 120) -> Path:
    """A point-mass results folder with the columns the track figure reads, from simple formulas."""
    folder.mkdir(parents=True)
    rng = np.random.default_rng(3)
    t = np.linspace(0.0, 30.0, n)
    pd_m, vd = -(3000.0 - 50.0 * t), 50.0 + 0 * t
    cda = 0.2 + 0.01 * np.sin(t)

    def write(name: str, cols: dict) -> None:
        np.savetxt(folder / name, np.column_stack(list(cols.values())), delimiter=",", header=",".join(cols),
                   comments="", fmt="%.9g")

    write("trajectory.csv", {"segment_time_s": t, "pos_d_m": pd_m, "vel_d_mps": vd, "cda_m2": cda,
                             "cda_m2_3sigma": 0.02 + 0 * t})
    res = {"segment_time_s": t}
    for comp in ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d"):
        res[f"{comp}_fit_z"] = rng.normal(0, 1, n)
        res[f"{comp}_constant_z"] = 40 * np.sin(t / 5) + rng.normal(0, 1, n)
    write("residuals_gps.csv", res)
    write("gps_fixes.csv", {"segment_time_s": t, "pos_d_m": pd_m, "vel_d_mps": vd, "used": 1 + 0 * t})
    (folder / "summary.json").write_text(json.dumps({"problem": "tiny-track"}))
    return folder


def test_point_mass_residual_axes_have_plain_tick_labels(tmp_path):
    fig = track_fit_figure(point_mass_folder(tmp_path / "pm"))
    fig.canvas.draw()
    symlog = [ax for ax in fig.axes if ax.get_yscale() == "symlog"]
    assert len(symlog) == 2
    for ax in symlog:
        labels = [t.get_text().replace("\u2212", "-") for t in ax.get_yticklabels() if t.get_text()]
        assert {"-10", "-3", "0", "3", "10"} <= set(labels)
        assert not any("^" in s or "$" in s for s in labels)      # not mathtext powers "-10^0, 0, 10^0"


def test_point_mass_legend_has_one_entry_per_line_style(tmp_path):
    fig = track_fit_figure(point_mass_folder(tmp_path / "pm"))
    (legend,) = fig.legends
    styles = [(h.get_color(), h.get_linestyle(), h.get_marker()) for h in legend.legend_handles
              if isinstance(h, Line2D)]
    assert len(styles) == len(set(styles)), [t.get_text() for t in legend.get_texts()]
