"""The results folder of a per-drop fit (written atomically by the caller's ``atomic_folder``).

Every column and JSON key names its unit (:mod:`casrecon.io.units`; gyro quantities in deg/s).
Files: ``trajectory.csv`` (time history with 3-sigma columns, UTC, latitude, longitude, h_MSL),
``parameters.json`` (values, 1- and 3-sigma absolute and chi-square-scaled, correlations),
``summary.json`` (convergence, chi-square per group, timings, the model-adequacy verdict,
reconciled-simulation differences), ``tables.md`` (EES Tables 3, 4, 5 style), ``report.txt``
(the console report), ``config/`` (the exact input files and the resolved settings), and for the
figures: ``residuals_imu.csv``, ``residuals_gps.csv`` (and
``residuals_<kind>.csv`` of every other measurement kind, e.g. ``residuals_baro.csv``),
``pitching_moment.csv``, ``cm_curves.csv``, ``reconciled.csv`` (forward simulation with the fitted
dispersions), ``nominal.csv`` (the same with the nominal database), ``gps_fixes.csv``,
``aero_coefficients.csv`` (coefficient histories with 3-sigma, dimensionless).
"""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import numpy as np

from casrecon.analysis.parameter_estimates import parameter_estimates
from casrecon.io.units import TIME_UNIX, UTC, utc_text
from casrecon.output.columns import geodetic_columns, write_table
from casrecon.output.results import write_json


def parameters_document(result) -> dict:
    """``parameters.json`` content; names match truth.json, values and sigmas in each entry's
    ``unit`` (gyro biases in deg/s, as truth.json and the problem file give them).

    Every float is stored at full precision (Python's ``json`` writes the shortest repr, which reads
    back bit-identical), so a loaded result's values, sigmas and correlations equal the fit's.
    """
    from casrecon.estimation.engine.information import information_text

    scale = float(np.sqrt(result.reduced_chi2))
    params = {e.name: e.record() for e in parameter_estimates(result)}
    return {"parameters": params,
            "correlation": {"names": list(result.params.names),
                            "matrix": np.asarray(result.correlation, dtype=float).tolist()},
            "covariance": {"information": result.covariance.information,
                           "hessian": f"{information_text(result.covariance.information)}, in the KKT matrix",
                           "sigma": ("widened by the time-block sandwich: the data say the noise model does not hold "
                                     "(see the notes)" if getattr(result, "uncertainty", "model") == "widened"
                                     else "absolute (noise sigmas as given)"),
                           "sigma_chi2_scaled": f"absolute times sqrt(reduced chi2) = {scale:.5f}"}}


def clock_document(result) -> dict:
    """How the results' UTC is made: the GPS receiver's UTC of IMU time t is
    ``utc_at_imu_zero + t + clock_offset_s``."""
    from casrecon.analysis.fit_products import unix_time  # CasADi only when a fit is written
    from casrecon.estimation.kinds.gps import CLOCK, clock_offset

    release = float(unix_time(result, np.array([result.data.release_imu_s]))[0])
    return {"utc_at_imu_zero": str(utc_text(result.scenario.config.imu.clock_utc_at_zero.timestamp())),
            "clock_offset_s": clock_offset(result), "clock_offset_estimated": CLOCK in result.params.names,
            "release_utc": str(utc_text(release)), "release_time_unix_s": release}


def summary_document(result) -> dict:
    sol, d = result.solver, result.data
    return {"problem": result.scenario.config.name, "converged": sol.converged, "status": sol.status,
            "iterations": sol.iterations, "objective": sol.objective, "solver": sol.method, "hessian": sol.hessian,
            "linear_solver": sol.linear_solver, "chi2": result.chi2, "n_measurements": result.n_measurements,
            "dof": result.dof, "reduced_chi2": result.reduced_chi2, "condition": result.condition,
            "timings": result.timings, **{k: result.timings[k] for k in ("build_s", "solve_s", "covariance_s",
                                                                          "total_s")},
            "release_imu_s": d.release_imu_s, "impact_imu_s": d.impact_imu_s, "window_imu_s": list(d.window),
            "clock": clock_document(result),
            "mesh": {"n_intervals": int(result.node_time_s.size - 1),
                     "h_s": float(result.node_time_s[1] - result.node_time_s[0])},
            "estimator": estimator_document(sol),
            "notes": list(result.notes)}


def estimator_document(sol) -> dict:
    """summary.json's ``estimator``: "map", or "marginal" with the marginal-likelihood run's figures."""
    run = sol.marginal
    if run is None:
        return {"method": "map"}
    return {"method": "marginal", "outer_iterations": run.outer_iterations, "inner_iterations": run.inner_iterations,
            "shift_from_map_sigma": run.shift_sigma, "half_log_det": run.half_log_det,
            "log_det_gradient_s": run.gradient_s, "inner_solves_s": run.inner_s}


