"""Synthetic drops flown through the error families (issue 49): a world changes what it says and
nothing else, and the world "none" reproduces the drop without one bit for bit."""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.scenario import Scenario
from casrecon.simulation.error_families import family_world
from casrecon.simulation.synthetic import make_synthetic, world_span


@pytest.fixture(scope="module")
def drop():
    scenario = Scenario.load(PROBLEMS / "ees-drop-3")
    return scenario, make_synthetic(scenario, seed=5)


def test_the_world_none_is_the_drop_without_one(drop):
    scenario, plain = drop
    none = make_synthetic(scenario, seed=5, world=family_world("none", world_span(scenario), 5))
    assert np.array_equal(none.imu_accel_mps2, plain.imu_accel_mps2)
    assert np.array_equal(none.gps.lat_deg, plain.gps.lat_deg)
    assert none.truth["error_family"] == "none"


def test_a_gps_family_changes_the_gps_only(drop):
    scenario, plain = drop
    steps = make_synthetic(scenario, seed=5, world=family_world("gps-steps", world_span(scenario), 5))
    assert np.array_equal(steps.imu_accel_mps2, plain.imu_accel_mps2)
    assert np.array_equal(steps.gps.vel_n_mps, plain.gps.vel_n_mps)  # velocity errors stay white
    moved = np.abs(steps.gps.h_msl_m - plain.gps.h_msl_m)
    assert moved.max() > 1.0


def test_turbulence_changes_the_flight(drop):
    scenario, plain = drop
    turbulent = make_synthetic(scenario, seed=5, world=family_world("turbulence", world_span(scenario), 5))
    n = min(turbulent.imu_accel_mps2.shape[0], plain.imu_accel_mps2.shape[0])
    diff = turbulent.imu_accel_mps2[:n] - plain.imu_accel_mps2[:n]
    # gusts and metre-scale profile structure move the specific force by far more than the noise
    assert np.abs(diff).max() > 1.0
    assert turbulent.profile_error is not None and turbulent.truth["error_family"] == "turbulence"
