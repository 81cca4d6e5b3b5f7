"""How the widened sigma of each parameter grows with the sandwich's block length, on one error-family
case (issue 49; not a test, prints).

One drop made as benchmarks/error_families.py makes its cases (EES vehicle, truth drawn from the
priors, flown through a family's world), fitted once with casrecon's defaults; then, for blocks of
1, 2, 4, 8, 16 and 32 s, the sandwich's p-value and mean excess, and for the parameters farthest
from the truth their error in model sigmas and their sigma widened by each block length alone over
the model's. A factor that does not grow with the block length while the error stays many sigmas
off is an error the residuals do not show (absorbed by the fit), which no block length recovers.

Run: python benchmarks/widening_block_lengths.py [--family turbulence] [--seed 207]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

from casrecon.analysis import widened_uncertainty as wu
from casrecon.analysis.estimator_mc import parameter_errors
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.simulation.error_families import FAMILIES
from casrecon.simulation.synthetic import synthetic_scenario, truth_parameters_by_name

sys.path.insert(0, str(Path(__file__).resolve().parent))
from error_families import fit_variant, study_case  # noqa: E402  (the families study's cases)

MERGES = (1, 2, 4, 8, 16, 32)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--family", default="turbulence", choices=sorted(FAMILIES))
    ap.add_argument("--seed", type=int, default=207)
    ap.add_argument("--worst", type=int, default=6, help="how many parameters to print")
    args = ap.parse_args()
    scenario, world, noise_seed = study_case(args.family, "ees", args.seed)
    with tempfile.TemporaryDirectory() as tmp:
        sc, _ = synthetic_scenario(scenario, Path(tmp), seed=noise_seed, world=world)
        result = fit_drop(fit_variant(sc, "default"))
        error, _ = parameter_errors(result, truth_parameters_by_name(sc))
    span = result.node_time_s[-1] - result.node_time_s[0]
    print(f"{args.family} seed {args.seed}: {span:.1f} s of flight")
    sandwiches = wu.block_sandwiches_of(result, MERGES)
    cov, part = result.covariance, result.part
    factors = []
    for merge, sw in zip(MERGES, sandwiches):
        widened = dataclasses.replace(cov, cov_w=cov.cov_w + sw.extra_w)
        factors.append(np.sqrt(np.diag(widened.covariance_of(part.theta_cols, part.params.scales))) / result.sigma)
        print(f"  {merge * wu.BLOCK_S:4g} s blocks ({sw.n_blocks}): p {sw.p_value:.2g}, mean excess {sw.excess:.2f}")
    factors = np.array(factors)
    lengths = ", ".join(f"{m:g} s" for m in MERGES)
    print(f"  {'parameter':16s} {'error/model sigma':>18s}   widened/model sigma at {lengths}")
    for i in np.argsort(-np.abs(error / result.sigma))[:args.worst]:
        print(f"  {result.params.names[i]:16s} {error[i] / result.sigma[i]:+18.1f}   "
              + " ".join(f"{f:5.2f}" for f in factors[:, i]))


if __name__ == "__main__":
    main()
