"""Figures of a result object, returned as ``matplotlib.figure.Figure`` (the public plot API).

Each function takes a :class:`~casrecon.output.drop_fit.DropFit` (from ``casrecon.fit`` or
``casrecon.load_results``), a results folder path, or a :class:`~casrecon.report.results_folder.DropFolder`
/ :class:`~casrecon.report.results_folder.DropTables`, and draws the same figure as ``casrecon
report`` does, without writing anything: ``fig.savefig("x.png")`` saves it. Figures use matplotlib's
object API on an Agg canvas (no pyplot state); in a notebook, display ``fig`` itself.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from casrecon.report import residual_figures, trajectory_figures
from casrecon.report.results_folder import DropFolder, DropTables


def _source(result: Any) -> DropFolder | DropTables:
    if isinstance(result, (DropFolder, DropTables)):
        return result
    if isinstance(result, (str, Path)):
        return DropFolder(Path(result))
    if hasattr(result, "figure_source"):
        return result.figure_source()
    raise TypeError(f"expected a per-drop result (casrecon.fit / casrecon.load_results) or a results folder, "
                    f"got {type(result).__name__}")


def plot_trajectory(result: Any) -> Figure:
    """Altitude AGL (m), down velocity and speed, north and east velocity (m/s) against flight time
    (s): reconstruction lines and GPS fixes as dots."""
    return trajectory_figures.altitude_velocity_figure(_source(result))


def plot_qbar_alpha_t(result: Any) -> Figure:
    """Dynamic pressure (Pa) and total angle of attack (deg) with 3-sigma bands against flight time (s)."""
    return trajectory_figures.qbar_alpha_t_figure(_source(result))


def plot_pitching_moment(result: Any) -> Figure:
    """C_m about the MRP against angle of attack (deg): reconstructed points, nominal and best-fit curves."""
    return trajectory_figures.pitching_moment_figure(_source(result))


def plot_reconciled(result: Any) -> Figure:
    """Reconstruction against the forward simulation with the fitted dispersions (and the nominal one)."""
    return trajectory_figures.reconciled_figure(_source(result))


def plot_residuals(result: Any, kind: str = "imu") -> Figure:
    """Sensor residuals (measured minus model, SI; gyros in deg/s) with +-1 and +-3 sigma lines.

    Parameters
    ----------
    result : DropFit, path or DropFolder
    kind : {"imu", "gps"}
        Measurement kind.
    """
    draw = {"imu": residual_figures.residuals_imu_figure, "gps": residual_figures.residuals_gps_figure}
    if kind not in draw:
        raise ValueError(f"no residual figure for kind {kind!r}; available: {', '.join(draw)}")
    return draw[kind](_source(result))


def plot_correlation(result: Any) -> Figure:
    """The parameter correlation matrix (-1..1) of a per-drop or joint result, names on both axes."""
    params = getattr(result, "params", None)
    if params is not None and hasattr(params, "correlation"):
        doc = {"correlation": {"names": list(params.names), "matrix": np.asarray(params.correlation).tolist()}}
        return residual_figures.correlation_figure(doc, str(getattr(result, "name", "fit")))
    source = _source(result)
    return residual_figures.correlation_figure(source.json("parameters.json"), source.name)
