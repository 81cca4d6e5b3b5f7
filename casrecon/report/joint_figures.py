"""Multi-drop overlays of a joint fit (the EES paper's Figs. 10-12 put the four drops on one plot).

Every drop of the joint fit on one figure per quantity group, one colour per drop, against flight
time since release (s): the reconstruction with its 3-sigma band shaded light (left column) and,
since most bands are too thin to see at the scale of the flight, the 3-sigma itself (right
column). One legend per figure (the drops), above the panels.

Figures (:data:`OVERLAYS`; file names as in a joint folder's ``figures/``):

- ``joint_altitude_speed``: altitude above ground (m) and speed (m/s) (EES Fig. 10);
- ``joint_qbar_alpha_t``: dynamic pressure (Pa) and total angle of attack (deg) (EES Fig. 11);
- ``joint_flow_angles``: angle of attack and sideslip (deg);
- ``joint_rates``: body rates p, q, r (deg/s);
- ``joint_pitching_moment``: C_m about the MRP against angle of attack (deg), points reconstructed
  from each drop's measured rates, with the nominal and the jointly fitted database (EES Fig. 12).

The speed's 3-sigma comes from the NED components' 3-sigma (sum of the squares of each
component's share, their correlation neglected) unless the trajectory has a ``speed_mps`` column.
The sources are :class:`~casrecon.report.results_folder.DropFolder` or
:class:`~casrecon.report.results_folder.DropTables`, one per drop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from casrecon.report import figure_style as style
from casrecon.report.results_folder import DropFolder, DropTables, MissingInput
from casrecon.report.trajectory_figures import CM_MAX_ALPHA_DEG, CM_MIN_QBAR_PA

#: Trajectory columns the overlays read (``<name>_3sigma`` beside each), in one place.
TIME = "flight_time_s"
VELOCITY = ("vel_n_mps", "vel_e_mps", "vel_d_mps")
SPEED = "speed_mps"
SIGMA_SUFFIX = "_3sigma"
#: Columns of pitching_moment.csv and cm_curves.csv.
PM_TIME, PM_ALPHA, PM_QBAR, PM_CM = "time_imu_s", "alpha_deg", "qbar_pa", "cm_recon"
CURVE_ALPHA, CURVE_NOMINAL, CURVE_FITTED = "alpha_deg", "cm_nominal", "cm_fitted"
#: The C_m difference axis spans this percentile of |difference| (and the nominal curve); the
#: few points beyond (early, low-qbar nodes) are drawn at its edge.
DIFF_PERCENTILE = 99.5
#: Transparency of the 3-sigma bands.
BAND_ALPHA = 0.22


@dataclass(frozen=True)
class Quantity:
    """One panel row: trajectory column (``SPEED`` is derived), mathtext label and unit."""

    column: str
    label: str
    unit: str


#: Figure name -> (title, rows).
OVERLAYS: dict[str, tuple[str, tuple[Quantity, ...]]] = {
    "joint_altitude_speed": ("altitude and speed", (
        Quantity("h_agl_m", r"altitude $h_{\mathrm{AGL}}$", "m"), Quantity(SPEED, r"speed $V$", "m/s"))),
    "joint_qbar_alpha_t": ("dynamic pressure and total angle of attack", (
        Quantity("qbar_pa", r"dynamic pressure $\bar q$", "Pa"),
        Quantity("alpha_t_deg", r"total angle of attack $\alpha_T$", "deg"))),
    "joint_flow_angles": ("angle of attack and sideslip", (
        Quantity("alpha_deg", r"angle of attack $\alpha$", "deg"), Quantity("beta_deg", r"sideslip $\beta$", "deg"))),
    "joint_rates": ("body rates", (
        Quantity("p_dps", r"roll rate $p$", "deg/s"), Quantity("q_dps", r"pitch rate $q$", "deg/s"),
        Quantity("r_dps", r"yaw rate $r$", "deg/s"))),
}


#: Colours of the drops, in order: matplotlib's cycle without the colours the EES paper's Fig. 12
#: gives a meaning (black reconstructed, blue nominal database, red best fit).
DROP_COLORS = ("tab:orange", "tab:green", "tab:purple", "tab:brown", "tab:pink", "tab:olive", "tab:cyan",
               "tab:gray")
#: The nominal database's curve (blue, as in the EES paper's Fig. 12); the best fit is style.SIM_COLOR (red).
NOMINAL_COLOR = "tab:blue"


def drop_color(k: int) -> str:
    """Colour of the k-th drop (:data:`DROP_COLORS`, repeated beyond eight drops)."""
    return DROP_COLORS[k % len(DROP_COLORS)]


def history(drop: DropFolder | DropTables, column: str) -> tuple[np.ndarray, np.ndarray]:
    """Values and 3-sigma of a trajectory column; the speed derived from the NED velocity when the
    trajectory has no ``speed_mps`` (its 3-sigma from the components', correlation neglected)."""
    tr = drop.traj
    if column in tr:
        return tr[column], tr.get(column + SIGMA_SUFFIX, np.full_like(tr[column], np.nan))
    if column != SPEED:
        raise KeyError(column)
    v = np.vstack([tr[c] for c in VELOCITY])
    s = np.vstack([tr.get(c + SIGMA_SUFFIX, np.zeros_like(tr[c])) for c in VELOCITY])
    speed = np.sqrt((v ** 2).sum(axis=0))
    with np.errstate(invalid="ignore", divide="ignore"):
        three = np.sqrt(((v * s) ** 2).sum(axis=0)) / speed
    return speed, three


def _legend(fig: Figure, drops, band: bool = True) -> None:
    handles = [Line2D([], [], color=drop_color(k), lw=1.6, label=d.name) for k, d in enumerate(drops)]
    if band:
        handles.append(Patch(color="0.5", alpha=BAND_ALPHA + 0.1, label=r"$\pm 3\sigma$ band (light)"))
    fig.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 5), fontsize=9, frameon=False)


