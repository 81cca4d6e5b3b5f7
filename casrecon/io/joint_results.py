"""The results folder of a joint fit: global parameters and correlations, a Table 5, per-drop
summary and a sigma comparison with single-drop fits at the top; one per-drop results folder (the
same files as a per-drop fit) under ``drops/<name>/``."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from casrecon.io.fit_results import write_fit_results
from casrecon.io.results import write_json
from casrecon.report.fit_report import fit_report
from casrecon.report.tables import fit_tables


def joint_parameters_document(result) -> dict:
    params = {n: {"value": float(v), "sigma": float(s), "three_sigma": 3 * float(s),
                  "sigma_chi2_scaled": float(s * np.sqrt(result.reduced_chi2)), "shared": n in result.shared}
              for n, v, s in zip(result.names, result.values, result.sigma)}
    return {"parameters": params,
            "correlation": {"names": list(result.names), "matrix": np.round(result.correlation, 6).tolist()},
            "covariance": {"hessian": "gauss-newton J^T J (Fisher information) in the KKT matrix"}}


def _table5(result) -> list[str]:
    lines = ["### Shared aero dispersions (EES Table 5 style)", "",
             "Normalised factors (database 3-sigma = 1), estimated from all drops in one NLP.", "",
             "| factor | estimate | 3-sigma |", "|---|---|---|"]
    for n in result.shared:
        i = result.names.index(n)
        lines.append(f"| {n} | {result.values[i]:.4f} | {3 * result.sigma[i]:.4f} |")
    return lines


def _per_drop(result, reconciled: dict[str, dict]) -> list[str]:
    lines = ["### Per-drop summary", "",
             "| drop | window, s after release | chi2 / n | wind bias N, E (m/s) | density factor | "
             "end speed, m/s | reconciled dt, s | reconciled dV, m/s |", "|---|---|---|---|---|---|---|---|"]
    for d in result.drops:
        name = d.scenario.config.name
        w = d.data.window
        chi2, n = sum(d.chi2.values()), sum(d.n_measurements.values())
        wn, we = d.parameter("wind_bias_n")[0], d.parameter("wind_bias_e")[0]
        rho = d.parameter("density_factor")[0]
        rec = reconciled.get(name, {})
        lines.append(f"| {name} | {w[0] - d.data.release_imu_s:.2f} to {w[1] - d.data.release_imu_s:.2f} | "
                     f"{chi2:.0f} / {n} | {wn:+.3f}, {we:+.3f} | {rho:+.5f} | "
                     f"{np.linalg.norm(d.states[-1, 3:6]):.2f} | "
                     f"{rec.get('flight_time_difference_s', float('nan')):+.3f} | "
                     f"{rec.get('impact_speed_difference_mps', float('nan')):+.3f} |")
    return lines


def _sigma_comparison(result, single: dict[str, dict[str, float]]) -> list[str]:
    if not single:
        return ["### Joint vs single-drop sigma", "", "Single-drop fits were not run (--no-single)."]
    drops = list(single)
    lines = ["### Joint vs single-drop sigma", "",
             "1-sigma of each shared factor in the joint fit and in each drop's own fit; the last column is "
             "the joint sigma over the smallest single-drop sigma.", "",
             "| factor | joint | " + " | ".join(drops) + " | joint / best single |",
             "|---" * (len(drops) + 3) + "|"]
    for n in result.shared:
        js = result.sigma[result.names.index(n)]
        singles = [single[d].get(n, float("nan")) for d in drops]
        best = np.nanmin(singles)
        lines.append(f"| {n} | {js:.4g} | " + " | ".join(f"{s:.4g}" for s in singles) + f" | {js / best:.3f} |")
    return lines


def joint_tables(result, single: dict, reconciled: dict) -> str:
    head = [f"# {result.config.name}: joint aero fit of {len(result.drops)} drops", "",
            f"{result.status} in {result.iterations} iterations; reduced chi-square {result.reduced_chi2:.4f}.", ""]
    return "\n".join(head + _table5(result) + [""] + _per_drop(result, reconciled) + [""]
                     + _sigma_comparison(result, single)) + "\n"


def write_joint_results(out: Path, result, single: dict[str, dict[str, float]]) -> None:
    """Write the joint results folder into ``out`` (an atomic temporary folder)."""
    out = Path(out)
    reconciled = {}
    for d in result.drops:
        name = d.scenario.config.name
        sub = out / "drops" / name
        sub.mkdir(parents=True)
        write_fit_results(sub, d, fit_report(d), fit_tables(d))
        reconciled[name] = json.loads((sub / "summary.json").read_text())["reconciled"]
    write_json(out / "parameters.json", joint_parameters_document(result))
    write_json(out / "summary.json", {
        "name": result.config.name, "converged": True, "status": result.status, "iterations": result.iterations,
        "drops": [d.scenario.config.name for d in result.drops], "shared": list(result.shared),
        "chi2": result.chi2, "dof": result.dof, "reduced_chi2": result.reduced_chi2, "timings": result.timings,
        **{k: result.timings[k] for k in ("build_s", "solve_s", "covariance_s", "total_s")},
        "chi2_per_drop": {d.scenario.config.name: d.chi2 for d in result.drops},
        "single_drop_sigma": single, "reconciled": reconciled})
    (out / "tables.md").write_text(joint_tables(result, single, reconciled))
