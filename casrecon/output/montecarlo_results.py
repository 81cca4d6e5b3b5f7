"""The cases table of a dispersed Monte Carlo."""

from __future__ import annotations

from pathlib import Path

import numpy as np


def write_cases_csv(path: str | Path, result) -> None:
    """``cases.csv`` of a :class:`~casrecon.analysis.montecarlo.MonteCarloResult`: one row per case,
    ``case`` first, then the drawn inputs and the outputs (SI, angles in deg)."""
    names, data = result.table()
    fmt = ["%d"] + ["%.10g"] * (len(names) - 1)
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)
