"""False-alarm rate of the model-adequacy verdict on an exact model (not a test; prints its figures).

For each seed, fresh synthetic IMU and GPS noise of one drop (same truth, see fit_seeds.py) is
fitted and the verdict (casrecon.analysis.adequacy) taken. The model is exact, so the verdict
should say "trusted" on at least 99 % of seeds (Bonferroni at a family-wise 1 %), and the pooled
Ljung-Box and chi-square p-values should be uniform (about 5 % below 0.05).

Run: python benchmarks/adequacy_false_alarm.py [--drop ees-drop-2] [--seeds 10] [--first 200]
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np
from fit_seeds import PROBLEMS, scenario_with_seed
from scipy import stats

from casrecon.analysis.fit_products import result_adequacy
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.scenario import Scenario


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drop", default="ees-drop-2")
    ap.add_argument("--seeds", type=int, default=10)
    ap.add_argument("--first", type=int, default=200, help="first noise seed")
    args = ap.parse_args()
    base = Scenario.load(PROBLEMS / args.drop)
    flagged, p_lb, p_chi2 = 0, [], []
    with tempfile.TemporaryDirectory() as tmp:
        for seed in range(args.first, args.first + args.seeds):
            t0 = time.perf_counter()
            a = result_adequacy(fit_drop(scenario_with_seed(base, seed, Path(tmp) / str(seed))))
            flagged += not a.trusted
            p_lb += [c.ljung_box_p for c in a.channels]
            # two-sided p of each reduced chi-square
            p_chi2 += [2 * min(stats.chi2.cdf(c.reduced_chi2 * c.n, c.n), stats.chi2.sf(c.reduced_chi2 * c.n, c.n))
                       for c in a.channels]
            print(f"seed {seed}: {'trusted' if a.trusted else 'FLAGGED'} ({time.perf_counter() - t0:.0f} s); "
                  f"smallest Ljung-Box p {min(c.ljung_box_p for c in a.channels):.2g}; prior NEES {a.nees.nees:.1f} "
                  f"on {a.nees.dof} dof; beyond 3 sigma of the prior: "
                  f"{', '.join(f'{d.name} {d.z:+.1f}' for d in a.deviations) or 'none'}"
                  + ("" if a.trusted else f"\n    {a.line}"), flush=True)
    p_lb, p_chi2 = np.array(p_lb), np.array(p_chi2)
    print(f"{args.drop}: {flagged} of {args.seeds} seeds flagged (expected at most 1 %); "
          f"Ljung-Box p < 0.05 in {np.mean(p_lb < 0.05):.1%} and reduced chi-square p < 0.05 in "
          f"{np.mean(p_chi2 < 0.05):.1%} of {p_lb.size} channel tests (5 % expected)")


if __name__ == "__main__":
    main()
