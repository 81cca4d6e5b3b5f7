"""The JSON documents of ``casrecon sensitivity``: Fisher directions, a profile likelihood and a drop
design study, each number named with its unit (:mod:`casrecon.io.units`)."""

from __future__ import annotations

from casrecon.io.units import output_unit


def fisher_document(result, directions) -> dict:
    """``fisher.json``: the scale of each parameter (in its output unit) and the eigen-directions of
    the Fisher information of the scaled, dimensionless parameters, weakest first.

    Parameters
    ----------
    result : casrecon.estimation.fit.FitResult
        The fit.
    directions : list of casrecon.analysis.observability.FisherDirection
        :func:`~casrecon.analysis.observability.fisher_directions` of ``result``.
    """
    scales = {}
    for spec in result.params.specs:
        unit, f = output_unit(spec.unit)
        scales[spec.name] = {"value": float(spec.scale) * f, "unit": unit}
    return {"scaling": "each parameter divided by its scale; eigenvalues, sigmas and weights are of the scaled "
                       "(dimensionless) parameters",
            "scales": scales,
            "directions": [{"eigenvalue": d.eigenvalue, "sigma_normalised": d.sigma, "weights": dict(d.weights)}
                           for d in directions]}


def profile_document(profile, unit: str) -> dict:
    """``profile_<name>.json`` of a :class:`~casrecon.analysis.observability.Profile` whose parameter
    is in ``unit`` (SI): held values, estimate, interval and Fisher 3-sigma in its output unit."""
    out_unit, f = output_unit(unit)
    return {"parameter": profile.name, "unit": out_unit,
            "values": [float(v) * f for v in profile.values], "delta_chi2": [float(v) for v in profile.delta_chi2],
            "estimate": float(profile.estimate) * f, "interval_delta_chi2_9": [float(v) * f for v in profile.interval],
            "fisher_three_sigma": float(profile.fisher_three_sigma) * f,
            "half_width_over_fisher_ratio": float(profile.agreement)}


def design_document(design: dict, unit: str) -> dict:
    """``design.json`` of :func:`~casrecon.analysis.observability.design_study` for a parameter in
    ``unit`` (SI): rows of the design variable and the predicted 1-sigma (output unit)."""
    out_unit, f = output_unit(unit)
    keys = {"pitch_rate": "pitch_rate_dps", "altitude": "h_agl_m", "n_drops": "n_drops"}
    doc = {"parameter": design["parameter"], "unit": out_unit}
    for study, key in keys.items():
        doc[study] = [{key: x, "sigma": float(s) * f} for x, s in design.get(study, [])]
    return doc


def parameter_unit(config, name: str) -> str:
    """The SI unit of parameter ``name`` of a 6-DOF problem (``"-"`` when it has no such parameter)."""
    from casrecon.estimation.drop import parameter_set  # CasADi only when a study is written

    return next((s.unit for s in parameter_set(config).specs if s.name == name), "-")
