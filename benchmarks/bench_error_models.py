"""What the atmosphere-profile and GPS error models cost in fit time (not a test; prints).

ees-drop-1 (40 s drop, which flies its sounding, white GPS errors) fitted in one process, three
ways, interleaved run by run (the machine's speed drifts within minutes):

- plain: the problem as shipped (no error model);
- models, one fit: the profile model at 0.5 m/s and 0.5 % over 300 m (the defaults) and the
  Gauss-Markov GPS error states (the defaults), the profile sigmas and the GPS error model held as
  configured (``profile_sigma_from_data = false``, ``error_model_from_data = false``): the fit
  the issue's 2x ceiling is about;
- models, default: the same with the profile sigmas and the GPS error model estimated from the
  data and refitted (both keys true, the defaults), as many fits as that takes.

For each: the median (min, max) wall time of ``fit_drop`` over --runs runs and the medians of its
parts (build, solve, of it the linear algebra, covariance with bands and products, the rest), the
iterations and the solver, and the ratio of the medians to the plain fit's.

Run: python benchmarks/bench_error_models.py [--runs 5]
"""

from __future__ import annotations

import argparse
import dataclasses
import statistics
import time
from pathlib import Path

from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.physics import compiled
from casrecon.scenario import Scenario

PROBLEM = Path(__file__).resolve().parents[1] / "problems" / "ees-drop-1"
PARTS = ("build_s", "solve_s", "solve_linear_algebra_s", "covariance_s")


def variants() -> dict[str, Scenario]:
    """The three scenarios (see the module docstring)."""
    plain = Scenario.load(PROBLEM)
    cfg = plain.config
    out = {"plain": plain}
    for name, from_data in (("models, one fit", False), ("models, default", True)):
        atmosphere = dataclasses.replace(cfg.atmosphere, profile_wind_sigma_mps=0.5, profile_density_sigma=0.005,
                                         profile_sigma_from_data=from_data)
        gps = dataclasses.replace(cfg.gps, error_model=type(cfg.gps.error_model)(),  # the default GPS error model
                                  error_model_from_data=from_data)
        out[name] = Scenario.from_config(dataclasses.replace(cfg, atmosphere=atmosphere, gps=gps))
    return out


def median(values: list[float]) -> str:
    return f"{statistics.median(values):6.2f} s (min {min(values):.2f}, max {max(values):.2f})"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=5)
    args = parser.parse_args()
    scenarios = variants()
    for sc in scenarios.values():  # compile caches and first-use costs out of the timings
        fit_drop(sc)
    compiled.wait_for_background_builds()  # the exact Hessians' libraries, built in the background
    wall: dict[str, list[float]] = {k: [] for k in scenarios}
    parts: dict[str, dict[str, list[float]]] = {k: {p: [] for p in PARTS} for k in scenarios}
    last = {}
    for run in range(args.runs):
        for name, sc in scenarios.items():
            t0 = time.perf_counter()
            result = fit_drop(sc)
            wall[name].append(time.perf_counter() - t0)
            for p in PARTS:
                parts[name][p].append(result.timings[p])
            last[name] = result
        print(f"run {run + 1}: " + ", ".join(f"{k} {v[-1]:.2f} s" for k, v in wall.items()), flush=True)
    plain = statistics.median(wall["plain"])
    print(f"\nees-drop-1, medians of {args.runs} interleaved runs in one process")
    for name in scenarios:
        result = last[name]
        split = ", ".join(f"{p[:-2]} {statistics.median(parts[name][p]):.2f}" for p in PARTS)
        ratio = statistics.median(wall[name]) / plain
        print(f"{name:16s} {median(wall[name])}  {ratio:4.2f} x plain  [{split}]")
        print(f"{'':16s} {result.solver.iterations} iterations, {result.solver.method}; "
              f"aero sigma Cm_add {result.parameter('Cm_add')[1]:.4g}")
        notes = [n for n in result.notes if "atmosphere-profile" in n]
        if notes:
            print(f"{'':16s} {notes[-1][:160]}")


if __name__ == "__main__":
    main()
