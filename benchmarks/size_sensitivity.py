"""Whether the profile sizes' sensitivity D carried into a fit's covariance is the fits' own (issue 49;
not a test, prints).

One case of benchmarks/error_families.py (``--case family:seed``, EES vehicle, ``--air-factor``),
fitted by default. On the fit that stands, D = dtheta / d log rho_wind (2 cov_w A^T u: see
casrecon/estimation/error_models/size_uncertainty.py) is compared with central differences of
three fits made from scratch at the standing fit's sizes, length and GPS error model, held fixed
(no sizes from the data), with the wind sigma times e^+h, e^-h and 1. Printed per parameter, in
the standing fit's sigmas: D's prediction, the finite difference, and the fit at the same sizes
against the standing one (where that is not near zero the fits from scratch found another
optimum, and the comparison says nothing), then the size uncertainty and the widening the fit's
note reports.

Run: python benchmarks/size_sensitivity.py [--case coarse-grid:263] [--air-factor 1] [--step 0.1]
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import tempfile
from pathlib import Path

import numpy as np

from casrecon.estimation.error_models.profile import PROFILE_COMPONENTS
from casrecon.estimation.error_models.profile_sigma import group_masks, profile_prior_rows
from casrecon.estimation.error_models.size_uncertainty import sensitivity
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.simulation.synthetic import synthetic_scenario

sys.path.insert(0, str(Path(__file__).resolve().parent))
from error_families import fit_variant, study_case  # noqa: E402  (the families study's cases)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--case", default="coarse-grid:263", help="family:seed of the error-families study")
    parser.add_argument("--air-factor", type=float, default=1.0)
    parser.add_argument("--step", type=float, default=0.1, help="h, the log wind-size step of the differences")
    args = parser.parse_args()
    family, seed = args.case.split(":")
    scenario, world, noise_seed = study_case(family, "ees", int(seed), args.air_factor)
    with tempfile.TemporaryDirectory() as tmp:
        sc, _ = synthetic_scenario(scenario, Path(tmp), seed=noise_seed, world=world)
        r = fit_drop(fit_variant(sc, "default"))
        for note in r.notes:
            if note.startswith("atmosphere-profile sizes' uncertainty"):
                print(note)
        grid = r.part.profile
        if grid is None:
            print("the fit that stands has no profile model: nothing to compare")
            return
        # D from the fit's covariance as published: with D V D^T already in it (under 2 % of cov_w on
        # the drops measured), which changes D by as little
        cov, prior = r.covariance, profile_prior_rows(r)
        (wind,) = group_masks(grid, prior.component_of_row, ("wind",))
        a = prior.jacobian @ cov.basis[prior.cols]
        d = sensitivity(cov.cov_w, [a[wind]], [prior.residuals[wind]])[:, 0]
        predicted = (cov.basis @ d)[r.part.theta_cols] * r.part.params.scales
        sizes = dict(zip([PROFILE_COMPONENTS[c] for c in grid.components], grid.prior))
        cfg = r.scenario.config

        def fixed(factor: float):
            atm = dataclasses.replace(cfg.atmosphere, profile_sigma_from_data=False,
                                      profile_wind_sigma_mps=sizes["wind_n"] * factor,
                                      profile_density_sigma=sizes.get("density", 0.0), profile_length_m=grid.length_m)
            gps = dataclasses.replace(cfg.gps, error_model_from_data=False)
            return fit_drop(dataclasses.replace(r.scenario, config=dataclasses.replace(cfg, atmosphere=atm, gps=gps)))

        h = args.step
        up, down, same = fixed(np.exp(h)), fixed(np.exp(-h)), fixed(1.0)
    difference = (up.values - down.values) / (2.0 * h)
    print(f"{args.case} (air x{args.air_factor:g}): wind {sizes['wind_n']:.3g} m/s, length {grid.length_m:.0f} m; "
          "per unit log wind size, in the standing fit's sigmas:")
    print(f"{'parameter':16s} {'D':>8s} {'refits':>8s} {'same sizes':>11s}")
    for i, name in enumerate(r.params.names):
        print(f"{name:16s} {predicted[i] / r.sigma[i]:+8.3f} {difference[i] / r.sigma[i]:+8.3f} "
              f"{(same.values[i] - r.values[i]) / r.sigma[i]:+11.3f}")


if __name__ == "__main__":
    main()
