"""Figure of a kinematic reconstruction: height and track, velocity, attitude with their 3-sigma
bands, and the whitened residuals of the preintegration and of the fixes."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from casrecon.report import figure_style as style
from casrecon.report.results_folder import read_csv


def plot_kinematic(folder: Path, formats: Sequence[str] = style.DEFAULT_FORMATS) -> Path:
    """``figures/kinematic.png`` of a kinematic results folder; saved in each of ``formats``, the
    PNG's (or first) path returned."""
    folder = Path(folder)
    tr, imu, gps = (read_csv(folder / n) for n in ("trajectory.csv", "residuals_imu.csv", "residuals_gps.csv"))
    summary = json.loads((folder / "summary.json").read_text())
    fig, ax = style.new_figure(3, 2, (13, 10.5), sharex=False)
    t = tr["segment_time_s"]
    c = style.RECONSTRUCTED_COLOR
    style.band(ax[0, 0], t, -tr["pos_d_m"], tr["pos_d_m_3sigma"], c, "reconstructed", style.PM3SIGMA)
    ax[0, 0].set_ylabel("height above the site, m")
    ax[0, 1].plot(tr["pos_e_m"], tr["pos_n_m"], color=c, lw=1.0)
    ax[0, 1].set_xlabel("east, m")
    ax[0, 1].set_ylabel("north, m")
    ax[0, 1].set_aspect("equal", adjustable="datalim")
    for comp, color in zip(("n", "e", "d"), ("tab:blue", "tab:green", "tab:red")):
        style.band(ax[1, 0], t, tr[f"vel_{comp}_mps"], tr[f"vel_{comp}_mps_3sigma"], color, f"$v_{comp.upper()}$")
        ax[2, 0].plot(imu["segment_time_s"], imu[f"vel_{'xyz'['ned'.index(comp)]}_z"], ".", ms=2, color=color,
                      label=f"velocity residual {'xyz'['ned'.index(comp)]}")
    ax[1, 0].set_ylabel("velocity, m/s")
    for name, color in zip(("roll", "pitch", "yaw"), ("tab:purple", "tab:orange", "tab:gray")):
        ax[1, 1].plot(t, tr[f"{name}_deg"], ".", ms=1.5, color=color, label=name)
    ax[1, 1].set_ylabel("attitude of the IMU axes, deg")
    three = dict(color=style.SIGMA_COLOR, ls=":", lw=0.9)
    for axis in ("n", "e", "d"):
        ax[2, 1].plot(t, tr[f"att_{axis}_deg_3sigma"], lw=0.9, label=f"attitude {style.PM3SIGMA} about {axis.upper()}")
    ax[2, 1].set_ylabel("attitude 3-sigma, deg")
    ax[2, 1].set_yscale("log")
    for s in (-3, 3):
        ax[2, 0].axhline(s, **three)
    valid = np.isfinite(gps["pos_n_z"])
    ax[2, 0].set_ylabel("whitened preintegration residual")
    for a in (ax[1, 0], ax[1, 1], ax[2, 0], ax[2, 1], ax[0, 0]):
        a.set_xlabel("time since the span's start, s")
    style.figure_legend(fig, ncol=5, markerscale=3)
    title = summary.get("problem") or folder.name
    fig.suptitle(f"{title}: IMU-driven reconstruction (reduced chi-square {summary['reduced_chi2']:.2f}, "
                 f"{int(valid.sum())} fixes)")
    return style.save_figure(fig, folder / "figures" / "kinematic", formats)[0]
