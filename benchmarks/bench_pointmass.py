"""Timing of the GPS-only (point-mass) fits of the three real speed-skydive tracks (not a test;
prints its figures).

For each track, medians over --runs runs of ``fit_point_mass`` with the problem's own model (drag-area
spline with horizontal lift areas) and with the constant-drag model: total (read + segment + build +
solve + covariance), the build, solve and covariance parts, Ipopt iterations; and, unless
--skip-command, the whole ``casrecon fit`` command (both models, results folder, figure) in a fresh
subprocess.

Run: python benchmarks/bench_pointmass.py [--runs 3] [--skip-command] [--only fs1-byron]
"""

from __future__ import annotations

import argparse
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from casrecon.estimation.pointmass.fit import fit_point_mass
from casrecon.io.pointmass_problem import load_point_mass

ROOT = Path(__file__).resolve().parents[1]
PROBLEMS = ROOT / "problems"
TRACKS = ("realdata-fs1-byron", "realdata-skyderby-411", "realdata-fs2-chicago")


def _med(values: list[float]) -> str:
    return f"{statistics.median(values):6.2f} s (min {min(values):.2f}, max {max(values):.2f})"


def fits(name: str, model: str, runs: int) -> dict[str, list[float]]:
    out: dict[str, list[float]] = {k: [] for k in ("total_s", "build_s", "solve_s", "covariance_s", "iterations")}
    cfg = load_point_mass(PROBLEMS / name)
    for _ in range(runs):
        r = fit_point_mass(cfg, model)
        for k in ("total_s", "build_s", "solve_s", "covariance_s"):
            out[k].append(r.timings[k])
        out["iterations"].append(r.solver.iterations)
    out["nodes"] = [r.t_unix.size]
    out["reduced_chi2"] = [r.reduced_chi2]
    return out


def command(name: str, runs: int) -> list[float]:
    walls = []
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            subprocess.run([sys.executable, "-m", "casrecon.cli", "fit", str(PROBLEMS / name), "--out",
                            str(Path(tmp) / "out"), "--quiet"], check=True, capture_output=True)
            walls.append(time.perf_counter() - t0)
    return walls


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--skip-command", action="store_true")
    ap.add_argument("--only", choices=[t.removeprefix("realdata-") for t in TRACKS], default=None)
    args = ap.parse_args()
    tracks = [t for t in TRACKS if args.only is None or t.endswith(args.only)]
    print(f"GPS-only point-mass fits, median of {args.runs} runs each")
    for name in tracks:
        print(f"\n{name}")
        for model in ("spline", "constant"):
            r = fits(name, model, args.runs)
            print(f"  {model:8s} {r['nodes'][0]} nodes, {statistics.median(r['iterations']):.0f} iterations, "
                  f"reduced chi2 {r['reduced_chi2'][0]:.2f}")
            print(f"           total {_med(r['total_s'])}; build {statistics.median(r['build_s']):.2f} s, solve "
                  f"{statistics.median(r['solve_s']):.2f} s, covariance {statistics.median(r['covariance_s']):.2f} s")
        if not args.skip_command:
            print(f"  casrecon fit (both models, folder, figure, fresh process): {_med(command(name, args.runs))}")


if __name__ == "__main__":
    main()
