"""The results folder of a per-drop fit (written atomically by the caller's ``atomic_folder``).

Files: ``trajectory.csv`` (time history with 3-sigma columns), ``parameters.json`` (values,
1- and 3-sigma absolute and chi-square-scaled, correlations), ``summary.json`` (convergence,
chi-square per group, timings, reconciled-simulation differences), ``tables.md`` (EES Tables 3,
4, 5 style), ``report.txt`` (the console report), ``config/`` (the exact input files and the
resolved settings), and for the figures: ``residuals_imu.csv``, ``residuals_gps.csv``,
``pitching_moment.csv``, ``cm_curves.csv``, ``reconciled.csv`` (forward simulation with the fitted
dispersions), ``nominal.csv`` (the same with the nominal database), ``gps_fixes.csv``.
"""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import numpy as np

from casrecon.io.results import write_columns, write_json


def parameters_document(result) -> dict:
    """``parameters.json`` content; names match truth.json."""
    scale = float(np.sqrt(result.reduced_chi2))
    params = {}
    for i, spec in enumerate(result.params.specs):
        s = float(result.sigma[i])
        params[spec.name] = {"value": float(result.values[i]), "sigma": s, "three_sigma": 3 * s,
                             "sigma_chi2_scaled": s * scale, "unit": spec.unit, "group": spec.group,
                             "prior_sigma": spec.prior_sigma}
    return {"parameters": params,
            "correlation": {"names": list(result.params.names), "matrix": np.round(result.correlation, 6).tolist()},
            "covariance": {"hessian": "gauss-newton J^T J (Fisher information) in the KKT matrix",
                           "sigma": "absolute (noise sigmas as given)",
                           "sigma_chi2_scaled": f"absolute times sqrt(reduced chi2) = {scale:.5f}"}}


def summary_document(result) -> dict:
    sol, d = result.solver, result.data
    return {"problem": result.scenario.config.name, "converged": sol.converged, "status": sol.status,
            "iterations": sol.iterations, "objective": sol.objective, "hessian": sol.hessian,
            "linear_solver": sol.linear_solver, "chi2": result.chi2, "n_measurements": result.n_measurements,
            "dof": result.dof, "reduced_chi2": result.reduced_chi2, "condition": result.condition,
            "timings": result.timings, **{k: result.timings[k] for k in ("build_s", "solve_s", "covariance_s",
                                                                          "total_s")},
            "release_imu_s": d.release_imu_s, "impact_imu_s": d.impact_imu_s, "window_imu_s": list(d.window),
            "mesh": {"intervals": int(result.node_time_s.size - 1),
                     "h_s": float(result.node_time_s[1] - result.node_time_s[0])},
            "notes": list(result.notes)}


def trajectory_table(result) -> tuple[list[str], np.ndarray]:
    cols = ["time_imu_s", "flight_time_s"]
    data = [result.node_time_s, result.flight_time_s]
    for i, name in enumerate(result.columns):
        cols += [name, f"{name}_3sigma"]
        data += [result.table[:, i], 3 * result.table_sigma[:, i]]
    return cols, np.column_stack(data)


def write_diagnostics(out: Path, result) -> dict:
    """Residual, pitching-moment and reconciled-simulation CSVs; returns the reconciled summary."""
    from casrecon.estimation import diagnostics as dg

    imu = dg.imu_residuals(result)
    cols = ["time_imu_s"] + [f"{c}_residual" for c in dg.IMU_CHANNELS] + [f"{c}_used" for c in dg.IMU_CHANNELS]
    write_columns(out / "residuals_imu.csv", cols, np.column_stack([imu["time_imu_s"], imu["residual"], imu["valid"]]))
    write_json(out / "imu_sigma.json", dict(zip(dg.IMU_CHANNELS, imu["sigma"].tolist())))
    gps = dg.gps_residuals(result)
    names = ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")
    write_columns(out / "residuals_gps.csv", ["time_imu_s"] + [f"{n}_residual" for n in names]
                  + [f"{n}_sigma" for n in names], np.column_stack([gps["time_imu_s"], gps["residual"], gps["sigma"]]))
    d = result.data
    gps_cols = ["time_imu_s", "pos_n_m", "pos_e_m", "pos_d_m", "vel_n_mps", "vel_e_mps", "vel_d_mps"]
    write_columns(out / "gps_fixes.csv", gps_cols, np.column_stack([gps["time_imu_s"], d.gps_pos_ned, d.gps_vel_ned]))
    pm = dg.pitching_moment(result)
    write_columns(out / "pitching_moment.csv", ["time_imu_s", "alpha_deg", "qbar_pa", "cm_recon"],
                  np.column_stack([pm["time_imu_s"], pm["alpha_deg"], pm["qbar_pa"], pm["cm_recon"]]))
    write_columns(out / "cm_curves.csv", ["alpha_deg", "cm_nominal", "cm_fitted"],
                  np.column_stack([pm["alpha_grid_deg"], pm["cm_nominal"], pm["cm_fitted"]]))
    keys = ["flight_time_s", "h_agl_m", "speed_mps", "alpha_t_deg", "p_dps"]
    rec = dg.reconciled_simulation(result)
    write_columns(out / "reconciled.csv", keys, np.column_stack([rec[k] for k in keys])[::5])
    nom = dg.reconciled_simulation(result, nominal=True)
    write_columns(out / "nominal.csv", keys, np.column_stack([nom[k] for k in keys])[::5])
    summary = {**rec["summary"], "nominal_database": nom["summary"]}
    if result.scenario.config.aero.vanes is not None:
        summary["roll_rate"] = roll_rate_comparison(result, rec, nom)
    return summary


