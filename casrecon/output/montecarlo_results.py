"""The tables of a dispersed Monte Carlo: the cases, and the envelopes of the time histories."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from casrecon.output.results import write_columns


def write_cases_csv(path: str | Path, result) -> None:
    """``cases.csv`` of a :class:`~casrecon.analysis.montecarlo.MonteCarloResult`: one row per case,
    ``case`` first, then the drawn inputs and the outputs (SI, angles in deg)."""
    names, data = result.table()
    fmt = ["%d"] + ["%.10g"] * (len(names) - 1)
    np.savetxt(path, data, delimiter=",", header=",".join(names), comments="", fmt=fmt)


def write_envelopes_csv(path: str | Path, envelopes: dict[str, np.ndarray]) -> None:
    """``envelopes.csv``: :meth:`~casrecon.analysis.mc_envelopes.Histories.envelopes`, one row per
    time of the grid: ``flight_time_s``, ``n_in_flight``, then ``<quantity>_<unit>_p1``, ``_p50``,
    ``_p99`` and ``_nominal`` per quantity (``nan`` where undefined: no case, or not the nominal, in flight)."""
    names = list(envelopes)
    write_columns(path, names, np.column_stack([envelopes[n] for n in names]), fmt="%.7g")
