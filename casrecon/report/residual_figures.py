"""Figures of a fit's quality: IMU and GPS residuals with their sigma lines, and the parameter
correlation matrix."""

from __future__ import annotations

import logging

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

from casrecon.report import figure_style as style
from casrecon.report import results_folder as rf
from casrecon.report.figure_layout import text_width_pt
from casrecon.report.results_folder import DropFolder, MissingInput

log = logging.getLogger(__name__)

#: Mathtext name of each IMU channel and GPS component.
IMU_SYMBOLS = {"ax": "$f_x$", "ay": "$f_y$", "az": "$f_z$", "wx": r"$\omega_x$", "wy": r"$\omega_y$",
               "wz": r"$\omega_z$"}
GPS_SYMBOLS = {"pos_n": "north position", "pos_e": "east position", "pos_d": "down position",
               "vel_n": "$v_N$", "vel_e": "$v_E$", "vel_d": "$v_D$"}


def _count(ax, text: str) -> None:
    ax.text(0.01, 0.97, text, transform=ax.transAxes, fontsize=7.5, va="top",
            bbox=dict(boxstyle="round,pad=0.2", fc="white", ec="0.8", alpha=0.85))


def residuals_imu_figure(drop: DropFolder, *, ax: style.UserAxes | None = None) -> Figure:
    """IMU residuals (measured - model) against flight time (s): specific force in m/s^2, angular
    rate in deg/s; masked samples (used = 0) in another colour; +-1/3 sigma from imu_sigma.json."""
    res = drop.csv("residuals_imu.csv")
    try:
        sigma = drop.json("imu_sigma.json")
    except MissingInput as exc:
        log.info("residuals_imu: no sigma lines (%s)", exc)
        sigma = {}
    t = drop.flight_time(res[rf.TIME_IMU])
    fig, axes = style.new_figure(3, 2, (13, 9), fixed=True, ax=ax)
    for k, ch in enumerate(rf.IMU_CHANNELS):
        ax = axes[k % 3, k // 3]
        unit = "deg/s" if ch.startswith("w") else style.MPS2
        r = res[rf.residual(ch)]
        used = res.get(rf.used(ch), np.ones_like(r)) > 0.5
        sig = float(sigma[rf.sigma(ch)]) if rf.sigma(ch) in sigma else None
        lim = _residual_limit(r[used], sig)
        ax.plot(t[used], r[used], ".", ms=1.5, color=style.MEASUREMENT_COLOR, alpha=0.6, rasterized=True,
                label="residual, sample used in the fit")
        beyond = int((np.abs(r[~used]) > lim).sum())
        if (~used).any():
            ax.plot(t[~used], np.clip(r[~used], -lim, lim), "x", ms=3, color=style.MASKED_COLOR, rasterized=True,
                    label="residual, masked sample (not fitted; drawn at the edge if beyond it)")
        if sig is not None:
            style.sigma_lines(ax, t[[0, -1]] if t.size else t, sig)
        ax.set_ylim(-lim, lim)
        ax.set_ylabel(f"{IMU_SYMBOLS[ch]} residual, {unit}")
        _count(ax, f"{used.sum()} used, {(~used).sum()} masked" + (f" ({beyond} beyond the axis)" if beyond else ""))
    for ax in axes[-1]:
        ax.set_xlabel(style.FLIGHT_TIME_LABEL)
    axes[0, 0].set_title("specific force (accelerometers), IMU axes")
    axes[0, 1].set_title("angular rate (gyros), IMU axes")
    style.figure_legend(fig, markerscale=4)
    fig.suptitle(f"{drop.name}: IMU residuals, measured minus model")
    return fig


def _residual_limit(used: np.ndarray, sigma: float | None) -> float:
    """Symmetric y-limit of a residual panel from the fitted samples only (so masked outliers such
    as clipped gyro samples do not squash the scale): 10 % above max(|used|, 3.5 sigma)."""
    big = float(np.max(np.abs(used))) if used.size else 0.0
    big = max(big, 3.5 * sigma if sigma else 0.0)
    return 1.1 * big if big > 0 else 1.0


def residuals_gps_figure(drop: DropFolder, *, ax: style.UserAxes | None = None) -> Figure:
    """GPS residuals (measured - model) against flight time (s): NED position (m) and velocity (m/s)
    with the receiver's own +-1 and +-3 sigma per fix."""
    res = drop.csv("residuals_gps.csv")
    t = drop.flight_time(res[rf.TIME_IMU])
    fig, axes = style.new_figure(3, 2, (13, 9), fixed=True, ax=ax)
    for k, ch in enumerate(rf.GPS_COMPONENTS):
        ax = axes[k % 3, k // 3]
        unit = "m" if ch.startswith("pos") else "m/s"
        ax.plot(t, res[rf.residual(ch)], "o", ms=2.5, color=style.MEASUREMENT_COLOR, label="residual of a fix")
        if rf.sigma(ch) in res:
            style.sigma_lines(ax, t, res[rf.sigma(ch)])
        ax.set_ylabel(f"{GPS_SYMBOLS[ch]} residual, {unit}")
    for ax in axes[-1]:
        ax.set_xlabel(style.FLIGHT_TIME_LABEL)
    axes[0, 0].set_title("antenna position, NED")
    axes[0, 1].set_title("antenna velocity, NED")
    style.figure_legend(fig, markerscale=2)
    fig.suptitle(f"{drop.name}: GPS residuals, measured minus model (sigma: the receiver's own accuracy)")
    return fig


def correlation_figure(parameters: dict, title: str, *, ax: style.UserAxes | None = None) -> Figure:
    """The parameter correlation matrix of parameters.json (``correlation`` {names, matrix}) as an
    image, names on both axes, colour scale -1..1; values printed when there are few parameters,
    black lines between the blocks of a joint fit (shared, then ``<drop>.<name>`` per drop).

    The matrix is a square of :func:`correlation_side_in` inches; the margins (inches) are measured from
    the names, so the figure needs no layout engine. With ``ax`` (one Axes of the caller's) the
    matrix is drawn there, its colour bar beside it."""
    corr = parameters.get("correlation")
    if not corr or "names" not in corr or "matrix" not in corr:
        raise MissingInput("parameters.json has no correlation {names, matrix}")
    names = list(corr["names"])
    mat = np.asarray(corr["matrix"], dtype=float)
    n = len(names)
    font = 9 if n <= 25 else 7 if n <= 50 else 5
    names_in = (max((text_width_pt(name, font) for name in names), default=0.0) + 8.0) / 72.0
    side = correlation_side_in(n)
    left, bottom, top, right = 0.1 + names_in, 0.1 + names_in, 0.45, CORRELATION_BAR_IN
    width, height = left + side + right, bottom + side + top
    if ax is not None:
        fig, (ax,) = style.user_axes(ax, 1)
        img = ax.imshow(mat, cmap="RdBu_r", vmin=-1.0, vmax=1.0, interpolation="nearest")
        fig.colorbar(img, ax=ax, label="correlation coefficient, -")
    else:
        fig = Figure(figsize=(width, height))
        FigureCanvasAgg(fig)
        ax = fig.add_axes((left / width, bottom / height, side / width, side / height))
        img = ax.imshow(mat, cmap="RdBu_r", vmin=-1.0, vmax=1.0, interpolation="nearest")
        cax = fig.add_axes(((left + side + 0.3) / width, (bottom + 0.1 * side) / height, 0.22 / width,
                            0.8 * side / height))
        fig.colorbar(img, cax=cax, label="correlation coefficient, -")
    ax.set_xticks(range(n), names, rotation=90, fontsize=font)
    ax.set_yticks(range(n), names, fontsize=font)
    groups = [name.split(".", 1)[0] if "." in name else "" for name in names]
    for k in range(1, n):
        if groups[k] != groups[k - 1]:
            ax.axhline(k - 0.5, color="k", lw=1.0)
            ax.axvline(k - 0.5, color="k", lw=1.0)
    if n <= 25:
        rows, cols = np.indices((n, n)).reshape(2, -1)
        style.cell_labels(ax, cols, rows, [f"{v:.2f}" for v in mat.ravel()],
                          ["white" if abs(v) > 0.6 else "black" for v in mat.ravel()])
    ax.set_title(f"{title}: parameter correlation matrix ({n} parameters)")
    return fig


#: Space right of the correlation matrix, in: gap, colour bar, its tick labels and label.
CORRELATION_BAR_IN = 1.45


def correlation_side_in(n: int) -> float:
    """Side (in) of the square correlation matrix of ``n`` parameters: 0.32 in a parameter, 4.5 to 21 in."""
    return float(np.clip(1.5 + 0.32 * n, 4.5, 21.0))
