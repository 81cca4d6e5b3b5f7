"""Figures of a result object, returned as ``matplotlib.figure.Figure`` (the public plot API).

Each function takes a :class:`~casrecon.results.drop_fit.DropFit` (from ``casrecon.fit`` or
``casrecon.load_results``), a results folder path, or a :class:`~casrecon.report.results_folder.DropFolder`
/ :class:`~casrecon.report.results_folder.DropTables`, and draws the same figure as ``casrecon
report`` does, without writing anything: ``fig.savefig("x.png")`` saves it. Figures use matplotlib's
object API on an Agg canvas (no pyplot state); in a notebook, display ``fig`` itself.

The ``plot_joint_*`` functions and :func:`plot_shared_correlation` take a
:class:`~casrecon.results.joint_fit.JointFit` (``casrecon.fit_joint``, ``casrecon.load_results`` on a
joint folder) or a joint results folder and draw the figures ``casrecon joint`` puts in its
``figures/`` (every drop on one plot).

Every function takes ``ax=``: the caller's matplotlib Axes to draw on instead of a new figure, one
per panel in row-major order (one Axes for a one-panel figure; e.g. ``fig.subplots(3, 2)`` for the
six panels of :func:`plot_trajectory`; a wrong number is a ValueError saying how many the figure
draws), and then returns the figure of those axes, with the title and legend on it (a figure with
``layout="constrained"`` keeps the legend clear of the panels).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
from matplotlib.figure import Figure

from casrecon.report import aero_figures, joint_correlation, joint_figures, residual_figures, trajectory_figures
from casrecon.report.figure_style import UserAxes
from casrecon.report.results_folder import DropFolder, DropTables, drop_folders, read_json


def _source(result: Any) -> DropFolder | DropTables:
    if isinstance(result, (DropFolder, DropTables)):
        return result
    if isinstance(result, (str, Path)):
        return DropFolder(Path(result))
    if hasattr(result, "figure_source"):
        return result.figure_source()
    raise TypeError(f"expected a per-drop result (casrecon.fit / casrecon.load_results) or a results folder, "
                    f"got {type(result).__name__}")


def plot_trajectory(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """Altitude AGL (m), down velocity and speed, north and east velocity (m/s) against flight time
    (s): reconstruction lines and GPS fixes as dots."""
    return trajectory_figures.altitude_velocity_figure(_source(result), ax=ax)


def plot_qbar_alpha_t(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """Dynamic pressure (Pa) and total angle of attack (deg) with 3-sigma bands against flight time (s)."""
    return trajectory_figures.qbar_alpha_t_figure(_source(result), ax=ax)


def plot_pitching_moment(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """C_m about the MRP against angle of attack (deg): reconstructed points, nominal and best-fit curves."""
    return trajectory_figures.pitching_moment_figure(_source(result), ax=ax)


def plot_reconciled(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """Reconstruction against the forward simulation with the fitted dispersions (and the nominal one)."""
    return trajectory_figures.reconciled_figure(_source(result), ax=ax)


def plot_aero_coefficients(result: Any, against: str = "time", *, ax: UserAxes | None = None) -> Figure:
    """C_A, C_Y, C_N (body axes) and C_l, C_m, C_n (about the MRP) along the reconstructed flight:
    reconstructed from the IMU (black) and of the best-fit database (red), each with its 3-sigma
    band, and of the nominal database (blue) (the DAVINCI paper's Figs. 12-15).

    Parameters
    ----------
    result : DropFit, path or DropFolder
    against : {"time", "alpha_t"}
        Flight time, s (six panels), or total angle of attack, deg (C_A and the crossflow-plane
        resultants C_N(alpha_T), C_m(alpha_T)).
    """
    draw = {"time": aero_figures.aero_coefficients_figure, "alpha_t": aero_figures.aero_alpha_t_figure}
    if against not in draw:
        raise ValueError(f"no aero coefficient figure against {against!r}; available: {', '.join(draw)}")
    return draw[against](_source(result), ax=ax)


def plot_aero_sigma(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """The size of the 3-sigma bands of :func:`plot_aero_coefficients` against flight time (s), log scale."""
    return aero_figures.aero_sigma_figure(_source(result), ax=ax)


def plot_residuals(result: Any, kind: str = "imu", *, ax: UserAxes | None = None) -> Figure:
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
    return draw[kind](_source(result), ax=ax)


def plot_correlation(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """The parameter correlation matrix (-1..1) of a per-drop or joint result, names on both axes;
    a joint result's is blocked (shared factors, then each drop's parameters), with short labels and
    values where the cells are large enough (:func:`casrecon.report.joint_correlation.joint_correlation_figure`)."""
    if _is_joint(result):
        doc, title = _joint_parameters(result)
        return joint_correlation.joint_correlation_figure(doc, title, ax=ax)
    params = getattr(result, "params", None)
    if params is not None and hasattr(params, "correlation"):
        doc = {"correlation": {"names": list(params.names), "matrix": np.asarray(params.correlation).tolist()}}
        return residual_figures.correlation_figure(doc, str(getattr(result, "name", "fit")), ax=ax)
    source = _source(result)
    return residual_figures.correlation_figure(source.json("parameters.json"), source.name, ax=ax)


def _is_joint(result: Any) -> bool:
    if isinstance(result, (str, Path)):
        return (Path(result) / "drops").is_dir()
    return isinstance(getattr(result, "drops", None), dict)


def _joint_parameters(result: Any) -> tuple[dict, str]:
    """``parameters.json``-like document and title of a JointFit or joint folder."""
    if isinstance(result, (str, Path)):
        folder = Path(result)
        summary = read_json(folder / "summary.json")
        return read_json(folder / "parameters.json"), str(summary.get("name") or folder.name)
    params = result.params
    doc = {"correlation": {"names": list(params.names), "matrix": np.asarray(params.correlation).tolist()}}
    return doc, str(result.name)


def _joint_drops(result: Any) -> tuple[list[DropFolder | DropTables], str]:
    """Each drop's tables and the title of a JointFit (``casrecon.fit_joint``, ``load_results``) or a
    joint results folder."""
    if isinstance(result, (str, Path)):
        folder = Path(result)
        drops = drop_folders(folder)
        if not drops:
            raise TypeError(f"{folder} is not a joint results folder (no drops/)")
        return [DropFolder(p) for p in drops], _joint_parameters(folder)[1]
    if not _is_joint(result):
        raise TypeError(f"expected a joint result (casrecon.fit_joint / casrecon.load_results) or a joint "
                        f"results folder, got {type(result).__name__}")
    return [d.figure_source() for d in result.drops.values()], str(result.name)


def plot_joint_altitude_speed(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """Altitude AGL (m) and speed (m/s) of every drop of a joint fit against flight time (s), one
    colour per drop, 3-sigma bands light (left) and the 3-sigma itself (right) (EES Fig. 10)."""
    return joint_figures.overlay_figure(*_overlay_args(result, "joint_altitude_speed"), ax=ax)


def plot_joint_qbar_alpha_t(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """Dynamic pressure (Pa) and total angle of attack (deg) of every drop of a joint fit, as
    :func:`plot_joint_altitude_speed` (EES Fig. 11)."""
    return joint_figures.overlay_figure(*_overlay_args(result, "joint_qbar_alpha_t"), ax=ax)


def plot_joint_flow_angles(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """Angle of attack and sideslip (deg) of every drop of a joint fit, as :func:`plot_joint_altitude_speed`."""
    return joint_figures.overlay_figure(*_overlay_args(result, "joint_flow_angles"), ax=ax)


def plot_joint_rates(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """Body rates p, q, r (deg/s) of every drop of a joint fit, as :func:`plot_joint_altitude_speed`."""
    return joint_figures.overlay_figure(*_overlay_args(result, "joint_rates"), ax=ax)


def plot_joint_pitching_moment(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """C_m about the MRP against angle of attack (deg) of every drop of a joint fit, with the nominal
    and jointly fitted database, and each drop's difference from the fit (EES Fig. 12)."""
    drops, title = _joint_drops(result)
    return joint_figures.pitching_moment_overlay(drops, title, ax=ax)


def plot_shared_correlation(result: Any, *, ax: UserAxes | None = None) -> Figure:
    """A joint fit's shared factors' correlations with each other and with each drop's own parameters."""
    doc, title = _joint_parameters(result) if _is_joint(result) else (None, "")
    if doc is None:
        raise TypeError(f"expected a joint result or a joint results folder, got {type(result).__name__}")
    return joint_correlation.shared_correlation_figure(doc, title, ax=ax)


def _overlay_args(result: Any, name: str) -> tuple[list, str, str]:
    drops, title = _joint_drops(result)
    return drops, name, title
