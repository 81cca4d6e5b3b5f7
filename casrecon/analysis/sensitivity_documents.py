"""The JSON documents of ``casrecon sensitivity`` (written by the command, drawn by the reports): Fisher
directions, a profile likelihood and a drop design study, each number named with its unit
(:mod:`casrecon.io.units`)."""

from __future__ import annotations

from collections.abc import Sequence

from casrecon.io.units import output_unit

#: What the numbers of fisher.json are in (written into the document).
FISHER_UNITS = {
    "parameters": "each parameter divided by its scale (scale in the parameter's output unit, named beside it; "
                  "dispersion factors: the database 3-sigma / 3), so every loading, eigenvalue and sigma is "
                  "dimensionless",
    "eigenvalue": "Fisher information along the direction, per (scaled parameter)^2: dimensionless",
    "sigma_normalised": "1-sigma along the unit direction, in scaled parameters: 1 / sqrt(eigenvalue)",
    "loadings": "components of the unit direction (sum of squares 1), dimensionless",
}


def fisher_document(problem: str, directions: Sequence, specs: Sequence) -> dict:
    """``fisher.json``: the eigen-directions of the parameters' Fisher information, weakest first.

    Parameters
    ----------
    problem : str
        Problem name.
    directions : sequence of casrecon.analysis.observability.FisherDirection
        Weakest first (:func:`~casrecon.analysis.observability.fisher_directions`).
    specs : sequence of casrecon.estimation.sixdof.parameters.ParameterSpec
        The fit's parameters (name, scale, SI unit), in fit order.

    Returns
    -------
    dict
        ``problem``, ``order``, ``units`` (what each number is in), ``parameters`` (name -> ``scale``
        in its output unit and that ``unit``, e.g. deg/s for gyro biases), ``directions``: per
        direction ``rank`` (1 = weakest), ``eigenvalue``, ``sigma_normalised``,
        ``three_sigma_normalised``, ``largest_loading`` (the parameter it is mostly made of) and
        ``loadings`` (parameter name -> component).
    """
    out = []
    for rank, d in enumerate(directions, start=1):
        loadings = {name: float(w) for name, w in d.weights.items()}
        largest = max(loadings, key=lambda n: abs(loadings[n]))
        out.append({"rank": rank, "eigenvalue": float(d.eigenvalue), "sigma_normalised": float(d.sigma),
                    "three_sigma_normalised": 3.0 * float(d.sigma), "largest_loading": largest,
                    "loadings": loadings})
    parameters = {}
    for spec in specs:
        unit, f = output_unit(spec.unit)
        parameters[spec.name] = {"scale": float(spec.scale) * f, "unit": unit}
    return {"problem": problem,
            "order": "weakest first: ascending eigenvalue (least information), descending sigma",
            "units": FISHER_UNITS, "parameters": parameters, "directions": out}


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
    from casrecon.estimation.sixdof.drop import parameter_set  # CasADi only when a study is written

    return next((s.unit for s in parameter_set(config).specs if s.name == name), "-")
