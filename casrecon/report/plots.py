"""Figures of a results folder (per-drop fit or multi-drop joint fit), drawn from its files only.

``draw_figures(results_dir, formats=("png",))`` reads the CSV/JSON files that ``casrecon fit`` writes
(no CasADi, no re-fit) and saves each figure into ``results_dir / "figures"`` once per format (PNG at
150 dpi, PDF, SVG). A joint folder (one sub-folder per drop under ``drops/``) gets each drop's figures
in ``drops/<name>/figures`` and the joint figures (multi-drop overlays, readable correlation figures;
:mod:`casrecon.report.joint_plots`) in ``results_dir / "figures"``.

Figures of one drop (flight time t = time_imu_s - release_imu_s, in s):

- ``altitude_velocity``: altitude AGL (m), speed and NED velocity (m/s), ground track; reconstruction
  lines, GPS fixes as dots;
- ``qbar_alpha_t``: dynamic pressure (Pa) and total angle of attack (deg) with 3-sigma bands, and the
  3-sigma itself against time;
- ``aero_coefficients``, ``aero_coefficients_alpha_t``, ``aero_coefficients_sigma``: the coefficient
  histories of aero_coefficients.csv with their 3-sigma bands against time and alpha_T, and the size
  of the bands (:mod:`casrecon.report.aero_figures`);
- ``pitching_moment``: C_m about the MRP against angle of attack (deg), reconstructed from the
  measured rates (qbar > 100 Pa, |alpha| < 20 deg), nominal and fitted database curves;
- ``reconciled``: reconstruction against the forward simulations with the fitted and nominal aero;
- ``residuals_imu``, ``residuals_gps``: sensor residuals with +-1 and +-3 sigma lines;
- ``inputs_imu``, ``inputs_gps``, ``inputs_sounding``: the data files the fit read
  (:mod:`casrecon.report.input_figures`);
- ``correlation``: the parameter correlation matrix.

The figures themselves live in :mod:`casrecon.report.trajectory_figures` (flight),
:mod:`casrecon.report.aero_figures`, :mod:`casrecon.report.input_figures` and
:mod:`casrecon.report.residual_figures` (residuals, correlation); their look (colour code, labels, one
legend per figure, formats) in :mod:`casrecon.report.figure_style`; this module draws them all.
Figures are drawn on ``matplotlib.figure.Figure`` objects (Agg canvas, never pyplot), so nothing is
registered globally and a figure is freed once saved and no longer referenced. The drop's figures are
laid out by :class:`casrecon.report.figure_layout.FixedLayout` (margins measured once from their text)
with few ticks: 0.15 to 0.8 s of CPU each on ees-drop-1, 5 to 7 s for all 13 on a loaded machine
(15 s with constrained layout and matplotlib's default ticks; ``benchmarks/bench_figures.py``). A
figure whose optional input file is missing is skipped with a note (logged, and appended to ``notes``
if given); one that cannot be drawn or written (an input file named by ``config/resolved.json`` that
is damaged, a read-only disk) is a failure (logged, and appended to ``failures`` if given). Every
file of the folder is read and checked before any figure is drawn
(:mod:`casrecon.output.results_reader`): a folder without ``summary.json`` or ``trajectory.csv``, or
with a damaged file, raises :class:`~casrecon.io.errors.InputError` naming the file.
"""

from __future__ import annotations

import logging
import os
import tempfile
from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path

from matplotlib.figure import Figure

from casrecon.output.results_reader import folder_kind, read_results_folder
from casrecon.parallel import parallel_map
from casrecon.report import figure_style as style
from casrecon.report.aero_figures import aero_alpha_t_figure, aero_coefficients_figure, aero_sigma_figure
from casrecon.report.input_figures import INPUT_FIGURES
from casrecon.report.joint_plots import draw_joint_figures
from casrecon.report.kinematic_plots import plot_kinematic
from casrecon.report.pointmass_plots import plot_track_fit
from casrecon.report.residual_figures import correlation_figure, residuals_gps_figure, residuals_imu_figure
from casrecon.report.results_folder import (
    REQUIRED_FILES,
    DropFolder,
    MissingInput,
    attempt_figure,
    drop_folders,
    read_json,
)
from casrecon.report.trajectory_figures import (
    altitude_velocity_figure,
    pitching_moment_figure,
    qbar_alpha_t_figure,
    reconciled_figure,
)

