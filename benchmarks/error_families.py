"""Fits of drops whose errors the fit's models do not contain (issue 49): per error family of
:mod:`casrecon.simulation.error_families`, vehicle and fit variant, print convergence, parameter
NEES against its 95 % interval, the worst |z| per parameter group, pooled truth-in-3-sigma band
coverage per trajectory quantity, the verdict counts and the fit times.

Each case draws a truth from the fit's priors (seeded by (seed, index)), flies it through the
family's world (its own random stream), and fits it as each variant says:

- ``default``: casrecon's defaults for the error models (the problem's own error-model keys
  replaced by the defaults: profile model 0.5 m/s, 0.5 %, 300 m with its sizes from the data,
  GPS error model 100 s / 0.6 s from the data), what a user who writes no error-model key gets;
- ``fixed``: the default error models with their configured sizes (no size estimate, no refit);
- ``plain``: both error models off;
- ``gusts``: ``fixed`` with gust states at every node (the weak-constraint option: 0.5, 0.5 and
  0.3 m/s north, east, down over 3 s, the keys' default time) and the marginal estimator;
- ``ground``: ``default`` with the impact as a measurement of altitude (``[estimation]
  impact_ground_sigma_m`` = GROUND_SIGMA_M: a surveyed drop zone; the simulated ground is the
  site's exactly).

Vehicles: ``ees`` (problems/ees-drop-3: 98.6 kg, 1.27 m) and ``light`` (the same shape scaled to
60 kg and 1.0 m, its inertia with it).

Run (one family, two seeds, both vehicles; cases on 2 processes)::

    python benchmarks/error_families.py --families turbulence --seeds 2 --vehicles ees light

Seeds are counted from ``--first-seed``: choose defaults on one range, accept on another.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import math
import os
import tempfile
import time
from functools import partial
from pathlib import Path

import numpy as np

from casrecon.analysis.estimator_mc import chi2_interval, draw_truth
from casrecon.analysis.model_error_mc import COVERAGE_GROUPS, fit_summary
from casrecon.io.atmosphere_config import AtmosphereConfig
from casrecon.parallel import parallel_map
from casrecon.physics.disturbance import DisturbanceModel
from casrecon.physics.sensor_errors import GpsErrorModel
from casrecon.scenario import Scenario
from casrecon.simulation.error_families import FAMILIES, SyntheticWorld, family_world, with_air_scaled
from casrecon.simulation.synthetic import synthetic_scenario, truth_parameters_by_name, world_span

ROOT = Path(__file__).resolve().parents[1]
PROBLEM = ROOT / "problems" / "ees-drop-3"
VARIANTS = ("default", "fixed", "plain", "gusts", "ground")
#: The ``ground`` variant's 1-sigma of the ground's altitude at the impact, m.
GROUND_SIGMA_M = 1.0
#: The ``gusts`` variant's prior: (sigma north, east, down m/s, then six model-error sigmas), times s.
GUST_PRIOR = DisturbanceModel((0.5, 0.5, 0.3, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0), (3.0,) * 3 + (1.0,) * 6)
#: Parameter groups of the worst-|z| columns, by name prefix.
GROUPS = {"aero": ("C",), "atmosphere": ("wind_bias", "density_factor", "sounding_shift"),
          "imu": ("accel_bias", "gyro_bias"),
          "clock": ("clock_offset",)}


def vehicle_scenario(name: str) -> Scenario:
    """ees-drop-3 with the EES vehicle (``ees``) or its 60 kg, 1.0 m scaled copy (``light``)."""
    scenario = Scenario.load(PROBLEM)
    if name == "ees":
        return scenario
    if name != "light":
        raise ValueError(f"unknown vehicle {name!r}; expected ees or light")
    cfg = scenario.config
    v = cfg.vehicle
    length = 1.0 / v.ref_length_m
    mass = 60.0 / v.mass_kg
    light = dataclasses.replace(v, name=f"{v.name} (60 kg, 1.0 m)", mass_kg=60.0, ref_length_m=1.0,
                                ref_area_m2=math.pi / 4, inertia_kgm2=np.asarray(v.inertia_kgm2) * mass * length**2,
                                cm_m=tuple(np.asarray(v.cm_m) * length), mrp_m=tuple(np.asarray(v.mrp_m) * length),
                                imu_position_m=tuple(np.asarray(v.imu_position_m) * length),
                                gps_position_m=tuple(np.asarray(v.gps_position_m) * length))
    return Scenario.from_config(dataclasses.replace(cfg, vehicle=light))


def fit_variant(scenario: Scenario, variant: str) -> Scenario:
    """The scenario's fit configuration for ``variant`` (see the module)."""
    if variant not in VARIANTS:
        raise ValueError(f"unknown variant {variant!r}; expected one of {VARIANTS}")
    cfg = scenario.config
    d = AtmosphereConfig
    atm = dataclasses.replace(cfg.atmosphere, profile_wind_sigma_mps=d.profile_wind_sigma_mps,
                              profile_density_sigma=d.profile_density_sigma, profile_length_m=d.profile_length_m,
                              profile_step_m=d.profile_step_m, profile_sigma_from_data=d.profile_sigma_from_data)
    gps = dataclasses.replace(cfg.gps, error_model=GpsErrorModel(), error_model_from_data=True)
    estimation = cfg.estimation
    if variant in ("fixed", "gusts"):
        atm = dataclasses.replace(atm, profile_sigma_from_data=False)
        gps = dataclasses.replace(gps, error_model_from_data=False)
    if variant == "gusts":
        estimation = dataclasses.replace(estimation, disturbance=GUST_PRIOR, method="marginal")
    elif variant == "ground":
        estimation = dataclasses.replace(estimation, impact_ground_sigma_m=GROUND_SIGMA_M)
    elif variant == "plain":
        atm = dataclasses.replace(atm, profile_wind_sigma_mps=0.0, profile_density_sigma=0.0,
                                  profile_sigma_from_data=False)
        gps = dataclasses.replace(gps, error_model=GpsErrorModel.white(), error_model_from_data=False)
    return Scenario.from_config(dataclasses.replace(cfg, atmosphere=atm, gps=gps, estimation=estimation))


