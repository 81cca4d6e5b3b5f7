"""Figures of a results folder (per-drop fit or multi-drop joint fit), drawn from its files only.

``draw_figures(results_dir)`` reads the CSV/JSON files that ``casrecon fit`` writes (no CasADi, no
re-fit) and saves PNGs (150 dpi) into ``results_dir / "figures"``. A joint folder (one sub-folder per
drop under ``drops/``) gets each drop's figures in ``drops/<name>/figures`` and the top-level
parameter correlation matrix in ``results_dir / "figures"``.

Figures of one drop (flight time t = time_imu_s - release_imu_s, in s):

- ``altitude_velocity.png``: altitude AGL (m), NED velocity and speed (m/s), reconstruction lines,
  GPS fixes as dots;
- ``qbar_alpha_t.png``: dynamic pressure (Pa) and total angle of attack (deg) with 3-sigma bands, and
  the 3-sigma itself against time;
- ``pitching_moment.png``: C_m about the MRP against angle of attack (deg), reconstructed from the
  measured rates (qbar > 100 Pa, |alpha| < 20 deg), nominal and fitted database curves;
- ``reconciled.png``: reconstruction against the forward simulation with the fitted dispersions;
- ``residuals_imu.png``, ``residuals_gps.png``: sensor residuals with +-1 and +-3 sigma lines;
- ``correlation.png``: the parameter correlation matrix.

Figures are drawn on ``matplotlib.figure.Figure`` objects (Agg canvas, never pyplot), so nothing is
registered globally and each figure is freed once saved. A figure whose optional input file is
missing or unreadable is skipped with a note (logged, and appended to ``notes`` if given); a folder
without ``summary.json`` or ``trajectory.csv`` raises ``FileNotFoundError`` naming the file.
"""

from __future__ import annotations

import json
import logging
from collections.abc import Callable
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

log = logging.getLogger(__name__)

DPI = 150
#: Files without which a folder is not a per-drop results folder.
REQUIRED_FILES = ("summary.json", "trajectory.csv")
#: Reconstructed C_m points are shown only above this dynamic pressure (Pa) ...
CM_MIN_QBAR_PA = 100.0
#: ... and below this |angle of attack| (deg).
CM_MAX_ALPHA_DEG = 20.0
IMU_CHANNELS = ("ax", "ay", "az", "wx", "wy", "wz")
GPS_CHANNELS = ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")
RECON_COLOR, GPS_COLOR, SIM_COLOR, MASK_COLOR = "C0", "k", "C3", "C1"


class MissingInput(Exception):
    """An optional input of one figure is absent; the figure is skipped."""


# ----------------------------------------------------------------------------- reading files
def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Columns of a CSV file with a one-line header, as float arrays keyed by header name."""
    if not path.is_file():
        raise MissingInput(f"{path.name} not found in {path.parent}")
    with path.open() as f:
        names = [n.strip() for n in f.readline().strip().split(",")]
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    if data.shape[0] == 0:
        data = np.zeros((0, len(names)))
    if data.shape[1] != len(names):
        raise ValueError(f"{path}: {data.shape[1]} columns but {len(names)} header names")
    return {name: data[:, k] for k, name in enumerate(names)}


def read_json(path: Path) -> dict:
    """A JSON file as a dict; MissingInput if absent."""
    if not path.is_file():
        raise MissingInput(f"{path.name} not found in {path.parent}")
    return json.loads(path.read_text())


class DropFolder:
    """The files of one drop's results folder, read lazily and cached.

    ``release_imu_s`` (s, IMU clock) comes from summary.json, or from the trajectory's first node
    (time_imu_s - flight_time_s) when the summary lacks it.
    """

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        for name in REQUIRED_FILES:
            if not (self.folder / name).is_file():
                raise FileNotFoundError(
                    f"{self.folder} is not a casrecon results folder: {name} is missing")
        self._cache: dict[str, object] = {}
        self.summary = read_json(self.folder / "summary.json")
        self.traj = self.csv("trajectory.csv")
        self.name = str(self.summary.get("problem") or self.folder.name)
        release = self.summary.get("release_imu_s")
        if release is None:
            release = self.traj["time_imu_s"][0] - self.traj["flight_time_s"][0]
        self.release_imu_s = float(release)

    def csv(self, name: str) -> dict[str, np.ndarray]:
        """Columns of ``name`` (MissingInput if absent)."""
        if name not in self._cache:
            self._cache[name] = read_csv(self.folder / name)
        return self._cache[name]

    def json(self, name: str) -> dict:
        """Contents of ``name`` (MissingInput if absent)."""
        if name not in self._cache:
            self._cache[name] = read_json(self.folder / name)
        return self._cache[name]

    def flight_time(self, time_imu_s: np.ndarray) -> np.ndarray:
        """Flight time (s since release) of IMU-clock times (s)."""
        return np.asarray(time_imu_s) - self.release_imu_s


# ----------------------------------------------------------------------------- figure helpers
def _new_figure(nrows: int, ncols: int, size: tuple[float, float], sharex: bool | str = True):
    """A constrained-layout Figure on an Agg canvas and its axes (2-D array)."""
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, sharex=sharex, squeeze=False)
    for ax in axes.flat:
        ax.grid(True, alpha=0.4)
    return fig, axes


def _save(fig: Figure, path: Path) -> Path:
    """Save at DPI, drop the figure's artists (frees memory) and return the path."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    fig.clear()
    return path


