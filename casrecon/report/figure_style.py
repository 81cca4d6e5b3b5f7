"""Shared look of the results-folder figures: size, resolution, colours, and the drawing helpers.

Figures are ``matplotlib.figure.Figure`` objects on an Agg canvas (never pyplot), so nothing is
registered globally and each figure is freed once saved.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

DPI = 150
RECON_COLOR, GPS_COLOR, SIM_COLOR, MASK_COLOR = "C0", "k", "C3", "C1"


def new_figure(nrows: int, ncols: int, size: tuple[float, float], sharex: bool | str = True):
    """A constrained-layout Figure on an Agg canvas and its axes (2-D array)."""
    fig = Figure(figsize=size, layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(nrows, ncols, sharex=sharex, squeeze=False)
    for ax in axes.flat:
        ax.grid(True, alpha=0.4)
    return fig, axes


def save_figure(fig: Figure, path: Path) -> Path:
    """Save at DPI, drop the figure's artists (frees memory) and return the path."""
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=DPI)
    fig.clear()
    return path


def band(ax, t, value, three_sigma, color: str, label: str) -> None:
    """A line with a shaded +-3-sigma band (same units as value)."""
    ax.fill_between(t, value - three_sigma, value + three_sigma, color=color, alpha=0.3,
                    linewidth=0, label=f"{label} 3-sigma band")
    ax.plot(t, value, color=color, lw=1.2, label=label)


def sigma_lines(ax, t, sigma, color: str = "k") -> None:
    """+-1 sigma (dashed) and +-3 sigma (dotted) lines drawn over the data; sigma a scalar or an
    array over t (same units as the residuals)."""
    sigma = np.broadcast_to(np.asarray(sigma, dtype=float), np.shape(t))
    for k, style in ((1, "--"), (3, ":")):
        kw = dict(color=color, ls=style, lw=1.3, zorder=4)
        ax.plot(t, k * sigma, label=f"+-{k} sigma", **kw)
        ax.plot(t, -k * sigma, **kw)


def speed(n, e, d) -> np.ndarray:
    """Norm of the (n, e, d) components, elementwise (same unit)."""
    return np.sqrt(np.asarray(n) ** 2 + np.asarray(e) ** 2 + np.asarray(d) ** 2)
