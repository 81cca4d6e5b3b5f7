"""Calibration of the weak-constraint gust fit across seeds (slow, about 3 min on 2 cores).

Four seeds of a 3-5 s terminal window of ees-drop-3, parameter truth drawn from the priors. Control:
in still air the parameter errors pass the pooled NEES test. With Gauss-Markov gusts the
normal-force and pitching-moment slope multipliers come out biased upward by several sigma on most
seeds (measured mean z +3.8 over 8 seeds for Cmn_mult; over 3 seeds +2.6 at 0.3 times the gust sigma, +1.1 at
0.1 times), the behaviour of a joint MAP estimate of a gain multiplying latent inputs; a strict
xfail records it until the fit maximises the marginal likelihood of the parameters. The Laplace-
marginal profile (casrecon.analysis.marginal) shows that this is the cause (last test; about 4 min).
"""

import numpy as np
import pytest
from conftest import PROBLEMS
from scipy import stats

from casrecon.analysis.gust_calibration import GustCase, marginal_profile_case, run_gust_case
from casrecon.parallel import parallel_map

pytestmark = pytest.mark.slow
SEEDS = (2, 3, 4, 5)


def _cases(truth_gusts: bool) -> list[dict]:
    tasks = [GustCase(PROBLEMS / "ees-drop-3", s, start_s=34.0, truth_gusts=truth_gusts) for s in SEEDS]
    cases = parallel_map(run_gust_case, tasks, workers=2)
    assert all(c["converged"] for c in cases)
    return cases


def test_still_air_control_passes_the_nees_test():
    cases = _cases(truth_gusts=False)
    nees, dof = sum(c["params"]["nees"] for c in cases), sum(c["params"]["dof"] for c in cases)
    print("control parameter NEES", nees, "over", dof)
    assert stats.chi2.ppf(0.005, dof) <= nees <= stats.chi2.ppf(0.995, dof)


@pytest.mark.xfail(strict=True, reason="known problem: with gust states the joint MAP biases the slope "
                   "multipliers CNY_mult and Cmn_mult upward (mean z +2.6 and +3.9 on these seeds)")
def test_gusty_slope_multipliers_are_unbiased():
    cases = _cases(truth_gusts=True)
    for name in ("CNY_mult", "Cmn_mult"):
        z = np.array([c["params"]["z"][name] for c in cases])
        print(name, "z per seed", z)
        assert abs(z.mean()) < 3 / np.sqrt(len(SEEDS))


def test_laplace_marginal_profile_removes_most_of_the_bias():
    """The diagnosis: adding 1/2 log det of the latent Hessian to the profile moves Cmn_mult's
    minimum to within 3 sigma of the truth on each seed (measured -0.01, -0.03, +2.17 sigma against
    +5.1 to +5.4 for the fit), while the joint profile's minimum reproduces the fit's estimate."""
    rows = parallel_map(marginal_profile_case, [GustCase(PROBLEMS / "ees-drop-3", s, start_s=34.0)
                                                for s in SEEDS[:3]], workers=2)
    for r in rows:
        print(r)
        assert abs(r["joint_minimum"] - r["estimate"]) < 0.2 * r["sigma"]
        assert abs(r["marginal_minimum"] - r["truth"]) < 3 * r["sigma"]
        assert abs(r["marginal_minimum"] - r["truth"]) < abs(r["estimate"] - r["truth"]) - 2 * r["sigma"]
