"""Figure of a GPS-only fit: data and fit, normalised residuals of both models, drag area."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure


def _csv(path: Path) -> dict[str, np.ndarray]:
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {n: data[n] for n in data.dtype.names}


def plot_track_fit(folder: Path, formats: Sequence[str] = ("png",)) -> Path:
    """``figures/track_fit.png`` of a point-mass results folder: height and vertical speed (GPS
    dots, fitted line), normalised residuals of the fitted and the constant-drag model, and the
    drag area with its 3-sigma band; saved in each of ``formats``, the PNG's (or first) path returned."""
    folder = Path(folder)
    tr, res, fix = _csv(folder / "trajectory.csv"), _csv(folder / "residuals_gps.csv"), _csv(folder / "gps_fixes.csv")
    import json

    name = json.loads((folder / "summary.json").read_text()).get("problem", folder.name)
    fig = Figure(figsize=(13, 10), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots(3, 2, sharex=True)
    used = fix["used"] > 0.5
    t = tr["time_s"]
    ax[0, 0].plot(fix["time_s"][used], -fix["pos_d_measured"][used], ".", ms=3, label="GPS")
    ax[0, 0].plot(t, -tr["pos_d_m"], lw=1.2, label="fit")
    ax[0, 0].set_ylabel("height above ground, m")
    ax[0, 1].plot(fix["time_s"][used], fix["vel_d_measured"][used], ".", ms=3, label="GPS")
    ax[0, 1].plot(t, tr["vel_d_mps"], lw=1.2, label="fit")
    ax[0, 1].set_ylabel("vertical speed (down), m/s")
    for k, comp in enumerate(("pos_d", "vel_d")):
        a = ax[1, k]
        a.plot(res["time_s"], res[f"{comp}_constant"], ".", ms=3, color="C3", label="constant drag area")
        a.plot(res["time_s"], res[f"{comp}_fit"], ".", ms=3, color="C0", label="fitted model")
        for s in (-3, 3):
            a.axhline(s, color="k", ls=":", lw=0.8)
        a.set_ylabel(f"{comp} residual / receiver sigma")
        a.set_yscale("symlog", linthresh=3)
    a = ax[2, 0]
    for comp, c in (("pos_n", "C0"), ("pos_e", "C1"), ("vel_n", "C2"), ("vel_e", "C4")):
        a.plot(res["time_s"], res[f"{comp}_fit"], ".", ms=2, color=c, label=comp)
    a.axhline(3, color="k", ls=":", lw=0.8)
    a.axhline(-3, color="k", ls=":", lw=0.8)
    a.set_ylabel("horizontal residual / sigma (fit)")
    a = ax[2, 1]
    a.fill_between(t, tr["cda_m2"] - tr["cda_m2_3sigma"], tr["cda_m2"] + tr["cda_m2_3sigma"], alpha=0.3,
                   label="3-sigma band")
    a.plot(t, tr["cda_m2"], label="drag area CdA")
    a.set_ylabel("drag area, m^2")
    for a in ax.flat:
        a.grid(True, alpha=0.4)
        a.legend(fontsize=8)
    for a in ax[-1]:
        a.set_xlabel("time since segment start, s")
    fig.suptitle(f"{name}: GPS-only point-mass fit (dots: measurements; dotted: +-3 sigma)")
    (folder / "figures").mkdir(exist_ok=True)
    paths = [folder / "figures" / f"track_fit.{fmt}" for fmt in formats]
    for path in paths:
        fig.savefig(path, dpi=120, format=path.suffix[1:])
    fig.clear()
    return paths[0]
