"""The GPS-only (point-mass) fit's own sections of its report (:mod:`casrecon.report.report_style`:
the statistics, variables and correlations come before them): both drag models' fit quality, the
drag area's range, the data notes and the model-adequacy verdict."""

from __future__ import annotations

import numpy as np

from casrecon.analysis.adequacy import Adequacy
from casrecon.analysis.fit_adequacy import pointmass_adequacy
from casrecon.report.adequacy_block import report_lines
from casrecon.report.report_style import section


def pointmass_sections(main, constant, adequacy: Adequacy | None = None) -> str:
    """The point-mass fit's own sections: ``[[Models]]`` (mass, atmosphere, and both drag models'
    status, iterations, reduced chi-square and normalised residual RMS), ``[[Drag area]]`` (CdA(t)'s
    range, m^2, and median 3-sigma), ``[[Data notes]]``, and the fitted model's model-adequacy verdict
    last (``adequacy``, computed from ``main`` when not given)."""
    cfg = main.config
    models = [f"point mass {cfg.mass_kg:g} kg, atmosphere "
              f"{'ICAO standard (no wind)' if cfg.sounding is None else cfg.sounding.name}"]
    for r in (main, constant):
        stats = r.residual_stats()
        worst = max(stats, key=lambda k: stats[k]["rms"])
        models.append(f"{r.model_name:8s} drag: {r.solver.status} in {r.solver.iterations} iterations, reduced chi2 "
                      f"{r.reduced_chi2:.3f}; normalised residual RMS " + ", ".join(
                          f"{k} {v['rms']:.2f}" for k, v in stats.items())
                      + f" (worst {worst}, lag-1 autocorrelation {stats[worst]['lag1_autocorrelation']:.2f})")
    lines = section("Models", models)
    band = 3 * np.median(main.cda_sigma)
    lines += section("Drag area", [f"CdA(t) of the {main.model_name} model: {main.cda.min():.3f} to "
                                   f"{main.cda.max():.3f} m^2 (median 3-sigma {band:.3g} m^2)"])
    lines += section("Data notes", main.notes)
    lines += report_lines(adequacy if adequacy is not None else pointmass_adequacy(main))
    return "\n".join(lines)
