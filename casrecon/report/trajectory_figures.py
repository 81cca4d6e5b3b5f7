"""Figures of a drop's flight: altitude and velocity, dynamic pressure and angle of attack, the
reconstructed pitching moment, and the reconciled forward simulation (flight time t in s since release)."""

from __future__ import annotations

import logging
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure

from casrecon.report import figure_style as style
from casrecon.report.results_folder import DropFolder, MissingInput

log = logging.getLogger(__name__)

#: Reconstructed C_m points are shown only above this dynamic pressure (Pa) ...
CM_MIN_QBAR_PA = 100.0
#: ... and below this |angle of attack| (deg).
CM_MAX_ALPHA_DEG = 20.0


def altitude_velocity_figure(drop: DropFolder) -> Figure:
    """Altitude AGL (m), vertical velocity and speed, horizontal velocity (m/s) against flight time
    (s): reconstruction lines and, if gps_fixes.csv exists, GPS fixes as dots (altitude = -pos_d)."""
    tr = drop.traj
    t = tr["flight_time_s"]
    speed = style.speed(tr["vel_n_mps"], tr["vel_e_mps"], tr["vel_d_mps"])
    try:
        gps = drop.csv("gps_fixes.csv")
    except MissingInput as exc:
        log.info("altitude_velocity: no GPS dots (%s)", exc)
        gps = None
    fig, axes = style.new_figure(3, 1, (9, 9.5))
    a_h, a_v, a_hor = axes[:, 0]
    a_h.plot(t, tr["h_agl_m"], color=style.RECON_COLOR, label="reconstruction")
    a_v.plot(t, tr["vel_d_mps"], color="C0", label="v_D reconstruction")
    a_v.plot(t, speed, color="C2", label="speed reconstruction")
    a_hor.plot(t, tr["vel_n_mps"], color="C0", label="v_N reconstruction")
    a_hor.plot(t, tr["vel_e_mps"], color="C1", label="v_E reconstruction")
    if gps is not None:
        tg = drop.flight_time(gps["time_imu_s"])
        dots = dict(s=9, zorder=3, marker="o", linewidths=0)
        a_h.scatter(tg, -gps["pos_d_m"], color=style.GPS_COLOR, label="GPS fix", **dots)
        a_v.scatter(tg, gps["vel_d_mps"], color="C0", edgecolors="k", label="v_D GPS", **dots)
        a_v.scatter(tg, style.speed(gps["vel_n_mps"], gps["vel_e_mps"], gps["vel_d_mps"]), color="C2",
                    label="speed GPS", **dots)
        a_hor.scatter(tg, gps["vel_n_mps"], color="C0", label="v_N GPS", **dots)
        a_hor.scatter(tg, gps["vel_e_mps"], color="C1", label="v_E GPS", **dots)
    a_h.set_ylabel("altitude AGL, m")
    a_v.set_ylabel("down velocity, speed, m/s")
    a_hor.set_ylabel("north, east velocity, m/s")
    a_hor.set_xlabel("flight time since release, s")
    for ax in axes[:, 0]:
        ax.legend(fontsize=8, ncol=2, loc="best")
    fig.suptitle(f"{drop.name}: altitude and velocity (lines: reconstruction, dots: GPS antenna)")
    return fig


def plot_altitude_velocity(drop: DropFolder, out: Path) -> Path:
    """Save :func:`altitude_velocity_figure` as ``out / "altitude_velocity.png"``."""
    return style.save_figure(altitude_velocity_figure(drop), out / "altitude_velocity.png")


def qbar_alpha_t_figure(drop: DropFolder) -> Figure:
    """Dynamic pressure (Pa) and total angle of attack (deg) against flight time (s) with shaded
    3-sigma bands (left), and the 3-sigma itself against time (right) since the bands are thin."""
    tr = drop.traj
    t = tr["flight_time_s"]
    fig, axes = style.new_figure(2, 2, (12, 7.5))
    rows = (("qbar_pa", "dynamic pressure", "Pa", "C0"),
            ("alpha_t_deg", "total angle of attack", "deg", "C3"))
    for k, (col, label, unit, color) in enumerate(rows):
        three = tr[f"{col}_3sigma"]
        style.band(axes[k, 0], t, tr[col], three, color, label)
        axes[k, 0].set_ylabel(f"{label}, {unit}")
        axes[k, 0].legend(fontsize=8)
        axes[k, 1].plot(t, three, color=color, label=f"3-sigma of {label}")
        axes[k, 1].set_ylabel(f"3-sigma, {unit}")
        axes[k, 1].set_ylim(bottom=0)
        axes[k, 1].legend(fontsize=8)
    for ax in axes[1]:
        ax.set_xlabel("flight time since release, s")
    axes[0, 0].set_title("value with 3-sigma band")
    axes[0, 1].set_title("size of the 3-sigma band")
    fig.suptitle(f"{drop.name}: dynamic pressure and total angle of attack")
    return fig


def plot_qbar_alpha_t(drop: DropFolder, out: Path) -> Path:
    """Save :func:`qbar_alpha_t_figure` as ``out / "qbar_alpha_t.png"``."""
    return style.save_figure(qbar_alpha_t_figure(drop), out / "qbar_alpha_t.png")