log = logging.getLogger(__name__)


#: Figures of one drop: (file stem, function of a DropFolder returning a Figure).
DROP_FIGURES: tuple[tuple[str, Callable[[DropFolder], Figure]], ...] = (
    ("altitude_velocity", altitude_velocity_figure),
    ("qbar_alpha_t", qbar_alpha_t_figure),
    ("aero_coefficients", aero_coefficients_figure),
    ("aero_coefficients_alpha_t", aero_alpha_t_figure),
    ("aero_coefficients_sigma", aero_sigma_figure),
    ("pitching_moment", pitching_moment_figure),
    ("reconciled", reconciled_figure),
    ("residuals_imu", residuals_imu_figure),
    ("residuals_gps", residuals_gps_figure),
    *INPUT_FIGURES,
)


#: Figures drawn first, the costliest first (CPU seconds of ees-drop-1's: 0.5 to 0.8 s; the others 0.15 to
#: 0.5 s; benchmarks/bench_figures.py), so that the workers finish together.
COSTLY_FIRST = ("residuals_imu", "reconciled", "aero_coefficients", "aero_coefficients_sigma", "inputs_imu",
                "inputs_gps", "altitude_velocity", "residuals_gps")


def draw_order(correlation: bool = True) -> list[int]:
    """Indices of :data:`DROP_FIGURES` (``len(DROP_FIGURES)``: the correlation matrix, if wanted) in
    drawing order: :data:`COSTLY_FIRST`, then the others in figure order."""
    labels = [label for label, _ in DROP_FIGURES] + (["correlation"] if correlation else [])
    rank = {label: k for k, label in enumerate(COSTLY_FIRST)}
    return sorted(range(len(labels)), key=lambda i: (rank.get(labels[i], len(rank)), i))


def draw_drop_figure(folder: Path, index: int, correlation: bool,
                     formats: Sequence[str] = style.DEFAULT_FORMATS) -> tuple[list[Path], list[str], list[str]]:
    """Figure number ``index`` of DROP_FIGURES (or the correlation matrix) of one drop folder: the
    paths written, the note of a figure skipped for want of an optional input, and the failure of
    one that could not be drawn or written (:func:`~casrecon.report.results_folder.attempt_figure`)."""
    drop = DropFolder(folder)
    out = drop.folder / "figures"
    if index < len(DROP_FIGURES):
        label, make = DROP_FIGURES[index]
        return attempt_figure(f"{drop.name} {label}", lambda: style.save_figure(make(drop), out / label, formats))
    return attempt_figure(f"{drop.name} correlation", lambda: style.save_figure(correlation_figure(
        drop.json("parameters.json"), drop.name), out / "correlation", formats))


def collect(done: Sequence[tuple[list[Path], list[str], list[str]]], notes: list[str],
            failures: list[str] | None) -> list[Path]:
    """The paths of figure outcomes ``(paths, notes, failures)``, in order; their notes appended to
    ``notes`` and their failures to ``failures`` (to ``notes`` when None), each logged."""
    paths: list[Path] = []
    for p, n, f in done:
        paths += p
        notes += n
        (notes if failures is None else failures).extend(f)
        for line in n + f:
            log.warning(line)
    return paths


def draw_drop_figures(folder: Path, notes: list[str] | None = None, correlation: bool = True, workers: int = 2,
                      formats: Sequence[str] = style.DEFAULT_FORMATS, failures: list[str] | None = None) -> list[Path]:
    """All figures of one drop's results folder into ``folder / "figures"``; returns the paths.

    Each figure is saved once per format of ``formats`` (``"png"``, ``"pdf"``, ``"svg"``).
    Figures are drawn by ``workers`` forked processes (matplotlib spends its time in layout and
    rasterisation, one core per figure); ``workers=1`` draws them in this process
    (:class:`casrecon.report.figure_pool.FigurePool` draws them with workers started before the fit).
    A figure skipped for want of an optional input is noted in ``notes``; one that could not be drawn
    or written in ``failures`` (in ``notes`` when None). InputError if summary.json or
    trajectory.csv is missing.
    """
    notes = [] if notes is None else notes
    DropFolder(folder)  # validates the folder before any worker starts
    indices = draw_order(correlation)
    drawn: list[int] = []

    def said(index: int, value: tuple[list[Path], list[str], list[str]]) -> None:  # a log line per figure
        drawn.append(index)
        log.info("figure %d of %d: %s", len(drawn), len(indices), ", ".join(p.name for p in value[0]) or "skipped")

    done = parallel_map(partial(draw_drop_figure, folder, correlation=correlation, formats=tuple(formats)), indices,
                        workers=workers, start_method="fork", on_done=said)
    return collect([d for _, d in sorted(zip(indices, done), key=lambda x: x[0])], notes, failures)