def overlay_figure(drops: list[DropFolder | DropTables], name: str, title: str = "joint fit", *,
                   ax: style.UserAxes | None = None) -> Figure:
    """Overlay figure ``name`` (a key of :data:`OVERLAYS`) of all drops."""
    if not drops:
        raise MissingInput("a joint overlay needs at least one drop")
    what, rows = OVERLAYS[name]
    fig, axes = style.new_figure(len(rows), 2, (13, 1.0 + 2.9 * len(rows)), ax=ax)
    for k, drop in enumerate(drops):
        t = drop.traj[TIME]
        for row, q in enumerate(rows):
            value, three = history(drop, q.column)
            color = drop_color(k)
            axes[row, 0].fill_between(t, value - three, value + three, color=color, alpha=BAND_ALPHA, lw=0)
            axes[row, 0].plot(t, value, color=color, lw=1.1)
            axes[row, 1].plot(t, three, color=color, lw=1.1)
    for row, q in enumerate(rows):
        axes[row, 0].set_ylabel(f"{q.label}, {q.unit}")
        axes[row, 1].set_ylabel(rf"$3\sigma$ of {q.label.split(' $')[0]}, {q.unit}")
        axes[row, 1].set_ylim(bottom=0)
    for ax in axes[-1]:
        ax.set_xlabel("flight time since release, s")
    axes[0, 0].set_title(r"reconstruction with $\pm 3\sigma$ band", fontsize=10)
    axes[0, 1].set_title(r"size of the $3\sigma$ band", fontsize=10)
    _legend(fig, drops)
    fig.suptitle(f"{title}: {what} of {len(drops)} drops")
    return fig


def _cm_points(drops) -> tuple[list[tuple[int, np.ndarray, np.ndarray]], dict | None]:
    """Per drop (index, alpha in deg, reconstructed C_m) within the per-drop figure's limits, and the
    database curves of the first drop that has them."""
    points, curves = [], None
    for k, drop in enumerate(drops):
        try:
            pm = drop.csv("pitching_moment.csv")
        except MissingInput:
            continue
        keep = (pm[PM_QBAR] > CM_MIN_QBAR_PA) & (np.abs(pm[PM_ALPHA]) < CM_MAX_ALPHA_DEG)
        points.append((k, pm[PM_ALPHA][keep], pm[PM_CM][keep]))
        if curves is None:
            try:
                curves = drop.csv("cm_curves.csv")
            except MissingInput:
                pass
    if not sum(a.size for _, a, _ in points):
        raise MissingInput("no drop has pitching_moment.csv points to draw")
    return points, curves


