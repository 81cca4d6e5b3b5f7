"""What leaving the log-determinant's curvature out of the marginal estimator's parameter covariance
costs (a diagnostic, not a test; prints).

For each seed of the whole-drop gust calibration case (ees-drop-3 from --start s, full-size gusts):
fit, move to the marginal-likelihood estimate, and compare the reported parameter covariance P^-1
(P the profile's Gauss-Newton Hessian) with (P + L)^-1, L the Hessian of 1/2 log det of the latent
block by finite differences of its gradient (about a minute per case): the eigenvalues of
P^-1/2 L P^-1/2, the largest change of a parameter sigma, and each gust axis's NEES at 1 s nodes
with the gust covariance's parameter part taken from either.

Run: python benchmarks/marginal_curvature.py [--seeds 2] [--first 7] [--workers 2] [--start 3.5]
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

from casrecon.analysis.gust_calibration import AXES, GustCase, curvature_case
from casrecon.parallel import parallel_map

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=2)
    ap.add_argument("--first", type=int, default=7)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--start", type=float, default=3.5, help="fit window start after release, s")
    a = ap.parse_args()
    cases = [GustCase(PROBLEMS / "ees-drop-3", s, start_s=a.start) for s in range(a.first, a.first + a.seeds)]
    for row in parallel_map(curvature_case, cases, workers=a.workers):
        ev = np.array(row["eigenvalues"])
        ratios = row["sigma_ratio"]
        worst = max(ratios, key=lambda k: abs(np.log(ratios[k])))
        print(f"seed {row['seed']}: eigenvalues of P^-1/2 L P^-1/2 in [{ev.min():+.4f}, {ev.max():+.4f}]; "
              f"largest sigma change {worst} x{ratios[worst]:.3f}")
        for axis in AXES:
            n = row["gust_nees"][axis]
            print(f"  {axis} NEES {n['without']:.1f} (reported) vs {n['with']:.1f} (with L) over {n['dof']} dof")


if __name__ == "__main__":
    main()
