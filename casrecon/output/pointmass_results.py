"""The results folder of a GPS-only (point-mass) fit: the fitted model (usually the drag-area
spline) next to the constant-drag model, so the residuals show what the constant model misses.

Files: ``trajectory.csv`` (``time_unix_s`` and ``utc``, ``segment_time_s`` (s since the segment's
first fix; a GPS-only segment has no release, so no ``flight_time_s``), the antenna's latitude,
longitude and h_MSL, NED position and velocity, drag area, each with 3-sigma), ``parameters.json``,
``summary.json`` (convergence, chi-square per group, normalised-residual RMS and lag-1
autocorrelation per component for both models, timings, segment notes, the fitted model's
model-adequacy verdict), ``residuals_gps.csv`` (normalised residuals of both models, ``_z``),
``gps_fixes.csv`` (both with ``time_unix_s`` and ``segment_time_s``), ``report.txt``, ``figures/``.
Units in every name (:mod:`casrecon.io.units`).
"""

from __future__ import annotations

import shutil
from pathlib import Path

from casrecon.analysis.adequacy import Adequacy
from casrecon.io.units import GPS_COMPONENT_UNITS, SEGMENT_TIME, TIME_UNIX, UTC, utc_text
from casrecon.output.columns import geodetic_columns, write_table
from casrecon.output.results import write_json

NAMES = ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")


def _model_summary(r) -> dict:
    return {"model": r.model_name, "lift": bool(r.config.drag.lift and r.model_name == "spline"),
            "converged": r.solver.converged,
            "status": r.solver.status, "iterations": r.solver.iterations, "chi2": r.chi2,
            "n_measurements": r.n_measurements, "reduced_chi2": r.reduced_chi2,
            "normalised_residuals": r.residual_stats(),
            "timings": r.timings}


def write_pointmass_results(out: Path, main, constant, report_text: str, adequacy: Adequacy) -> None:
    """Write the folder into ``out`` (an atomic temporary folder).

    Parameters
    ----------
    out : Path
        Existing (empty) folder.
    main, constant : casrecon.estimation.pointmass.fit.PointMassResult
        The fitted model and the constant-drag model (the same object when the model is constant).
    report_text : str
        Written as ``report.txt`` (:meth:`casrecon.results.pointmass_fit.PointMassFit.fit_report`).
    adequacy : Adequacy
        The model-adequacy verdict of ``main`` (:func:`~casrecon.analysis.fit_adequacy.pointmass_adequacy`)
        for ``summary.json`` (``adequacy``).
    """
    out = Path(out)
    times = {TIME_UNIX: main.t_unix, SEGMENT_TIME: main.t_unix - main.t_unix[0]}
    cols = {TIME_UNIX: main.t_unix, UTC: utc_text(main.t_unix), SEGMENT_TIME: times[SEGMENT_TIME],
            **geodetic_columns(main.states[:, :3], 3 * main.state_sigma[:, :3], main.config.site)}
    for i, n in enumerate(NAMES):
        name = f"{n}_{GPS_COMPONENT_UNITS[n]}"
        cols[name], cols[f"{name}_3sigma"] = main.states[:, i], 3 * main.state_sigma[:, i]
    for j, name in enumerate(("cda_m2", "lift_n_m2", "lift_e_m2")[:main.areas.shape[1]]):
        cols[name], cols[f"{name}_3sigma"] = main.areas[:, j], 3 * main.area_sigma[:, j]
    if main.area_process is not None:
        for j, area in enumerate(("cda", "lift_n", "lift_e")):
            name = f"{area}_process_m2"
            cols[name], cols[f"{name}_3sigma"] = main.area_process[:, j], 3 * main.area_process_sigma[:, j]
    write_table(out / "trajectory.csv", cols)
    residuals = {f"{n}_{m}_z": r[:, i] for m, r in (("fit", main.normalized_residuals),
                                                    ("constant", constant.normalized_residuals))
                 for i, n in enumerate(NAMES)}
    if main.whitened_residuals is not None:  # the series the adequacy tests: innovations, NaN where none
        residuals.update({f"{n}_fit_innovation_z": main.whitened_residuals[:, i] for i, n in enumerate(NAMES)})
    write_table(out / "residuals_gps.csv", {**times, **residuals})
    fixes = {f"{n}_{GPS_COMPONENT_UNITS[n]}": main.y[:, i] for i, n in enumerate(NAMES)}
    write_table(out / "gps_fixes.csv", {**times, **fixes, "used": (main.inv_sigma[:, 0] > 0).astype(float)})
    params = {s.name: {"value": float(v), "sigma": float(sg), "three_sigma": 3 * float(sg), "unit": s.unit}
              for s, v, sg in zip(main.params.specs, main.values, main.sigma)}
    write_json(out / "parameters.json", {"parameters": params})
    write_json(out / "summary.json", {
        "problem": main.config.name, "kind": "point-mass", "converged": main.solver.converged,
        "fit": _model_summary(main), "constant_drag": _model_summary(constant),
        "segment_utc_unix_s": [float(main.t_unix[0]), float(main.t_unix[-1])], "notes": list(main.notes),
        "mass_kg": main.config.mass_kg, "total_s": main.timings["total_s"] + constant.timings["total_s"],
        "adequacy": adequacy.to_dict()})
    (out / "report.txt").write_text(report_text + "\n")
    config_dir = out / "config"
    config_dir.mkdir()
    shutil.copy2(main.config.path, config_dir / "problem.toml")
