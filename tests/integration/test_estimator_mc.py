"""Estimator Monte Carlo plumbing on a coarse-mesh copy of ees-drop-1: every case is reproducible
from (seed, index) alone, different cases draw different truths, and the results folder holds the
NEES test. (The consistency result itself needs >= 50 fits: benchmarks/estimator_consistency.py.)"""

from __future__ import annotations

import json

import numpy as np
from scipy.stats import chi2

from casrecon.analysis.estimator_mc import estimator_montecarlo, run_case
from casrecon.output.consistency import write_consistency


def test_cases_reproducible_and_written(problem_copy, tmp_path):
    text = problem_copy.read_text()
    problem_copy.write_text(text.replace("[estimation]\n", "[estimation]\ninterval_s = 0.05\n", 1))  # 7 s fits
    res = estimator_montecarlo(problem_copy, 2, seed=3, workers=1)
    assert not res.failed, res.failed
    first, second = res.cases
    assert first["names"] == second["names"] and len(first["names"]) == res.n_params
    assert not np.allclose(first["error"], second["error"])
    again = run_case(str(problem_copy.resolve()), 3, 1)
    np.testing.assert_array_equal(again["error"], second["error"])
    np.testing.assert_array_equal(again["sigma"], second["sigma"])
    dof = 2 * res.n_params
    assert res.interval == (chi2.ppf(0.025, dof), chi2.ppf(0.975, dof))
    assert res.nees_sum == first["nees"] + second["nees"]
    write_consistency(tmp_path, res, wall_s=1.0)
    doc = json.loads((tmp_path / "nees.json").read_text())
    assert doc["n_converged"] == 2 and doc["consistent"] == res.consistent
    assert set(doc["normalised_error"]) == set(first["names"])
    rows = (tmp_path / "cases.csv").read_text().splitlines()
    assert len(rows) == 3 and rows[0].startswith("index,nees,reduced_chi2,z_")
