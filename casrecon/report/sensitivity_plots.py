"""Figures of the observability studies: profile likelihood and predicted sigma of drop designs."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure


def plot_profile(profile, out: Path, formats: Sequence[str] = ("png",)) -> Path:
    """Delta chi-square against the held value, with the 3-sigma line (delta chi-square = 9) and the
    Fisher 3-sigma interval for comparison; saved in each of ``formats``, the first one's path returned."""
    fig = Figure(figsize=(8, 5), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    ax.plot(profile.values, profile.delta_chi2, "o-", label="profile likelihood (refit with the value held)")
    ax.axhline(9.0, color="k", ls=":", label="delta chi-square = 9 (3 sigma)")
    for x in (profile.estimate - profile.fisher_three_sigma, profile.estimate + profile.fisher_three_sigma):
        ax.axvline(x, color="C3", ls="--", lw=1)
    ax.plot([], [], "C3--", label="Fisher 3-sigma")
    ax.set_xlabel(f"{profile.name} (held value)")
    ax.set_ylabel("delta chi-square")
    ax.set_title(f"profile likelihood of {profile.name}: half-width / Fisher 3-sigma = {profile.agreement:.3f}")
    ax.grid(True, alpha=0.4)
    ax.legend()
    out.mkdir(parents=True, exist_ok=True)
    return _save(fig, out / f"profile_{profile.name}", formats)


def plot_design(design: dict, out: Path, formats: Sequence[str] = ("png",)) -> Path:
    """Predicted 1-sigma of the parameter against the initial pitch rate, the release altitude and
    the number of drops; saved in each of ``formats``, the first one's path returned."""
    fig = Figure(figsize=(13, 4.5), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(1, 3)
    for ax, key, label in zip(axes, ("pitch_rate", "altitude", "n_drops"),
                              ("initial pitch rate, deg/s", "release altitude AGL, m", "number of drops")):
        x, y = zip(*design[key]) if design[key] else ((), ())
        ax.plot(x, y, "o-")
        ax.set_xlabel(label)
        ax.set_ylabel(f"predicted 1-sigma of {design['parameter']}")
        ax.grid(True, alpha=0.4)
    fig.suptitle(f"design of drops: how well {design['parameter']} would be determined")
    out.mkdir(parents=True, exist_ok=True)
    return _save(fig, out / "design", formats)


def _save(fig: Figure, stem: Path, formats: Sequence[str]) -> Path:
    paths = [stem.with_suffix(f".{fmt}") for fmt in formats]
    for path in paths:
        fig.savefig(path, dpi=120, format=path.suffix[1:])
    return paths[0]
