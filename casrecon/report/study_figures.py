"""Figures of the Monte Carlo and observability studies, returned as ``matplotlib.figure.Figure``
(the public plot API, as :mod:`casrecon.report.result_figures` is for fits).

Each function takes the study's result object or the results folder the command wrote, and draws
the figure the command draws, without writing anything (``fig.savefig("x.pdf")`` saves it):

- :func:`plot_montecarlo_histograms`, :func:`plot_montecarlo_impact`,
  :func:`plot_montecarlo_envelopes`: a :class:`~casrecon.analysis.montecarlo.MonteCarloResult`
  (``casrecon.montecarlo``) or a ``casrecon montecarlo --out`` folder;
- :func:`plot_fisher_directions`: a fresh fit (``casrecon.fit``, whose Fisher information is
  decomposed here), a ``fisher.json`` document, or a ``casrecon sensitivity --out`` folder;
- :func:`plot_profile_likelihood`: a :class:`~casrecon.analysis.observability.Profile`, a
  ``profile_<name>.json`` document or file, or a sensitivity folder (its profile of ``name``);
- :func:`plot_design_study`: the dict of :func:`~casrecon.analysis.observability.design_study`,
  a ``design.json`` document, or a sensitivity folder.

Each also takes ``ax=``, the caller's matplotlib Axes to draw on (one per panel, row-major), as the
functions of :mod:`casrecon.report.result_figures` do.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from casrecon.analysis.montecarlo import MonteCarloResult
from casrecon.analysis.observability import Profile, fisher_directions
from casrecon.analysis.sensitivity_documents import fisher_document
from casrecon.io.montecarlo_config import Dispersions
from casrecon.report import montecarlo_plots, sensitivity_plots
from casrecon.report.figure_style import UserAxes
from casrecon.report.results_folder import read_csv, read_json


def _montecarlo(result: Any) -> MonteCarloResult:
    """A MonteCarloResult, or one read back from a ``casrecon montecarlo`` folder (no histories)."""
    if isinstance(result, MonteCarloResult):
        return result
    if not isinstance(result, (str, Path)):
        raise TypeError(f"expected a Monte Carlo result (casrecon.montecarlo) or its results folder, "
                        f"got {type(result).__name__}")
    folder = Path(result)
    stats = read_json(folder / "statistics.json")
    columns = read_csv(folder / "cases.csv")
    disp = dict(stats.get("dispersions_1sigma") or {})
    disp["aero_factors"] = tuple(disp.get("aero_factors", ()))
    return MonteCarloResult(columns, int(stats["seed"]), Dispersions(**disp), float(stats["dt_s"]),
                            float(stats.get("wall_s") or 0.0), dict(stats.get("nominal") or {}),
                            str(stats.get("problem", "")))


def plot_montecarlo_histograms(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """Histograms of the flight time (s), impact speed (m/s) and peak total angle of attack (deg) over
    the impacted cases, with the mean, mean +-3 sd, the 1st/99th percentiles and the nominal flight."""
    return montecarlo_plots.histogram_figure(_montecarlo(result), ax=ax)


def plot_montecarlo_impact(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """Impact speed (m/s) against flight time (s) of every impacted case, coloured by release altitude (m)."""
    return montecarlo_plots.speed_time_figure(_montecarlo(result), ax=ax)


def plot_montecarlo_envelopes(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """p1-p99 envelopes, median and nominal flight of the altitude (m), speed (m/s), total angle of
    attack and pitch (deg) against flight time (s), with the touchdown window. A result needs its
    histories (``history_dt_s``); a folder needs ``envelopes.csv``."""
    if isinstance(result, MonteCarloResult):
        return montecarlo_plots.montecarlo_envelope_figure(result, ax=ax)
    mc = _montecarlo(result)
    stats = read_json(Path(result) / "statistics.json")
    ft = stats.get("flight_time_s")
    title = f"{mc.problem}: dispersed Monte Carlo, seed {mc.seed}, RK4 $\\Delta t$ = {mc.dt_s:g} s"
    return montecarlo_plots.envelope_figure(read_csv(Path(result) / "envelopes.csv"), title,
                                            int(stats.get("n_history_cases") or mc.n_cases),
                                            (ft["p1"], ft["p99"]) if ft else None, ax=ax)


def _document(source: Any, file_name: str) -> dict:
    """A JSON document given as a dict, its file, or a folder holding ``file_name``."""
    if isinstance(source, dict):
        return source
    if isinstance(source, (str, Path)):
        path = Path(source)
        return read_json(path / file_name if path.is_dir() else path)
    raise TypeError(f"expected {file_name} (a dict, the file or its folder), got {type(source).__name__}")


def plot_fisher_directions(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """The eigen-directions of the parameters' Fisher information, weakest first: loadings per
    parameter and the sigma of each direction (parameters divided by their scale).

    Parameters
    ----------
    result : DropFit, FitResult, dict or path
        A fresh fit (``casrecon.fit``; a result loaded from a folder lacks the parameter scales),
        the estimator's :class:`~casrecon.estimation.sixdof.fit.FitResult`, a ``fisher.json`` document, or
        that file or the ``casrecon sensitivity --out`` folder holding it.
    """
    fit = getattr(result, "fit", result)
    if hasattr(fit, "params") and hasattr(fit, "correlation") and hasattr(fit, "scenario"):
        return sensitivity_plots.fisher_figure(fisher_document(fit.scenario.config.name, fisher_directions(fit),
                                                               fit.params.specs), ax=ax)
    if hasattr(result, "params") and not isinstance(result, (dict, str, Path)):
        raise TypeError("a loaded result has no parameter scales: plot a fresh casrecon.fit result, or the "
                        "fisher.json of casrecon sensitivity")
    return sensitivity_plots.fisher_figure(_document(result, "fisher.json"), ax=ax)


def plot_profile_likelihood(profile: Any, name: str | None = None, *, ax: UserAxes | None = None) -> Figure:
    """Delta chi-square of a profile likelihood against the held value, with the delta chi-square = 9
    line and the Fisher 3-sigma interval.

    Parameters
    ----------
    profile : Profile, dict or path
        :func:`casrecon.analysis.observability.profile_likelihood`'s result, a ``profile_<name>.json``
        document or file, or the ``casrecon sensitivity profile --out`` folder.
    name : str, optional
        The profiled parameter, for a folder (default: its only profile).
    """
    if not isinstance(profile, Profile):
        if isinstance(profile, (str, Path)) and Path(profile).is_dir():
            found = sorted(Path(profile).glob(f"profile_{name or '*'}.json"))
            if len(found) != 1:
                raise FileNotFoundError(f"{profile}: expected one profile_{name or '<name>'}.json, found "
                                        f"{[p.name for p in found] or 'none'}")
            profile = found[0]
        doc = _document(profile, "")
        profile = Profile(doc["parameter"], np.asarray(doc["values"], float), np.asarray(doc["delta_chi2"], float),
                          float(doc["estimate"]), float(doc["fisher_three_sigma"]),
                          tuple(doc["interval_delta_chi2_9"]))
    return sensitivity_plots.profile_figure(profile, ax=ax)


def plot_design_study(design: Any, *, ax: UserAxes | None = None) -> Figure:
    """Predicted 1-sigma of a parameter against the initial pitch rate (deg/s), the release altitude
    (m) and the number of drops: the dict of :func:`casrecon.analysis.observability.design_study`,
    a ``design.json`` document, or that file or its folder."""
    doc = _document(design, "design.json")
    rows = {"pitch_rate": "pitch_rate_dps", "altitude": "h_agl_m", "n_drops": "n_drops"}
    study = {"parameter": doc["parameter"]}
    for key, column in rows.items():
        study[key] = [(r[column], r["sigma"]) if isinstance(r, dict) else tuple(r) for r in doc.get(key, [])]
    return sensitivity_plots.design_figure(study, ax=ax)
