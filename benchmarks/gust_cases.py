"""The whole-drop gust calibration cases the gust diagnostics run (ees-drop-3 from a window start,
full-size gusts), and the command line that chooses them; imported by
``gust_error_structure.py`` and ``marginal_curvature.py``."""

from __future__ import annotations

import argparse
from pathlib import Path

from casrecon.analysis.gust_calibration import GustCase

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def case_arguments(description: str) -> argparse.ArgumentParser:
    """``--seeds``, ``--first``, ``--workers`` and ``--start`` (fit window start after release, s)."""
    ap = argparse.ArgumentParser(description=description)
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--first", type=int, default=7)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--start", type=float, default=3.5, help="fit window start after release, s")
    ap.add_argument("--interval", type=float, help="the fit's collocation interval, s (default: the problem's)")
    return ap


def whole_drop_cases(args: argparse.Namespace) -> list[GustCase]:
    """The cases of seeds ``first`` to ``first + seeds - 1`` from window start ``start``."""
    seeds = range(args.first, args.first + args.seeds)
    return [GustCase(PROBLEMS / "ees-drop-3", s, start_s=args.start, interval_s=args.interval) for s in seeds]
