"""Timing and memory of the per-drop and joint fits (not a test; prints its figures).

Measures, as medians over --runs runs:
- the per-drop fit of ees-drop-1 (40 s drop, every 500 Hz IMU sample used): NLP construction
  (``build_s``), Ipopt solve, covariance, and the whole ``casrecon fit`` command in a fresh
  subprocess (wall time and peak resident memory);
- MUMPS against SPRAL and the Gauss-Newton against the exact Hessian (solve time, iterations);
- the four-drop joint fit's build + solve against one drop's (acceptance: at most 5 times).

Run: python benchmarks/bench_fit.py [--runs 3] [--skip-joint] [--skip-solvers]
"""

from __future__ import annotations

import argparse
import resource
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from casrecon.estimation.fit import fit_drop
from casrecon.estimation.joint import JointConfig, fit_joint
from casrecon.scenario import Scenario

ROOT = Path(__file__).resolve().parents[1]
PROBLEMS = ROOT / "problems"


def _median(values: list[float]) -> str:
    return f"{statistics.median(values):7.2f} s (min {min(values):.2f}, max {max(values):.2f})"


def per_drop(runs: int, name: str = "ees-drop-1", **kw) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {"build_s": [], "solve_s": [], "covariance_s": [], "total_s": [], "iterations": []}
    for _ in range(runs):
        r = fit_drop(Scenario.load(PROBLEMS / name), **kw)
        for k in ("build_s", "solve_s", "covariance_s", "total_s"):
            out[k].append(r.timings[k])
        out["iterations"].append(r.solver.iterations)
    return out


def command(runs: int, extra: list[str]) -> tuple[list[float], list[float]]:
    """Wall time and peak RSS (MB) of `casrecon fit` in a fresh process."""
    walls, rss = [], []
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as tmp:
            before = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "casrecon.cli", "fit", str(PROBLEMS / "ees-drop-1"), "--out",
                            str(Path(tmp) / "out"), "--quiet", *extra], check=True, capture_output=True)
            walls.append(time.perf_counter() - t0)
            rss.append(max(resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss, before) / 1024)
    return walls, rss


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--skip-joint", action="store_true")
    ap.add_argument("--skip-solvers", action="store_true")
    args = ap.parse_args()

    print(f"per-drop fit of ees-drop-1, {args.runs} runs (Gauss-Newton Hessian, MUMPS)")
    base = per_drop(args.runs)
    for k in ("build_s", "solve_s", "covariance_s", "total_s"):
        print(f"  {k:14s} {_median(base[k])}")
    print(f"  iterations     {statistics.median(base['iterations'])}")
    for label, extra in (("casrecon fit --no-figures", ["--no-figures"]), ("casrecon fit (with figures)", [])):
        walls, rss = command(args.runs, extra)
        print(f"  {label:28s} wall {_median(walls)}; peak RSS {max(rss):.0f} MB")

    if not args.skip_solvers:
        for label, kw in (("SPRAL", {"linear_solver": "spral"}), ("exact Hessian", {"hessian": "exact"})):
            r = per_drop(1, **kw)
            print(f"  {label:14s} solve {r['solve_s'][0]:.2f} s, {r['iterations'][0]} iterations "
                  f"(MUMPS + Gauss-Newton: {statistics.median(base['solve_s']):.2f} s, "
                  f"{statistics.median(base['iterations'])} iterations)")

    if not args.skip_joint:
        drops = [PROBLEMS / f"ees-drop-{i}" for i in (1, 2, 3, 4)]
        one = per_drop(args.runs, "ees-drop-3")
        joint = []
        for _ in range(args.runs):
            r = fit_joint([Scenario.load(d) for d in drops], JointConfig("bench", tuple(drops)))
            joint.append(r.timings["build_s"] + r.timings["solve_s"])
        single = statistics.median([b + s for b, s in zip(one["build_s"], one["solve_s"])])
        print(f"joint fit of 4 drops: build + solve {_median(joint)}; one drop (ees-drop-3) {single:.2f} s; "
              f"ratio {statistics.median(joint) / single:.2f} (acceptance: <= 5)")


if __name__ == "__main__":
    main()
