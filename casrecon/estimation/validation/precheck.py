"""The pre-solve data check alone, on a problem folder: read the files, run every check of
:mod:`casrecon.estimation.validation.data_checks` and prepare the data as the fit would, without building or
solving anything (milliseconds to a fraction of a second)."""

from __future__ import annotations

from pathlib import Path

from casrecon.estimation.kinematic.inputs import inputs_from_config
from casrecon.estimation.pointmass.fit import prepare_data
from casrecon.estimation.sixdof.fitdata import load_fit_data
from casrecon.io.kinematic_problem import load_kinematic
from casrecon.io.pointmass_problem import load_point_mass
from casrecon.io.problem import load_problem
from casrecon.io.problem_file import problem_document, problem_kind


def check_problem(path: str | Path) -> tuple[str, ...]:
    """Check the data of a 6-DOF, point-mass or kinematic problem (folder or ``problem.toml``) as a
    fit would (a kinematic problem: its files read onto one clock and its span found).

    Returns
    -------
    tuple of str
        The notes the fit would carry (what was dropped or masked, and why).

    Raises
    ------
    InputError
        A malformed file, or data the pre-solve check refuses (located).
    FitError, FitDataError
        Data a fit cannot use for another reason (no release or impact found, too few fixes).
    """
    document = problem_document(path)
    kind = problem_kind(document)
    if kind == "point-mass":
        return prepare_data(load_point_mass(document)).notes
    if kind == "kinematic":
        return inputs_from_config(load_kinematic(document))[0].notes
    return load_fit_data(load_problem(document)).notes
