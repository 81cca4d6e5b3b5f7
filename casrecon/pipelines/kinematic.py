"""The IMU-driven (kinematic) pipeline: problem -> inputs -> fit -> verdict -> report -> KinematicFit."""

from __future__ import annotations

from pathlib import Path

from casrecon.io.toml_fields import TomlDocument
from casrecon.pipelines.options import DEFAULT_OPTIONS, FitOptions
from casrecon.results.kinematic_fit import KinematicFit


def fit_kinematic_problem(problem: str | Path | TomlDocument, options: FitOptions = DEFAULT_OPTIONS) -> KinematicFit:
    """The IMU-driven reconstruction of a ``kind = "kinematic"`` problem, with its verdict.

    Raises
    ------
    InputError
        Bad input files.
    FitError, FitDataError
        The fit failed, or the data cannot be fitted (the message says why).
    """
    from casrecon.analysis.fit_adequacy import kinematic_adequacy
    from casrecon.estimation.kinds.sample_registry import kinematic_sample_kinds
    from casrecon.estimation.kinematic.fit import fit_kinematic
    from casrecon.estimation.kinematic.inputs import inputs_from_config
    from casrecon.io.kinematic_problem import load_kinematic
    from casrecon.report.kinematic_report import kinematic_sections

    cfg = load_kinematic(problem)
    data, fit_options = inputs_from_config(cfg)
    result = fit_kinematic(data, fit_options, print_level=options.print_level,
                           sample_kinds=kinematic_sample_kinds(cfg))
    adequacy = kinematic_adequacy(result)
    sections = kinematic_sections(result, adequacy)
    return KinematicFit.from_fit(result, sections, cfg.site, cfg.path, cfg.name, adequacy.to_dict())
