"""Figure of a GPS-only fit: data and fit, normalised residuals of both models, drag area."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from matplotlib.figure import Figure
from matplotlib.ticker import FixedLocator, FuncFormatter, NullLocator

from casrecon.report import figure_style as style
from casrecon.report.results_folder import read_csv

#: Colours and names of the horizontal residual components (not the colour code's meanings).
COMPONENT_COLORS = ("tab:cyan", "tab:olive", "tab:pink", "tab:brown")
COMPONENT_LABELS = {"pos_n": "north position", "pos_e": "east position", "vel_n": "$v_N$", "vel_e": "$v_E$"}


#: Ticks of the symmetric-log residual axes (in sigmas): linear within +-3 sigma, then decades.
SYMLOG_TICKS = (0.0, *[sign * v for v in (3.0, 10.0, 100.0, 1e3, 1e4) for sign in (-1.0, 1.0)])


def plot_track_fit(folder: Path, formats: Sequence[str] = style.DEFAULT_FORMATS) -> Path:
    """``figures/track_fit.png`` of a point-mass results folder (:func:`track_fit_figure`), saved in
    each of ``formats``; the PNG's (or first) path returned."""
    return style.save_figure(track_fit_figure(folder), Path(folder) / "figures" / "track_fit", formats)[0]


def residual_axis(ax) -> None:
    """Symmetric-log y axis of normalised residuals: linear within +-3 sigma, plain tick labels
    (``-10, -3, 0, 3, 10``, not matplotlib's ``-10^0, 0, 10^0``)."""
    ax.set_yscale("symlog", linthresh=3)
    ax.yaxis.set_major_locator(FixedLocator(SYMLOG_TICKS))
    ax.yaxis.set_minor_locator(NullLocator())
    ax.yaxis.set_major_formatter(FuncFormatter(lambda v, _: f"{v:g}"))


def track_fit_figure(folder: Path) -> Figure:
    """The figure of a point-mass results folder: height and vertical speed (GPS dots, fitted line),
    normalised residuals of the fitted and the constant-drag model, and the drag area (the fit's
    black line) with its 3-sigma band."""
    folder = Path(folder)
    tr, res, fix = (read_csv(folder / name) for name in ("trajectory.csv", "residuals_gps.csv", "gps_fixes.csv"))
    import json

    name = json.loads((folder / "summary.json").read_text()).get("problem", folder.name)
    fig, ax = style.new_figure(3, 2, (13, 10.5))
    used = fix["used"] > 0.5
    t = tr["segment_time_s"]
    gps = dict(ls="none", marker=".", ms=3, color=style.MEASUREMENT_COLOR, label="GPS fix")
    fit = dict(color=style.RECONSTRUCTED_COLOR, lw=1.2, label="fit (fitted drag area)")
    ax[0, 0].plot(fix["segment_time_s"][used], -fix["pos_d_m"][used], **gps)
    ax[0, 0].plot(t, -tr["pos_d_m"], **fit)
    ax[0, 0].set_ylabel("height above ground, m")
    ax[0, 1].plot(fix["segment_time_s"][used], fix["vel_d_mps"][used], **gps)
    ax[0, 1].plot(t, tr["vel_d_mps"], **fit)
    ax[0, 1].set_ylabel("vertical speed $v_D$ (down), m/s")
    three = dict(color=style.SIGMA_COLOR, ls=":", lw=0.9, label=style.PM3SIGMA)
    for k, (comp, label) in enumerate((("pos_d", "down position"), ("vel_d", "$v_D$"))):
        a = ax[1, k]
        a.plot(res["segment_time_s"], res[f"{comp}_constant_z"], ".", ms=3, color=style.NOMINAL_COLOR,
               label="residual, constant drag area")
        a.plot(res["segment_time_s"], res[f"{comp}_fit_z"], ".", ms=3, color=style.RECONSTRUCTED_COLOR,
               label="residual, fitted drag area")
        for s in (-3, 3):
            a.axhline(s, **three)
        a.set_ylabel(f"{label} residual / receiver $\\sigma$")
        residual_axis(a)
    a = ax[2, 0]
    for comp, c in zip(("pos_n", "pos_e", "vel_n", "vel_e"), COMPONENT_COLORS):
        a.plot(res["segment_time_s"], res[f"{comp}_fit_z"], ".", ms=2, color=c,
               label=f"residual {COMPONENT_LABELS[comp]}")
    for s in (-3, 3):
        a.axhline(s, **three)
    a.set_ylabel("horizontal residual / $\\sigma$ (fitted drag area)")
    a = ax[2, 1]
    # the fit's black line, already in the legend as "fit (fitted drag area)": not a second entry
    style.band(a, t, tr["cda_m2"], tr["cda_m2_3sigma"], style.RECONSTRUCTED_COLOR, "_nolegend_",
               f"drag area {style.PM3SIGMA}")
    a.set_ylabel("drag area $C_D A$, m$^2$")
    for a in ax[-1]:
        a.set_xlabel("time since segment start, s")
    style.figure_legend(fig, ncol=5, markerscale=3)
    fig.suptitle(f"{name}: GPS-only point-mass fit")
    return fig
