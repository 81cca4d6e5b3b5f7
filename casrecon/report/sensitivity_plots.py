"""Figures of the observability studies (``casrecon sensitivity``), one legend per figure:

- ``fisher``: the Fisher directions as a map of their loadings (one row per direction, weakest at
  the top, one column per parameter, values printed), beside the sigma each direction is
  determined to (log scale, 1-sigma and 3-sigma);
- ``profile_<name>``: delta chi-square of a profile likelihood against the held value, with the
  delta chi-square = 9 line and the Fisher 3-sigma interval;
- ``design``: predicted 1-sigma of a parameter against the initial pitch rate, the release altitude
  and the number of drops.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.ticker import MaxNLocator

from casrecon.report import figure_style as style
from casrecon.report.parameter_labels import short_label

#: Smallest |loading| printed in the Fisher map, -.
MIN_PRINTED_LOADING = 0.1
#: Colours: profile and design points, the Fisher interval, sigma bars.
POINTS_COLOR, FISHER_COLOR, SIGMA_COLOR = "tab:blue", "tab:red", "0.35"


def _save(fig: Figure, path: Path, formats: Sequence[str]) -> Path:
    """Save ``fig`` as ``path`` in each of ``formats``; the first format's path."""
    return style.save_figure(fig, path, formats)[0]


def fisher_figure(document: dict, *, ax: style.UserAxes | None = None) -> Figure:
    """The Fisher directions of ``fisher.json`` (:func:`casrecon.analysis.sensitivity_documents.fisher_document`):
    loadings (-1..1) per direction and parameter, weakest direction at the top, and each
    direction's sigma (scaled parameters, log axis). With ``ax``: two Axes of the caller's (loadings,
    sigmas)."""
    directions = document["directions"]
    names = list(directions[0]["loadings"]) if directions else []
    load = np.array([[d["loadings"][n] for n in names] for d in directions])
    sigma = np.array([d["sigma_normalised"] for d in directions])
    n_dir, n_par = load.shape
    width = float(np.clip(4.5 + 0.48 * n_par, 8.0, 20.0))
    height = float(np.clip(2.2 + 0.36 * n_dir, 4.5, 16.0))
    if ax is not None:
        fig, (ax, bar) = style.user_axes(ax, 2)
    else:
        fig = Figure(figsize=(width, height), layout="constrained")
        FigureCanvasAgg(fig)
        ax, bar = fig.subplots(1, 2, gridspec_kw={"width_ratios": [max(n_par, 1), 5.0]})
    bar.grid(True, axis="x", alpha=0.4)
    img = ax.imshow(load, cmap="RdBu_r", vmin=-1, vmax=1, aspect="auto", interpolation="nearest")
    for i, j in zip(*np.nonzero(np.abs(load) >= MIN_PRINTED_LOADING)):
        ax.text(j, i, f"{load[i, j]:.2f}", ha="center", va="center", fontsize=7,
                color="white" if abs(load[i, j]) > 0.6 else "black")
    ax.set_xticks(range(n_par), [short_label(n) for n in names], rotation=90, fontsize=9)
    ax.set_yticks(range(n_dir), [f"{d['rank']}" for d in directions], fontsize=8)
    ax.set_ylabel("direction (1 = least information)")
    ax.set_title(f"loadings of each direction (values where |loading| $\\geq$ {MIN_PRINTED_LOADING:g})",
                 fontsize=10)
    fig.colorbar(img, ax=ax, location="bottom", shrink=0.5, aspect=40, fraction=0.04, pad=0.01,
                 label="loading (component of the unit direction), -")
    y = np.arange(n_dir)
    bar.barh(y, 3 * sigma, color=SIGMA_COLOR, alpha=0.35, height=0.8)
    bar.barh(y, sigma, color=SIGMA_COLOR, height=0.8)
    bar.set_xscale("log")
    bar.set_ylim(n_dir - 0.5, -0.5)
    bar.yaxis.tick_right()
    bar.set_yticks(y, [f"{s:.3g}" for s in sigma], fontsize=8)
    bar.set_xlabel(r"$\sigma$ (scaled parameters), -")
    bar.set_title(r"$\sigma$ of each direction", fontsize=10)
    handles = [Line2D([], [], color=SIGMA_COLOR, lw=8, label=r"$1\sigma$"),
               Line2D([], [], color=SIGMA_COLOR, alpha=0.35, lw=8, label=r"$3\sigma$")]
    fig.legend(handles=handles, loc="outside lower right", ncol=2, fontsize=9, frameon=False)
    fig.suptitle(f"{document.get('problem', '')}: Fisher information directions, weakest first (parameters "
                 f"divided by their scale; dispersion factors: database $3\\sigma$ / 3)")
    return fig