def pitching_moment_figure(drop: DropFolder) -> Figure:
    """C_m,body about the MRP against angle of attack (deg): points reconstructed from the measured
    rates (qbar > 100 Pa and |alpha| < 20 deg, colored by flight time, s), nominal database curve and
    best-fit dispersed curve at beta = 0 (EES paper Fig. 12)."""
    pm = drop.csv("pitching_moment.csv")
    keep = (pm["qbar_pa"] > CM_MIN_QBAR_PA) & (np.abs(pm["alpha_deg"]) < CM_MAX_ALPHA_DEG)
    try:
        curves = drop.csv("cm_curves.csv")
    except MissingInput as exc:
        log.info("pitching_moment: no database curves (%s)", exc)
        curves = None
    fig, axes = style.new_figure(1, 1, (9, 6.5))
    ax = axes[0, 0]
    pts = ax.scatter(pm["alpha_deg"][keep], pm["cm_recon"][keep], c=drop.flight_time(
        pm["time_imu_s"][keep]), cmap="viridis", s=12, zorder=2, label=f"reconstructed ({keep.sum()} nodes)")
    fig.colorbar(pts, ax=ax, label="flight time since release, s")
    if curves is not None:
        # fitted under the points, nominal dashed on top: both stay visible when they coincide
        ax.plot(curves["alpha_deg"], curves["cm_fitted"], color="C3", lw=2.5, zorder=1.5,
                label="best-fit dispersed")
        ax.plot(curves["alpha_deg"], curves["cm_nominal"], "k--", lw=1.3, zorder=3,
                label="nominal database")
    ax.axhline(0, color="0.5", lw=0.8)
    ax.axvline(0, color="0.5", lw=0.8)
    ax.set_xlabel("angle of attack alpha, deg")
    ax.set_ylabel("pitching moment coefficient C_m about the MRP, -")
    ax.legend(fontsize=9)
    ax.set_title(f"{drop.name}: pitching moment (points: qbar > {CM_MIN_QBAR_PA:.0f} Pa, "
                 f"|alpha| < {CM_MAX_ALPHA_DEG:.0f} deg; curves at beta = 0)")
    return fig


def plot_pitching_moment(drop: DropFolder, out: Path) -> Path:
    """Save :func:`pitching_moment_figure` as ``out / "pitching_moment.png"``."""
    return style.save_figure(pitching_moment_figure(drop), out / "pitching_moment.png")


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


def reconciled_figure(drop: DropFolder) -> Figure:
    """Reconstruction against the reconciled forward simulation: altitude AGL (m), speed (m/s),
    total angle of attack (deg) and, if reconciled.csv has it, roll rate (deg/s) against flight time
    (s) (left; the nominal-database simulation of nominal.csv dotted if present), and fitted
    simulation minus reconstruction at the nodes (right); a text box gives the differences."""
    sim = drop.csv("reconciled.csv")
    try:
        nominal = drop.csv("nominal.csv")
    except MissingInput:
        nominal = None
    tr = drop.traj
    t = tr["flight_time_s"]
    recon = {"h_agl_m": tr["h_agl_m"], "alpha_t_deg": tr["alpha_t_deg"], "p_dps": tr["p_dps"],
             "speed_mps": style.speed(tr["vel_n_mps"], tr["vel_e_mps"], tr["vel_d_mps"])}
    inside = (t >= sim["flight_time_s"].min()) & (t <= sim["flight_time_s"].max())
    rows = [("h_agl_m", "altitude AGL", "m"), ("speed_mps", "speed (inertial)", "m/s"),
            ("alpha_t_deg", "total angle of attack", "deg")]
    if "p_dps" in sim:
        rows.append(("p_dps", "roll rate p", "deg/s"))
    fig, axes = style.new_figure(len(rows), 2, (14, 3.2 * len(rows)))
    for k, (col, label, unit) in enumerate(rows):
        ax, ad = axes[k]
        y = recon[col]
        ax.plot(t, y, color=style.RECON_COLOR, lw=1.5, label="reconstruction")
        ax.plot(sim["flight_time_s"], sim[col], color=style.SIM_COLOR, lw=1.0, ls="--",
                label="simulation, fitted dispersions")
        if nominal is not None and col in nominal:
            ax.plot(nominal["flight_time_s"], nominal[col], color="0.45", lw=1.0, ls=":",
                    label="simulation, nominal database")
        ax.set_ylabel(f"{label}, {unit}")
        ax.legend(fontsize=8, loc="best")
        diff = np.interp(t[inside], sim["flight_time_s"], sim[col]) - y[inside]
        ad.plot(t[inside], diff, color="C4", lw=1.0, label="fitted simulation - reconstruction")
        ad.axhline(0, color="0.4", lw=0.8)
        ad.set_ylabel(f"{label} difference, {unit}")
        ad.legend(fontsize=8, loc="best")
    for ax in axes[-1]:
        ax.set_xlabel("flight time since release, s")
    axes[0, 0].set_title("reconstruction and simulation")
    axes[0, 1].set_title("fitted simulation minus reconstruction (at the nodes)")
    axes[0, 0].text(0.02, 0.05, _reconciled_text(drop.summary), transform=axes[0, 0].transAxes,
                    fontsize=8.5, va="bottom", bbox=dict(boxstyle="round", fc="white", ec="0.6"))
    fig.suptitle(f"{drop.name}: reconstruction vs forward simulation with the fitted dispersions")
    return fig


def plot_reconciled(drop: DropFolder, out: Path) -> Path:
    """Save :func:`reconciled_figure` as ``out / "reconciled.png"``."""
    return style.save_figure(reconciled_figure(drop), out / "reconciled.png")
