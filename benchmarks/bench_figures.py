"""CPU time of each per-drop figure of a results folder (not a test; prints a table).

Each figure of :data:`casrecon.report.plots.DROP_FIGURES` and the correlation matrix is drawn in
this process with :func:`casrecon.report.plots.draw_drop_figure` (as a figure worker draws it:
reading the folder's files, building the figure, saving the PNG) after one warm-up draw of every
figure (fonts, mathtext parser, imports). CPU time (``time.process_time``) is measured, not wall
time, so another process on the machine does not skew it. Per figure: the median (min, max) over
--runs draws; the total is the sum of the medians. The figures are written into ``<folder>/figures``.

With no --folder, ``casrecon fit <problem> --no-figures`` writes a results folder into a temporary
directory first.

Run: python benchmarks/bench_figures.py [--folder DIR] [--problem ees-drop-1] [--runs 5] [--only NAME ...]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def figure_labels() -> list[str]:
    """The figure names in :data:`DROP_FIGURES` order, then ``correlation``."""
    from casrecon.report.plots import DROP_FIGURES

    return [label for label, _ in DROP_FIGURES] + ["correlation"]


def cpu_per_figure(folder: Path, runs: int, only: list[str] | None = None) -> dict[str, list[float]]:
    """CPU seconds of each figure's draw (read, build, save PNG), ``runs`` times after one warm-up."""
    from casrecon.report.plots import draw_drop_figure

    labels = figure_labels()
    chosen = [i for i, label in enumerate(labels) if not only or label in only]
    for i in chosen:  # warm-up
        _, notes = draw_drop_figure(folder, i, True)
        if notes:
            print(f"  note: {'; '.join(notes)}")
    times: dict[str, list[float]] = {labels[i]: [] for i in chosen}
    for _ in range(runs):
        for i in chosen:
            t0 = time.process_time()
            draw_drop_figure(folder, i, True)
            times[labels[i]].append(time.process_time() - t0)
    return times


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--folder", type=Path, help="an existing per-drop results folder")
    ap.add_argument("--problem", default="ees-drop-1", help="problem to fit when no --folder is given")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--only", nargs="*", help="figure names to time (default: all)")
    args = ap.parse_args()
    folder = args.folder
    if folder is None:
        folder = Path(tempfile.mkdtemp(prefix="casrecon-bench-figures-")) / "out"
        subprocess.run([sys.executable, "-m", "casrecon", "fit", str(ROOT / "problems" / args.problem),
                        "--out", str(folder), "--no-figures", "--quiet"], check=True)
    times = cpu_per_figure(folder, args.runs, args.only)
    print(f"{folder}: CPU s per figure, median (min, max) of {args.runs} draws")
    for label, values in times.items():
        print(f"  {label:27s} {statistics.median(values):6.3f} ({min(values):.3f}, {max(values):.3f})")
    total = sum(statistics.median(v) for v in times.values())
    print(f"  {'total':27s} {total:6.3f}")


if __name__ == "__main__":
    main()
