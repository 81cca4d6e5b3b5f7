"""Profile errors the Gauss-Markov model does not contain: a sounding off by a smooth ramp (not a test; prints).

The atmosphere-profile model describes the difference between the air flown and the sounding as
a Gauss-Markov process in altitude (docs/design.md, Atmosphere-profile error), and by default its
sigmas are then set to what the data say (type-II maximum likelihood) and the fit made again.
Here the sounding the fit reads differs from the air flown by errors of another shape:

- ``--density-ramp F``: the sounding's temperature too low by a fraction growing linearly from 0
  at the ground to F at the release height (its density too high by as much: a morning sounding
  for a drop after the layer above has warmed);
- ``--wind-wave A``: north and east wind off by A sin and 0.75 A cos of height (400 m and 700 m
  wavelengths);
- ``--jet A``: an east jet of A m/s (60 m 1-sigma wide) at the middle of the drop.

The data are simulated through the problem's own sounding (white GPS errors, the problem's IMU),
and fitted from the altered sounding with the profile model at 0.5 m/s and 0.5 % (300 m), twice:
as by default (sigmas from the data, refitted) and with the configured sigmas kept. Printed for
each: the parameter NEES against its 95 % interval, the largest |z| against the truth, the pooled
3-sigma band coverage, the verdict line and the profile sigmas the data said.

Run: python benchmarks/profile_structure.py [--problem problems/davinci-ztu] [--seed 1]
     [--density-ramp 0.008] [--wind-wave 0.8] [--jet 1.5]
"""

from __future__ import annotations

import argparse
import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np

from casrecon.analysis.estimator_mc import parameter_errors
from casrecon.analysis.fit_products import result_adequacy
from casrecon.analysis.model_error_mc import band_coverage
from casrecon.estimation.sixdof.fit import FitError, fit_drop
from casrecon.io.sounding import read_sounding, write_sounding_csv
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import synthetic_scenario, truth_parameters_by_name

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
#: 0.975 quantile of the standard normal (the NEES interval, by the Wilson-Hilferty approximation).
Z_975 = 1.959964


def altered_sounding(scenario: Scenario, out: Path, density_ramp: float, wind_wave_mps: float,
                     jet_mps: float) -> Path:
    """The problem's sounding with the errors of the module docstring, written to ``out``."""
    s = read_sounding(scenario.config.atmosphere.sounding, launch=scenario.config.atmosphere.launch)
    h = s.altitude_msl_m
    ground = scenario.config.site.ground_alt_msl_m
    top = ground + scenario.config.release.h_agl_m
    share = np.clip((h - ground) / (top - ground), 0.0, None)
    north = s.wind_north_mps + wind_wave_mps * np.sin(2.0 * np.pi * (h - ground) / 400.0)
    east = (s.wind_east_mps + 0.75 * wind_wave_mps * np.cos(2.0 * np.pi * (h - ground) / 700.0)
            + jet_mps * np.exp(-0.5 * ((h - 0.5 * (ground + top)) / 60.0) ** 2))
    altered = dataclasses.replace(s, temperature_k=s.temperature_k * (1.0 - density_ramp * share),
                                  wind_north_mps=north, wind_east_mps=east, density_kgm3=None)
    write_sounding_csv(out, altered)
    return out


def nees_interval(dof: int) -> tuple[float, float]:
    """95 % interval of a chi-square with ``dof`` degrees of freedom (Wilson-Hilferty)."""
    def q(z: float) -> float:
        return dof * (1.0 - 2.0 / (9.0 * dof) + z * np.sqrt(2.0 / (9.0 * dof))) ** 3
    return q(-Z_975), q(Z_975)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problem", type=Path, default=PROBLEMS / "davinci-ztu")
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--density-ramp", type=float, default=0.008)
    ap.add_argument("--wind-wave", type=float, default=0.0)
    ap.add_argument("--jet", type=float, default=0.0)
    args = ap.parse_args()
    problem = Scenario.load(args.problem)
    with tempfile.TemporaryDirectory() as tmp:
        sc, data = synthetic_scenario(problem, Path(tmp), seed=args.seed)
        truth = truth_parameters_by_name(sc)
        release = float(data.truth["release_imu_time_s"])
        sounding = altered_sounding(sc, Path(tmp) / "altered.csv", args.density_ramp, args.wind_wave, args.jet)
        print(f"{args.problem.name}, seed {args.seed}: the fit's sounding off by a density ramp to "
              f"{100 * args.density_ramp:g} %, wind waves {args.wind_wave:g} m/s, a {args.jet:g} m/s jet")
        for label, from_data in (("default (sigmas from the data)", True), ("configured sigmas kept", False)):
            atm = dataclasses.replace(sc.config.atmosphere, sounding=sounding, profile_wind_sigma_mps=0.5,
                                      profile_density_sigma=0.005, profile_sigma_from_data=from_data)
            t0 = time.perf_counter()
            try:
                result = fit_drop(Scenario.from_config(dataclasses.replace(sc.config, atmosphere=atm)))
            except FitError as err:
                print(f"\n{label}: failed: {err}")
                continue
            error, nees = parameter_errors(result, truth)
            z = error / result.sigma
            lo, hi = nees_interval(z.size)
            worst = sorted(zip(result.params.names, z), key=lambda t: -abs(t[1]))[:4]
            coverage = band_coverage(result, data.trajectory, release)
            print(f"\n{label}: {time.perf_counter() - t0:.1f} s")
            print(f"  parameter NEES {nees:.1f} on {z.size}, 95 % interval [{lo:.1f}, {hi:.1f}]: "
                  f"{'inside' if lo <= nees <= hi else 'OUTSIDE'}")
            print("  largest |z|: " + ", ".join(f"{n} {v:+.2f}" for n, v in worst))
            print("  3-sigma band coverage: " + ", ".join(f"{g} {100 * a / b:.1f} %" for g, (a, b) in coverage.items()))
            print(f"  verdict: {result_adequacy(result).line}")
            for note in result.notes:
                if "sigmas the data say" in note:
                    print(f"  {note}")


if __name__ == "__main__":
    main()
