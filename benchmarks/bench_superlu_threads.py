"""Benchmark: peak memory of SuperLU factors made on worker threads and kept after them.

Why casrecon makes every SuperLU factor in the thread that keeps it (docs/design.md, Threads):
scipy ties a factor's memory to the thread that made it, and a factor that outlives that thread
leaks it (scipy issues 15921 and 25759). Each mode runs in its own process: ``rounds`` times, four
factors of a banded matrix of ``rows`` rows are made, each solved once, then dropped:

- ``calling``: made in the calling thread;
- ``pool``: made on a two-thread pool that ends before they are used (``in_threads``' old use);
- ``inside``: made, solved and dropped inside the pool's threads (only solutions leave them).

Prints each mode's peak RSS (``resource.getrusage``) and time.

Usage: ``python benchmarks/bench_superlu_threads.py [rows] [rounds]``
"""

from __future__ import annotations

import resource
import subprocess
import sys
import time
from concurrent.futures import ThreadPoolExecutor

import numpy as np
import scipy
import scipy.sparse as sps
from scipy.sparse.linalg import splu

MODES = ("calling", "pool", "inside")


def run_mode(mode: str, rows: int, rounds: int) -> None:
    """Run one mode in this process and print its peak RSS and time."""
    ones = np.ones(rows)
    matrix = sps.diags([ones[1:], 10.0 * ones, ones[1:], 0.5 * ones[50:]], [-1, 0, 1, 50]).tocsc()
    start = time.perf_counter()
    for _ in range(rounds):
        if mode == "calling":
            factors = [splu(matrix) for _ in range(4)]
        elif mode == "pool":
            with ThreadPoolExecutor(2) as pool:
                factors = list(pool.map(lambda _: splu(matrix), range(4)))
        else:
            with ThreadPoolExecutor(2) as pool:
                solutions = list(pool.map(lambda _: splu(matrix).solve(ones), range(4)))
            assert len(solutions) == 4
            factors = []
        for factor in factors:
            factor.solve(ones)
        del factors
    peak_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
    print(f"{mode:8s} peak RSS {peak_mb:8.0f} MB  {time.perf_counter() - start:6.2f} s")


def main() -> None:
    rows = int(sys.argv[1]) if len(sys.argv) > 1 else 200_000
    rounds = int(sys.argv[2]) if len(sys.argv) > 2 else 10
    print(f"scipy {scipy.__version__}: {rounds} rounds of 4 factors of a {rows}-row banded matrix")
    for mode in MODES:
        subprocess.run([sys.executable, __file__, "--mode", mode, str(rows), str(rounds)], check=True)


if __name__ == "__main__":
    if len(sys.argv) > 1 and sys.argv[1] == "--mode":
        run_mode(sys.argv[2], int(sys.argv[3]), int(sys.argv[4]))
    else:
        main()