def study_case(family: str, vehicle: str, seed: int, air_factor: float = 1.0) -> tuple[Scenario, SyntheticWorld, int]:
    """Case ``seed`` of the study: (the vehicle's scenario with a truth drawn from the fit's priors,
    ``family``'s world with its air's departures from the sounding times ``air_factor``, the noise
    seed of its data), all drawn from ``default_rng([seed, 49])``: the truth depends on the seed
    alone, so every family and both vehicles fly the same one."""
    rng = np.random.default_rng([seed, 49])
    scenario = draw_truth(vehicle_scenario(vehicle), rng)
    world = with_air_scaled(family_world(family, world_span(scenario), seed), air_factor)
    return scenario, world, int(rng.integers(2**31))


def run_case(family: str, vehicle: str, variants: tuple[str, ...], seed: int, air_factor: float = 1.0,
             forced_widening: bool = False) -> dict:
    """One drop (:func:`study_case`), fitted per variant (``forced_widening``: see
    :func:`~casrecon.analysis.model_error_mc.fit_summary`)."""
    scenario, world, noise_seed = study_case(family, vehicle, seed, air_factor)
    out = {"family": family, "vehicle": vehicle, "seed": seed}
    with tempfile.TemporaryDirectory() as tmp:
        sc, data = synthetic_scenario(scenario, Path(tmp), seed=noise_seed, world=world)
        truth = truth_parameters_by_name(sc)
        release = float(data.truth["release_imu_time_s"])
        for variant in variants:
            out[variant] = fit_summary(fit_variant(sc, variant), truth, data.trajectory, release,
                                       forced_widening=forced_widening)
    return out


def run_job(variants: tuple[str, ...], air_factor: float, forced_widening: bool, job: tuple[str, str, int]) -> dict:
    """:func:`run_case` of a (family, vehicle, seed) job (picklable, for the process pool)."""
    return run_case(job[0], job[1], variants, job[2], air_factor, forced_widening)


