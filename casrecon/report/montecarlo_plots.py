"""Figures of a dispersed Monte Carlo: histograms of flight time, impact speed and peak total
angle of attack (mean, 3-sigma and 1/99 percentile lines), and impact speed against flight time."""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.backends.backend_agg import FigureCanvasAgg
from matplotlib.figure import Figure

_LABELS = {"flight_time_s": ("flight time (release to touchdown)", "s"),
           "impact_speed_mps": ("impact speed", "m/s"),
           "max_alpha_t_deg": ("peak total angle of attack", "deg")}


def _histogram(ax, values: np.ndarray, stats: dict, nominal: float | None, name: str, n: int) -> None:
    label, unit = _LABELS[name]
    bins = min(80, max(10, int(np.sqrt(values.size))))
    ax.hist(values, bins=bins, color="C0", alpha=0.75, label=f"{values.size} cases")
    ax.axvline(stats["mean"], color="k", lw=1.5, label=f"mean {stats['mean']:.3f} {unit}")
    ax.axvline(stats["mean_minus_3sigma"], color="C3", ls="--", lw=1.2,
               label=f"mean +- 3 sd (3 sd = {stats['three_sigma']:.3f} {unit})")
    ax.axvline(stats["mean_plus_3sigma"], color="C3", ls="--", lw=1.2)
    ax.axvline(stats["p1"], color="C2", ls=":", lw=1.5, label=f"1st / 99th percentile {stats['p1']:.3f} / "
                                                                 f"{stats['p99']:.3f}")
    ax.axvline(stats["p99"], color="C2", ls=":", lw=1.5)
    if nominal is not None and np.isfinite(nominal):
        ax.axvline(nominal, color="C1", lw=1.2, label=f"nominal {nominal:.3f} {unit}")
    ax.set_xlabel(f"{label}, {unit}")
    ax.set_ylabel("cases")
    ax.set_title(f"{label}: {n} dispersed cases")
    ax.legend(fontsize=8)


def plot_montecarlo(result, folder: str | Path, formats: Sequence[str] = ("png",)) -> list[Path]:
    """Write ``histograms`` and ``speed_vs_time`` into ``folder`` in each of ``formats`` (``png``,
    ``pdf``, ``svg``); returns the paths.

    ``result`` is a :class:`~casrecon.analysis.montecarlo.MonteCarloResult`.
    """
    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    stats = result.statistics()
    ok = result["impacted"] > 0.5
    title = f"{result.problem}: dispersed Monte Carlo, seed {result.seed}, RK4 dt {result.dt_s:g} s"
    names = [n for n in _LABELS if stats.get(n)]
    paths = []

    fig = Figure(figsize=(6 * max(len(names), 1), 4.8), layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(1, max(len(names), 1)))
    for ax, name in zip(axes, names):
        _histogram(ax, result[name][ok], stats[name], result.nominal.get(name), name, result.n_cases)
    fig.suptitle(title)
    paths += _save(fig, folder / "histograms", formats)

    fig = Figure(figsize=(7.5, 6), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    sc = ax.scatter(result["flight_time_s"][ok], result["impact_speed_mps"][ok], s=4, alpha=0.6,
                    c=result["h_agl_m"][ok], cmap="viridis", label="dispersed case")
    fig.colorbar(sc, ax=ax, label="release altitude above ground, m")
    if result.nominal:
        ax.plot(result.nominal["flight_time_s"], result.nominal["impact_speed_mps"], "r*", ms=14,
                label="nominal flight")
    ax.set_xlabel("flight time (release to touchdown), s")
    ax.set_ylabel("impact speed, m/s")
    ax.set_title(f"Impact speed against flight time ({int(ok.sum())} of {result.n_cases} cases impacted)")
    ax.legend()
    ax.grid(alpha=0.3)
    fig.suptitle(title)
    paths += _save(fig, folder / "speed_vs_time", formats)
    return paths


def _save(fig: Figure, stem: Path, formats: Sequence[str]) -> list[Path]:
    paths = [stem.with_suffix(f".{fmt}") for fmt in formats]
    for path in paths:
        fig.savefig(path, dpi=110, format=path.suffix[1:])
    return paths
