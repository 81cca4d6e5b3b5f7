"""The documents of ``casrecon sensitivity``: the Fisher directions (``fisher.json``) and a profile
likelihood (``profile_<name>.json``)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

#: What the numbers of fisher.json are in (written into the document).
FISHER_UNITS = {
    "parameters": "each parameter divided by its scale (scale in the parameter's unit; dispersion factors: "
                  "the database 3-sigma / 3), so every loading, eigenvalue and sigma is dimensionless",
    "eigenvalue": "Fisher information along the direction, per (scaled parameter)^2: dimensionless",
    "sigma": "1-sigma along the unit direction, in scaled parameters: 1 / sqrt(eigenvalue), dimensionless",
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
    specs : sequence of casrecon.estimation.parameters.ParameterSpec
        The fit's parameters (name, scale, unit), in fit order.

    Returns
    -------
    dict
        ``problem``, ``order``, ``units`` (what each number is in), ``parameters`` (name -> scale
        and unit), ``directions``: per direction ``rank`` (1 = weakest), ``eigenvalue``, ``sigma``,
        ``three_sigma``, ``largest_loading`` (the parameter it is mostly made of) and ``loadings``
        (parameter name -> component).
    """
    out = []
    for rank, d in enumerate(directions, start=1):
        loadings = {name: float(w) for name, w in d.weights.items()}
        largest = max(loadings, key=lambda n: abs(loadings[n]))
        out.append({"rank": rank, "eigenvalue": float(d.eigenvalue), "sigma": float(d.sigma),
                    "three_sigma": 3.0 * float(d.sigma), "largest_loading": largest, "loadings": loadings})
    return {"problem": problem,
            "order": "weakest first: ascending eigenvalue (least information), descending sigma",
            "units": FISHER_UNITS,
            "parameters": {s.name: {"scale": float(s.scale), "unit": s.unit} for s in specs},
            "directions": out}


def profile_document(profile) -> dict:
    """``profile_<name>.json`` of a :class:`~casrecon.analysis.observability.Profile` (values in the
    parameter's own unit; delta chi-square dimensionless)."""
    return {"parameter": profile.name, "values": np.asarray(profile.values).tolist(),
            "delta_chi2": np.asarray(profile.delta_chi2).tolist(), "estimate": profile.estimate,
            "interval_delta_chi2_9": list(profile.interval), "fisher_three_sigma": profile.fisher_three_sigma,
            "half_width_over_fisher": profile.agreement}