def pooled(fits: list[dict]) -> dict:
    """A variant's pooled figures over its cases."""
    ok = [f for f in fits if "nees" in f]
    out = {"converged": len(ok), "cases": len(fits), "seconds": [f["seconds"] for f in fits]}
    if not ok:
        return out
    names = ok[0]["names"]
    z = np.array([np.asarray(f["error"]) / np.asarray(f["sigma"]) for f in ok])
    out["nees_sum"] = float(sum(f["nees"] for f in ok))
    out["interval"] = chi2_interval(len(names) * len(ok))
    out["worst_z"] = {}
    for group, prefixes in GROUPS.items():
        cols = [i for i, n in enumerate(names) if n.startswith(prefixes)]
        if cols:
            j = int(np.argmax(np.max(np.abs(z[:, cols]), axis=0)))
            out["worst_z"][group] = (names[cols[j]], float(np.max(np.abs(z[:, cols[j]]))))
    out["coverage"] = {g: sum(f["coverage"][g][0] for f in ok) / max(sum(f["coverage"][g][1] for f in ok), 1)
                       for g in COVERAGE_GROUPS}
    out["trusted"] = sum(f["trusted"] for f in ok)
    return out


def print_table(cases: list[dict], variants: tuple[str, ...]) -> None:
    keys = sorted({(c["family"], c["vehicle"]) for c in cases})
    for family, vehicle in keys:
        mine = [c for c in cases if c["family"] == family and c["vehicle"] == vehicle]
        print(f"\n## {family}, {vehicle}: {len(mine)} cases (seeds {', '.join(str(c['seed']) for c in mine)})")
        for variant in variants:
            p = pooled([c[variant] for c in mine])
            secs = np.median(p["seconds"]) if p["seconds"] else float("nan")
            line = f"  {variant:8s} converged {p['converged']}/{p['cases']}, median {secs:.0f} s"
            if "nees_sum" in p:
                lo, hi = p["interval"]
                line += (f", NEES {p['nees_sum']:.0f} (95 % {lo:.0f}-{hi:.0f}), trusted {p['trusted']}/{p['converged']}"
                         "\n    worst |z| " + ", ".join(f"{g} {n} {v:.1f}" for g, (n, v) in p["worst_z"].items())
                         + "\n    coverage " + ", ".join(f"{g} {100 * v:.0f} %" for g, v in p["coverage"].items()))
            failed = [f["failed"][:100] for f in (c[variant] for c in mine) if "failed" in f]
            if failed:
                line += "\n    failed: " + " | ".join(failed)
            print(line)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--families", nargs="+", default=list(FAMILIES), choices=list(FAMILIES))
    ap.add_argument("--vehicles", nargs="+", default=["ees", "light"], choices=["ees", "light"])
    ap.add_argument("--variants", nargs="+", default=list(VARIANTS), choices=list(VARIANTS))
    ap.add_argument("--seeds", type=int, default=10, help="cases per family and vehicle")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--json", type=Path, help="also write every case's figures here (after each case)")
    ap.add_argument("--air-factor", type=float, default=1.0,
                    help="the air's departures from the sounding (profile errors, gusts) times this (2: twice)")
    ap.add_argument("--forced-widening", action="store_true",
                    help="for fits published with their own sigmas, also record (--json) the widened ones")
    args = ap.parse_args()
    jobs = [(f, v, s) for f in args.families for v in args.vehicles
            for s in range(args.first_seed, args.first_seed + args.seeds)]
    t0 = time.perf_counter()
    done: list[dict] = []

    def keep(_job, case: dict) -> None:  # every finished case on disk at once (a long study may be stopped)
        done.append(case)
        if args.json:
            tmp = args.json.with_name(args.json.name + ".tmp")
            tmp.write_text(json.dumps(done, indent=1, default=str))
            os.replace(tmp, args.json)

    cases = parallel_map(partial(run_job, tuple(args.variants), args.air_factor, args.forced_widening), jobs,
                         workers=args.workers, progress="error families", on_done=keep)
    print(f"{len(jobs)} cases in {time.perf_counter() - t0:.0f} s")
    print_table(cases, tuple(args.variants))


if __name__ == "__main__":
    main()
