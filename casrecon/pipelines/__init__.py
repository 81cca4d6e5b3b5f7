"""One pipeline per problem kind: load -> fit -> products -> report -> result object.

Both the public API (:func:`casrecon.fit`, :func:`casrecon.fit_joint`) and the command line
(``casrecon fit``, ``casrecon joint``) call these functions, so that an option exists in both or in
neither and a results folder is written by the same code whichever way it was asked for:

- :func:`fit_problem` decides a problem's kind (``[problem] kind``, in one place) and runs
  :func:`~casrecon.pipelines.sixdof.fit_sixdof`, :func:`~casrecon.pipelines.pointmass.fit_point_mass`
  or :func:`~casrecon.pipelines.kinematic.fit_kinematic_problem`;
- :func:`~casrecon.pipelines.joint.fit_joint_problems` fits several 6-DOF drops jointly.

A result's ``save(folder)`` (or ``write(out)`` inside a folder being made) writes its folder.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from casrecon.io.problem_file import problem_document, problem_kind
from casrecon.io.toml_fields import TomlDocument
from casrecon.pipelines.options import DEFAULT_OPTIONS, FitOptions

if TYPE_CHECKING:
    from casrecon.results.drop_fit import DropFit
    from casrecon.results.kinematic_fit import KinematicFit
    from casrecon.results.pointmass_fit import PointMassFit


def fit_problem(problem: str | Path | TomlDocument, options: FitOptions = DEFAULT_OPTIONS
                ) -> DropFit | PointMassFit | KinematicFit:
    """Fit one problem by its kind, reading its ``problem.toml`` once.

    Parameters
    ----------
    problem : path or TomlDocument
        Problem folder, its ``problem.toml``, or the file as already parsed
        (:func:`casrecon.io.problem_file.problem_document`).
    options : FitOptions
        Overrides of the problem's ``[estimation]`` table and the run's options.

    Returns
    -------
    DropFit, PointMassFit or KinematicFit

    Raises
    ------
    InputError
        Bad input files, or an option that does not apply to the problem's kind.
    FitError
        No convergence, singular KKT matrix or unusable data (the message says which).
    """
    document = problem_document(problem)
    kind = problem_kind(document)
    if kind == "point-mass":
        from casrecon.pipelines.pointmass import fit_point_mass

        options.require_six_dof_options_unset(document.path, kind)
        return fit_point_mass(document, options)
    if kind == "kinematic":
        from casrecon.pipelines.kinematic import fit_kinematic_problem

        options.require_six_dof_options_unset(document.path, kind)
        return fit_kinematic_problem(document, options)
    from casrecon.pipelines.sixdof import fit_sixdof

    return fit_sixdof(document, options)
