"""The size test of a prior process (casrecon.analysis.process_scale) on a linear-Gaussian toy whose
truth is known: a Gauss-Markov process of 150 values seen through noisy local averages. Drawn at
the prior's size the test passes at its level and the data's sigma is near the truth's; drawn
at twice or a tenth of it, the test flags it, the right way round."""

from __future__ import annotations

import numpy as np
import pytest

from casrecon.analysis.adequacy import assess
from casrecon.analysis.process_scale import ProcessPrior, ProcessScale, process_scale

N, PHI = 150, 0.9


def whitening() -> np.ndarray:
    """W with W g ~ N(0, I) for a unit Gauss-Markov sequence g (first value, then the steps)."""
    w = np.eye(N) / np.sqrt(1 - PHI ** 2)
    w[0, 0] = 1.0
    w[np.arange(1, N), np.arange(N - 1)] = -PHI / np.sqrt(1 - PHI ** 2)
    return w


def fitted_prior(rng: np.random.Generator, true_scale: float, assumed_sigma: float = 0.5) -> ProcessPrior:
    """Draw a process at ``true_scale`` times the assumed sigma, observe local means of 3 values with
    unit noise, and return the posterior at the assumed sigma as a ProcessPrior."""
    w = whitening()
    g = np.linalg.solve(w, rng.normal(size=N)) * true_scale * assumed_sigma
    h = np.zeros((N, N))
    for i in range(N):
        h[i, max(0, i - 1):i + 2] = 1 / 3
    y = h @ g + 0.05 * rng.normal(size=N)
    hw = h / 0.05
    prior_w = w / assumed_sigma
    precision = hw.T @ hw + prior_w.T @ prior_w
    p = np.linalg.inv(precision)
    g_hat = p @ (hw.T @ (y / 0.05))
    return ProcessPrior("toy", "m/s", assumed_sigma, prior_w @ g_hat, prior_w @ p @ prior_w.T)


def test_at_the_prior_size_the_test_passes_and_the_sigma_is_recovered():
    rng = np.random.default_rng(7)
    tests = [process_scale(fitted_prior(rng, 1.0), 0.01) for _ in range(40)]
    flagged = sum(t.too_large or t.too_small for t in tests)
    assert flagged <= 2, flagged
    nees = sum(t.nees for t in tests) / sum(t.dof for t in tests)
    assert 0.95 < nees < 1.05, nees
    ratio = np.array([t.estimated_sigma / t.assumed_sigma for t in tests])
    assert 0.93 < np.median(ratio) < 1.07, np.median(ratio)
    assert all(0 < t.informed < t.n for t in tests)


@pytest.mark.parametrize("scale, large", [(2.0, True), (0.1, False)])
def test_a_process_of_another_size_is_flagged_and_its_size_estimated(scale, large):
    rng = np.random.default_rng(11)
    for _ in range(5):
        t = process_scale(fitted_prior(rng, scale), 0.01)
        assert t.too_large is large and t.too_small is not large
        if large:  # the one-step estimate moves most of the way from the assumed towards the truth
            assert 1.6 < t.estimated_sigma / t.assumed_sigma < 2.4
        else:
            assert t.estimated_sigma / t.assumed_sigma < 0.5


def test_verdict_fails_on_a_large_process_and_cautions_on_a_small_one():
    rng = np.random.default_rng(3)
    white = {"ch": rng.normal(size=400)}
    large = assess(white, [], np.zeros(0), np.zeros(0), np.zeros((0, 0)), processes=(fitted_prior(rng, 2.0),))
    assert not large.trusted and "larger than assumed: toy about" in large.line
    small = assess(white, [], np.zeros(0), np.zeros(0), np.zeros((0, 0)), processes=(fitted_prior(rng, 0.1),))
    assert small.trusted and small.line.startswith("bands can be trusted, and are conservative: atmosphere profile")
    assert small.n_tests == 3 and len(small.cautions) == 1
    again = type(small).from_dict(small.to_dict())
    assert again.processes == small.processes and isinstance(again.processes[0], ProcessScale)


def test_a_refit_without_any_profile_error_the_data_see_is_the_plain_fit():
    """profile_refit: every group estimated at zero -> the profile model off (no prior sigmas); one
    group at zero -> the same unknowns with that group's prior at MIN_RATIO of the fitted sigma."""
    from conftest import PROBLEMS

    from casrecon.estimation.error_models.profile_sigma import MIN_RATIO, ProfileSigmaEstimate, profile_refit
    from casrecon.scenario import Scenario

    cfg = Scenario.load(PROBLEMS / "ees-drop-3-model-error").config
    fitted = {"wind": 0.5, "density": 0.005}
    comps = ("wind_n", "wind_e", "density")
    none = ProfileSigmaEstimate(fitted, {"wind": 0.0, "density": 0.0}, 10.0, comps, {"wind": 1.0, "density": 0.5})
    plain, prior = profile_refit(cfg, none)
    assert prior is None and none.refit
    assert plain.atmosphere.profile_wind_sigma_mps == 0 and plain.atmosphere.profile_density_sigma == 0
    some = ProfileSigmaEstimate(fitted, {"wind": 0.2, "density": 0.0}, 10.0, comps, {"wind": 30.0, "density": 0.5})
    same, prior = profile_refit(cfg, some)
    assert same is cfg and np.allclose(prior, [0.2, 0.2, MIN_RATIO * 0.005])
    close = ProfileSigmaEstimate(fitted, {"wind": 0.45, "density": 0.0055}, 1.0, comps, {"wind": 99., "density": 9.})
    assert not close.refit


def test_the_estimate_on_a_refit_is_judged_against_the_sigmas_the_refit_was_meant_to_have():
    """differs_from: a group the refit held at its floor because its estimate was 0 agrees only with
    an estimate of 0 again; a group estimated at a size agrees within REFIT_FACTOR of it."""
    from casrecon.estimation.error_models.profile_sigma import MIN_RATIO, REFIT_FACTOR, ProfileSigmaEstimate

    comps = ("wind_n", "wind_e", "density")
    fitted = {"wind": 1.8e-3, "density": MIN_RATIO * 0.005}  # the refit: wind at its estimate, density at its floor
    meant = {"wind": 1.8e-3, "density": 0.0}
    again = ProfileSigmaEstimate(fitted, {"wind": 1.7e-3, "density": 0.0}, 0.1, comps, {"wind": 9.0, "density": 0.0})
    assert not again.differs_from(meant)
    assert again.refit  # against the floor's literal sigma the zero would differ: why the refit keeps what it meant
    none = ProfileSigmaEstimate(fitted, {"wind": 0.0, "density": 0.0}, 18.1, comps, {"wind": 0.0, "density": 0.0})
    assert none.differs_from(meant)
    grown = ProfileSigmaEstimate(fitted, {"wind": 1.8e-3 * REFIT_FACTOR * 1.01, "density": 0.0}, 1.0, comps,
                                 {"wind": 20.0, "density": 0.0})
    assert grown.differs_from(meant)
    floor_grew = ProfileSigmaEstimate(fitted, {"wind": 1.8e-3, "density": 1e-4}, 1.0, comps, {"wind": 2, "density": 4})
    assert floor_grew.differs_from(meant)
