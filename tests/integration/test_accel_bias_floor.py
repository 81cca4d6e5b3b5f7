"""The accelerometer bias along the specific force from the GPS velocities and the IMU alone
(casrecon.analysis.accel_bias_floor; issue 49): right on an exact-model drop, where it leaves the fit
alone, and a fit whose bias is traded against forces the model lacks is widened to cover it."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest

from casrecon.analysis.accel_bias_floor import BIAS_NAMES, DETECTION_SIGMA, NOTE_START, bias_floored, kinematic_bias
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import truth_parameters_by_name

PROBLEMS = Path(__file__).resolve().parents[2] / "problems"


@pytest.fixture(scope="module")
def exact_fit():
    scenario = Scenario.load(PROBLEMS / "ees-drop-1")
    return fit_drop(scenario), truth_parameters_by_name(scenario)


def test_the_kinematic_bias_is_the_truth_and_leaves_a_right_fit_alone(exact_fit):
    result, truth = exact_fit
    check = kinematic_bias(result)
    assert check is not None and check.n_fixes > 100
    u = check.direction_imu
    assert abs(np.linalg.norm(u) - 1.0) < 1e-12 and abs(u[0]) > 0.95  # the capsule's axis
    true_u = float(u @ np.array([truth[n] for n in BIAS_NAMES]))
    assert abs(check.kinematic_mps2 - true_u) < 3.0 * check.kinematic_sigma_mps2
    assert 0.5 < check.reduced_chi2 < 2.0
    assert check.kinematic_sigma_mps2 < 0.005  # informative: a tenth of the bias prior's 0.05 m/s^2
    assert abs(check.z) < DETECTION_SIGMA
    same, again = bias_floored(result)
    assert same is result and again.kinematic_mps2 == check.kinematic_mps2


def test_a_bias_traded_against_the_drag_is_found_and_covered(exact_fit):
    result, truth = exact_fit
    names = result.params.names
    i = names.index("accel_bias_x")
    values = result.values.copy()
    values[i] += 0.05  # as turbulence seed 262 did: 0.07 m/s^2 off with a sigma of 0.0006
    moved = dataclasses.replace(result, values=values)
    wide, check = bias_floored(moved)
    assert check is not None and abs(check.z) > 10
    assert wide.sigma[i] > 0.04  # the difference, with the kinematic sigma
    assert abs(values[i] - truth["accel_bias_x"]) < 3.0 * wide.sigma[i]
    # only the uncertainty changes, and it only grows: parameters and bands
    np.testing.assert_array_equal(wide.values, moved.values)
    assert np.all(wide.sigma >= result.sigma * (1 - 1e-9))
    assert np.all(wide.table_sigma >= result.table_sigma * (1 - 1e-9))
    # what is correlated with the bias grows with it; what is not, stays
    corr = np.abs(result.correlation[i])
    assert wide.sigma[np.argsort(corr)[-2]] > result.sigma[np.argsort(corr)[-2]] * 1.5
    j = int(np.argmin(corr))
    assert wide.sigma[j] == pytest.approx(result.sigma[j], rel=0.05)
    # the widened covariance is a covariance (symmetric, unit diagonal of correlations)
    np.testing.assert_allclose(np.diag(wide.correlation), 1.0, atol=1e-9)
    np.testing.assert_allclose(wide.correlation, wide.correlation.T, atol=1e-9)
    note = wide.notes[-1]
    assert note.startswith(NOTE_START) and "GPS velocities" in note
