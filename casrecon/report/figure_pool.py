"""Figure workers started before the fit, so that ``casrecon fit`` does not wait for matplotlib.

A :class:`FigurePool` forks its workers when it is created; each imports matplotlib and the figure
modules and draws one small figure (fonts, mathtext parser) while the parent fits, on the core the
fit leaves idle. :meth:`FigurePool.draw` then draws a per-drop results folder's figures with them,
exactly as :func:`casrecon.report.plots.draw_drop_figures` does (the same figures, the same files,
the costliest first). This module imports no matplotlib in the parent.
"""

from __future__ import annotations

import io
import logging
import multiprocessing
import signal
from collections.abc import Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from pathlib import Path

from casrecon.parallel import ignore_interrupts, stop_pool

log = logging.getLogger(__name__)


def warm_up() -> None:
    """Worker initializer: Ctrl-C left to the parent, SIGTERM (the parent's stop) back to its default
    (the forked worker inherits the command's handler, which would print a traceback); import the
    figure modules and draw a small figure with mathtext into memory (loads the fonts and builds the
    mathtext parser once)."""
    ignore_interrupts()
    signal.signal(signal.SIGTERM, signal.SIG_DFL)
    from casrecon.report import figure_style as style
    from casrecon.report import plots  # noqa: F401  (imported here, not when the first figure is due)

    fig, axes = style.new_figure(1, 1, (2.0, 2.0))
    axes[0, 0].plot([1.0, 2.0], [1.0, 10.0], label=style.PM3SIGMA)
    axes[0, 0].set_yscale("log")
    axes[0, 0].set_ylabel(f"$\\bar q$, {style.MPS2}")
    style.figure_legend(fig)
    fig.savefig(io.BytesIO(), dpi=style.DPI, format="png")


def draw_order() -> list[int]:
    """The figure indices in drawing order (:func:`casrecon.report.plots.draw_order`), from a worker."""
    from casrecon.report.plots import draw_order as order

    return order(True)


def draw_one(folder: Path, index: int, formats: tuple[str, ...]) -> tuple[list[Path], list[str], list[str]]:
    """One figure of a per-drop folder, in a worker (:func:`casrecon.report.plots.draw_drop_figure`)."""
    from casrecon.report.plots import draw_drop_figure

    return draw_drop_figure(folder, index, True, formats)


class FigurePool:
    """Forked figure workers, ready before the figures are due; a context manager.

    Parameters
    ----------
    workers : int
        Worker processes (2: the machine's second core while the fit runs, both afterwards).
    """

    def __init__(self, workers: int = 2) -> None:
        self.pool = ProcessPoolExecutor(max_workers=workers, mp_context=multiprocessing.get_context("fork"),
                                        initializer=warm_up)
        self.order = self.pool.submit(draw_order)  # starts the workers now

    def draw(self, folder: Path, notes: list[str] | None = None,
             formats: Sequence[str] = ("png",)) -> list[Path]:
        """Every figure of the per-drop results folder ``folder`` into ``folder / "figures"``, in each
        of ``formats``; the paths in figure order. Skipped figures, and figures that could not be drawn
        or written, are logged and their reasons appended to ``notes``; InputError if the folder lacks
        summary.json or trajectory.csv."""
        notes = [] if notes is None else notes
        indices = self.order.result()
        futures = {self.pool.submit(draw_one, Path(folder), i, tuple(formats)): i for i in indices}
        drawn: dict[int, tuple[list[Path], list[str], list[str]]] = {}
        for future in as_completed(futures):
            drawn[futures[future]] = future.result()
            names = ", ".join(p.name for p in drawn[futures[future]][0]) or "skipped"
            log.info("figure %d of %d: %s", len(drawn), len(futures), names)
        paths: list[Path] = []
        for _, (p, n, f) in sorted(drawn.items()):
            paths += p
            notes += n + f
            for note in n + f:
                log.warning(note)
        return paths

    def close(self, failed: bool = False) -> None:
        """Stop the workers: wait for them, or (``failed``) cancel and terminate them."""
        if failed:
            stop_pool(self.pool)
        else:
            self.pool.shutdown(wait=True, cancel_futures=True)

    def __enter__(self) -> FigurePool:
        return self

    def __exit__(self, kind, exc, tb) -> None:
        self.close(failed=kind is not None)
