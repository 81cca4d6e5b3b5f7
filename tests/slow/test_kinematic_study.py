"""The kinematic reconstruction's acceptance study (issue 14): 10 synthetic ees-drop-1 cases with
truths drawn from the priors, each fitted with its IMU at 500, 100 and 13 Hz: pooled over the
cases, at least 98 % of the node values of position, velocity and attitude lie inside their
3-sigma bands, and the parameter NEES lies inside its 95 % interval (benchmarks/kinematic_truth.py
prints the same study)."""

import pytest

from casrecon.analysis.kinematic_truth import kinematic_truth_study

pytestmark = pytest.mark.slow


def test_kinematic_reconstruction_is_honest_at_three_imu_rates():
    study = kinematic_truth_study("problems/ees-drop-1", 10, (1, 5, 38), seed=0, workers=2)
    for step, s in study.items():
        assert not s["failed"], (step, s["failed"])
        for group, share in s["coverage"].items():
            assert share >= 0.98, (s["rate_hz"], group, share)
        lo, hi = s["nees_interval"]
        assert lo <= s["nees"] <= hi, (s["rate_hz"], s["nees"], lo, hi)