#: Files without which ``report`` cannot draw a folder of each kind (a joint folder: ``drops/`` and,
#: in each drop, those of a per-drop folder).
REPORT_REQUIRED = {"drop": REQUIRED_FILES, "joint": ("drops/",), "point-mass": ("summary.json", "trajectory.csv",
                                                                               "residuals_gps.csv", "gps_fixes.csv"),
                   "kinematic": ("summary.json", "trajectory.csv", "residuals_imu.csv", "residuals_gps.csv")}


def figure_folders(results_dir: Path) -> list[Path]:
    """The ``figures/`` folders :func:`draw_figures` writes into (a joint folder's and each drop's)."""
    results_dir = Path(results_dir)
    return [results_dir / "figures"] + [d / "figures" for d in drop_folders(results_dir)]


def check_writable(results_dir: Path) -> None:
    """OSError naming the folder unless every ``figures/`` folder of ``results_dir`` can be made and
    written (a file is created and removed in each, a folder made for it removed again): checked
    before any figure is drawn."""
    for figures in figure_folders(results_dir):
        made = not figures.exists()
        try:
            figures.mkdir(exist_ok=True)
            fd, probe = tempfile.mkstemp(prefix=".casrecon-probe-", dir=figures)
            os.close(fd)
            os.unlink(probe)
        except OSError as err:
            raise OSError(err.errno, f"{err.strerror or err}; no figure written", str(figures)) from None
        if made:
            figures.rmdir()  # made again by the first figure; none left if the folder turns out damaged


def draw_figures(results_dir: Path, notes: list[str] | None = None,
                 formats: Sequence[str] = style.DEFAULT_FORMATS, failures: list[str] | None = None) -> list[Path]:
    """Draw every figure of a results folder in each of ``formats`` and return the paths.

    Every file of the folder is read and checked first (:func:`casrecon.output.results_reader.read_results_folder`):
    a damaged one is an InputError naming it, before any figure is drawn. A per-drop folder gets its
    figures in ``results_dir / "figures"``. A joint folder (sub-folders ``drops/<name>/``) gets each
    drop's figures in ``drops/<name>/figures`` and the joint figures (:mod:`casrecon.report.joint_plots`:
    multi-drop overlays, the blocked correlation matrix of ``results_dir / "parameters.json"`` and
    the shared factors' correlations) in ``results_dir / "figures"``. A point-mass folder gets its
    track fit (:mod:`casrecon.report.pointmass_plots`), a kinematic one its reconstruction
    (:mod:`casrecon.report.kinematic_plots`). Figures skipped for want of an optional input are
    logged and noted in ``notes``; figures that could not be drawn or written in ``failures`` (in
    ``notes`` when None).
    Raises InputError if ``results_dir`` (or a drop sub-folder) is not a results folder or holds a
    damaged file.
    """
    results_dir = Path(results_dir)
    notes = [] if notes is None else notes
    kind = folder_kind(results_dir)
    read_results_folder(results_dir, kind, REPORT_REQUIRED[kind], REQUIRED_FILES)
    if kind in ("point-mass", "kinematic"):
        draw = partial(plot_track_fit if kind == "point-mass" else plot_kinematic, results_dir, tuple(formats))
        return collect([attempt_figure(f"{results_dir.name} {kind}", lambda: [draw()])], notes, failures)
    drops = drop_folders(results_dir)
    if kind == "drop":
        return draw_drop_figures(results_dir, notes, formats=formats, failures=failures)
    paths: list[Path] = []
    for k, folder in enumerate(drops):
        log.info("figures of drop %d of %d (%s)", k + 1, len(drops), folder.name)
        paths += draw_drop_figures(folder, notes, correlation=False, formats=formats, failures=failures)
    title = _joint_title(results_dir, drops)
    log.info("joint figures")
    paths += draw_joint_figures(results_dir, drops, title, notes, formats=formats, failures=failures)
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
