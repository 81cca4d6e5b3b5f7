"""The results folder of a GPS-only (point-mass) fit: the fitted model (usually the drag-area
spline) next to the constant-drag model, so the residuals show what the constant model misses.

Files: ``trajectory.csv`` (antenna NED position/velocity, MSL height, drag area, each with 3-sigma),
``parameters.json``, ``summary.json`` (convergence, chi-square per group, normalised-residual RMS
and lag-1 autocorrelation per component for both models, timings, segment notes, the fitted
model's model-adequacy verdict),
``residuals_gps.csv`` (normalised residuals of both models), ``report.txt``, ``figures/``.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np

from casrecon.analysis.adequacy import Adequacy
from casrecon.analysis.fit_adequacy import pointmass_adequacy
from casrecon.output.results import write_columns, write_json

NAMES = ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")


def _model_summary(r) -> dict:
    return {"model": r.model_name, "lift": r.areas.shape[1] > 1, "converged": r.solver.converged,
            "status": r.solver.status, "iterations": r.solver.iterations, "chi2": r.chi2,
            "n_measurements": r.n_measurements, "reduced_chi2": r.reduced_chi2, "residuals": r.residual_stats(),
            "timings": r.timings}


def write_pointmass_results(out: Path, main, constant, report_text: str, adequacy: Adequacy | None = None) -> None:
    """Write the folder into ``out`` (an atomic temporary folder).

    Parameters
    ----------
    out : Path
        Existing (empty) folder.
    main, constant : casrecon.estimation.pointmass_fit.PointMassResult
        The fitted model and the constant-drag model (the same object when the model is constant).
    report_text : str
        Written as ``report.txt`` (:func:`casrecon.report.pointmass_report.pointmass_report`).
    adequacy : Adequacy, optional
        The model-adequacy verdict of ``main`` for ``summary.json`` (``adequacy``); the
        deterministic :func:`~casrecon.analysis.fit_adequacy.pointmass_adequacy` of ``main`` when None.
    """
    out = Path(out)
    t0 = main.t_unix[0]
    cols, data = ["time_utc_unix_s", "time_s"], [main.t_unix, main.t_unix - t0]
    for i, n in enumerate(NAMES):
        unit = "m" if i < 3 else "mps"
        cols += [f"{n}_{unit}", f"{n}_{unit}_3sigma"]
        data += [main.states[:, i], 3 * main.state_sigma[:, i]]
    cols += ["h_msl_m"]
    data += [main.config.site.ground_alt_msl_m - main.states[:, 2]]
    for j, name in enumerate(("cda_m2", "lift_n_m2", "lift_e_m2")[:main.areas.shape[1]]):
        cols += [name, f"{name}_3sigma"]
        data += [main.areas[:, j], 3 * main.area_sigma[:, j]]
    # UTC seconds need ms resolution: the default 9 significant digits round 1.5e9 s to 10 s
    write_columns(out / "trajectory.csv", cols, np.column_stack(data), fmt=["%.3f"] + ["%.9g"] * (len(cols) - 1))
    rcols = ["time_s"] + [f"{n}_{m}" for m in ("fit", "constant") for n in NAMES]
    write_columns(out / "residuals_gps.csv", rcols, np.column_stack(
        [main.t_unix - t0, main.normalized_residuals, constant.normalized_residuals]))
    write_columns(out / "gps_fixes.csv", ["time_s"] + [f"{n}_measured" for n in NAMES] + ["used"],
                  np.column_stack([main.t_unix - t0, main.y, main.inv_sigma[:, 0] > 0]))
    params = {s.name: {"value": float(v), "sigma": float(sg), "three_sigma": 3 * float(sg), "unit": s.unit}
              for s, v, sg in zip(main.params.specs, main.values, main.sigma)}
    write_json(out / "parameters.json", {"parameters": params})
    write_json(out / "summary.json", {
        "problem": main.config.name, "kind": "point-mass", "converged": main.solver.converged,
        "fit": _model_summary(main), "constant_drag": _model_summary(constant),
        "segment_utc_unix_s": [float(main.t_unix[0]), float(main.t_unix[-1])], "notes": list(main.notes),
        "mass_kg": main.config.mass_kg, "total_s": main.timings["total_s"] + constant.timings["total_s"],
        "adequacy": (adequacy if adequacy is not None else pointmass_adequacy(main)).to_dict()})
    (out / "report.txt").write_text(report_text + "\n")
    config_dir = out / "config"
    config_dir.mkdir()
    shutil.copy2(main.config.path, config_dir / "problem.toml")
