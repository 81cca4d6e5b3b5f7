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

import numpy as np
from gust_cases import case_arguments, whole_drop_cases

from casrecon.analysis.gust_calibration import AXES, curvature_case
from casrecon.parallel import parallel_map


def main() -> None:
    a = case_arguments(__doc__.splitlines()[0]).parse_args()
    cases = whole_drop_cases(a)
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
