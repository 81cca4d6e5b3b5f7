"""Figures of a dispersed Monte Carlo (``casrecon montecarlo``), each with one legend below its panels:

- ``histograms``: flight time, impact speed and peak total angle of attack over the impacted cases,
  with the mean, mean +-3 sd, the 1st/99th percentiles and the nominal flight (numbers per panel);
- ``speed_vs_time``: impact speed against flight time, coloured by release altitude;
- ``envelopes``: altitude, speed, total angle of attack and pitch against flight time: the band
  between the 1st and 99th percentiles across the cases, the median and the nominal flight, with
  the touchdown window (1st to 99th percentile of the flight time) shaded
  (:mod:`casrecon.analysis.mc_envelopes`).
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np
from matplotlib.figure import Figure
from matplotlib.lines import Line2D
from matplotlib.patches import Patch

from casrecon.analysis.mc_envelopes import envelope_column
from casrecon.report import figure_style as style

#: Quantities of the histograms: column -> (label, unit).
HISTOGRAMS = {"flight_time_s": ("flight time (release to touchdown)", "s"),
              "impact_speed_mps": ("impact speed", "m/s"),
              "max_alpha_t_deg": (r"peak total angle of attack $\alpha_T$", "deg")}
#: Panels of the envelope figure: history channel (envelope column prefix) -> (label, unit).
ENVELOPES = {"h_agl_m": (r"altitude $h_{\mathrm{AGL}}$", "m"), "speed_mps": (r"speed $V$", "m/s"),
             "alpha_t_deg": (r"total angle of attack $\alpha_T$", "deg"), "pitch_deg": (r"pitch $\theta$", "deg")}
#: Envelope columns read (as :func:`casrecon.analysis.mc_envelopes.envelope_column` names them).
TIME, IN_FLIGHT = "flight_time_s", "n_in_flight"
#: Speed and attitude envelopes are drawn where at least this fraction of the cases is in flight
#: (their percentiles are over the cases in flight; the few slowest ones are not the distribution).
MIN_IN_FLIGHT_FRACTION = 0.5
#: Colours: the cases (histograms, envelope band), their median, the nominal flight, statistics lines.
CASES_COLOR, MEDIAN_COLOR, NOMINAL_COLOR, SD_COLOR, PCT_COLOR = "tab:blue", "k", "tab:orange", "tab:red", "tab:green"


def _title(result) -> str:
    return f"{result.problem}: dispersed Monte Carlo, seed {result.seed}, RK4 $\\Delta t$ = {result.dt_s:g} s"


def histogram_figure(result, *, ax: style.UserAxes | None = None) -> Figure:
    """Histograms of :data:`HISTOGRAMS` over the impacted cases of a
    :class:`~casrecon.analysis.montecarlo.MonteCarloResult`."""
    stats = result.statistics()
    ok = result["impacted"] > 0.5
    names = [n for n in HISTOGRAMS if stats.get(n)]
    fig, axes = style.new_figure(1, max(len(names), 1), (5.5 * max(len(names), 1), 4.8), sharex=False, ax=ax)
    for ax, name in zip(axes[0], names):
        values, st = result[name][ok], stats[name]
        label, unit = HISTOGRAMS[name]
        ax.hist(values, bins=min(80, max(10, int(np.sqrt(values.size)))), color=CASES_COLOR, alpha=0.75)
        ax.axvline(st["mean"], color="k", lw=1.5)
        for x in (st["mean_minus_3sigma"], st["mean_plus_3sigma"]):
            ax.axvline(x, color=SD_COLOR, ls="--", lw=1.2)
        for x in (st["p1"], st["p99"]):
            ax.axvline(x, color=PCT_COLOR, ls=":", lw=1.5)
        nominal = result.nominal.get(name)
        if nominal is not None and np.isfinite(nominal):
            ax.axvline(nominal, color=NOMINAL_COLOR, lw=1.2)
        ax.text(0.02, 0.97, f"mean {st['mean']:.3f} {unit}\n$3\\sigma$ {st['three_sigma']:.3f} {unit}\n"
                f"p1 {st['p1']:.3f}, p99 {st['p99']:.3f} {unit}", transform=ax.transAxes, va="top", fontsize=8,
                bbox=dict(boxstyle="round", fc="white", ec="0.7", alpha=0.9))
        ax.set_xlabel(f"{label}, {unit}")
        ax.set_ylabel("cases")
    handles = [Patch(color=CASES_COLOR, alpha=0.75, label=f"{int(ok.sum())} impacted cases"),
               Line2D([], [], color="k", lw=1.5, label="mean"),
               Line2D([], [], color=SD_COLOR, ls="--", lw=1.2, label=r"mean $\pm 3\sigma$ (sample sd)"),
               Line2D([], [], color=PCT_COLOR, ls=":", lw=1.5, label="1st and 99th percentiles"),
               Line2D([], [], color=NOMINAL_COLOR, lw=1.2, label="nominal (undispersed) flight")]
    fig.legend(handles=handles, loc="outside lower center", ncol=5, fontsize=9, frameon=False)
    fig.suptitle(_title(result))
    return fig


def speed_time_figure(result, *, ax: style.UserAxes | None = None) -> Figure:
    """Impact speed (m/s) against flight time (s) of every impacted case, coloured by release altitude (m)."""
    ok = result["impacted"] > 0.5
    fig, axes = style.new_figure(1, 1, (7.5, 6.2), ax=ax)
    ax = axes[0, 0]
    sc = ax.scatter(result["flight_time_s"][ok], result["impact_speed_mps"][ok], s=6, alpha=0.7,
                    c=result["h_agl_m"][ok], cmap="viridis")
    fig.colorbar(sc, ax=ax, label=r"release altitude $h_{\mathrm{AGL}}$, m")
    handles = [Line2D([], [], color="0.4", marker="o", ls="", ms=4, label="dispersed case")]
    if result.nominal:
        ax.plot(result.nominal["flight_time_s"], result.nominal["impact_speed_mps"], "*", color=NOMINAL_COLOR,
                ms=14, mec="k")
        handles.append(Line2D([], [], color=NOMINAL_COLOR, marker="*", mec="k", ls="", ms=12,
                              label="nominal (undispersed) flight"))
    ax.set_xlabel("flight time (release to touchdown), s")
    ax.set_ylabel("impact speed, m/s")
    ax.set_title(f"impact speed against flight time ({int(ok.sum())} of {result.n_cases} cases impacted)",
                 fontsize=10)
    fig.legend(handles=handles, loc="outside lower center", ncol=2, fontsize=9, frameon=False)
    fig.suptitle(_title(result))
    return fig


def envelope_figure(envelopes: dict[str, np.ndarray], title: str, n_cases: int,
                    touchdown_s: tuple[float, float] | None = None, *, ax: style.UserAxes | None = None) -> Figure:
    """The p1-p99 band, median and nominal flight of :data:`ENVELOPES` against flight time (s), the
    altitude also about its median (the band is too thin to see at the scale of the drop), and the
    number of cases in flight.

    Parameters
    ----------
    envelopes : dict of str to array
        :meth:`~casrecon.analysis.mc_envelopes.Histories.envelopes` (or ``envelopes.csv`` read back).
    title : str
        Figure title.
    n_cases : int
        Cases of the run (for :data:`MIN_IN_FLIGHT_FRACTION`).
    touchdown_s : (float, float) or None
        1st and 99th percentiles of the flight time, s, shaded as the touchdown window.
    """
    t = envelopes[TIME]
    many = envelopes[IN_FLIGHT] >= MIN_IN_FLIGHT_FRACTION * n_cases
    fig, axes = style.new_figure(3, 2, (13, 10.5), ax=ax)
    panels = [("h_agl_m", False), ("h_agl_m", True), ("speed_mps", False), ("alpha_t_deg", False),
              ("pitch_deg", False)]
    for ax, (channel, about_median) in zip(axes.flat, panels):
        label, unit = ENVELOPES[channel]
        shown = np.ones_like(many) if channel == "h_agl_m" else many
        lo, mid, hi = (np.where(shown, envelopes[envelope_column(channel, p)], np.nan) for p in (1, 50, 99))
        nominal = envelopes[envelope_column(channel, "nominal")]
        ref = mid if about_median else 0.0
        ax.fill_between(t, lo - ref, hi - ref, color=CASES_COLOR, alpha=0.3, lw=0)
        ax.plot(t, mid - ref, color=MEDIAN_COLOR, lw=1.1)
        ax.plot(t, nominal - ref, color=NOMINAL_COLOR, lw=1.1, ls="--")
        ax.set_ylabel(f"{label} minus its median, {unit}" if about_median else f"{label}, {unit}")
    count = axes[2, 1]
    count.plot(t, envelopes[IN_FLIGHT], color=CASES_COLOR, lw=1.3)
    count.set_ylim(0, 1.05 * n_cases)
    count.set_ylabel("cases in flight")
    for ax in axes.flat:
        if touchdown_s is not None:
            ax.axvspan(*touchdown_s, color="0.5", alpha=0.15, lw=0)
    for ax in axes[-1]:
        ax.set_xlabel("flight time since release, s")
    handles = [Patch(color=CASES_COLOR, alpha=0.3, label="1st to 99th percentile of the cases"),
               Line2D([], [], color=MEDIAN_COLOR, lw=1.1, label="median (50th percentile)"),
               Line2D([], [], color=NOMINAL_COLOR, ls="--", lw=1.1, label="nominal (undispersed) flight")]
    if touchdown_s is not None:
        handles.append(Patch(color="0.5", alpha=0.15, label="touchdown window (flight time p1 to p99)"))
    fig.legend(handles=handles, loc="outside lower center", ncol=4, fontsize=9, frameon=False)
    fig.suptitle(f"{title}\nenvelopes of {n_cases} cases (altitude: landed cases at 0 m; speed and attitude: "
                 f"cases in flight, drawn while $\\geq$ {MIN_IN_FLIGHT_FRACTION:.0%} fly)")
    return fig


def montecarlo_envelope_figure(result, *, ax: style.UserAxes | None = None) -> Figure:
    """:func:`envelope_figure` of a :class:`~casrecon.analysis.montecarlo.MonteCarloResult` with
    histories (ValueError without)."""
    if result.histories is None:
        raise ValueError("the Monte Carlo result has no histories (run with history_dt_s)")
    ft = result.statistics()["flight_time_s"]
    window = (ft["p1"], ft["p99"]) if ft else None
    return envelope_figure(result.histories.envelopes(), _title(result), result.histories.n_cases, window, ax=ax)


def plot_montecarlo(result, folder: str | Path, formats: Sequence[str] = style.DEFAULT_FORMATS) -> list[Path]:
    """Write ``histograms``, ``speed_vs_time`` and (with histories) ``envelopes`` into ``folder``
    in each of ``formats`` (``png``, ``pdf``, ``svg``); returns the paths.

    ``result`` is a :class:`~casrecon.analysis.montecarlo.MonteCarloResult`.
    """
    folder = Path(folder)
    figures = {"histograms": histogram_figure, "speed_vs_time": speed_time_figure}
    if result.histories is not None:
        figures["envelopes"] = montecarlo_envelope_figure
    paths: list[Path] = []
    for name, draw in figures.items():
        paths += style.save_figure(draw(result), folder / name, formats)
    return paths
