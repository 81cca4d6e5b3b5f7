"""Gust hypothesis (slow): synthetic drop-3 data with Gauss-Markov gusts the balloon did not see.

The strong-constraint fit cannot explain them (it fails or leaves a reduced chi-square far above 1);
the weak-constraint fit with gust states at the nodes recovers the horizontal gust history (error well below
the gust itself, at least 95 % of the nodes inside the 3-sigma band), with a reduced chi-square near
1. The joint MAP does not recover the vertical gust (a near-constant offset), and its parameters are
biased (the worst was 4.2 sigma off on a 12.5 ms mesh); the marginal-likelihood
estimate of the same fit recovers the vertical gust and has every parameter within 4 sigma.

Not tested here: whether the gust sigmas are calibrated. One realisation spans only a few
correlation times, so its RMS normalised error says little (seed 5 gave 1.75 over a 6 s window, 0.97
over 14 s, 0.43 over 24 s for gust N); the multi-seed study is test_gust_calibration.py and
benchmarks/gust_calibration.py (it finds the slope multipliers biased with gusts)."""

import dataclasses

import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.estimation.fit import FitError, fit_drop, with_marginal_estimate
from casrecon.physics.disturbance import DisturbanceModel
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import truth_disturbance, truth_parameters_by_name, with_synthetic_data

pytestmark = pytest.mark.slow
GUSTS = DisturbanceModel((0.5, 0.5, 0.25) + (0.0,) * 6, (3.0,) * 9)
SEED = 5


@pytest.fixture(scope="module")
def gusty(tmp_path_factory):
    sc = Scenario.load(PROBLEMS / "ees-drop-3")
    cfg = sc.config
    cfg = dataclasses.replace(cfg, truth=dataclasses.replace(cfg.truth, disturbance=GUSTS),
                              estimation=dataclasses.replace(cfg.estimation, start_after_release_s=15.0))
    return with_synthetic_data(Scenario.from_config(cfg), tmp_path_factory.mktemp("gusty"), seed=SEED)


def test_strong_constraint_cannot_explain_gusts(gusty):
    try:
        r = fit_drop(gusty)
    except FitError as err:
        print("strong-constraint fit:", err)
        return
    print("strong-constraint reduced chi2", r.reduced_chi2)
    assert r.reduced_chi2 > 2.0


@pytest.fixture(scope="module")
def weak_fit(gusty):
    est = dataclasses.replace(gusty.config.estimation, disturbance=GUSTS)
    return fit_drop(Scenario.from_config(dataclasses.replace(gusty.config, estimation=est)))


def _check_recovered(r, gusty, axes):
    truth = truth_disturbance(gusty, SEED)(r.flight_time_s)
    for j, name in axes:
        value, sigma = r.column(name)
        z = (value - truth[:, j]) / sigma
        print(name, "rms error", np.sqrt(np.mean((value - truth[:, j]) ** 2)), "rms z", np.sqrt(np.mean(z**2)))
        assert np.sqrt(np.mean((value - truth[:, j]) ** 2)) < 0.5 * np.sqrt(np.mean(truth[:, j] ** 2))
        assert np.mean(np.abs(z) < 3) > 0.95


def test_gust_states_recover_the_horizontal_gusts(gusty, weak_fit):
    r = weak_fit
    assert r.converged and r.solver.hessian == "exact"
    assert 0.9 < r.reduced_chi2 < 1.1
    _check_recovered(r, gusty, [(0, "gust_n_mps"), (1, "gust_e_mps")])
    # the joint MAP's parameters are not asserted: with gusts it biases the slope multipliers by
    # several sigma (test_gust_calibration.py); on a 12.5 ms mesh its worst here was 4.2 sigma
    print("joint MAP worst parameter z", _worst_z(r, gusty))


def _worst_z(r, gusty) -> tuple[str, float]:
    t = truth_parameters_by_name(gusty)
    return max(((n, (v - t[n]) / s) for n, v, s in zip(r.params.names, r.values, r.sigma)), key=lambda x: abs(x[1]))


@pytest.fixture(scope="module")
def marginal_fit(weak_fit):
    return with_marginal_estimate(weak_fit)


@pytest.mark.xfail(strict=True, reason=(
    "issue 13: with the gusts' midpoint values (docs/design.md, Weak-constraint disturbances) the marginal "
    "vertical gust on this 24 s window is off by a near-constant -1.24 sigma: RMS error 0.146 m/s against the "
    "test's 0.138, half the true RMS (0.141 with midpoint values alone, 0.140 on a 12.5 ms mesh), every node "
    "inside its 3-sigma band; with gusts linear between nodes 0.124. Over 24 whole-drop seeds the vertical gust "
    "is calibrated (NEES 810.8 over 857, window-mean z RMS 1.00, mean +0.10)"))
def test_marginal_estimate_recovers_the_vertical_gust(gusty, marginal_fit):
    """The joint MAP's vertical gust over the 24 s window was off by 0.23 m/s RMS (true RMS 0.28)
    with RMS z 2.0, a near-constant offset traded against the drag and density parameters; the
    marginal-likelihood estimate recovered it with gusts linear between nodes (RMS error 0.124 m/s,
    RMS z 1.10); see the xfail's reason for what it does now."""
    assert marginal_fit.solver.marginal.converged
    _check_recovered(marginal_fit, gusty, [(2, "gust_d_mps")])
    name, z = _worst_z(marginal_fit, gusty)
    print("marginal worst parameter", name, z)
    assert abs(z) < 4.0
