"""Calibration of the weak-constraint gust fit across seeds (slow, about 3 min on 2 cores).

Four seeds of a 3-5 s terminal window of ees-drop-3, parameter truth drawn from the priors. Control:
in still air the parameter errors pass the pooled NEES test. With Gauss-Markov gusts the
normal-force and pitching-moment slope multipliers come out biased upward by several sigma on most
seeds (measured mean z +3.8 over 8 seeds for Cmn_mult; over 3 seeds +2.6 at 0.3 times the gust sigma, +1.1 at
0.1 times), the behaviour of a joint MAP estimate of a gain multiplying latent inputs; a strict
xfail records it until the fit maximises the marginal likelihood of the parameters.
"""

import numpy as np
import pytest
from conftest import PROBLEMS
from scipy import stats

from casrecon.analysis.gust_calibration import GustCase, run_gust_case
from casrecon.analysis.montecarlo import map_with_progress

pytestmark = pytest.mark.slow
SEEDS = (2, 3, 4, 5)


def _cases(truth_gusts: bool) -> list[dict]:
    tasks = [GustCase(PROBLEMS / "ees-drop-3", s, start_s=34.0, truth_gusts=truth_gusts) for s in SEEDS]
    cases = map_with_progress(run_gust_case, tasks, workers=2)
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
