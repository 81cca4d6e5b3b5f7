"""Figure of the kinematic check: the coefficients the IMU-driven reconstruction implies against the
dynamic fit's best-fit database, with their 3-sigma bands, over time (left) and the implied
coefficients against alpha_T with the database along the same flow (right)."""

from __future__ import annotations

import json
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from casrecon.report import figure_style as style
from casrecon.report.results_folder import read_csv

#: The coefficients drawn over time, one row each, and the crossflow-plane one drawn against alpha_T.
DRAWN = ("CA", "CN", "Cm")
AGAINST_ALPHA_T = {"CA": "CA", "CN": "CN_crossflow", "Cm": "Cm_crossflow"}


def plot_kinematic_check(folder: Path, formats: Sequence[str] = style.DEFAULT_FORMATS) -> Path:
    """``figures/kinematic_check.png`` of a results folder holding ``kinematic_check.csv`` and
    ``implied_aero.csv``; saved in each of ``formats``, the PNG's (or first) path returned."""
    folder = Path(folder)
    check, implied = read_csv(folder / "kinematic_check.csv"), read_csv(folder / "implied_aero.csv")
    verdict = json.loads((folder / "kinematic_check.json").read_text())["verdict"]
    fig, ax = style.new_figure(len(DRAWN), 2, (13, 3.2 * len(DRAWN)), sharex=False)
    t = check["time_imu_s"] - check["time_imu_s"][0]
    for row, c in enumerate(DRAWN):
        style.band(ax[row, 0], t, check[f"{c}_implied"], check[f"{c}_implied_3sigma"], style.RECONSTRUCTED_COLOR,
                   "implied by the kinematic fit")
        style.band(ax[row, 0], t, check[f"{c}_best_fit"], check[f"{c}_best_fit_3sigma"], style.BEST_FIT_COLOR,
                   "dynamic fit's database")
        ax[row, 0].set_ylabel(f"${c[0]}_{{{c[1:]}}}$")
        a = AGAINST_ALPHA_T[c]
        ok = np.isfinite(implied[f"{a}_implied"])
        ax[row, 1].errorbar(implied["alpha_t_deg"][ok], implied[f"{a}_implied"][ok],
                            xerr=implied["alpha_t_deg_3sigma"][ok], yerr=implied[f"{a}_implied_3sigma"][ok],
                            fmt=".", ms=2, lw=0.4, color=style.RECONSTRUCTED_COLOR, alpha=0.5)
        ax[row, 1].plot(implied["alpha_t_deg"][ok], implied[f"{a}_database"][ok], ".", ms=2,
                        color=style.BEST_FIT_COLOR)
        ax[row, 1].set_ylabel(a.replace("_crossflow", " (crossflow plane)"))
        ax[row, 1].set_xlabel(r"$\alpha_T$, deg")
    ax[-1, 0].set_xlabel("time since the first compared node, s")
    style.figure_legend(fig, ncol=4)
    fig.suptitle(verdict, fontsize=9)
    return style.save_figure(fig, folder / "figures" / "kinematic_check", formats)[0]
