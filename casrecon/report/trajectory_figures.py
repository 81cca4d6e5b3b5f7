"""Figures of a drop's flight: altitude and velocity, dynamic pressure and angle of attack, the
reconstructed pitching moment, and the reconciled forward simulation (flight time t in s since
release). Colours follow :mod:`casrecon.report.figure_style` (reconstructed black, nominal blue, best
fit red, measurements orange)."""

from __future__ import annotations

import logging

import numpy as np
from matplotlib.figure import Figure

from casrecon.report import figure_style as style
from casrecon.report import results_folder as rf
from casrecon.report.results_folder import DropFolder, MissingInput

log = logging.getLogger(__name__)

#: Reconstructed C_m points are shown only above this dynamic pressure (Pa) ...
CM_MIN_QBAR_PA = 100.0
#: ... and below this |angle of attack| (deg).
CM_MAX_ALPHA_DEG = 20.0
#: Labels of the reconstruction and the GPS.
RECON_LABEL = "reconstruction (centre of mass)"
GPS_LABEL = "GPS fix (antenna)"


def altitude_velocity_figure(drop: DropFolder, *, ax: style.UserAxes | None = None) -> Figure:
    """Altitude AGL (m), speed, north, east and down velocity (m/s) against flight time (s) and the
    ground track (m, when the trajectory has north and east positions): reconstruction lines and, if
    gps_fixes.csv exists, GPS fixes as dots (altitude = -pos_d)."""
    tr = drop.traj
    t = tr[rf.FLIGHT_TIME]
    vel = [tr[c] for c in rf.VEL_NED]
    try:
        gps = drop.csv("gps_fixes.csv")
    except MissingInput as exc:
        log.info("altitude_velocity: no GPS dots (%s)", exc)
        gps = None
    fig, axes = style.new_figure(3, 2, (13, 9.5), sharex=False, fixed=True, ax=ax)
    panels = ((axes[0, 0], tr[rf.H_AGL], "altitude AGL $h$, m"), (axes[0, 1], style.speed(*vel), "speed $|v|$, m/s"),
              (axes[1, 0], vel[0], "north velocity $v_N$, m/s"), (axes[1, 1], vel[1], "east velocity $v_E$, m/s"),
              (axes[2, 0], vel[2], "down velocity $v_D$, m/s"))
    dots = dict(ls="none", marker="o", ms=2.2, color=style.MEASUREMENT_COLOR, zorder=3, label=GPS_LABEL)
    if gps is not None:
        tg = drop.flight_time(gps[rf.TIME_IMU])
        gvel = [gps[c] for c in rf.VEL_NED]
        measured = (-gps[rf.POS_NED[2]], style.speed(*gvel), *gvel)
    for k, (ax, y, label) in enumerate(panels):
        ax.sharex(axes[0, 0])
        ax.plot(t, y, color=style.RECONSTRUCTED_COLOR, lw=1.1, zorder=4, label=RECON_LABEL)
        if gps is not None:
            ax.plot(tg, measured[k], **dots)
        ax.set_ylabel(label)
        ax.set_xlabel(style.FLIGHT_TIME_LABEL)
    ax = axes[2, 1]
    if rf.POS_NED[0] in tr and rf.POS_NED[1] in tr:
        ax.plot(tr[rf.POS_NED[1]], tr[rf.POS_NED[0]], color=style.RECONSTRUCTED_COLOR, lw=1.2, label=RECON_LABEL)
        if gps is not None:
            ax.plot(gps[rf.POS_NED[1]], gps[rf.POS_NED[0]], **dots)
        ax.set_aspect("equal", adjustable="datalim")
        ax.set_xlabel("east of the site, m")
        ax.set_ylabel("north of the site, m")
        ax.set_title("ground track", fontsize=10)
    else:
        ax.set_axis_off()  # a trajectory without horizontal positions: no ground track
    style.figure_legend(fig, markerscale=2)
    fig.suptitle(f"{drop.name}: altitude and velocity")
    return fig


