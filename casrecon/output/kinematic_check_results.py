"""Files of the kinematic check of a dynamic fit (``casrecon fit --kinematic-check``).

``implied_aero.csv`` (:func:`casrecon.analysis.implied_aero.implied_columns`: the kinematic
reconstruction's coefficients, alpha_T, qbar and Mach with 3-sigma, and the database's with the
fitted dispersions along the same flow), ``kinematic_check.csv``
(:func:`casrecon.analysis.kinematic_check.check_columns`: implied and best-fit coefficients with
3-sigma and their normalised difference) and ``kinematic_check.json`` (the verdict, the share of
nodes beyond 3 sigma and the largest |z| per coefficient, the kinematic fit's reduced chi-square).
"""

from __future__ import annotations

from pathlib import Path

from casrecon.output.columns import write_table
from casrecon.output.results import write_json


def write_kinematic_check(folder: Path, implied: dict, check) -> list[Path]:
    """Write the three files into ``folder``; their paths."""
    folder = Path(folder)
    paths = [folder / "implied_aero.csv", folder / "kinematic_check.csv", folder / "kinematic_check.json"]
    write_table(paths[0], implied)
    write_table(paths[1], check.table)
    write_json(paths[2], check.document())
    return paths
