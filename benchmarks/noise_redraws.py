"""One study case's truth held, its noise drawn anew: how far each parameter lands, in its own
sigmas, over other noise realisations (issue 49; not a test, prints).

A case of benchmarks/error_families.py is a truth drawn from the fit's priors at
``default_rng([seed, 49])`` and a noise seed drawn after it. This script keeps that truth and
family world, simulates it again with each noise seed given (``--noise-seeds``; ``study`` names the
study's own), fits each with one variant of error_families.py and prints every parameter's z =
(estimate - truth) / sigma, then each parameter's mean and standard deviation of z over the noise
seeds. For a fixed truth a posterior is not unbiased: along a direction its prior holds, the
estimate is pulled towards the prior mean by the prior's share of the information (the mean of z),
and the noise moves it by less than one sigma (the standard deviation). Over truths drawn from the
prior both average out; this shows what one truth does.

Run (seed 296's truth, the `none` family, the plain fit, the study's noise and thirty others)::

    python benchmarks/noise_redraws.py --seed 296 --family none --variant plain --noise-seeds study 10-39
"""

from __future__ import annotations

import argparse
import tempfile
from pathlib import Path

import numpy as np
from error_families import VARIANTS, fit_variant, study_case

from casrecon.estimation.engine.checks import FitError
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.simulation.error_families import FAMILIES
from casrecon.simulation.synthetic import synthetic_scenario, truth_parameters_by_name


def noise_seeds(words: list[str], study_seed: int) -> list[int]:
    """The noise seeds named: integers, ranges ``a-b`` (both ends included), ``study`` (the study's own)."""
    out: list[int] = []
    for word in words:
        if word == "study":
            out.append(study_seed)
        elif "-" in word:
            first, last = (int(v) for v in word.split("-"))
            out.extend(range(first, last + 1))
        else:
            out.append(int(word))
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seed", type=int, required=True, help="the study case's seed (its truth)")
    ap.add_argument("--family", default="none", choices=list(FAMILIES))
    ap.add_argument("--vehicle", default="ees", choices=["ees", "light"])
    ap.add_argument("--variant", default="plain", choices=list(VARIANTS))
    ap.add_argument("--noise-seeds", nargs="+", default=["study", "10-19"])
    args = ap.parse_args()
    scenario, world, study_noise = study_case(args.family, args.vehicle, args.seed)
    rows: list[np.ndarray] = []
    names: list[str] = []
    for noise in noise_seeds(args.noise_seeds, study_noise):
        with tempfile.TemporaryDirectory() as tmp:
            sc, _ = synthetic_scenario(scenario, Path(tmp), seed=noise, world=world)
            truth = truth_parameters_by_name(sc)
            try:
                result = fit_drop(fit_variant(sc, args.variant))
            except FitError as err:
                print(f"noise {noise}: the fit failed: {err}", flush=True)
                continue
        names = list(result.params.names)
        z = np.array([(result.values[i] - truth[n]) / result.sigma[i] for i, n in enumerate(names)])
        rows.append(z)
        own = " (the study's)" if noise == study_noise else ""
        print(f"noise {noise}{own}: " + " ".join(f"{n} {v:+.2f}" for n, v in zip(names, z)), flush=True)
    if len(rows) < 2:
        return
    z = np.array(rows)
    print(f"\n{args.vehicle} {args.family} seed {args.seed}, {args.variant} fits, {len(rows)} noise draws: "
          "z of each parameter")
    for j, n in enumerate(names):
        col = z[:, j]
        print(f"{n:16s} mean {col.mean():+.2f}  sd {col.std(ddof=1):.2f}  largest |z| {np.abs(col).max():.2f}")


if __name__ == "__main__":
    main()
