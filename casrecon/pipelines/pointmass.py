"""The GPS-only point-mass pipeline: problem -> fitted and constant-drag fits -> report -> PointMassFit."""

from __future__ import annotations

import logging
from pathlib import Path

from casrecon.io.toml_fields import TomlDocument
from casrecon.pipelines.options import DEFAULT_OPTIONS, FitOptions
from casrecon.progress import stage
from casrecon.results.pointmass_fit import PointMassFit

LOG = logging.getLogger(__name__)


def fit_point_mass(problem: str | Path | TomlDocument, options: FitOptions = DEFAULT_OPTIONS) -> PointMassFit:
    """The GPS-only fit of a ``kind = "point-mass"`` problem, with the constant-drag comparison.

    Raises
    ------
    InputError
        Bad input files.
    FitError, FitDataError
        The fit failed, or the data cannot be fitted (the message says why).
    """
    from casrecon.analysis.fit_adequacy import pointmass_adequacy
    from casrecon.estimation.pointmass.fit import fit_with_comparison
    from casrecon.io.pointmass_problem import load_point_mass
    from casrecon.report.pointmass_report import pointmass_sections

    main, constant = fit_with_comparison(load_point_mass(problem), print_level=options.print_level)
    with stage(LOG, "model adequacy"):
        adequacy = pointmass_adequacy(main)  # once: the report and summary.json read this verdict
    return PointMassFit.from_fit(main, constant, pointmass_sections(main, constant, adequacy), adequacy)
