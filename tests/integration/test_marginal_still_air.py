"""The marginal-likelihood estimator on a strong-constraint fit (no disturbance states, still
air; a window of ees-drop-2 with its atmosphere-profile model off): the latent unknowns are the node
states, fixed by the first node, and the GPS errors, whose Hessian block is constant, so the
log-determinant hardly depends on the parameters and the marginal estimate equals the joint MAP
within 0.1 sigma."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.estimation.sixdof.fit import fit_drop, with_marginal_estimate
from casrecon.scenario import Scenario


@pytest.fixture(scope="module")
def fits():
    cfg = Scenario.load(PROBLEMS / "ees-drop-2").config
    est = dataclasses.replace(cfg.estimation, start_after_release_s=20.0)
    atm = dataclasses.replace(cfg.atmosphere, profile_wind_sigma_mps=0.0, profile_density_sigma=0.0)
    sc = Scenario.from_config(dataclasses.replace(cfg, estimation=est, atmosphere=atm))
    joint_map = fit_drop(sc)
    return joint_map, with_marginal_estimate(joint_map)


def test_marginal_equals_map_in_still_air(fits):
    joint_map, marginal = fits
    run = marginal.solver.marginal
    assert run.converged and marginal.solver.method.endswith("then marginal likelihood")
    shift = np.abs(marginal.values - joint_map.values) / joint_map.sigma
    print("largest shift (sigma)", shift.max(), "Newton steps", run.outer_iterations)
    assert shift.max() < 0.1
    assert np.allclose(marginal.sigma, joint_map.sigma, rtol=0.02)


def test_fit_method_setting_runs_the_marginal_estimator(fits):
    joint_map, _ = fits
    via_setting = fit_drop(joint_map.scenario, method="marginal")
    assert via_setting.solver.marginal is not None and via_setting.solver.marginal.converged
