"""The joint figures of a joint results folder, drawn into its ``figures/`` from its files only:
the multi-drop overlays of :mod:`casrecon.report.joint_figures` and the correlation figures of
:mod:`casrecon.report.joint_correlation` (``correlation.png``: the whole blocked matrix;
``correlation_shared.png``: the shared factors against each other and each drop's parameters)."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from functools import partial
from pathlib import Path

from matplotlib.figure import Figure

from casrecon.parallel import parallel_map
from casrecon.report import figure_style as style
from casrecon.report.joint_correlation import joint_correlation_figure, shared_correlation_figure
from casrecon.report.joint_figures import JOINT_FIGURES
from casrecon.report.results_folder import DropFolder, attempt_figure, read_json

#: File stems of the joint folder's figures, in drawing order.
JOINT_FIGURE_NAMES = (*JOINT_FIGURES, "correlation", "correlation_shared")


def joint_figure(results_dir: Path, drop_dirs: list[Path], name: str, title: str) -> Figure:
    """Joint figure ``name`` (one of :data:`JOINT_FIGURE_NAMES`) of a joint folder."""
    if name in JOINT_FIGURES:
        return JOINT_FIGURES[name]([DropFolder(p) for p in drop_dirs], title)
    draw: Callable[[dict, str], Figure] = (joint_correlation_figure if name == "correlation"
                                           else shared_correlation_figure)
    return draw(read_json(Path(results_dir) / "parameters.json"), title)


def _draw_one(results_dir: Path, drop_dirs: list[Path], title: str, formats: tuple[str, ...],
              name: str) -> tuple[list[Path], list[str], list[str]]:
    return attempt_figure(f"joint {name}", lambda: style.save_figure(
        joint_figure(results_dir, drop_dirs, name, title), Path(results_dir) / "figures" / name, formats))


def draw_joint_figures(results_dir: Path, drop_dirs: list[Path], title: str, notes: list[str],
                       workers: int = 2, formats: Sequence[str] = style.DEFAULT_FORMATS,
                       failures: list[str] | None = None) -> list[Path]:
    """Every joint figure into ``results_dir / "figures"`` in each of ``formats`` (``png``, ``pdf``,
    ``svg``), drawn by ``workers`` forked processes; a figure whose input is missing is skipped and
    its reason appended to ``notes``, one that could not be drawn or written to ``failures`` (to
    ``notes`` when None). Returns the paths written."""
    done = parallel_map(partial(_draw_one, Path(results_dir), list(drop_dirs), title, tuple(formats)),
                        list(JOINT_FIGURE_NAMES), workers=workers, start_method="fork")
    paths: list[Path] = []
    for p, n, f in done:
        paths += p
        notes += n
        (notes if failures is None else failures).extend(f)
    return paths
