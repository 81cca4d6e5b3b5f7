"""Kinematic (IMU-driven) reconstruction against known truths: synthetic drops of a 6-DOF problem
with truths drawn from the priors, fitted kinematically at several IMU rates (the 500 Hz record
decimated); prints per rate the pooled share of node values inside the 3-sigma bands (position,
velocity, attitude) and of the implied aerodynamics' bands (coefficients, alpha_T, qbar), the
parameter NEES against its 95 % interval, the mean z per parameter and the fit times.

    python benchmarks/kinematic_truth.py [--problem problems/ees-drop-1] [--cases 10] [--steps 1,5,38]
"""

from __future__ import annotations

import argparse

import numpy as np

from casrecon.analysis.kinematic_truth import kinematic_truth_study


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", default="problems/ees-drop-1")
    ap.add_argument("--cases", type=int, default=10)
    ap.add_argument("--steps", default="1,5,38", help="IMU decimation steps (500 Hz / step)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    steps = tuple(int(s) for s in args.steps.split(","))
    study = kinematic_truth_study(args.problem, args.cases, steps, args.seed, args.workers)
    for s in study.values():
        lo, hi = s["nees_interval"]
        cov = ", ".join(f"{g} {v:.4f}" for g, v in s["coverage"].items())
        print(f"IMU {s['rate_hz']:.1f} Hz: {s['fits']} fits, {len(s['failed'])} failed, {s['trusted']} trusted by "
              f"the adequacy verdict; coverage {cov}; "
              f"NEES {s['nees']:.1f} in [{lo:.1f}, {hi:.1f}]; median fit {np.median(s['seconds']):.1f} s")
        print("   implied aero coverage: " + ", ".join(f"{c} {v:.4f}" for c, v in s["aero_coverage"].items()))
        print("   mean z: " + ", ".join(f"{n} {z:+.2f}" for n, z in zip(s["names"], s["mean_z"])))
        for why in s["failed"]:
            print(f"   failed: {why}")


if __name__ == "__main__":
    main()
