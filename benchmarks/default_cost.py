"""What the default fit costs against the plain fit of the same drop (issue 49; not a test, prints).

A 6-DOF drop with a model error, made as benchmarks/error_families.py makes its cases (the EES
vehicle of problems/ees-drop-3, a truth drawn from the priors, flown through one error family's
world; default ``gps-long-time``, seed 200: GPS errors correlated over 400 s and 40 s), fitted in
one process, two ways, alternating run by run (the machine's speed drifts within minutes). The
shipped problems/ees-drop-3-model-error is no such case: its plain fit does not converge (250
iterations), which is why the error models are on by default.

- ``plain``: both error models off (``profile_wind_sigma_mps = 0``, ``profile_density_sigma = 0``,
  white GPS errors);
- ``default``: casrecon's defaults for both error models (the problem's own keys replaced by them,
  sizes from the data), as many fits as that takes.

A warm-up fit of each comes first (compiled libraries and first-use costs out of the timings; the
libraries are built in the background and waited for). For each: the median (min, max) of the
wall time of ``fit_drop`` over --runs runs, the ratio to the plain fit's, and the median split over
every fit made: build, solve, covariance (with the bands), the size estimates, the rest, and the
number of refits. The 1-minute load average is printed with every run (the 2-core machine is
shared).

With ``--track`` (a GPS-only point-mass problem folder), its fit's solve and covariance are timed
too; ``--rate-hz`` resamples its fixes to that rate first (linear interpolation of every column:
a case of that size for the cost, not for the estimates).

Run: python benchmarks/default_cost.py [--runs 3] [--family gps-long-time] [--seed 200]
[--track problems/realdata-fs2-chicago --rate-hz 25]
"""

from __future__ import annotations

import argparse
import csv
import os
import shutil
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from casrecon.estimation.pointmass.fit import fit_point_mass
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.io.pointmass_problem import load_point_mass
from casrecon.physics import compiled
from casrecon.scenario import Scenario
from casrecon.simulation.error_families import FAMILIES
from casrecon.simulation.synthetic import synthetic_scenario

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(Path(__file__).resolve().parent))
from error_families import fit_variant, study_case  # noqa: E402  (the families study's cases)

PARTS = ("all_build_s", "all_solve_s", "all_covariance_s", "estimate_s")


def load() -> str:
    return f"load {os.getloadavg()[0]:.1f}"


def split(result) -> dict[str, float]:
    """The parts of a fit's time over every fit it made (a plain fit: its own parts)."""
    t = result.timings
    out = {p: t.get(p, t.get(p.removeprefix("all_"), 0.0)) for p in PARTS}
    out["rest_s"] = t["total_s"] - sum(out.values())
    out["refits"] = t.get("refits", 0.0)
    return out


def drop_costs(family: str, seed: int, runs: int) -> None:
    scenario, world, noise_seed = study_case(family, "ees", seed)
    with tempfile.TemporaryDirectory() as tmp:
        sc, _ = synthetic_scenario(scenario, Path(tmp), seed=noise_seed, world=world)
        drop_runs(sc, f"{family} seed {seed}", runs)


def drop_runs(scenario: Scenario, title: str, runs: int) -> None:
    variants = {name: fit_variant(scenario, name) for name in ("plain", "default")}
    for sc in variants.values():
        fit_drop(sc)
    compiled.wait_for_background_builds()
    wall: dict[str, list[float]] = {k: [] for k in variants}
    parts: dict[str, list[dict]] = {k: [] for k in variants}
    for run in range(runs):
        for name, sc in variants.items():
            before = load()
            t0 = time.perf_counter()
            result = fit_drop(sc)
            wall[name].append(time.perf_counter() - t0)
            parts[name].append(split(result))
            print(f"run {run + 1} {name:8s} {wall[name][-1]:7.1f} s  ({before} before, {load()} after)", flush=True)
    plain = statistics.median(wall["plain"])
    print(f"\n{title}: medians of {runs} alternating runs")
    for name in variants:
        med = statistics.median(wall[name])
        cols = ", ".join(f"{p.removeprefix('all_').removesuffix('_s')} "
                         f"{statistics.median(d[p] for d in parts[name]):.1f}" for p in (*PARTS, "rest_s"))
        refits = statistics.median(d["refits"] for d in parts[name])
        print(f"{name:8s} {med:7.1f} s (min {min(wall[name]):.1f}, max {max(wall[name]):.1f})  "
              f"{med / plain:4.1f} x plain  [{cols}; {refits:.0f} refits]")


def resampled(problem: Path, rate_hz: float, folder: Path) -> Path:
    """A copy of a FlySight point-mass problem with its GNSS fixes linearly interpolated to ``rate_hz``."""
    copy = folder / problem.name
    shutil.copytree(problem, copy)
    track = copy / "TRACK.CSV"
    lines = track.read_text().splitlines()
    head = [ln for ln in lines if not ln.startswith("$GNSS")]
    rows = list(csv.reader(ln for ln in lines if ln.startswith("$GNSS")))
    t = np.array([np.datetime64(r[1].rstrip("Z"), "ms").astype(float) / 1000.0 for r in rows])
    values = np.array([[float(v) for v in r[2:]] for r in rows])
    t_new = np.arange(t[0], t[-1], 1.0 / rate_hz)
    new = np.column_stack([np.interp(t_new, t, values[:, j]) for j in range(values.shape[1])])
    out = head[: head.index("$DATA") + 1] if "$DATA" in head else head
    for ti, v in zip(t_new, new):
        stamp = np.datetime_as_string(np.datetime64(int(round(ti * 1000)), "ms"), unit="ms") + "Z"
        out.append(",".join(["$GNSS", stamp] + [f"{x:.7f}" for x in v[:-1]] + [str(int(round(v[-1])))]))
    track.write_text("\n".join(out) + "\n")
    return copy


def track_costs(problem: Path, rate_hz: float | None) -> None:
    with tempfile.TemporaryDirectory() as tmp:
        folder = resampled(problem, rate_hz, Path(tmp)) if rate_hz else problem
        before = load()
        result = fit_point_mass(load_point_mass(folder))
    t = result.timings
    print(f"\n{problem.name}{f' at {rate_hz:g} Hz' if rate_hz else ''}: {result.states.shape[0]} nodes, "
          f"total {t['total_s']:.1f} s: build {t['build_s']:.1f}, solve {t['solve_s']:.1f}, "
          f"covariance {t['covariance_s']:.1f} s ({before} before, {load()} after)")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=3)
    parser.add_argument("--family", default="gps-long-time", choices=sorted(FAMILIES))
    parser.add_argument("--seed", type=int, default=200)
    parser.add_argument("--track", type=Path, default=None, help="a GPS-only point-mass problem folder")
    parser.add_argument("--rate-hz", type=float, default=None, help="resample the track's fixes to this rate")
    parser.add_argument("--skip-drop", action="store_true", help="only the track")
    args = parser.parse_args()
    if not args.skip_drop:
        drop_costs(args.family, args.seed, args.runs)
    if args.track is not None:
        track_costs(args.track, args.rate_hz)


if __name__ == "__main__":
    main()
