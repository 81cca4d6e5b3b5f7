"""Benchmark: the pre-solve check of every shipped problem (reading its files, every data and
plausibility check, the data prepared as the fit would: :func:`casrecon.estimation.validation.precheck.check_problem`),
median of 3 runs each in a fresh state (the process's first run also pays the imports, done once
before timing). Fails (exit 1) when a problem's median reaches the 1 s budget of issue 51.

Usage: ``python benchmarks/bench_prechecks.py [PROBLEMS_DIR]``
"""

from __future__ import annotations

import statistics
import sys
import time
from pathlib import Path

from casrecon.estimation.validation.precheck import check_problem

BUDGET_S = 1.0
RUNS = 3


def main() -> int:
    root = Path(sys.argv[1]) if len(sys.argv) > 1 else Path(__file__).resolve().parents[1] / "problems"
    folders = sorted(p.parent for p in root.glob("*/problem.toml"))
    over = []
    print(f"{'problem':34s} {'median s':>9s} {'runs s':>24s}")
    for folder in folders:
        times = []
        for _ in range(RUNS):
            t0 = time.perf_counter()
            check_problem(folder)
            times.append(time.perf_counter() - t0)
        median = statistics.median(times)
        over += [folder.name] if median >= BUDGET_S else []
        print(f"{folder.name:34s} {median:9.3f} {' '.join(f'{t:7.3f}' for t in times):>24s}")
    print(f"{len(folders)} problems; budget {BUDGET_S:g} s each: " + ("all within" if not over else
                                                                      f"OVER: {', '.join(over)}"))
    return 1 if over else 0


if __name__ == "__main__":
    sys.exit(main())