def qbar_alpha_t_figure(drop: DropFolder, *, ax: style.UserAxes | None = None) -> Figure:
    """Dynamic pressure (Pa) and total angle of attack (deg) against flight time (s) with shaded
    3-sigma bands (left), and the 3-sigma itself against time (right) since the bands are thin."""
    tr = drop.traj
    t = tr[rf.FLIGHT_TIME]
    fig, axes = style.new_figure(2, 2, (13, 7.5), fixed=True, ax=ax)
    rows = ((rf.QBAR, r"dynamic pressure $\bar q$", "Pa"), (rf.ALPHA_T, r"total angle of attack $\alpha_T$", "deg"))
    for k, (col, label, unit) in enumerate(rows):
        three = tr[rf.three_sigma(col)]
        style.band(axes[k, 0], t, tr[col], three, style.RECONSTRUCTED_COLOR, "reconstruction",
                   f"reconstruction {style.PM3SIGMA}")
        axes[k, 0].set_ylabel(f"{label}, {unit}")
        axes[k, 1].plot(t, three, color=style.SIGMA_COLOR, lw=1.2, label=f"size of the {style.PM3SIGMA} band")
        axes[k, 1].set_ylabel(f"3$\\sigma$ of {label.split(' $')[0]}, {unit}")
        axes[k, 1].set_ylim(bottom=0)
    for ax in axes[1]:
        ax.set_xlabel(style.FLIGHT_TIME_LABEL)
    axes[0, 0].set_title(f"value with its {style.PM3SIGMA} band")
    axes[0, 1].set_title(f"size of the {style.PM3SIGMA} band")
    style.figure_legend(fig)
    fig.suptitle(f"{drop.name}: dynamic pressure and total angle of attack")
    return fig


def pitching_moment_figure(drop: DropFolder, *, ax: style.UserAxes | None = None) -> Figure:
    """C_m,body about the MRP against angle of attack (deg): points reconstructed from the measured
    rates (qbar > 100 Pa and |alpha| < 20 deg), nominal database curve and best-fit dispersed curve at
    beta = 0 (EES paper Fig. 12: black, blue, red)."""
    pm = drop.csv("pitching_moment.csv")
    keep = ((pm[rf.QBAR] > CM_MIN_QBAR_PA) & (np.abs(pm[rf.ALPHA]) < CM_MAX_ALPHA_DEG)
            & np.isfinite(pm[rf.CM_RECONSTRUCTED]))
    try:
        curves = drop.csv("cm_curves.csv")
    except MissingInput as exc:
        log.info("pitching_moment: no database curves (%s)", exc)
        curves = None
    fig, axes = style.new_figure(1, 1, (9, 6.8), fixed=True, ax=ax)
    ax = axes[0, 0]
    ax.plot(pm[rf.ALPHA][keep], pm[rf.CM_RECONSTRUCTED][keep], ".", ms=3, color=style.RECONSTRUCTED_COLOR,
            zorder=2, rasterized=True, label=f"reconstructed from the measured rates ({keep.sum()} nodes)")
    if curves is not None:
        ax.plot(curves[rf.ALPHA], curves[rf.CM_NOMINAL], color=style.NOMINAL_COLOR, lw=2.0, zorder=3,
                label="nominal database")
        ax.plot(curves[rf.ALPHA], curves[rf.CM_BEST_FIT], color=style.BEST_FIT_COLOR, lw=2.0, ls="--", zorder=3,
                label="best-fit dispersed database")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.axvline(0, color="0.5", lw=0.8)
    ax.set_xlabel(r"angle of attack $\alpha$, deg")
    ax.set_ylabel(r"pitching moment coefficient $C_m$ about the MRP, -")
    ax.set_title(rf"points: $\bar q$ > {CM_MIN_QBAR_PA:.0f} Pa, $|\alpha|$ < {CM_MAX_ALPHA_DEG:.0f} deg; "
                 r"curves: static $C_m$ at $\beta$ = 0", fontsize=10)
    style.figure_legend(fig, ncol=1, markerscale=3)
    fig.suptitle(f"{drop.name}: pitching moment")
    return fig


