"""Does the Laplace marginal remove the gust fit's slope-multiplier bias? (issue 5; not a test)

For each seed, one gust case (casrecon.analysis.gust_calibration, 3-5 s terminal window of drop 3)
is fitted and ``Cmn_mult`` profiled two ways (casrecon.analysis.marginal): the joint objective the
fit minimises, and the Laplace marginal (plus 1/2 log det of the latent Gauss-Newton Hessian). Prints
truth, the fit's estimate and sigma, and both profile minima in sigmas from the truth.

Run: python benchmarks/gust_marginal_profile.py [--seeds 2 3 4] [--parameter Cmn_mult] [--workers 2]
"""

from __future__ import annotations

import argparse
import time
from functools import partial
from pathlib import Path

from casrecon.analysis.gust_calibration import GustCase, marginal_profile_case
from casrecon.parallel import parallel_map

PROBLEM = Path(__file__).resolve().parents[1] / "problems" / "ees-drop-3"


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, nargs="+", default=[2, 3, 4])
    ap.add_argument("--parameter", default="Cmn_mult")
    ap.add_argument("--workers", type=int, default=2)
    a = ap.parse_args()
    t0 = time.perf_counter()
    rows = parallel_map(partial(marginal_profile_case, name=a.parameter),
                        [GustCase(PROBLEM, s, start_s=34.0) for s in a.seeds], workers=a.workers)
    print(f"wall {time.perf_counter() - t0:.0f} s with {a.workers} workers")
    for r in rows:
        z = {k: (r[k] - r["truth"]) / r["sigma"] for k in ("estimate", "joint_minimum", "marginal_minimum")}
        print(f"seed {r['seed']}: {r['name']} truth {r['truth']:+.3f}, fit {r['estimate']:+.3f} +- {r['sigma']:.3f} "
              f"({z['estimate']:+.2f} sigma); joint-profile minimum {r['joint_minimum']:+.3f} "
              f"({z['joint_minimum']:+.2f}); Laplace-marginal minimum {r['marginal_minimum']:+.3f} "
              f"({z['marginal_minimum']:+.2f}){'' if r['all_converged'] else '; some refits did not converge'}")


if __name__ == "__main__":
    main()
