"""Figures of the aerodynamic coefficient histories of ``aero_coefficients.csv`` (the DAVINCI paper's
Figs. 12-15): reconstructed from the IMU (black, with its 3-sigma band), best-fit database (red, with
its band) and nominal database (blue) along the reconstructed trajectory, against flight time and
against the total angle of attack; and the size of the 3-sigma bands."""

from __future__ import annotations

import numpy as np
from matplotlib.figure import Figure

from casrecon.analysis import aero_columns as cols
from casrecon.report import figure_style as style
from casrecon.report.figure_layout import log_axis
from casrecon.report.results_folder import DropFolder

TABLE = "aero_coefficients.csv"
#: Mathtext symbol of each coefficient.
SYMBOLS = {"CA": r"$C_A$", "CY": r"$C_Y$", "CN": r"$C_N$", "Cl": r"$C_l$", "Cm": r"$C_m$", "Cn": r"$C_n$",
           "CN_crossflow": r"$C_N(\alpha_T)$", "Cm_crossflow": r"$C_m(\alpha_T)$"}
#: Panels of the time figure: forces (left column), moments about the MRP (right column).
TIME_PANELS = (("CA", "Cl"), ("CY", "Cm"), ("CN", "Cn"))
#: Panels of the alpha_T figure (crossflow-plane resultants).
ALPHA_PANELS = ("CA", "CN_crossflow", "Cm_crossflow")
#: Error bars drawn on at most this many reconstructed points of the alpha_T figure.
MAX_ERROR_BARS = 60
#: The y range of a time panel covers this central share of the plotted values (an early spike at
#: low dynamic pressure does not squash the rest), plus a margin.
Y_QUANTILES = (0.002, 0.998)

VARIANTS = ((cols.RECONSTRUCTED, "reconstructed from the IMU", style.RECONSTRUCTED_COLOR),
            (cols.BEST_FIT, "best-fit database", style.BEST_FIT_COLOR))
#: Line style of each variant in the time figure: the reconstruction on top of the best fit.
LINES = {cols.RECONSTRUCTED: dict(lw=0.9, zorder=3.0), cols.BEST_FIT: dict(lw=2.6, alpha=0.45, zorder=2.5)}


def band_width_pt(ax, three_sigma: np.ndarray) -> float:
    """Median full width (pt, on the page) of a +-3-sigma band ``three_sigma`` (data units) drawn
    on ``ax`` at its current y limits (the axes' height before the final layout)."""
    lo, hi = ax.get_ylim()
    fig = ax.get_figure(root=True)
    height_pt = ax.get_position().height * fig.get_figheight() * 72.0
    three = np.asarray(three_sigma, float)
    three = three[np.isfinite(three)]
    return float(np.median(2.0 * three)) / abs(hi - lo) * height_pt if three.size and hi != lo else 0.0


def note_narrow_bands(ax, tab, coef: str) -> None:
    """Say in a panel of the time figure which +-3-sigma band is there but narrower than the line
    drawn over it (mostly hidden under it), so a missing band is not read as no band."""
    narrow = []
    for variant, label, _ in VARIANTS:
        if band_width_pt(ax, tab[cols.sigma_column(coef, variant)]) < LINES[variant]["lw"]:
            narrow.append(f"{label} {style.PM3SIGMA} band narrower than its line")
    if narrow:
        ax.text(0.01, 0.97, "\n".join(narrow), transform=ax.transAxes, va="top", ha="left", fontsize=7.5,
                bbox=dict(boxstyle="round", fc="white", ec="0.7", alpha=0.85), zorder=5)


def _y_range(values: list[np.ndarray]) -> tuple[float, float] | None:
    v = np.concatenate([np.asarray(x)[np.isfinite(x)] for x in values])
    if v.size == 0:
        return None
    lo, hi = np.quantile(v, Y_QUANTILES)
    pad = 0.08 * (hi - lo) if hi > lo else max(abs(hi), 1e-6) * 0.1
    return float(lo - pad), float(hi + pad)


def label_time_panels(axes) -> None:
    """Time axis labels under the bottom row, and the force / moment column titles."""
    for ax in axes[-1]:
        ax.set_xlabel(style.FLIGHT_TIME_LABEL)
    axes[0, 0].set_title("force coefficients, body axes")
    axes[0, 1].set_title("moment coefficients about the MRP, body axes")