def roll_rate_comparison(result, rec: dict, nom: dict, n: int = 6) -> list[dict]:
    """Reconstructed roll rate (with 3-sigma) against the spin-vane model with the fitted and the
    nominal lift-curve slope, at ``n`` times through the fit window (deg/s)."""
    p, p_sigma = result.column("p_dps")
    t = result.flight_time_s
    out = []
    for tt in np.linspace(t[0], t[-1], n):
        out.append({"flight_time_s": float(tt), "reconstructed_dps": float(np.interp(tt, t, p)),
                    "reconstructed_3sigma_dps": float(3 * np.interp(tt, t, p_sigma)),
                    "model_fitted_dps": float(np.interp(tt, rec["flight_time_s"], rec["p_dps"])),
                    "model_nominal_dps": float(np.interp(tt, nom["flight_time_s"], nom["p_dps"]))})
    return out


def roll_rate_table(rows: list[dict], cla_mult: tuple[float, float] | None) -> str:
    """Markdown table of :func:`roll_rate_comparison`."""
    fit = "" if cla_mult is None else f" (CLa_mult {cla_mult[0]:.4f} +/- {3 * cla_mult[1]:.4f}, 3-sigma)"
    lines = ["### Roll rate: reconstruction vs spin-vane model", "",
             f"Forward simulations from the reconstructed first state with the fitted C_La{fit} and the nominal "
             "(2 pi / 5) vane lift-curve slope.", "",
             "| flight time, s | reconstructed, deg/s | 3-sigma | model, fitted C_La | model, nominal C_La |",
             "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['flight_time_s']:.1f} | {r['reconstructed_dps']:.2f} | "
                     f"{r['reconstructed_3sigma_dps']:.3f} | "
                     f"{r['model_fitted_dps']:.2f} | {r['model_nominal_dps']:.2f} |")
    return "\n".join(lines) + "\n"


def write_fit_results(out: Path, result, report_text: str, tables_md: str) -> None:
    """Write every file of the results folder into ``out`` (an atomic temporary folder)."""
    out = Path(out)
    write_columns(out / "trajectory.csv", *trajectory_table(result))
    write_json(out / "parameters.json", parameters_document(result))
    reconciled = write_diagnostics(out, result)
    write_json(out / "summary.json", {**summary_document(result), "reconciled": reconciled})
    if "roll_rate" in reconciled:
        cla = result.parameter("CLa_mult") if "CLa_mult" in result.params.names else None
        tables_md += "\n" + roll_rate_table(reconciled["roll_rate"], cla)
    (out / "tables.md").write_text(tables_md)
    (out / "report.txt").write_text(report_text + "\n")
    cfg = result.scenario.config
    config_dir = out / "config"
    config_dir.mkdir()
    for key, src in cfg.sources.items():
        shutil.copy2(src, config_dir / f"{key}{Path(src).suffix}")
    for src in cfg.aero.source_files[1:]:
        shutil.copy2(src, config_dir / Path(src).name)
    write_json(config_dir / "resolved.json", {"estimation": dataclasses.asdict(cfg.estimation),
                                              "dynamics": dataclasses.asdict(cfg.dynamics),
                                              "site": dataclasses.asdict(cfg.site),
                                              "parameters": [dataclasses.asdict(s) for s in result.params.specs]})
