"""Estimator Monte Carlo: simulate and fit many times, test the NEES against chi-square (issue 5).

Each case draws a truth from the fit's own prior (see casrecon.analysis.estimator_mc), makes fresh
synthetic IMU and GPS data, fits, and computes NEES = e^T C^-1 e over the estimated parameters. The
sum over the cases must lie in its two-sided 95 % chi-square interval. Also printed: the RMS of
the normalised errors per parameter, the worst case, the solvers used, and the wall time, whole
and per case (its distribution and the slowest case against the median).

Run: python benchmarks/estimator_consistency.py [--problem problems/ees-drop-3] [--cases 50]
     [--workers 2] [--seed 0] [--method map|marginal] [--information observed|expected]
     [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import time
from collections import Counter
from pathlib import Path

import numpy as np

from casrecon.analysis.estimator_mc import estimator_montecarlo

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", type=Path, default=PROBLEMS / "ees-drop-3")
    ap.add_argument("--cases", type=int, default=50)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--method", choices=("map", "marginal"), default=None,
                    help="the fits' estimator (default: the problem's [estimation] method)")
    ap.add_argument("--information", choices=("observed", "expected"), default=None,
                    help="curvature the covariance inverts (default: the problem's [estimation] information)")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    t0 = time.perf_counter()
    res = estimator_montecarlo(a.problem, a.cases, seed=a.seed, workers=a.workers, method=a.method,
                               information=a.information)
    wall = time.perf_counter() - t0
    ok = [c for c in res.cases if "nees" in c]
    print(f"{a.problem.name}: {len(ok)} of {a.cases} fits converged in {wall:.0f} s ({a.workers} workers)")
    for c in res.failed:
        print(f"  case {c['index']} failed: {c['failed']}")
    print(f"NEES sum {res.nees_sum:.1f} over {len(ok)} x {res.n_params} = {len(ok) * res.n_params} dof; "
          f"95 % interval [{res.interval[0]:.1f}, {res.interval[1]:.1f}] -> "
          f"{'CONSISTENT' if res.consistent else 'NOT consistent'}")
    nees = np.array([c["nees"] for c in ok])
    print(f"NEES per case: mean {nees.mean():.2f} (expected {res.n_params}), max {nees.max():.1f} "
          f"(case {ok[int(nees.argmax())]['index']})")
    stops = Counter(c["status"].split(" (")[0] for c in ok)
    solvers = Counter(c.get("solver", "ipopt") for c in ok)
    print("stopped by: " + ", ".join(f"{k} {v}" for k, v in stops.items())
          + "; solved by: " + ", ".join(f"{k} {v}" for k, v in solvers.items())
          + f"; iterations median {np.median([c['iterations'] for c in ok]):.0f}, "
          f"max {max(c['iterations'] for c in ok)}")
    seconds = np.array([c["case_s"] for c in res.cases])
    slowest = res.cases[int(seconds.argmax())]
    print(f"case wall time (simulate + fit, s): median {np.median(seconds):.1f}, p90 {np.percentile(seconds, 90):.1f}, "
          f"max {seconds.max():.1f} (case {slowest['index']}, {slowest.get('iterations', '?')} iterations); "
          f"max / median {seconds.max() / np.median(seconds):.2f} (acceptance: <= 3)")
    print("  distribution: " + " ".join(f"{s:.0f}" for s in np.sort(seconds)))
    z = np.array([np.array(c["error"]) / np.array(c["sigma"]) for c in ok])
    print("RMS of (estimate - truth) / sigma per parameter:")
    for name, rms, mean in zip(ok[0]["names"], np.sqrt((z**2).mean(0)), z.mean(0)):
        print(f"  {name:16s} rms {rms:5.2f}  mean {mean:+5.2f}")
    if a.json:
        a.json.write_text(json.dumps({"nees_sum": res.nees_sum, "interval": res.interval, "wall_s": wall,
                                      "cases": res.cases}, indent=1))


if __name__ == "__main__":
    main()
