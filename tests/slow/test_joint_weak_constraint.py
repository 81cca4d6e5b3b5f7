"""A joint fit of two drops that both estimate gust states (slow, minutes): it converges, each drop
keeps its own gust columns, and the marginal-likelihood estimator runs on the joint NLP."""

import dataclasses

import pytest
from conftest import PROBLEMS

from casrecon.estimation.sixdof.joint import JointConfig, fit_joint
from casrecon.physics.disturbance import DisturbanceModel
from casrecon.scenario import Scenario

pytestmark = pytest.mark.slow
GUSTS = DisturbanceModel((0.5, 0.5, 0.25) + (0.0,) * 6, (3.0,) * 9)
WINDOWS = (("ees-drop-3", 34.0), ("ees-drop-4", 30.0))  # short terminal windows, s after release


def test_joint_fit_with_gust_states_and_the_marginal_estimator():
    scenarios = []
    for name, start in WINDOWS:
        cfg = Scenario.load(PROBLEMS / name).config
        est = dataclasses.replace(cfg.estimation, start_after_release_s=start, disturbance=GUSTS)
        scenarios.append(Scenario.from_config(dataclasses.replace(cfg, estimation=est)))
    cfg = JointConfig(name="gusty", drops=tuple(PROBLEMS / n for n, _ in WINDOWS))
    result = fit_joint(scenarios, cfg, method="marginal")
    sol = result.drops[0].solver
    assert sol.converged and sol.marginal is not None and sol.marginal.converged
    cols = [set(d.part.u_cols.ravel().tolist()) for d in result.drops]
    assert cols[0] and cols[1] and not cols[0] & cols[1]
    for d in result.drops:
        assert 0.9 < d.reduced_chi2 < 1.1
        value, sigma = d.column("gust_n_mps")
        assert (sigma > 0).all()