def products_summary(products) -> dict:
    """``summary.json`` entries from a fit's products: ``adequacy`` (the model-adequacy verdict,
    :meth:`casrecon.analysis.adequacy.Adequacy.to_dict`) and ``reconciled``."""
    out = {} if products.adequacy is None else {"adequacy": products.adequacy.to_dict()}
    return {**out, "reconciled": products.reconciled_summary}


def trajectory_table(result) -> dict[str, np.ndarray]:
    """``trajectory.csv`` columns: ``time_imu_s``, ``flight_time_s``, ``time_unix_s`` and ``utc`` (the
    GPS receiver's UTC, :func:`~casrecon.analysis.fit_products.unix_time`), the centre of mass's
    ``latitude_deg``, ``longitude_deg``, ``h_msl_m``, each with its ``_3sigma``
    (:func:`~casrecon.output.columns.geodetic_columns`), then each reconstructed column and its
    ``<name>_3sigma`` (absolute)."""
    from casrecon.analysis.fit_products import unix_time  # CasADi only when a fit is written

    t_unix = unix_time(result, result.node_time_s)
    pos = [result.column(c) for c in ("pos_n_m", "pos_e_m", "pos_d_m")]
    cols = {"time_imu_s": result.node_time_s, "flight_time_s": result.flight_time_s, TIME_UNIX: t_unix,
            UTC: utc_text(t_unix), **geodetic_columns(np.column_stack([p[0] for p in pos]),
                                                      3 * np.column_stack([p[1] for p in pos]),
                                                      result.scenario.config.site)}
    for i, name in enumerate(result.columns):
        cols[name] = result.table[:, i]
        cols[f"{name}_3sigma"] = 3 * result.table_sigma[:, i]
    return cols


#: Tables written at every n-th row only (the forward simulations, at 2 ms steps).
TABLE_EVERY = {"reconciled.csv": 5, "nominal.csv": 5}


def product_tables(products) -> dict[str, dict[str, np.ndarray]]:
    """The tables of a :class:`~casrecon.analysis.fit_products.FitProducts` by their results-folder
    file name (``residuals_<kind>.csv`` for the IMU, the GPS and every other kind, ``gps_fixes.csv``,
    ``pitching_moment.csv``, ``cm_curves.csv``, ``reconciled.csv``, ``nominal.csv``,
    ``aero_coefficients.csv`` when computed), all rows."""
    tables = {"residuals_imu.csv": products.imu_residuals, "residuals_gps.csv": products.gps_residuals}
    tables.update({f"residuals_{kind}.csv": columns for kind, columns in products.kind_residuals.items()})
    tables.update({"gps_fixes.csv": products.gps_fixes, "pitching_moment.csv": products.pitching_moment,
                   "cm_curves.csv": products.cm_curves, "reconciled.csv": products.reconciled,
                   "nominal.csv": products.nominal})
    if products.aero_coefficients:
        tables["aero_coefficients.csv"] = products.aero_coefficients
    return tables


def write_diagnostics(out: Path, products) -> None:
    """The files of :func:`product_tables` (the simulations at every 5th sample, TABLE_EVERY) and
    ``imu_sigma.json``."""
    for name, columns in product_tables(products).items():
        write_table(out / name, columns, every=TABLE_EVERY.get(name, 1))
    write_json(out / "imu_sigma.json", products.imu_sigma)


def write_fit_results(out: Path, result, products, report_text: str, tables_md: str) -> None:
    """Write every file of the results folder into ``out`` (an atomic temporary folder).

    Parameters
    ----------
    out : Path
        Existing (empty) folder.
    result : casrecon.estimation.sixdof.fit.FitResult
        The fit.
    products : casrecon.analysis.fit_products.FitProducts
        Its residuals, pitching moment and reconciled simulations.
    report_text : str
        Written as ``report.txt``.
    tables_md : str
        Written as ``tables.md``.
    """
    out = Path(out)
    write_table(out / "trajectory.csv", trajectory_table(result))
    write_json(out / "parameters.json", parameters_document(result))
    write_diagnostics(out, products)
    write_json(out / "summary.json", {**summary_document(result), **products_summary(products)})
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
                                              "parameters": [dataclasses.asdict(s) for s in result.params.specs],
                                              "inputs": inputs_document(cfg)})


def inputs_document(cfg) -> dict:
    """Where the fit's data files are (absolute paths) and how they are read, for the input figures
    that ``casrecon report`` redraws: IMU file, its CSV layout and the UTC of its time 0 (Unix s),
    GPS file, sounding file and launch."""
    def where(path) -> str | None:
        return None if path is None else str(Path(path).resolve())

    return {"imu": {"file": where(cfg.imu.file), "spec": dataclasses.asdict(cfg.imu.spec),
                    "utc_at_zero_unix_s": cfg.imu.clock_utc_at_zero.timestamp()},
            "gps": {"file": where(cfg.gps.file)},
            "sounding": {"file": where(cfg.atmosphere.sounding), "launch": cfg.atmosphere.launch}}
