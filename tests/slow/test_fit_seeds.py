"""Coverage of the per-drop fit's parameter sigmas over 20 noise seeds of ees-drop-3 (about 3 min).

The normalised errors (value - truth) / sigma of every parameter over every seed should have RMS
near 1; [0.8, 1.25] is accepted. With 19 parameters x 20 seeds = 380 values the RMS of truly N(0, 1)
values has sd about 0.04, but the values are correlated within a seed and, more importantly, the
priors make the check imperfect: density_factor is prior-dominated (its posterior sigma is ~0.94 of
its prior sigma) while its truth is fixed at +0.65 prior sigma, so it is shrunk towards 0 on every
seed, and the aero factors correlated with it (those scaling with dynamic pressure: C_A, C_m/C_n and
C_mq multipliers) inherit that bias with a small scatter. That is honest Bayesian behaviour; it lowers
the RMS below 1 for those parameters (their sigma includes the prior's uncertainty, which does not
vary from seed to seed). The per-parameter table is printed (run with -s) and in
``benchmarks/fit_seeds.py``.

Run: pytest -m slow tests/slow/test_fit_seeds.py -s
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import script_module

BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "fit_seeds.py"


@pytest.mark.slow
def test_normalised_errors_over_seeds(tmp_path):
    fs = script_module(BENCH)
    res = fs.run_seeds("ees-drop-3", range(100, 120), tmp_path)
    s = fs.summarise(res)
    fs.print_summary(res, s)
    assert len(res["seeds"]) >= 20
    assert 0.8 <= s["rms_all"] <= 1.25
    # every fit honest on its own too: chi2/dof near 1, each parameter's errors never wildly off
    assert np.all(np.abs(res["reduced_chi2"] - 1) < 0.05)
    z = (res["values"] - res["truth"]) / res["sigma"]
    assert np.abs(z).max() < 4.5
    for c, b in s["bands"].items():
        assert b["inside_3sigma"] >= 0.99, (c, b)
