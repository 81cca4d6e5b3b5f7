"""Estimator Monte Carlo under model error, with and without the error models (issue 18).

Each case draws a truth from the fit's priors, simulates the problem's drop with its ``[truth]``
error processes (by default problems/ees-drop-3-model-error: a sounding 0.5 m/s (1-sigma, 300 m
correlation length) off in each wind component and 0.5 % in density, GPS errors correlated over
20 s (position) and 2 s (velocity) at the receiver's stated accuracies), and fits the data twice:
as the problem says (atmosphere-profile corrections and the GPS error model on) and with both
models off. Printed for each: converged fits, the parameter NEES sum against its 95 % chi-square
interval, each aero factor's mean z, the pooled 3-sigma band coverage of position, velocity,
Euler angles, body rates, qbar and alpha_T (target >= 98 %), the adequacy verdicts, and the time
per fit (median and max).

Run: python benchmarks/model_error_mc.py [--problem DIR] [--cases 30] [--workers 2] [--seed 0]
     [--json out.json] [--variants with_models without_models] [--method map|marginal]
     [--information auto|observed|expected] [--exact-air]
     [--white-gps | --matched-gps | --default-gps-model]
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from casrecon.analysis.model_error_mc import COVERAGE_GROUPS, VARIANTS, World, model_error_montecarlo

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def print_variant(label: str, v: dict) -> None:
    lo, hi = v["interval"]
    verdict = "inside" if lo <= v["nees_sum"] <= hi else "OUTSIDE"
    print(f"\n{label}: {v['converged']} of {v['cases']} fits converged")
    print(f"  parameter NEES sum {v['nees_sum']:.1f}, 95 % interval [{lo:.1f}, {hi:.1f}]: {verdict}")
    z = [f"{n} {m:+.2f}" for n, m in zip(v["names"], v["mean_z"]) if n.endswith(("_mult", "_add"))]
    print("  aero mean z: " + ", ".join(z))
    others = [f"{n} {m:+.2f}" for n, m in zip(v["names"], v["mean_z"]) if not n.endswith(("_mult", "_add"))]
    print("  other mean z: " + ", ".join(others))
    wide = [f"{n} {r:.2f}" for n, r in zip(v["names"], v["rms_z"]) if r > 1.5]
    print("  RMS z above 1.5 (1 expected): " + (", ".join(wide) or "none"))
    print("  3-sigma band coverage: " + ", ".join(f"{g} {100 * v['coverage'][g]:.1f} %" for g in COVERAGE_GROUPS))
    print(f"  adequacy verdict 'trusted' on {v['trusted']} of {v['converged']} ({v['conservative']} of them "
          "conservative: residuals smaller than their sigmas)")
    if v["reasons"]:
        print(f"  verdict failures ({len(v['reasons'])} in all), the first: " + "; ".join(v["reasons"][:5]))
    s = np.asarray(v["seconds"])
    if s.size:
        print(f"  seconds per fit: median {np.median(s):.1f}, max {s.max():.1f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", type=Path, default=PROBLEMS / "ees-drop-3-model-error")
    ap.add_argument("--cases", type=int, default=30)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", type=Path)
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=VARIANTS,
                    help="which fits of each case to run (default both)")
    ap.add_argument("--method", choices=("map", "marginal"), help="estimator (default: the problem's)")
    ap.add_argument("--information", choices=("auto", "observed", "expected"),
                    help="curvature the covariance inverts (default: the problem's)")
    ap.add_argument("--exact-air", action="store_true",
                    help="the air flown is the sounding (no profile error in the data; the fit's model stays on)")
    ap.add_argument("--white-gps", action="store_true", help="white GPS errors in the data, and the fit told so")
    ap.add_argument("--matched-gps", action="store_true",
                    help="GPS errors drawn from the fit's own GPS error model (correlation times and white share)")
    ap.add_argument("--default-gps-model", action="store_true",
                    help="the data's GPS errors as the problem says, the fit's GPS error model casrecon's default")
    a = ap.parse_args()
    world = World(a.exact_air, a.white_gps, a.matched_gps, a.default_gps_model)
    t0 = time.perf_counter()
    study = model_error_montecarlo(a.problem, a.cases, seed=a.seed, workers=a.workers, variants=tuple(a.variants),
                                   method=a.method, information=a.information, world=world)
    print(f"{a.problem.name}: {a.cases} cases in {time.perf_counter() - t0:.0f} s ({a.workers} workers, "
          f"method {a.method or 'as the problem says'}, information {a.information or 'as the problem says'}"
          + world.describe() + ")")
    labels = {"with_models": "WITH the error models", "without_models": "WITHOUT the error models"}
    for name, label in ((v, labels[v]) for v in a.variants):
        print_variant(label, study.variant(name))
        for c in study.cases:
            if "failed" in c.get(name, {}):
                print(f"  case {c['index']} failed: {c[name]['failed'][:200]}")
    if a.json:
        a.json.write_text(json.dumps(study.cases, indent=1))


if __name__ == "__main__":
    main()
