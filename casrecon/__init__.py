"""casrecon: reconstruct a dropped capsule's 6-DOF flight and aerodynamics from IMU, GPS and a sounding.

The public Python API (in the spirit of lmfit and rockit)::

    import casrecon

    result = casrecon.fit("problems/ees-drop-1")
    print(result.params["CA_mult"].value, result.params["CA_mult"].stderr)
    print(result.fit_report())                      # lmfit-style: 1- and 3-sigma named; result.correl
    result.sample("alpha_t_deg", [2.0, 5.0])        # values and 3-sigma at flight times, s (or UTC instants)
    result.save("results/ees-drop-1")               # the folder `casrecon fit --out` writes
    again = casrecon.load_results("results/ees-drop-1")
    casrecon.plot_trajectory(result).savefig("trajectory.png")
    mc = casrecon.montecarlo("problems/ees-drop-1", 200)       # dispersions of its [montecarlo] table
    casrecon.plot_montecarlo_envelopes(mc).savefig("envelopes.pdf")

Importing ``casrecon`` is cheap: CasADi, pandas and matplotlib are imported when first needed.
"""

from __future__ import annotations

import importlib
from collections.abc import Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from casrecon.io.errors import InputError
from casrecon.parallel import single_threaded_blas

if TYPE_CHECKING:
    from casrecon.analysis.montecarlo import MonteCarloResult
    from casrecon.estimation.engine.checks import FitError
    from casrecon.io.kinematic_problem import KinematicConfig
    from casrecon.io.montecarlo_config import Dispersions
    from casrecon.io.pointmass_problem import PointMassConfig
    from casrecon.report.result_figures import (
        plot_aero_coefficients,
        plot_aero_sigma,
        plot_correlation,
        plot_joint_altitude_speed,
        plot_joint_flow_angles,
        plot_joint_pitching_moment,
        plot_joint_qbar_alpha_t,
        plot_joint_rates,
        plot_pitching_moment,
        plot_qbar_alpha_t,
        plot_reconciled,
        plot_residuals,
        plot_shared_correlation,
        plot_trajectory,
    )
    from casrecon.report.study_figures import (
        plot_design_study,
        plot_fisher_directions,
        plot_montecarlo_envelopes,
        plot_montecarlo_histograms,
        plot_montecarlo_impact,
        plot_profile_likelihood,
    )
    from casrecon.results.drop_fit import DropFit
    from casrecon.results.joint_fit import JointFit
    from casrecon.results.kinematic_fit import KinematicFit
    from casrecon.results.parameters import Parameter, Parameters
    from casrecon.results.pointmass_fit import PointMassFit
    from casrecon.scenario import Scenario

__all__ = [
    "__version__",
    "load_problem",
    "fit",
    "fit_joint",
    "load_results",
    "montecarlo",
    "Dispersions",
    "DropFit",
    "JointFit",
    "PointMassFit",
    "KinematicFit",
    "Parameter",
    "Parameters",
    "plot_trajectory",
    "plot_qbar_alpha_t",
    "plot_pitching_moment",
    "plot_reconciled",
    "plot_residuals",
    "plot_correlation",
    "plot_joint_altitude_speed",
    "plot_joint_qbar_alpha_t",
    "plot_joint_flow_angles",
    "plot_joint_rates",
    "plot_joint_pitching_moment",
    "plot_shared_correlation",
    "plot_aero_coefficients",
    "plot_aero_sigma",
    "plot_montecarlo_histograms",
    "plot_montecarlo_impact",
    "plot_montecarlo_envelopes",
    "plot_fisher_directions",
    "plot_profile_likelihood",
    "plot_design_study",
    "InputError",
    "FitError",
]

#: Names imported on first use (module, attribute): their modules import CasADi, pandas or matplotlib.
_LAZY = {
    "FitError": ("casrecon.estimation.engine.checks", "FitError"),
    "DropFit": ("casrecon.results.drop_fit", "DropFit"),
    "JointFit": ("casrecon.results.joint_fit", "JointFit"),
    "PointMassFit": ("casrecon.results.pointmass_fit", "PointMassFit"),
    "KinematicFit": ("casrecon.results.kinematic_fit", "KinematicFit"),
    "Parameter": ("casrecon.results.parameters", "Parameter"),
    "Parameters": ("casrecon.results.parameters", "Parameters"),
    "Dispersions": ("casrecon.io.montecarlo_config", "Dispersions"),
    **{name: ("casrecon.report.result_figures", name) for name in (
        "plot_trajectory", "plot_qbar_alpha_t", "plot_pitching_moment", "plot_reconciled", "plot_residuals",
        "plot_correlation", "plot_joint_altitude_speed", "plot_joint_qbar_alpha_t", "plot_joint_flow_angles",
        "plot_joint_rates", "plot_joint_pitching_moment", "plot_shared_correlation", "plot_aero_coefficients",
        "plot_aero_sigma")},
    **{name: ("casrecon.report.study_figures", name) for name in (
        "plot_montecarlo_histograms", "plot_montecarlo_impact", "plot_montecarlo_envelopes", "plot_fisher_directions",
        "plot_profile_likelihood", "plot_design_study")},
}


