"""The results folder of a joint fit: global parameters and correlations, a Table 5, per-drop
summary, the model-adequacy verdict and a sigma comparison with single-drop fits at the top
(:mod:`casrecon.report.joint_tables`), the text report (``report.txt``); one per-drop results
folder (the same files as a per-drop fit) under ``drops/<name>/``."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from casrecon.analysis.fit_adequacy import joint_adequacy
from casrecon.analysis.parameter_estimates import parameter_estimate
from casrecon.io.units import output_unit
from casrecon.output.fit_results import write_fit_results
from casrecon.output.results import write_json
from casrecon.report.joint_tables import joint_tables
from casrecon.report.tables import drop_tables


def joint_specs(result) -> dict[str, object]:
    """Global parameter name -> its ParameterSpec (shared ones by their name, a drop's own as
    ``<drop>.<name>``), from the drops' parameter sets."""
    specs = {}
    for d in result.drops:
        for spec in d.params.specs:
            specs.setdefault(spec.name, spec)
            specs[f"{d.scenario.config.name}.{spec.name}"] = spec
    return {n: specs[n] for n in result.names}


def joint_parameters_document(result) -> dict:
    """``parameters.json`` of a joint fit: per global parameter the record of
    :meth:`~casrecon.analysis.parameter_estimates.ParameterEstimate.record` (values in its ``unit``; gyro biases in
    deg/s) and ``shared``; the correlation matrix over all (full precision)."""
    from casrecon.estimation.engine.information import information_text

    scale = float(np.sqrt(result.reduced_chi2))
    specs = joint_specs(result)
    information = result.drops[0].covariance.information  # one covariance, shared by every drop
    params = {n: {**parameter_estimate(specs[n], v, s, scale).record(), "shared": n in result.shared}
              for n, v, s in zip(result.names, result.values, result.sigma)}
    return {"parameters": params,
            "correlation": {"names": list(result.names),
                            "matrix": np.asarray(result.correlation, dtype=float).tolist()},
            "covariance": {"information": information,
                           "hessian": f"{information_text(information)}, in the KKT matrix"}}


def joint_summary_document(result, single: dict[str, dict[str, float]], reconciled: dict[str, dict],
                           adequacy=None) -> dict:
    """``summary.json`` of a joint fit: the joint chi-square over the joint dof (``reduced_chi2``),
    each drop's own chi-square per group, dof and reduced chi-square, the single-drop sigmas (each
    parameter's output unit, named in ``units``), the model-adequacy verdict (``adequacy``, a
    :class:`~casrecon.analysis.adequacy.Adequacy` or None) and the reconciled simulations."""
    drops = {d.scenario.config.name: d for d in result.drops}
    units = {}
    for d in result.drops:
        units.update({spec.name: output_unit(spec.unit)[0] for spec in d.params.specs})
    return {"name": result.config.name, "converged": True, "status": result.status,
            "iterations": int(result.iterations), "drops": list(drops), "shared": list(result.shared),
            "chi2": float(result.chi2), "dof": int(result.dof), "reduced_chi2": float(result.reduced_chi2),
            "timings": dict(result.timings),
            **{k: result.timings[k] for k in ("build_s", "solve_s", "covariance_s", "total_s") if k in result.timings},
            "chi2_per_drop": {n: dict(d.chi2) for n, d in drops.items()},
            "dof_per_drop": {n: int(d.dof) for n, d in drops.items()},
            "reduced_chi2_per_drop": {n: float(d.reduced_chi2) for n, d in drops.items()},
            "single_drop_sigma": single, "units": units,
            **({} if adequacy is None else {"adequacy": adequacy.to_dict()}), "reconciled": reconciled}


def write_joint_results(out: Path, result, single: dict[str, dict[str, float]], products: dict, report_text: str,
                        drop_reports: dict[str, str]) -> None:
    """Write the joint results folder into ``out`` (an atomic temporary folder).

    Parameters
    ----------
    out : Path
        Existing (empty) folder.
    result : casrecon.estimation.sixdof.joint.JointResult
        The joint fit.
    single : dict of str to dict of str to float
        Drop name -> parameter -> 1-sigma of the drop's own fit, output unit (empty when not run).
    products : dict of str to casrecon.analysis.fit_products.FitProducts
        Drop name -> the residuals and reconciled simulations of its part of the joint fit.
    report_text : str
        Written as ``report.txt`` (:meth:`casrecon.results.joint_fit.JointFit.fit_report`).
    drop_reports : dict of str to str
        Drop name -> its ``drops/<name>/report.txt``.
    """
    out = Path(out)
    reconciled = {}
    for d in result.drops:
        name = d.scenario.config.name
        sub = out / "drops" / name
        sub.mkdir(parents=True)
        write_fit_results(sub, d, products[name], drop_reports[name], drop_tables(d, products[name]))
        reconciled[name] = products[name].reconciled_summary
    adequacy = joint_adequacy({n: p.adequacy for n, p in products.items() if p.adequacy is not None})
    write_json(out / "parameters.json", joint_parameters_document(result))
    write_json(out / "summary.json", joint_summary_document(result, single, reconciled, adequacy))
    (out / "tables.md").write_text(joint_tables(result, single, reconciled, adequacy))
    (out / "report.txt").write_text(report_text + "\n")