def _reconciled_text(summary: dict) -> str:
    """Flight time (s) and impact speed (m/s) of summary["reconciled"], simulated minus
    reconstructed."""
    rec = summary.get("reconciled") or {}

    def fmt(key: str, form: str) -> str:
        value = rec.get(key)
        return format(value, form) if isinstance(value, (int, float)) else "n/a"

    return (f"simulation minus reconstruction:\n"
            f"flight time {fmt('flight_time_difference_s', '+.4g')} s "
            f"(sim {fmt('simulated_flight_time_s', '.3f')} s, "
            f"recon {fmt('reconstructed_flight_time_s', '.3f')} s)\n"
            f"impact speed {fmt('impact_speed_difference_mps', '+.4g')} m/s "
            f"(sim {fmt('simulated_impact_speed_mps', '.2f')} m/s, "
            f"recon {fmt('reconstructed_end_speed_mps', '.2f')} m/s)")


def reconciled_figure(drop: DropFolder, *, ax: style.UserAxes | None = None) -> Figure:
    """Reconstruction against the reconciled forward simulation: altitude AGL (m), speed (m/s),
    total angle of attack (deg) and, if reconciled.csv has it, roll rate (deg/s) against flight time
    (s) (left; the nominal-database simulation of nominal.csv too if present), and fitted
    simulation minus reconstruction at the nodes (right); a text box gives the differences."""
    sim = drop.csv("reconciled.csv")
    try:
        nominal = drop.csv("nominal.csv")
    except MissingInput:
        nominal = None
    tr = drop.traj
    t = tr[rf.FLIGHT_TIME]
    recon = {rf.H_AGL: tr[rf.H_AGL], rf.ALPHA_T: tr[rf.ALPHA_T], rf.ROLL_RATE: tr[rf.ROLL_RATE],
             rf.SPEED: style.speed(*[tr[c] for c in rf.VEL_NED])}
    ts = sim[rf.FLIGHT_TIME]
    inside = (t >= ts.min()) & (t <= ts.max())
    rows = [(rf.H_AGL, "altitude AGL $h$", "m"), (rf.SPEED, "speed $|v|$ (inertial)", "m/s"),
            (rf.ALPHA_T, r"total angle of attack $\alpha_T$", "deg")]
    if rf.ROLL_RATE in sim:
        rows.append((rf.ROLL_RATE, "roll rate $p$", "deg/s"))
    fig, axes = style.new_figure(len(rows), 2, (14, 3.1 * len(rows) + 0.6), fixed=True, ax=ax)
    for k, (col, label, unit) in enumerate(rows):
        ax, ad = axes[k]
        y = recon[col]
        ax.plot(t, y, color=style.RECONSTRUCTED_COLOR, lw=1.4, label="reconstruction")
        if nominal is not None and col in nominal:
            ax.plot(nominal[rf.FLIGHT_TIME], nominal[col], color=style.NOMINAL_COLOR, lw=1.0, ls=":",
                    label="simulation, nominal database")
        ax.plot(ts, sim[col], color=style.BEST_FIT_COLOR, lw=1.0, ls="--", label="simulation, best-fit dispersions")
        ax.set_ylabel(f"{label}, {unit}")
        diff = np.interp(t[inside], ts, sim[col]) - y[inside]
        ad.plot(t[inside], diff, color=style.BEST_FIT_COLOR, lw=1.0)
        ad.axhline(0, color="0.4", lw=0.8)
        ad.ticklabel_format(axis="y", style="plain", useOffset=False)  # no "1e-5" above the axis: plain numbers
        ad.set_ylabel(f"difference, {unit}")
    for ax in axes[-1]:
        ax.set_xlabel(style.FLIGHT_TIME_LABEL)
    axes[0, 0].set_title("reconstruction and simulations")
    axes[0, 1].set_title("best-fit simulation minus reconstruction (at the nodes)")
    axes[0, 0].text(0.02, 0.05, _reconciled_text(drop.summary), transform=axes[0, 0].transAxes,
                    fontsize=8.5, va="bottom", bbox=dict(boxstyle="round", fc="white", ec="0.6"))
    style.figure_legend(fig)
    fig.suptitle(f"{drop.name}: reconstruction against forward simulations")
    return fig
