"""Gust hypothesis (slow): synthetic drop-3 data with Gauss-Markov gusts the balloon did not see.

The strong-constraint fit cannot explain them (it fails or leaves a reduced chi-square far above 1);
the weak-constraint fit with gust states at the nodes recovers the horizontal gust history (error well below
the gust itself, at least 95 % of the nodes inside the 3-sigma band), with a reduced chi-square near
1. The joint MAP does not recover the vertical gust (a near-constant offset), and its parameters are
biased (the worst was 4.2 sigma off on a 12.5 ms mesh); the marginal-likelihood
estimate of the same fit recovers the vertical gust and has every parameter within 4 sigma.

The gust checks are made on seed 5 and, pooled, on the first eight seeds (the seed study): the
criterion "error below half the true RMS" is decided on one 24 s realisation by how far the truth's
window mean lies from zero, which the data barely observe for the vertical gust: the marginal
estimate fails it on at least one axis on six of the eight seeds (seed 5 by its vertical gust).

Not tested here: whether the gust sigmas are calibrated node by node. One realisation spans only a
few correlation times, so its RMS normalised error says little (seed 5 gave 1.75 over a 6 s window,
0.97 over 14 s, 0.43 over 24 s for gust N); the multi-seed studies are test_gust_calibration.py,
test_gust_calibration_whole_drop.py and benchmarks/gust_calibration.py."""

import dataclasses

import numpy as np
import pytest
from conftest import PROBLEMS
from scipy import stats

from casrecon.estimation.sixdof.fit import FitError, fit_drop, with_marginal_estimate
from casrecon.physics.disturbance import DisturbanceModel
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import truth_disturbance, truth_parameters_by_name, with_synthetic_data

pytestmark = pytest.mark.slow
GUSTS = DisturbanceModel((0.5, 0.5, 0.25) + (0.0,) * 6, (3.0,) * 9)
SEED = 5
SEEDS = tuple(range(1, 9))  # the seed study's seeds: the first eight, none left out


def gusty_drop(folder, seed: int) -> Scenario:
    """Drop 3 flown through GUSTS (seed ``seed``), the fit's window from 15 s after release."""
    cfg = Scenario.load(PROBLEMS / "ees-drop-3").config
    cfg = dataclasses.replace(cfg, truth=dataclasses.replace(cfg.truth, disturbance=GUSTS),
                              estimation=dataclasses.replace(cfg.estimation, start_after_release_s=15.0))
    return with_synthetic_data(Scenario.from_config(cfg), folder, seed=seed)


def weak_constraint(scenario: Scenario) -> Scenario:
    """The same drop fitted with gust states (the truth's GUSTS as the prior)."""
    est = dataclasses.replace(scenario.config.estimation, disturbance=GUSTS)
    return Scenario.from_config(dataclasses.replace(scenario.config, estimation=est))


@pytest.fixture(scope="module")
def gusty(tmp_path_factory):
    return gusty_drop(tmp_path_factory.mktemp("gusty"), SEED)


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
    return fit_drop(weak_constraint(gusty))


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


@dataclasses.dataclass(frozen=True)
class GustAxis:
    """One fit's gust on one axis of the window against the truth (m/s at the nodes)."""

    error_mps: np.ndarray
    truth_mps: np.ndarray
    sigma_mps: np.ndarray
    mean_error_mps: float        # the window mean's error
    mean_sigma_mps: float        # its 1-sigma from the fit's covariance (node values only)

    @property
    def inside_3_sigma(self) -> float:
        return float(np.mean(np.abs(self.error_mps / self.sigma_mps) < 3))


AXES = ("gust_n_mps", "gust_e_mps", "gust_d_mps")


def gust_axes(r, scenario, seed: int) -> dict[str, GustAxis]:
    """Each gust axis of fit ``r`` against the truth of ``seed``."""
    truth = truth_disturbance(scenario, seed)(r.flight_time_s)
    out = {}
    for j, name in enumerate(AXES):
        value, sigma = r.column(name)
        entry = list(r.part.active).index(j)
        cols = r.part.u_cols[:, entry]
        cov = r.covariance.covariance_of(cols, np.full(cols.size, r.part.u_scale[entry]))
        mean = np.full(cols.size, 1.0 / cols.size)
        error = value - truth[:, j]
        out[name] = GustAxis(error, truth[:, j], sigma, float(np.mean(error)), float(np.sqrt(mean @ cov @ mean)))
    return out


@dataclasses.dataclass(frozen=True)
class SeedFit:
    """One seed's fit: its gust axes and its parameter farthest from the truth (name, z)."""

    axes: dict[str, GustAxis]
    worst_parameter: tuple[str, float]


