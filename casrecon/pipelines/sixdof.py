"""The 6-DOF per-drop pipeline: problem -> fit -> products -> report (and kinematic check) -> DropFit."""

from __future__ import annotations

import dataclasses
import logging
import time
from pathlib import Path

from casrecon.io.toml_fields import TomlDocument
from casrecon.pipelines.options import DEFAULT_OPTIONS, FitOptions
from casrecon.progress import stage
from casrecon.results.drop_fit import DropFit
from casrecon.scenario import Scenario

LOG = logging.getLogger(__name__)


def fit_sixdof(problem: str | Path | TomlDocument | Scenario, options: FitOptions = DEFAULT_OPTIONS) -> DropFit:
    """Reconstruct one drop: the fit, its residuals and reconciled simulations, the report with the
    model-adequacy verdict, and (``options.kinematic_check``) the kinematic check.

    Parameters
    ----------
    problem : path, TomlDocument or Scenario
        Problem folder, its ``problem.toml`` (parsed or not), or a loaded scenario.
    options : FitOptions

    Returns
    -------
    DropFit

    Raises
    ------
    InputError
        Bad input files.
    FitError
        The fit (or the kinematic check's reconstruction) failed; the message says why.
    """
    from casrecon.analysis.aero_coefficients import aero_coefficients
    from casrecon.analysis.fit_products import fit_products
    from casrecon.analysis.widened_uncertainty import published_result
    from casrecon.estimation.kinds.sample_registry import sixdof_sample_kinds
    from casrecon.estimation.sixdof.fit import FitError, fit_drop
    from casrecon.report.fit_report import sixdof_sections

    t0 = time.perf_counter()
    scenario = problem if isinstance(problem, Scenario) else Scenario.load(problem)
    result = fit_drop(scenario, **options.solver_overrides, sample_kinds=sixdof_sample_kinds(scenario.config))
    with stage(LOG, "residuals, reconciled simulations, aerodynamic coefficients and model adequacy"):
        products = fit_products(result, concurrent=options.concurrent)
    with stage(LOG, "time-block sandwich (widens the uncertainty if the data say the model is wrong)"):
        result, widening = published_result(result, trusted=products.adequacy.trusted)
        if widening is not None:  # the coefficient bands from the widened covariance
            products = dataclasses.replace(products, aero_coefficients=aero_coefficients(result))
    sections = sixdof_sections(result, products.adequacy)  # the verdict of these products, not computed again
    check = None
    if options.kinematic_check:
        from casrecon.analysis.kinematic_check import kinematic_check

        try:
            with stage(LOG, "kinematic check"):
                _, implied, verdict = kinematic_check(result, products.aero_coefficients)
        except FitError as err:
            raise FitError(f"kinematic check: {err}") from err
        sections = f"{sections.rstrip()}\n{verdict.verdict()}\n"
        check = (implied, verdict)
    result.timings["total_s"] = time.perf_counter() - t0
    return DropFit.from_fit(result, products, sections, check)