def plot_fisher(document: dict, out: Path, formats: Sequence[str] = style.DEFAULT_FORMATS) -> Path:
    """Save :func:`fisher_figure` as ``out / "fisher.<format>"`` in each of ``formats``; the first one's path."""
    return _save(fisher_figure(document), Path(out) / "fisher", formats)


def profile_figure(profile, *, ax: style.UserAxes | None = None) -> Figure:
    """Delta chi-square against the held value of a :class:`~casrecon.analysis.observability.Profile`,
    with the delta chi-square = 9 line (3 sigma) and the Fisher 3-sigma interval for comparison."""
    fig, axes = style.new_figure(1, 1, (8, 5.5), ax=ax)
    ax = axes[0, 0]
    ax.plot(profile.values, profile.delta_chi2, "o-", color=POINTS_COLOR)
    ax.axhline(9.0, color="k", ls=":")
    for x in (profile.estimate - profile.fisher_three_sigma, profile.estimate + profile.fisher_three_sigma):
        ax.axvline(x, color=FISHER_COLOR, ls="--", lw=1)
    label = short_label(profile.name)
    ax.set_xlabel(f"{label} (held value)")
    ax.set_ylabel(r"$\Delta\chi^2$, -")
    ax.set_title(f"half-width of the profile interval / Fisher $3\\sigma$ = {profile.agreement:.3f}", fontsize=10)
    handles = [Line2D([], [], color=POINTS_COLOR, marker="o", label="profile likelihood (refit with the value held)"),
               Line2D([], [], color="k", ls=":", label=r"$\Delta\chi^2 = 9$ ($3\sigma$)"),
               Line2D([], [], color=FISHER_COLOR, ls="--", label=r"Fisher $\pm 3\sigma$")]
    fig.legend(handles=handles, loc="outside lower center", ncol=3, fontsize=9, frameon=False)
    fig.suptitle(f"profile likelihood of {label} ({profile.name})")
    return fig


def plot_profile(profile, out: Path, formats: Sequence[str] = style.DEFAULT_FORMATS) -> Path:
    """Save :func:`profile_figure` as ``out / "profile_<name>.<format>"`` in each of ``formats``; the
    first one's path."""
    return _save(profile_figure(profile), Path(out) / f"profile_{profile.name}", formats)


def design_figure(design: dict, *, ax: style.UserAxes | None = None) -> Figure:
    """Predicted 1-sigma of ``design["parameter"]`` against the initial pitch rate (deg/s), the
    release altitude (m) and the number of drops, on one y scale from 0."""
    fig, axes = style.new_figure(1, 3, (13, 4.6), sharex=False, ax=ax)
    label = short_label(design["parameter"])
    for ax, key, xlabel in zip(axes[0], ("pitch_rate", "altitude", "n_drops"),
                               ("initial pitch rate $q_0$, deg/s", r"release altitude $h_{\mathrm{AGL}}$, m",
                                "number of drops in a joint fit")):
        x, y = zip(*design[key]) if design[key] else ((), ())
        ax.plot(x, y, "o-", color=POINTS_COLOR)
        ax.set_xlabel(xlabel)
        if ax is not axes[0, 0]:
            ax.sharey(axes[0, 0])
    axes[0, 2].xaxis.set_major_locator(MaxNLocator(integer=True))
    axes[0, 0].set_ylabel(f"predicted $1\\sigma$ of {label}")
    axes[0, 0].set_ylim(bottom=0)
    fig.legend(handles=[Line2D([], [], color=POINTS_COLOR, marker="o", label=(
        "KKT covariance at the truth of a simulated drop (no fit)"))], loc="outside lower center", fontsize=9,
        frameon=False)
    fig.suptitle(f"design of drops: how well {label} ({design['parameter']}) would be determined")
    return fig


def plot_design(design: dict, out: Path, formats: Sequence[str] = style.DEFAULT_FORMATS) -> Path:
    """Save :func:`design_figure` as ``out / "design.<format>"`` in each of ``formats``; the first one's path."""
    return _save(design_figure(design), Path(out) / "design", formats)
