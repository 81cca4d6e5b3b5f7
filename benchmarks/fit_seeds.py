"""Frequentist check of the per-drop fit's uncertainties over many noise seeds (not a test).

For each seed, fresh synthetic IMU and GPS data of one drop are made (the truth is the same for
every seed, only the noise changes), the drop is fitted, and the normalised parameter errors
(value - truth) / sigma are collected. If the reported sigmas are right, these are ~N(0, 1): their
RMS over every parameter and seed should be near 1 (the slow test accepts [0.8, 1.25]).

Caveat (reported per parameter): the dispersion priors are N(0, (1/3)^2) while the truth is fixed
at non-zero values, so a parameter the data hardly determine is shrunk towards 0 on every seed:
that is the correct Bayesian posterior, but the error is then a bias, not noise, and its
normalised error has a non-zero mean. Such parameters are the "prior-dominated" ones, whose
posterior sigma is close to the prior sigma (ratio near 1).

The trajectory bands are checked too: the normalised error of N, E, D position and velocity at
every node, pooled over seeds (RMS near 1 and >= 99 % inside 3 sigma if the bands are right).

Run: python benchmarks/fit_seeds.py [--drop ees-drop-3] [--seeds 20] [--first 100] [--json out.json]
"""

from __future__ import annotations

import argparse
import json
import tempfile
import time
from dataclasses import replace
from pathlib import Path

import numpy as np

from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.io.flysight import write_flysight1
from casrecon.io.imu import write_imu_csv
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import make_synthetic, simulate_truth, truth_parameters_by_name

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
BAND_COLUMNS = ("pos_n_m", "pos_e_m", "pos_d_m", "vel_n_mps", "vel_e_mps", "vel_d_mps")


def scenario_with_seed(scenario: Scenario, seed: int, folder: Path) -> Scenario:
    """The scenario with new synthetic IMU and GPS files (noise seed ``seed``) written to ``folder``."""
    cfg = scenario.config
    data = make_synthetic(scenario, seed=seed)
    folder.mkdir(parents=True, exist_ok=True)
    imu_path, gps_path = folder / "imu.csv", folder / "gps.csv"
    write_imu_csv(imu_path, data.imu_time_s, data.imu_accel_mps2, data.imu_gyro_radps, cfg.imu.spec)
    write_flysight1(gps_path, data.gps)
    new = replace(cfg, imu=replace(cfg.imu, file=imu_path), gps=replace(cfg.gps, file=gps_path))
    return Scenario.from_config(new)


def truth_at_nodes(scenario: Scenario, node_time_s: np.ndarray, seed: int) -> np.ndarray:
    """Truth states (K, 13) at the fit's node times (IMU clock) of the data of ``seed`` (its gusts and
    atmosphere-profile error, if the truth has them)."""
    traj, t_zero = simulate_truth(scenario, seed)
    t = t_zero + traj.time_s
    idx = np.searchsorted(t, node_time_s - 1e-6)
    if not np.all(np.abs(t[idx] - node_time_s) < 1e-6):
        raise AssertionError("fit nodes are not on the truth's IMU grid")
    return traj.states[idx]


