"""1-sigma of every parameter in each drop's own fit: the single-drop column of a joint fit's sigma comparison."""

from __future__ import annotations

import logging
from pathlib import Path

from casrecon.analysis.parameter_estimates import parameter_estimates
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.io.problem import ProblemConfig
from casrecon.parallel import parallel_map
from casrecon.scenario import Scenario

LOG = logging.getLogger(__name__)


def single_drop_sigma(problem: str | Path | ProblemConfig) -> tuple[str, dict[str, float]]:
    """Fit one drop on its own.

    Parameters
    ----------
    problem : str, Path or ProblemConfig
        Problem folder or ``problem.toml``, or the problem as already parsed (not read again).

    Returns
    -------
    tuple of (str, dict of str to float)
        The problem name and the absolute 1-sigma of each estimated parameter, in its output unit
        (:func:`~casrecon.io.units.output_unit`: SI, gyro biases in deg/s).

    Raises
    ------
    casrecon.estimation.sixdof.fit.FitError
        When the fit fails.
    """
    scenario = Scenario.from_config(problem) if isinstance(problem, ProblemConfig) else Scenario.load(problem)
    result = fit_drop(scenario)
    return result.scenario.config.name, {e.name: e.sigma for e in parameter_estimates(result)}


def single_drop_sigmas(problems: list[Path | ProblemConfig], workers: int = 2) -> dict[str, dict[str, float]]:
    """1-sigma of every parameter in each drop's own fit, the drops fitted in parallel processes.

    Parameters
    ----------
    problems : list of Path or ProblemConfig
        Problem folders or ``problem.toml`` files, or the problems as already parsed.
    workers : int
        Local (spawned) processes.

    Returns
    -------
    dict of str to dict of str to float
        Problem name -> parameter name -> absolute 1-sigma (output unit, as :func:`single_drop_sigma`),
        in the order of ``problems``.
    """
    items = [p if isinstance(p, ProblemConfig) else str(p) for p in problems]
    done = []

    def finished(_item, value: tuple[str, dict[str, float]]) -> None:
        done.append(value[0])
        LOG.info("single-drop fit %d of %d done (%s)", len(done), len(items), value[0])

    return dict(parallel_map(single_drop_sigma, items, workers=workers, on_done=finished))