def pitching_moment_overlay(drops: list[DropFolder | DropTables], title: str = "joint fit", *,
                            ax: style.UserAxes | None = None) -> Figure:
    """C_m about the MRP against angle of attack (deg): each drop's points reconstructed from its
    measured rates (qbar and |alpha| limits of the per-drop figure), the nominal database and the
    jointly fitted one at beta = 0 (from the first drop that has cm_curves.csv; the shared
    factors make them the same for every drop); below, each drop's points and the nominal curve
    minus the fitted curve, where the drops can be told apart."""
    points, curves = _cm_points(drops)
    rows = 2 if curves is not None else 1
    fig, axes = style.new_figure(rows, 1, (9, 4.2 + 2.8 * rows), ax=ax)
    ax = axes[0, 0]
    for k, alpha, cm in points:
        ax.scatter(alpha, cm, s=9, color=drop_color(k), alpha=0.6, linewidths=0, zorder=2)
    handles = [Line2D([], [], color=drop_color(k), marker="o", ls="", label=f"{d.name} (reconstructed)")
               for k, d in enumerate(drops)]
    if curves is not None:
        a, fitted, nominal = curves[CURVE_ALPHA], curves[CURVE_FITTED], curves[CURVE_NOMINAL]
        ax.plot(a, fitted, color=style.SIM_COLOR, lw=1.3, zorder=3)
        ax.plot(a, nominal, color=NOMINAL_COLOR, ls="--", lw=1.3, zorder=4)
        handles += [Line2D([], [], color=style.SIM_COLOR, lw=1.3, label="best-fit dispersed database (joint)"),
                    Line2D([], [], color=NOMINAL_COLOR, ls="--", lw=1.3, label="nominal database")]
        low = axes[1, 0]
        diffs = [cm - np.interp(alpha, a, fitted) for _, alpha, cm in points]
        lim = 1.15 * max(float(np.max(np.abs(nominal - fitted))),
                         float(np.percentile(np.abs(np.concatenate(diffs)), DIFF_PERCENTILE)))
        beyond = sum(int((np.abs(d) > lim).sum()) for d in diffs)
        for (k, alpha, _), d in zip(points, diffs):
            low.scatter(alpha, np.clip(d, -lim, lim), s=7, color=drop_color(k), alpha=0.6, linewidths=0)
        low.plot(a, nominal - fitted, color=NOMINAL_COLOR, ls="--", lw=1.3)
        low.axhline(0, color=style.SIM_COLOR, lw=1.3)
        low.set_ylim(-lim, lim)
        low.set_ylabel(r"$C_m - C_{m,\mathrm{best\,fit}}$, -")
        low.set_title(r"difference from the best-fit database at the same $\alpha$"
                      + (f" ({beyond} points beyond the axis drawn at its edge)" if beyond else ""), fontsize=10)
    for axis in axes[:, 0]:
        axis.axvline(0, color="0.5", lw=0.8)
    ax.axhline(0, color="0.5", lw=0.8)
    axes[-1, 0].set_xlabel(r"angle of attack $\alpha$, deg")
    ax.set_ylabel(r"pitching moment coefficient $C_m$ about the MRP, -")
    fig.legend(handles=handles, loc="outside lower center", ncol=2, fontsize=9, frameon=False)
    fig.suptitle(f"{title}: pitching moment of {len(drops)} drops ($\\bar q$ > {CM_MIN_QBAR_PA:.0f} Pa, "
                 f"$|\\alpha|$ < {CM_MAX_ALPHA_DEG:.0f} deg; curves at $\\beta$ = 0)")
    return fig


#: Every overlay figure: file stem -> function(drops, title) -> Figure.
JOINT_FIGURES = {**{name: (lambda drops, title, _n=name: overlay_figure(drops, _n, title)) for name in OVERLAYS},
                 "joint_pitching_moment": pitching_moment_overlay}
