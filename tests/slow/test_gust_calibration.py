"""Calibration of the weak-constraint gust fit across seeds (slow, about 6 min on 2 cores).

Four seeds of a 3-5 s terminal window of ees-drop-3, parameter truth drawn from the priors. Control:
in still air the parameter errors pass the pooled NEES test. With Gauss-Markov gusts the joint MAP
estimate biases the normal-force and pitching-moment slope multipliers upward by several sigma
(measured mean z +3.8 over 8 seeds for Cmn_mult; over 3 seeds +2.6 at 0.3 times the gust sigma,
+1.1 at 0.1 times), the behaviour of a joint MAP estimate of a gain multiplying latent inputs; the
marginal-likelihood estimate (``[estimation] method = "marginal"``) of the same fits is unbiased.
The Laplace-marginal profile of one parameter (casrecon.analysis.marginal) agrees (last test).
"""

from functools import partial

import numpy as np
import pytest
from conftest import PROBLEMS
from scipy import stats

from casrecon.analysis.gust_calibration import GustCase, marginal_profile_case, run_gust_case
from casrecon.parallel import parallel_map

pytestmark = pytest.mark.slow
SEEDS = (2, 3, 4, 5)


def _cases(truth_gusts: bool, marginal: bool = False) -> list[dict]:
    tasks = [GustCase(PROBLEMS / "ees-drop-3", s, start_s=34.0, truth_gusts=truth_gusts) for s in SEEDS]
    cases = parallel_map(partial(run_gust_case, marginal=marginal), tasks, workers=2)
    assert all(c["marginal"]["converged"] and c["map"]["converged"] if marginal else c["converged"] for c in cases)
    return cases


def test_still_air_control_passes_the_nees_test():
    cases = _cases(truth_gusts=False)
    nees, dof = sum(c["params"]["nees"] for c in cases), sum(c["params"]["dof"] for c in cases)
    print("control parameter NEES", nees, "over", dof)
    assert stats.chi2.ppf(0.005, dof) <= nees <= stats.chi2.ppf(0.995, dof)


def test_gusty_slope_multipliers_biased_by_the_map_unbiased_by_the_marginal():
    cases = _cases(truth_gusts=True, marginal=True)
    for name in ("CNY_mult", "Cmn_mult"):
        z_map = np.array([c["map"]["params"]["z"][name] for c in cases])
        z = np.array([c["marginal"]["params"]["z"][name] for c in cases])
        print(name, "z per seed: joint MAP", z_map, "marginal", z)
        assert z_map.mean() > 3 / np.sqrt(len(SEEDS))  # the MAP's bias (measured +2.6 and +3.9)
        assert abs(z.mean()) < 3 / np.sqrt(len(SEEDS))
    nees = sum(c["marginal"]["params"]["nees"] for c in cases)
    dof = sum(c["marginal"]["params"]["dof"] for c in cases)
    print("marginal parameter NEES", nees, "over", dof)
    assert stats.chi2.ppf(0.005, dof) <= nees <= stats.chi2.ppf(0.995, dof)


def test_laplace_marginal_profile_removes_most_of_the_bias():
    """The diagnosis: adding 1/2 log det of the latent Hessian to the profile moves Cmn_mult's
    minimum to within 3 sigma of the truth on each seed (measured +0.02, -0.10, +2.12 sigma against
    +5.1 to +5.4 for the fit), while the joint profile's minimum reproduces the fit's estimate."""
    rows = parallel_map(marginal_profile_case, [GustCase(PROBLEMS / "ees-drop-3", s, start_s=34.0)
                                                for s in SEEDS[:3]], workers=2)
    for r in rows:
        print(r)
        assert abs(r["joint_minimum"] - r["estimate"]) < 0.2 * r["sigma"]
        assert abs(r["marginal_minimum"] - r["truth"]) < 3 * r["sigma"]
        assert abs(r["marginal_minimum"] - r["truth"]) < abs(r["estimate"] - r["truth"]) - 2 * r["sigma"]