@pytest.fixture(scope="module")
def seed_study(tmp_path_factory, gusty, weak_fit, marginal_fit):
    """The 24 s window of the first eight seeds (seed 5's fits are the module's), each fitted by the
    joint MAP and moved to the marginal estimate: {"map": [SeedFit...], "marginal": [...]}."""
    study = {"map": [], "marginal": []}
    for seed in SEEDS:
        if seed == SEED:
            scenario, joint, marginal = gusty, weak_fit, marginal_fit
        else:
            scenario = gusty_drop(tmp_path_factory.mktemp(f"gusty{seed}"), seed)
            joint = fit_drop(weak_constraint(scenario))
            marginal = with_marginal_estimate(joint)
        assert joint.converged and marginal.solver.marginal.converged
        for name, r in (("map", joint), ("marginal", marginal)):
            study[name].append(SeedFit(gust_axes(r, scenario, seed), _worst_z(r, scenario)))
    return study


def pooled(fits: list[SeedFit], axis: str) -> dict[str, float]:
    """The study's figures on one axis over seeds: RMS error and half the true RMS (m/s), the window
    means' chi-square (over len(fits) dof) and the smallest share of nodes inside the 3-sigma band."""
    gusts = [f.axes[axis] for f in fits]
    out = {"rms_error": np.sqrt(np.mean(np.concatenate([g.error_mps for g in gusts]) ** 2)),
           "half_true_rms": 0.5 * np.sqrt(np.mean(np.concatenate([g.truth_mps for g in gusts]) ** 2)),
           "window_mean_chi2": sum((g.mean_error_mps / g.mean_sigma_mps) ** 2 for g in gusts),
           "least_inside_3_sigma": min(g.inside_3_sigma for g in gusts)}
    for seed, g in zip(SEEDS, gusts):
        print(f"{axis} seed {seed}: rms error {np.sqrt(np.mean(g.error_mps ** 2)):.3f} (half the true RMS "
              f"{0.5 * np.sqrt(np.mean(g.truth_mps ** 2)):.3f}), window mean {g.mean_error_mps:+.3f} "
              f"+- {g.mean_sigma_mps:.3f}, inside 3 sigma {g.inside_3_sigma:.3f}")
    print(axis, {k: round(float(v), 4) for k, v in out.items()})
    return out


def test_marginal_estimate_recovers_the_vertical_gust(seed_study):
    """Pooled over the first eight seeds the marginal estimate's vertical gust is within half the
    true RMS, its window means are calibrated and every node of every seed is inside its band, and
    every parameter is within 4 sigma. One seed is no test of this: the window mean of the vertical
    gust is barely observed (its sigma 0.109 m/s against the prior's 0.117 on seed 5: a constant
    vertical wind trades against the drag and density factors), so a calibrated estimate misses half
    the true RMS on one realisation in five (0.215 on seed 5 by the fit's own covariance); seed 5,
    whose truth has a window mean of +0.18 m/s, is off by 0.146 m/s against its 0.138 (gusts linear
    between nodes: 0.124), while pooled over these eight seeds the model with midpoint values is off
    by 0.125 m/s against 0.129 and gusts linear between nodes by 0.134."""
    figures = pooled(seed_study["marginal"], "gust_d_mps")
    assert figures["rms_error"] < figures["half_true_rms"]
    assert figures["window_mean_chi2"] < stats.chi2.ppf(0.975, len(SEEDS))
    assert figures["least_inside_3_sigma"] > 0.95
    print("worst parameters", [f.worst_parameter for f in seed_study["marginal"]])
    assert all(abs(f.worst_parameter[1]) < 4.0 for f in seed_study["marginal"])


def test_marginal_estimate_recovers_the_horizontal_gusts_on_every_seed(seed_study):
    """The horizontal check of seed 5 (test_gust_states_recover_the_horizontal_gusts), pooled over
    the eight seeds: on single seeds it fails on some (an error above half the true RMS)."""
    for axis in AXES[:2]:
        figures = pooled(seed_study["marginal"], axis)
        assert figures["rms_error"] < figures["half_true_rms"]
        assert figures["least_inside_3_sigma"] > 0.95


def test_joint_map_misses_the_vertical_gust(seed_study):
    """The joint MAP on the same seeds: a near-constant offset traded against the drag and density
    parameters, with the slope multipliers biased (the marginal estimate's reason to exist)."""
    figures = pooled(seed_study["map"], "gust_d_mps")
    print("worst parameters", [f.worst_parameter for f in seed_study["map"]])
    assert figures["rms_error"] > figures["half_true_rms"]
    assert figures["window_mean_chi2"] > stats.chi2.ppf(0.975, len(SEEDS))