def aero_coefficients_figure(drop: DropFolder, *, ax: style.UserAxes | None = None) -> Figure:
    """C_A, C_Y, C_N (body axes) and C_l, C_m, C_n (about the MRP) against flight time (s): the
    reconstruction with its 3-sigma band, the best-fit database with its band and the nominal
    database along the reconstructed trajectory."""
    tab = drop.csv(TABLE)
    t = tab[cols.FLIGHT_TIME]
    fig, axes = style.new_figure(3, 2, (13, 9.5), fixed=True, ax=ax)
    for r, row in enumerate(TIME_PANELS):
        for c, coef in enumerate(row):
            ax = axes[r, c]
            shown = []
            ax.plot(t, tab[cols.column(coef, cols.NOMINAL)], color=style.NOMINAL_COLOR, lw=1.0, ls="--",
                    label="nominal database")
            # the best fit a wide translucent line under the reconstruction's black one, on top: where
            # they agree the black line runs inside a light red one (a thin black line under a wide
            # red one, or on an opaque one, was hidden)
            for variant, label, color in VARIANTS[::-1]:
                value, three = tab[cols.column(coef, variant)], tab[cols.sigma_column(coef, variant)]
                ax.fill_between(t, value - three, value + three, color=color, alpha=style.BAND_ALPHA, lw=0,
                                label=f"{label} {style.PM3SIGMA}")
                ax.plot(t, value, color=color, label=label, **LINES[variant])
                shown += [value - three, value + three]
            limits = _y_range(shown)
            if limits is not None:
                ax.set_ylim(*limits)
            note_narrow_bands(ax, tab, coef)
            ax.set_ylabel(f"{SYMBOLS[coef]}, -")
    label_time_panels(axes)
    style.figure_legend(fig, ncol=5)
    fig.suptitle(f"{drop.name}: aerodynamic coefficients along the reconstructed trajectory")
    return fig


def aero_sigma_figure(drop: DropFolder, *, ax: style.UserAxes | None = None) -> Figure:
    """Size of the 3-sigma bands of :func:`aero_coefficients_figure` against flight time (s), log
    scale: which coefficient is limited by the measurement noise and which by the parameters."""
    tab = drop.csv(TABLE)
    t = tab[cols.FLIGHT_TIME]
    fig, axes = style.new_figure(3, 2, (13, 9.5), fixed=True, ax=ax)
    for r, row in enumerate(TIME_PANELS):
        for c, coef in enumerate(row):
            ax = axes[r, c]
            for variant, label, color in VARIANTS:
                ax.plot(t, tab[cols.sigma_column(coef, variant)], color=color, lw=1.0, label=label)
            log_axis(ax.yaxis)
            ax.set_ylabel(f"3$\\sigma$ of {SYMBOLS[coef]}, -")
    label_time_panels(axes)
    style.figure_legend(fig)
    fig.suptitle(f"{drop.name}: size of the {style.PM3SIGMA} bands of the aerodynamic coefficients")
    return fig


def aero_alpha_t_figure(drop: DropFolder, *, ax: style.UserAxes | None = None) -> Figure:
    """C_A and the crossflow-plane C_N and C_m against the total angle of attack (deg) at every node:
    reconstructed points (3-sigma error bars on a subset), best-fit and nominal database points."""
    tab = drop.csv(TABLE)
    a = tab[cols.ALPHA_T]
    fig, axes = style.new_figure(1, 3, (15, 5.2), sharex=True, fixed=True, ax=ax)
    for ax, coef in zip(axes[0], ALPHA_PANELS):
        rec, three = tab[cols.column(coef, cols.RECONSTRUCTED)], tab[cols.sigma_column(coef, cols.RECONSTRUCTED)]
        ax.plot(a, tab[cols.column(coef, cols.NOMINAL)], ".", ms=2, color=style.NOMINAL_COLOR, rasterized=True,
                label="nominal database")
        ax.plot(a, tab[cols.column(coef, cols.BEST_FIT)], ".", ms=3, color=style.BEST_FIT_COLOR, rasterized=True,
                label="best-fit database")
        ax.plot(a, rec, ".", ms=1.2, color=style.RECONSTRUCTED_COLOR, rasterized=True,
                label="reconstructed from the IMU")
        every = max(1, int(np.isfinite(rec).sum()) // MAX_ERROR_BARS)
        some = np.flatnonzero(np.isfinite(rec))[::every]
        ax.errorbar(a[some], rec[some], yerr=three[some], fmt="none", ecolor="0.4", elinewidth=0.8, capsize=2,
                    label=f"reconstructed {style.PM3SIGMA} (every {every}th node)")
        ax.set_ylabel(f"{SYMBOLS[coef]}, -")
        ax.set_xlabel(r"total angle of attack $\alpha_T$, deg")
    axes[0, 0].set_title("axial force")
    axes[0, 1].set_title("normal force in the crossflow plane")
    axes[0, 2].set_title("pitching moment in the crossflow plane (MRP)")
    style.figure_legend(fig, markerscale=4)
    fig.suptitle(f"{drop.name}: aerodynamic coefficients against total angle of attack (every node)")
    return fig