def __getattr__(name: str) -> Any:
    if name == "__version__":
        from importlib.metadata import PackageNotFoundError, version

        try:
            return version("casrecon")
        except PackageNotFoundError:
            return "0+unknown"
    if name in _LAZY:
        module, attr = _LAZY[name]
        value = getattr(importlib.import_module(module), attr)
        globals()[name] = value
        return value
    raise AttributeError(f"module 'casrecon' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


def load_problem(path: str | Path) -> Scenario | PointMassConfig | KinematicConfig:
    """Read a problem folder (or its ``problem.toml``).

    Returns
    -------
    Scenario, PointMassConfig or KinematicConfig
        The 6-DOF problem with its atmosphere and flight model built, or the configuration of a
        ``kind = "point-mass"`` (GPS-only) or ``kind = "kinematic"`` (IMU-driven) problem.

    Raises
    ------
    InputError
        A malformed or missing input, located (file, line, field).
    """
    from casrecon.io.problem_file import problem_document, problem_kind

    path = Path(path)
    if not path.exists():
        raise InputError(path, "problem folder or problem.toml not found")
    document = problem_document(path)
    kind = problem_kind(document)
    if kind == "point-mass":
        from casrecon.io.pointmass_problem import load_point_mass

        return load_point_mass(document)
    if kind == "kinematic":
        from casrecon.io.kinematic_problem import load_kinematic

        return load_kinematic(document)
    from casrecon.scenario import Scenario

    return Scenario.load(document)


@single_threaded_blas()
def fit(problem: str | Path | Scenario, *, linear_solver: str | None = None, hessian: str | None = None,
        print_level: int = 0, solver: str | None = None, method: str | None = None,
        kinematic_check: bool = False) -> DropFit | PointMassFit | KinematicFit:
    """Reconstruct one drop: what ``casrecon fit`` computes and writes (the same pipeline,
    :mod:`casrecon.pipelines`), with its residuals and reconciled simulations; for a
    ``kind = "point-mass"`` problem the GPS-only fit, a :class:`PointMassFit`; for a
    ``kind = "kinematic"`` problem the IMU-driven reconstruction, a :class:`KinematicFit`.

    Parameters
    ----------
    problem : path or Scenario
        Problem folder, its ``problem.toml``, or a loaded :class:`~casrecon.scenario.Scenario`.
    linear_solver : {"mumps", "spral"}, optional
        Overrides ``[estimation] linear_solver`` (6-DOF problems; ``--linear-solver``).
    hessian : {"gauss-newton", "exact"}, optional
        Overrides ``[estimation] hessian`` (6-DOF problems; ``--hessian``).
    print_level : int
        Ipopt's print level (0 silent, 5 every iteration; ``--verbose``).
    solver : {"auto", "ipopt"}, optional
        Overrides ``[estimation] solver``: "auto" solves with the null-space Gauss-Newton solver
        where it applies (no disturbance states), else with Ipopt (6-DOF problems; ``--solver``).
    method : {"map", "marginal"}, optional
        Overrides ``[estimation] method``: "marginal" moves the parameters from the joint MAP to
        the maximum of their Laplace marginal likelihood (6-DOF problems; ``--method``; see
        :mod:`casrecon.estimation.engine.laplace`).
    kinematic_check : bool
        Also reconstruct the drop from its IMU without the aero model and compare the aero
        coefficients; the verdict ends the report, ``save`` writes ``implied_aero.csv`` and
        ``kinematic_check.csv``/``.json`` (6-DOF problems; ``--kinematic-check``).

    Returns
    -------
    DropFit, PointMassFit or KinematicFit

    Raises
    ------
    InputError
        Bad input files, or a 6-DOF option given for a point-mass or kinematic problem.
    FitError
        No convergence, singular KKT matrix or unusable data (the message says which).
    """
    from casrecon.pipelines import fit_problem
    from casrecon.pipelines.options import FitOptions
    from casrecon.pipelines.sixdof import fit_sixdof
    from casrecon.scenario import Scenario

    options = FitOptions(linear_solver=linear_solver, hessian=hessian, solver=solver, method=method,
                         print_level=print_level, kinematic_check=kinematic_check)
    if isinstance(problem, Scenario):
        return fit_sixdof(problem, options)
    return fit_problem(problem, options)


@single_threaded_blas()
def fit_joint(problems: str | Path | Sequence[str | Path], *, name: str = "joint", shared: Sequence[str] | None = None,
              per_drop: Sequence[str] = (), fixed: Sequence[str] = (), single: bool = True, hessian: str | None = None,
              linear_solver: str | None = None, solver: str | None = None, method: str | None = None,
              print_level: int = 0) -> JointFit:
    """Joint aero fit of several drops in one NLP: what ``casrecon joint`` computes and writes (the
    same pipeline, :mod:`casrecon.pipelines.joint`).

    Parameters
    ----------
    problems : path or list of paths
        A joint ``.toml`` file (``[joint] name, drops, shared, per_drop, fixed``; the keyword
        arguments below are then ignored), or at least two problem folders.
    name : str
        Name of the joint fit (problem folders only; ``--name``).
    shared, per_drop, fixed : list of str
        Dispersion factors common to all drops (None: every factor the drops estimate), estimated
        by each drop for itself, held at 0 (``--shared``, ``--per-drop``, ``--fixed``).
    single : bool
        Also fit each drop alone, on two processes beside the joint fit, for the joint-vs-single
        sigma table (default, as ``casrecon joint``; False is ``--no-single``).
    hessian, linear_solver, solver, method, print_level
        As for :func:`fit`, for every drop.

    Returns
    -------
    JointFit

    Raises
    ------
    InputError, FitError
    """
    from casrecon.pipelines.joint import fit_joint_problems, joint_problem
    from casrecon.pipelines.options import FitOptions

    problem = joint_problem(problems, name=name, shared=shared, per_drop=per_drop, fixed=fixed)
    options = FitOptions(linear_solver=linear_solver, hessian=hessian, solver=solver, method=method,
                         print_level=print_level)
    return fit_joint_problems(problem, options, single=single)


def montecarlo(problem: str | Path, cases: int | None = None, *, seed: int | None = None,
               dispersions: Dispersions | None = None, workers: int = 1, scheduler: str | None = None,
               progress: bool = False) -> MonteCarloResult:
    """Dispersed Monte Carlo of a 6-DOF problem (``casrecon montecarlo``, without writing a folder).

    Parameters
    ----------
    problem : path
        Problem folder or its ``problem.toml``.
    cases, seed : int, optional
        Number of cases and the seed (case i draws from the stream (seed, i)); default the
        problem's ``[montecarlo]`` table (1000 and 0 without one).
    dispersions : Dispersions, optional
        1-sigma dispersions; default the ``[montecarlo]`` table's.
    workers, scheduler
        Local processes, or a Dask scheduler address (``"tcp://host:8786"``).
    progress : bool
        Draw a progress bar on stderr (one step per case).

    Returns
    -------
    casrecon.analysis.montecarlo.MonteCarloResult
        Every case's drawn inputs and outcomes (``result["impact_speed_mps"]``), ``statistics()``,
        and the first cases' histories; plot it with the ``plot_montecarlo_*`` functions.

    Raises
    ------
    InputError
        A malformed problem (a bad ``[montecarlo]`` value included), located.
    ValueError
        ``cases`` below 1 or ``seed`` below 0.
    """
    from casrecon.analysis.montecarlo import run_montecarlo

    return run_montecarlo(problem, cases, seed, dispersions, workers=workers, scheduler=scheduler, progress=progress)


def load_results(folder: str | Path) -> DropFit | JointFit | PointMassFit | KinematicFit:
    """Read a results folder written by ``casrecon fit --out``, ``casrecon joint --out`` or a result's
    ``save``: a :class:`DropFit`, a :class:`JointFit` for a folder with ``drops/``, or a
    :class:`PointMassFit` for a point-mass fit's folder.

    Every file is read and checked (:mod:`casrecon.output.results_reader`): a JSON file that is not
    an object, a CSV row cut mid-line or with a cell missing, a parameter value or sigma that is not
    a finite number, text that is not UTF-8 are refused.

    Raises
    ------
    InputError
        The folder does not exist, is not a results folder (the message names the folder and the
        missing file), or holds a damaged file (the file, the line or key, and what was expected).
    """
    from casrecon.output.results_reader import folder_kind
    from casrecon.results.drop_fit import DropFit
    from casrecon.results.joint_fit import JointFit
    from casrecon.results.pointmass_fit import PointMassFit

    kind = folder_kind(folder)
    if kind == "joint":
        return JointFit.load(folder)
    if kind == "point-mass":
        return PointMassFit.load(folder)
    if kind == "kinematic":
        from casrecon.results.kinematic_fit import KinematicFit

        return KinematicFit.load(folder)
    return DropFit.load(folder)
