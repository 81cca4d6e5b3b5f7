"""The results folder of a joint fit: global parameters and correlations, a Table 5, per-drop
summary, the model-adequacy verdict and a sigma comparison with single-drop fits at the top
(:mod:`casrecon.report.joint_tables`); one per-drop results folder (the same files as a per-drop
fit) under ``drops/<name>/``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from casrecon.analysis.fit_adequacy import joint_adequacy
from casrecon.output.fit_results import write_fit_results
from casrecon.output.results import write_json
from casrecon.report.fit_report import fit_report
from casrecon.report.joint_tables import joint_tables
from casrecon.report.tables import drop_tables


def joint_parameters_document(result) -> dict:
    params = {n: {"value": float(v), "sigma": float(s), "three_sigma": 3 * float(s),
                  "sigma_chi2_scaled": float(s * np.sqrt(result.reduced_chi2)), "shared": n in result.shared}
              for n, v, s in zip(result.names, result.values, result.sigma)}
    return {"parameters": params,
            "correlation": {"names": list(result.names),
                            "matrix": np.asarray(result.correlation, dtype=float).tolist()},
            "covariance": {"hessian": "gauss-newton J^T J (Fisher information) in the KKT matrix"}}


def write_joint_results(out: Path, result, single: dict[str, dict[str, float]], products: dict) -> None:
    """Write the joint results folder into ``out`` (an atomic temporary folder).

    Parameters
    ----------
    out : Path
        Existing (empty) folder.
    result : casrecon.estimation.joint.JointResult
        The joint fit.
    single : dict of str to dict of str to float
        Drop name -> parameter -> 1-sigma of the drop's own fit (empty when not run).
    products : dict of str to casrecon.analysis.fit_products.FitProducts
        Drop name -> the residuals and reconciled simulations of its part of the joint fit.
    """
    out = Path(out)
    reconciled = {}
    for d in result.drops:
        name = d.scenario.config.name
        sub = out / "drops" / name
        sub.mkdir(parents=True)
        write_fit_results(sub, d, products[name], fit_report(d, products[name].adequacy),
                          drop_tables(d, products[name]))
        reconciled[name] = products[name].reconciled_summary
    adequacy = joint_adequacy({n: p.adequacy for n, p in products.items() if p.adequacy is not None})
    write_json(out / "parameters.json", joint_parameters_document(result))
    write_json(out / "summary.json", {
        "name": result.config.name, "converged": True, "status": result.status, "iterations": result.iterations,
        "drops": [d.scenario.config.name for d in result.drops], "shared": list(result.shared),
        "chi2": result.chi2, "dof": result.dof, "reduced_chi2": result.reduced_chi2, "timings": result.timings,
        **{k: result.timings[k] for k in ("build_s", "solve_s", "covariance_s", "total_s")},
        "chi2_per_drop": {d.scenario.config.name: d.chi2 for d in result.drops},
        "single_drop_sigma": single, "adequacy": adequacy.to_dict(), "reconciled": reconciled})
    (out / "tables.md").write_text(joint_tables(result, single, reconciled, adequacy))