def run_seeds(drop: str, seeds, workdir: Path, verbose: bool = True) -> dict:
    """Fit ``drop`` once per seed; returns names, values, sigmas, truth, prior sigmas, band errors."""
    base = Scenario.load(PROBLEMS / drop)
    truth = truth_parameters_by_name(base)
    names, values, sigmas, chi2, band, times = None, [], [], [], [], []
    for seed in seeds:
        sc = scenario_with_seed(base, seed, workdir / f"seed{seed}")
        t0 = time.perf_counter()
        r = fit_drop(sc)
        times.append(time.perf_counter() - t0)
        names = r.params.names
        values.append(r.values)
        sigmas.append(r.sigma)
        chi2.append(r.reduced_chi2)
        x_truth = truth_at_nodes(base, r.node_time_s, seed)
        cols = [r.columns.index(c) for c in BAND_COLUMNS]
        band.append((r.table[:, cols] - x_truth[:, :6]) / r.table_sigma[:, cols])
        if verbose:
            worst = np.max(np.abs((r.values - [truth[n] for n in names]) / r.sigma))
            print(f"seed {seed:4d}: {times[-1]:5.1f} s, {r.solver.iterations} it, chi2/dof {r.reduced_chi2:.4f}, "
                  f"worst |err|/sigma {worst:.2f}", flush=True)
    prior = [s.prior_sigma for s in r.params.specs]
    return {"drop": drop, "seeds": list(seeds), "names": list(names), "values": np.array(values),
            "sigma": np.array(sigmas), "truth": np.array([truth[n] for n in names]),
            "prior_sigma": np.array([np.nan if p is None else p for p in prior]),
            "reduced_chi2": np.array(chi2), "band_errors": np.array(band), "fit_s": np.array(times)}


def summarise(res: dict) -> dict:
    """Normalised-error statistics, overall and per parameter."""
    z = (res["values"] - res["truth"]) / res["sigma"]
    ratio = np.median(res["sigma"], axis=0) / res["prior_sigma"]
    per = {n: {"mean": float(z[:, i].mean()), "rms": float(np.sqrt(np.mean(z[:, i] ** 2))),
               "sd": float(z[:, i].std(ddof=1)), "max_abs": float(np.abs(z[:, i]).max()),
               "sigma_over_prior": float(ratio[i])}
           for i, n in enumerate(res["names"])}
    be = res["band_errors"]
    bands = {c: {"rms": float(np.sqrt(np.mean(be[:, :, j] ** 2))),
                 "inside_3sigma": float(np.mean(np.abs(be[:, :, j]) <= 3))}
             for j, c in enumerate(BAND_COLUMNS)}
    return {"rms_all": float(np.sqrt(np.mean(z ** 2))), "per_parameter": per, "bands": bands,
            "reduced_chi2_mean": float(res["reduced_chi2"].mean()),
            "reduced_chi2_sd": float(res["reduced_chi2"].std(ddof=1)),
            "fit_s_median": float(np.median(res["fit_s"]))}


def print_summary(res: dict, s: dict) -> None:
    print(f"\n{res['drop']}: {len(res['seeds'])} seeds, median fit {s['fit_s_median']:.1f} s, "
          f"chi2/dof {s['reduced_chi2_mean']:.4f} +- {s['reduced_chi2_sd']:.4f}")
    print(f"RMS of (value - truth)/sigma over all parameters and seeds: {s['rms_all']:.3f}")
    print(f"{'parameter':<16s} {'mean':>7s} {'sd':>6s} {'rms':>6s} {'max':>6s} {'sigma/prior':>11s}")
    for n, p in s["per_parameter"].items():
        flag = "  prior-dominated" if p["sigma_over_prior"] > 0.5 else ""
        print(f"{n:<16s} {p['mean']:7.2f} {p['sd']:6.2f} {p['rms']:6.2f} {p['max_abs']:6.2f} "
              f"{p['sigma_over_prior']:11.3f}{flag}")
    print("band normalised errors (all nodes, all seeds):")
    for c, b in s["bands"].items():
        print(f"  {c:<10s} rms {b['rms']:.3f}  inside 3 sigma {100 * b['inside_3sigma']:.1f} %")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--drop", default="ees-drop-3")
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--first", type=int, default=100)
    ap.add_argument("--json", type=Path)
    args = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        res = run_seeds(args.drop, range(args.first, args.first + args.seeds), Path(tmp))
    s = summarise(res)
    print_summary(res, s)
    if args.json:
        args.json.write_text(json.dumps({"drop": res["drop"], "seeds": res["seeds"], **s}, indent=2))


if __name__ == "__main__":
    main()
