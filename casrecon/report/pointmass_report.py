"""Text report of a GPS-only (point-mass) fit: both drag models' fit quality, the fitted parameters and
the model-adequacy verdict."""

from __future__ import annotations

import numpy as np

from casrecon.analysis.adequacy import Adequacy
from casrecon.analysis.fit_adequacy import pointmass_adequacy
from casrecon.report.adequacy_block import report_lines


def pointmass_report(main, constant, adequacy: Adequacy | None = None) -> str:
    """Text report: both models' fit quality, the main model's parameters and its model-adequacy
    verdict (``adequacy``, computed from ``main`` when not given)."""
    cfg = main.config
    lines = [f"[[GPS-only fit: {cfg.name}]] point mass {cfg.mass_kg:g} kg, atmosphere "
             f"{'ICAO standard (no wind)' if cfg.sounding is None else cfg.sounding.name}"]
    for r in (main, constant):
        stats = r.residual_stats()
        worst = max(stats, key=lambda k: stats[k]["rms"])
        lines.append(f"    {r.model_name:8s} drag: {r.solver.status} in {r.solver.iterations} iterations, reduced chi2 "
                     f"{r.reduced_chi2:.3f}; normalised residual RMS " + ", ".join(
                         f"{k} {v['rms']:.2f}" for k, v in stats.items())
                     + f" (worst {worst}, lag-1 autocorrelation {stats[worst]['lag1_autocorrelation']:.2f})")
    lines.append("[[Parameters]] (fitted model; 3-sigma absolute; spline coefficients in parameters.json)")
    for spec, v, s in zip(main.params.specs, main.values, main.sigma):
        if spec.group != "drag" or spec.name == "CdA":
            lines.append(f"    {spec.name:12s} = {v: .5g} +/- {3 * s:.3g} [{spec.unit}]")
    lines.append(f"    drag area CdA(t): {main.cda.min():.3f} to {main.cda.max():.3f} m^2 "
                 f"(median 3-sigma {3 * np.median(main.cda_sigma):.3g} m^2)")
    lines += ["[[Data notes]]", *[f"    {n}" for n in main.notes]]
    lines += report_lines(adequacy if adequacy is not None else pointmass_adequacy(main))
    return "\n".join(lines)
