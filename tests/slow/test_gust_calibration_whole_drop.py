"""Whole-drop gust calibration of the marginal-likelihood estimator (slow, about 4 min on 2 cores).

Issue 13's acceptance setup on its minimum of 8 seeds: ees-drop-3 from 3.5 s after release to
impact through full-size Gauss-Markov gusts (0.5, 0.5, 0.25 m/s, 3 s) the balloon did not see,
parameter truth drawn from the priors, each case fitted by the joint MAP and moved to the marginal
estimate, on the default 25 ms mesh. The simulator's gusts vary every 2 ms; the fit models what
they do between its nodes (midpoint values, sub-grid integrals and the IMU samples' departures,
docs/design.md). With the gusts linear between nodes instead, the part the fit could not follow
made the east gust's sigmas too small on 25 ms (NEES 340.3 over 284 on these seeds) and a 12.5 ms
mesh was needed. Measured with the model (seeds 1-8, 25 ms): marginal parameter NEES 178.8 over
152 dof, aero factors' mean z within +-0.44, gust NEES at 1 s nodes N 264.1, E 271.5, D 303.7
over 284 dof; the joint MAP's parameter NEES 602.0.
"""

from functools import partial

import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.analysis.estimator_mc import chi2_interval
from casrecon.analysis.gust_calibration import AXES, GustCase, run_gust_case
from casrecon.parallel import parallel_map

pytestmark = pytest.mark.slow
SEEDS = tuple(range(1, 9))
AERO = ("CA_mult", "CN_add", "CNY_mult", "CY_add", "Cm_add", "Cmn_mult", "Cn_add", "Cmq_mult", "Cl_add")


@pytest.fixture(scope="module")
def cases() -> list[dict]:
    tasks = [GustCase(PROBLEMS / "ees-drop-3", s, start_s=3.5) for s in SEEDS]
    rows = parallel_map(partial(run_gust_case, marginal=True), tasks, workers=2)
    assert all(c["map"]["converged"] and c["marginal"]["converged"] for c in rows)
    return rows


def _pooled(rows: list[dict], which: str, key: str) -> tuple[float, int]:
    return sum(r[which][key]["nees"] for r in rows), sum(r[which][key]["dof"] for r in rows)


def test_marginal_parameters_are_calibrated_where_the_map_is_not(cases):
    nees, dof = _pooled(cases, "marginal", "params")
    lo, hi = chi2_interval(dof)
    map_nees, _ = _pooled(cases, "map", "params")
    print("parameter NEES: marginal", nees, "MAP", map_nees, "over", dof, "interval", lo, hi)
    assert lo <= nees <= hi
    assert map_nees > hi
    for name in AERO:
        z = np.mean([c["marginal"]["params"]["z"][name] for c in cases])
        print(name, "marginal mean z", z)
        assert abs(z) <= 0.5


def test_gust_sigmas_are_calibrated_on_every_axis(cases):
    for axis in AXES:
        nees, dof = _pooled(cases, "marginal", axis)
        lo, hi = chi2_interval(dof)
        print(axis, "NEES", nees, "over", dof, "interval", lo, hi)
        assert lo <= nees <= hi
