"""casrecon: reconstruct a dropped capsule's 6-DOF flight and aerodynamics from IMU, GPS and a sounding.

The public Python API (in the spirit of lmfit and rockit)::

    import casrecon

    result = casrecon.fit("problems/ees-drop-1")
    print(result.params["CA_mult"].value, result.params["CA_mult"].stderr)
    print(result.report())
    result.sample("alpha_t_deg", [2.0, 5.0])        # values and 3-sigma at flight times, s
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
    from casrecon.io.montecarlo_config import Dispersions
    from casrecon.io.pointmass_problem import PointMassConfig
    from casrecon.output.drop_fit import DropFit
    from casrecon.output.joint_fit import JointFit
    from casrecon.output.kinematic_fit_result import KinematicFit
    from casrecon.output.parameter_records import Parameter, Parameters
    from casrecon.output.pointmass_result import PointMassFit
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
    "DropFit": ("casrecon.output.drop_fit", "DropFit"),
    "JointFit": ("casrecon.output.joint_fit", "JointFit"),
    "PointMassFit": ("casrecon.output.pointmass_result", "PointMassFit"),
    "KinematicFit": ("casrecon.output.kinematic_fit_result", "KinematicFit"),
    "Parameter": ("casrecon.output.parameter_records", "Parameter"),
    "Parameters": ("casrecon.output.parameter_records", "Parameters"),
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


def load_problem(path: str | Path) -> Scenario | PointMassConfig:
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
    from casrecon.io.pointmass_problem import load_point_mass, problem_kind
    from casrecon.scenario import Scenario

    path = Path(path)
    if not path.exists():
        raise InputError(path, "problem folder or problem.toml not found")
    kind = problem_kind(path)
    if kind == "point-mass":
        return load_point_mass(path)
    if kind == "kinematic":
        from casrecon.io.kinematic_problem import load_kinematic

        return load_kinematic(path)
    return Scenario.load(path)


@single_threaded_blas()
def fit(problem: str | Path | Scenario, *, linear_solver: str | None = None, hessian: str | None = None,
        print_level: int = 0, solver: str | None = None, method: str | None = None
        ) -> DropFit | PointMassFit | KinematicFit:
    """Reconstruct one drop: the per-drop fit of ``casrecon fit``, with its residuals and reconciled
    simulations (for a ``kind = "point-mass"`` problem the GPS-only fit, a :class:`PointMassFit`;
    for a ``kind = "kinematic"`` problem the IMU-driven reconstruction, a :class:`KinematicFit`;
    ``linear_solver``, ``hessian``, ``solver`` and ``method`` do not apply to them).

    Parameters
    ----------
    problem : path or Scenario
        Problem folder, its ``problem.toml``, or a loaded :class:`~casrecon.scenario.Scenario`.
    linear_solver : {"mumps", "spral"}, optional
        Overrides ``[estimation] linear_solver``.
    hessian : {"gauss-newton", "exact"}, optional
        Overrides ``[estimation] hessian``.
    print_level : int
        Ipopt's print level (0 silent, 5 every iteration).
    solver : {"auto", "ipopt"}, optional
        Overrides ``[estimation] solver``: "auto" solves with the null-space Gauss-Newton solver
        where it applies (no disturbance states), else with Ipopt.
    method : {"map", "marginal"}, optional
        Overrides ``[estimation] method``: "marginal" moves the parameters from the joint MAP to
        the maximum of their Laplace marginal likelihood (6-DOF fits; see
        :mod:`casrecon.estimation.engine.laplace`).

    Returns
    -------
    DropFit, PointMassFit or KinematicFit

    Raises
    ------
    InputError
        Bad input files.
    FitError
        No convergence, singular KKT matrix or unusable data (the message says which).
    """
    import time

    from casrecon.analysis.fit_products import fit_products
    from casrecon.estimation.fit import fit_drop
    from casrecon.output.drop_fit import DropFit
    from casrecon.report.fit_report import fit_report

    t0 = time.perf_counter()
    scenario = problem if hasattr(problem, "config") and hasattr(problem, "model") else load_problem(problem)
    if hasattr(scenario, "imu") and not hasattr(scenario, "model"):  # a kinematic problem
        return _fit_kinematic(scenario, print_level)
    if not hasattr(scenario, "model"):
        return _fit_point_mass(scenario, print_level)
    result = fit_drop(scenario, linear_solver=linear_solver, hessian=hessian, print_level=print_level, solver=solver,
                      method=method)
    products = fit_products(result)
    report = fit_report(result, products.adequacy)
    result.timings["total_s"] = time.perf_counter() - t0
    return DropFit.from_fit(result, products, report)


def _fit_kinematic(cfg, print_level: int) -> KinematicFit:
    """The IMU-driven reconstruction of ``casrecon fit`` on a kinematic problem, with its verdict."""
    from casrecon.analysis.fit_adequacy import kinematic_adequacy
    from casrecon.estimation.kinematic_fit import fit_kinematic
    from casrecon.estimation.kinematic_inputs import inputs_from_config
    from casrecon.output.kinematic_fit_result import KinematicFit
    from casrecon.report.kinematic_report import kinematic_report

    result = fit_kinematic(*inputs_from_config(cfg), print_level=print_level)
    adequacy = kinematic_adequacy(result)
    report = kinematic_report(result, cfg.name, adequacy)
    return KinematicFit.from_fit(result, report, cfg.site, cfg.path, cfg.name, adequacy.to_dict())


def _fit_point_mass(cfg: PointMassConfig, print_level: int) -> PointMassFit:
    """The GPS-only fit of ``casrecon fit`` on a point-mass problem, with the constant-drag comparison."""
    from casrecon.estimation.pointmass_fit import fit_with_comparison
    from casrecon.output.pointmass_result import PointMassFit
    from casrecon.report.pointmass_report import pointmass_report

    main, constant = fit_with_comparison(cfg, print_level=print_level)
    return PointMassFit.from_fit(main, constant, pointmass_report(main, constant))


def fit_joint(problems: str | Path | Sequence[str | Path], *, name: str = "joint", shared: Sequence[str] | None = None,
              per_drop: Sequence[str] = (), fixed: Sequence[str] = (), single: bool = False, hessian: str | None = None,
              linear_solver: str | None = None, print_level: int = 0) -> JointFit:
    """Joint aero fit of several drops in one NLP (``casrecon joint``).

    Parameters
    ----------
    problems : path or list of paths
        A joint ``.toml`` file (``[joint] name, drops, shared, per_drop, fixed``; the keyword
        arguments below are then ignored), or at least two problem folders.
    name : str
        Name of the joint fit (problem folders only).
    shared, per_drop, fixed : list of str
        Dispersion factors common to all drops (None: every factor the drops estimate), estimated
        by each drop for itself, held at 0.
    single : bool
        Also fit each drop alone for the joint-vs-single sigma table (slower).
    hessian, linear_solver, print_level
        As for :func:`fit`.

    Returns
    -------
    JointFit

    Raises
    ------
    InputError, FitError
    """
    import time

    from casrecon.analysis.fit_products import fit_products
    from casrecon.analysis.single_sigmas import single_drop_sigmas
    from casrecon.estimation import joint
    from casrecon.output.joint_fit import JointFit
    from casrecon.scenario import Scenario

    t0 = time.perf_counter()
    if isinstance(problems, (str, Path)):
        if not Path(problems).is_file():
            raise InputError(problems, "expected a joint .toml file or a list of at least two problem folders")
        cfg = joint.load_joint(problems)
    else:
        if len(problems) < 2:
            raise InputError(", ".join(map(str, problems)) or "(none)", "a joint fit needs at least two problems")
        cfg = joint.JointConfig(name=name, drops=tuple(Path(p) for p in problems),
                                shared=tuple(shared) if shared is not None else None, per_drop=tuple(per_drop),
                                fixed=tuple(fixed))
    scenarios = [Scenario.load(p) for p in cfg.drops]
    result = joint.fit_joint(scenarios, cfg, hessian=hessian, linear_solver=linear_solver, print_level=print_level)
    sigmas = single_drop_sigmas(list(cfg.drops)) if single else {}
    result.timings["total_s"] = time.perf_counter() - t0
    return JointFit.from_fit(result, {d.scenario.config.name: fit_products(d) for d in result.drops}, sigmas)


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

    Raises
    ------
    InputError
        The folder does not exist or is not a results folder (the message names the folder and
        the missing file).
    """
    from casrecon.output.drop_fit import DropFit, read_document
    from casrecon.output.joint_fit import JointFit
    from casrecon.output.pointmass_result import PointMassFit

    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(folder, "results folder not found")
    if (folder / "drops").is_dir():
        return JointFit.load(folder)
    summary = folder / "summary.json"
    kind = read_document(summary).get("kind") if summary.is_file() else None
    if kind == "point-mass":
        return PointMassFit.load(folder)
    if kind == "kinematic":
        from casrecon.output.kinematic_fit_result import KinematicFit

        return KinematicFit.load(folder)
    return DropFit.load(folder)