def _band(ax, t, value, three_sigma, color: str, label: str) -> None:
    """A line with a shaded +-3-sigma band (same units as value)."""
    ax.fill_between(t, value - three_sigma, value + three_sigma, color=color, alpha=0.3,
                    linewidth=0, label=f"{label} 3-sigma band")
    ax.plot(t, value, color=color, lw=1.2, label=label)


def _sigma_lines(ax, t, sigma, color: str = "k") -> None:
    """+-1 sigma (dashed) and +-3 sigma (dotted) lines drawn over the data; sigma a scalar or an
    array over t (same units as the residuals)."""
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), np.shape(t))
    for k, style in ((1, "--"), (3, ":")):
        kw = dict(color=color, ls=style, lw=1.3, zorder=4)
        ax.plot(t, k * sigma, label=f"+-{k} sigma", **kw)
        ax.plot(t, -k * sigma, **kw)


def _speed(n, e, d) -> np.ndarray:
    return np.sqrt(np.asarray(n) ** 2 + np.asarray(e) ** 2 + np.asarray(d) ** 2)


# ----------------------------------------------------------------------------- one figure each
def plot_altitude_velocity(drop: DropFolder, out: Path) -> Path:
    """Altitude AGL (m), vertical velocity and speed, horizontal velocity (m/s) against flight time
    (s): reconstruction lines and, if gps_fixes.csv exists, GPS fixes as dots (altitude = -pos_d)."""
    tr = drop.traj
    t = tr["flight_time_s"]
    speed = _speed(tr["vel_n_mps"], tr["vel_e_mps"], tr["vel_d_mps"])
    try:
        gps = drop.csv("gps_fixes.csv")
    except MissingInput as exc:
        log.info("altitude_velocity: no GPS dots (%s)", exc)
        gps = None
    fig, axes = _new_figure(3, 1, (9, 9.5))
    a_h, a_v, a_hor = axes[:, 0]
    a_h.plot(t, tr["h_agl_m"], color=RECON_COLOR, label="reconstruction")
    a_v.plot(t, tr["vel_d_mps"], color="C0", label="v_D reconstruction")
    a_v.plot(t, speed, color="C2", label="speed reconstruction")
    a_hor.plot(t, tr["vel_n_mps"], color="C0", label="v_N reconstruction")
    a_hor.plot(t, tr["vel_e_mps"], color="C1", label="v_E reconstruction")
    if gps is not None:
        tg = drop.flight_time(gps["time_imu_s"])
        dots = dict(s=9, zorder=3, marker="o", linewidths=0)
        a_h.scatter(tg, -gps["pos_d_m"], color=GPS_COLOR, label="GPS fix", **dots)
        a_v.scatter(tg, gps["vel_d_mps"], color="C0", edgecolors="k", label="v_D GPS", **dots)
        a_v.scatter(tg, _speed(gps["vel_n_mps"], gps["vel_e_mps"], gps["vel_d_mps"]), color="C2",
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
    return _save(fig, out / "altitude_velocity.png")


def plot_qbar_alpha_t(drop: DropFolder, out: Path) -> Path:
    """Dynamic pressure (Pa) and total angle of attack (deg) against flight time (s) with shaded
    3-sigma bands (left), and the 3-sigma itself against time (right) since the bands are thin."""
    tr = drop.traj
    t = tr["flight_time_s"]
    fig, axes = _new_figure(2, 2, (12, 7.5))
    rows = (("qbar_pa", "dynamic pressure", "Pa", "C0"),
            ("alpha_t_deg", "total angle of attack", "deg", "C3"))
    for k, (col, label, unit, color) in enumerate(rows):
        three = tr[f"{col}_3sigma"]
        _band(axes[k, 0], t, tr[col], three, color, label)
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
    return _save(fig, out / "qbar_alpha_t.png")


def plot_pitching_moment(drop: DropFolder, out: Path) -> Path:
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
    fig, axes = _new_figure(1, 1, (9, 6.5))
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
    return _save(fig, out / "pitching_moment.png")


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


def plot_reconciled(drop: DropFolder, out: Path) -> Path:
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
             "speed_mps": _speed(tr["vel_n_mps"], tr["vel_e_mps"], tr["vel_d_mps"])}
    inside = (t >= sim["flight_time_s"].min()) & (t <= sim["flight_time_s"].max())
    rows = [("h_agl_m", "altitude AGL", "m"), ("speed_mps", "speed (inertial)", "m/s"),
            ("alpha_t_deg", "total angle of attack", "deg")]
    if "p_dps" in sim:
        rows.append(("p_dps", "roll rate p", "deg/s"))
    fig, axes = _new_figure(len(rows), 2, (14, 3.2 * len(rows)))
    for k, (col, label, unit) in enumerate(rows):
        ax, ad = axes[k]
        y = recon[col]
        ax.plot(t, y, color=RECON_COLOR, lw=1.5, label="reconstruction")
        ax.plot(sim["flight_time_s"], sim[col], color=SIM_COLOR, lw=1.0, ls="--",
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
    return _save(fig, out / "reconciled.png")


def plot_residuals_imu(drop: DropFolder, out: Path) -> Path:
    """IMU residuals (measured - model) against flight time (s): specific force in m/s^2, angular
    rate in deg/s; masked samples (used = 0) in another colour; +-1/3 sigma from imu_sigma.json."""
    res = drop.csv("residuals_imu.csv")
    try:
        sigma = drop.json("imu_sigma.json")
    except MissingInput as exc:
        log.info("residuals_imu: no sigma lines (%s)", exc)
        sigma = {}
    t = drop.flight_time(res["time_imu_s"])
    fig, axes = _new_figure(3, 2, (13, 9))
    for k, ch in enumerate(IMU_CHANNELS):
        ax = axes[k % 3, k // 3]
        gyro = ch.startswith("w")
        scale, unit = (np.degrees(1.0), "deg/s") if gyro else (1.0, "m/s^2")
        r = res[f"{ch}_residual"] * scale
        used = res.get(f"{ch}_used", np.ones_like(r)) > 0.5
        sig = float(sigma[ch]) * scale if ch in sigma else None
        lim = _residual_limit(r[used], sig)
        ax.plot(t[used], r[used], ".", ms=1.5, color="C0", alpha=0.6,
                label=f"used in the fit ({used.sum()})")
        beyond = int((np.abs(r[~used]) > lim).sum())
        ax.plot(t[~used], np.clip(r[~used], -lim, lim), "x", ms=3, color=MASK_COLOR,
                label=f"masked, not fitted ({(~used).sum()}"
                      + (f"; {beyond} beyond the axis, drawn at its edge)" if beyond else ")"))
        if sig is not None:
            _sigma_lines(ax, t[[0, -1]] if t.size else t, sig)
        ax.set_ylim(-lim, lim)
        ax.set_ylabel(f"{ch} residual, {unit}")
        ax.legend(fontsize=7, loc="upper right", markerscale=3)
    for ax in axes[-1]:
        ax.set_xlabel("flight time since release, s")
    axes[0, 0].set_title("specific force (accelerometers)")
    axes[0, 1].set_title("angular rate (gyros)")
    fig.suptitle(f"{drop.name}: IMU residuals, measured minus model")
    return _save(fig, out / "residuals_imu.png")


def _residual_limit(used: np.ndarray, sigma: float | None) -> float:
    """Symmetric y-limit of a residual panel from the fitted samples only (so masked outliers such
    as clipped gyro samples do not squash the scale): 10 % above max(|used|, 3.5 sigma)."""
    big = float(np.max(np.abs(used))) if used.size else 0.0
    big = max(big, 3.5 * sigma if sigma else 0.0)
    return 1.1 * big if big > 0 else 1.0


def plot_residuals_gps(drop: DropFolder, out: Path) -> Path:
    """GPS residuals (measured - model) against flight time (s): NED position (m) and velocity (m/s)
    with the receiver's own +-1 and +-3 sigma per fix."""
    res = drop.csv("residuals_gps.csv")
    t = drop.flight_time(res["time_imu_s"])
    fig, axes = _new_figure(3, 2, (13, 9))
    for k, ch in enumerate(GPS_CHANNELS):
        ax = axes[k % 3, k // 3]
        unit = "m" if ch.startswith("pos") else "m/s"
        ax.plot(t, res[f"{ch}_residual"], "o", ms=3, color="C0", label="residual")
        if f"{ch}_sigma" in res:
            _sigma_lines(ax, t, res[f"{ch}_sigma"])
        ax.set_ylabel(f"{ch} residual, {unit}")
        ax.legend(fontsize=7, loc="upper right")
    for ax in axes[-1]:
        ax.set_xlabel("flight time since release, s")
    axes[0, 0].set_title("position (antenna, NED)")
    axes[0, 1].set_title("velocity (NED)")
    fig.suptitle(f"{drop.name}: GPS residuals, measured minus model")
    return _save(fig, out / "residuals_gps.png")


def plot_correlation(parameters: dict, title: str, out: Path) -> Path:
    """The parameter correlation matrix of parameters.json (``correlation`` {names, matrix}) as an
    image, names on both axes, colour scale -1..1; values printed when there are few parameters,
    black lines between the blocks of a joint fit (shared, then ``<drop>.<name>`` per drop)."""
    corr = parameters.get("correlation")
    if not corr or "names" not in corr or "matrix" not in corr:
        raise MissingInput("parameters.json has no correlation {names, matrix}")
    names = list(corr["names"])
    mat = np.asarray(corr["matrix"], dtype=float)
    n = len(names)
    side = float(np.clip(3.0 + 0.32 * n, 6.0, 24.0))
    fig, axes = _new_figure(1, 1, (side + 1.5, side), sharex=False)
    ax = axes[0, 0]
    ax.grid(False)
    img = ax.imshow(mat, cmap="RdBu_r", vmin=-1.0, vmax=1.0, interpolation="nearest")
    fig.colorbar(img, ax=ax, label="correlation coefficient, -", shrink=0.8)
    font = 9 if n <= 25 else 7 if n <= 50 else 5
    ax.set_xticks(range(n), names, rotation=90, fontsize=font)
    ax.set_yticks(range(n), names, fontsize=font)
    groups = [name.split(".", 1)[0] if "." in name else "" for name in names]
    for k in range(1, n):
        if groups[k] != groups[k - 1]:
            ax.axhline(k - 0.5, color="k", lw=1.0)
            ax.axvline(k - 0.5, color="k", lw=1.0)
    if n <= 25:
        for i in range(n):
            for j in range(n):
                ax.text(j, i, f"{mat[i, j]:.2f}", ha="center", va="center", fontsize=6,
                        color="white" if abs(mat[i, j]) > 0.6 else "black")
    ax.set_title(f"{title}: parameter correlation matrix ({n} parameters)")
    return _save(fig, out / "correlation.png")


# ----------------------------------------------------------------------------- drivers
DROP_FIGURES: tuple[tuple[str, Callable[[DropFolder, Path], Path]], ...] = (
    ("altitude_velocity", plot_altitude_velocity),
    ("qbar_alpha_t", plot_qbar_alpha_t),
    ("pitching_moment", plot_pitching_moment),
    ("reconciled", plot_reconciled),
    ("residuals_imu", plot_residuals_imu),
    ("residuals_gps", plot_residuals_gps),
)


def _attempt(label: str, draw: Callable[[], Path], notes: list[str]) -> list[Path]:
    """Run one figure; a missing or unreadable optional input skips it with a note."""
    try:
        return [draw()]
    except (MissingInput, KeyError, ValueError, OSError) as exc:
        what = f"missing column {exc}" if isinstance(exc, KeyError) else str(exc)
        notes.append(f"skipped {label}: {what}")  # logged by the caller (a worker's log would be lost)
        return []


def _draw_one(folder: Path, index: int, correlation: bool) -> tuple[list[Path], list[str]]:
    """Figure number ``index`` of DROP_FIGURES (or the correlation matrix) of one drop folder."""
    notes: list[str] = []
    drop = DropFolder(folder)
    out = drop.folder / "figures"
    if index < len(DROP_FIGURES):
        label, draw = DROP_FIGURES[index]
        return _attempt(f"{drop.name} {label}", lambda: draw(drop, out), notes), notes
    return _attempt(f"{drop.name} correlation", lambda: plot_correlation(
        drop.json("parameters.json"), drop.name, out), notes), notes


def draw_drop_figures(folder: Path, notes: list[str] | None = None,
                      correlation: bool = True, workers: int = 2) -> list[Path]:
    """All figures of one drop's results folder into ``folder / "figures"``; returns the paths.

    Figures are drawn by ``workers`` forked processes (matplotlib spends its time in layout and
    rasterisation, one core per figure); ``workers=1`` draws them in this process.
    Raises FileNotFoundError if summary.json or trajectory.csv is missing.
    """
    notes = [] if notes is None else notes
    DropFolder(folder)  # validates the folder before any worker starts
    indices = list(range(len(DROP_FIGURES) + (1 if correlation else 0)))
    if workers > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("fork")) as pool:
            done = list(pool.map(_draw_one, [folder] * len(indices), indices, [correlation] * len(indices)))
    else:
        done = [_draw_one(folder, i, correlation) for i in indices]
    paths: list[Path] = []
    for p, n in done:
        paths += p
        notes += n
        for note in n:
            log.warning(note)
    return paths


def drop_folders(results_dir: Path) -> list[Path]:
    """The per-drop sub-folders ``drops/<name>/`` of a joint results folder (empty if none)."""
    drops = Path(results_dir) / "drops"
    return sorted(p for p in drops.iterdir() if p.is_dir()) if drops.is_dir() else []


def draw_figures(results_dir: Path, notes: list[str] | None = None) -> list[Path]:
    """Draw every figure of a results folder and return the PNG paths.

    A per-drop folder gets its figures in ``results_dir / "figures"``. A joint folder (sub-folders
    ``drops/<name>/``) gets each drop's figures in ``drops/<name>/figures`` and the top-level
    correlation matrix (from ``results_dir / "parameters.json"``) in ``results_dir / "figures"``.
    Skipped figures are logged and their reasons appended to ``notes`` when a list is given.
    Raises FileNotFoundError if ``results_dir`` (or a drop sub-folder) is not a results folder.
    """
    results_dir = Path(results_dir)
    notes = [] if notes is None else notes
    if not results_dir.is_dir():
        raise FileNotFoundError(f"results folder {results_dir} does not exist")
    drops = drop_folders(results_dir)
    if not drops:
        return draw_drop_figures(results_dir, notes)
    paths: list[Path] = []
    for folder in drops:
        paths += draw_drop_figures(folder, notes, correlation=False)
    title = _joint_title(results_dir, drops)
    joint_notes: list[str] = []
    paths += _attempt("joint correlation", lambda: plot_correlation(
        read_json(results_dir / "parameters.json"), title, results_dir / "figures"), joint_notes)
    for note in joint_notes:
        log.warning(note)
    notes += joint_notes
    return paths


def _joint_title(results_dir: Path, drops: list[Path]) -> str:
    """A title for a joint folder's figures: its summary's problem name, or the list of drops."""
    try:
        summary = read_json(results_dir / "summary.json")
    except (MissingInput, ValueError):
        summary = {}
    name = summary.get("problem") or summary.get("name")
    listed = "drops " + ", ".join(p.name for p in drops)
    return f"joint fit {name!s} ({listed})" if name else f"joint fit ({listed})"
