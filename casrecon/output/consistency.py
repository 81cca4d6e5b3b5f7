"""The results folder of an estimator Monte Carlo: the NEES consistency test and the per-case errors."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from casrecon.output.results import write_columns, write_json


def write_consistency(out: Path, res, wall_s: float) -> None:
    """``nees.json`` (the test and per-parameter RMS of the normalised errors) and ``cases.csv``.

    Parameters
    ----------
    out : Path
        Existing folder.
    res : casrecon.analysis.estimator_mc.ConsistencyResult
        The estimator Monte Carlo.
    wall_s : float
        Its wall time, s.
    """
    ok = [c for c in res.cases if "nees" in c]
    doc = {"n_cases": len(res.cases), "n_converged": len(ok), "n_params": res.n_params, "nees_sum": res.nees_sum,
           "chi2_95_interval": list(res.interval), "consistent": res.consistent, "wall_s": wall_s,
           "failed": [{"index": c["index"], "reason": c["failed"]} for c in res.failed]}
    if ok:
        z = np.array([np.array(c["error"]) / np.array(c["sigma"]) for c in ok])
        doc["normalised_error"] = {n: {"mean": float(m), "rms": float(r)} for n, m, r in
                                   zip(ok[0]["names"], z.mean(0), np.sqrt((z**2).mean(0)))}
        write_columns(out / "cases.csv", ["index", "nees", "reduced_chi2"] + [f"z_{n}" for n in ok[0]["names"]],
                      np.column_stack([[c["index"] for c in ok], [c["nees"] for c in ok],
                                       [c["reduced_chi2"] for c in ok], z]))
    write_json(out / "nees.json", doc)
