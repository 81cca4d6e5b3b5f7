"""Hand cases for the design-of-drops arithmetic (no fit needed)."""

import numpy as np
import pytest

from casrecon.analysis.observability import _crossing, multi_drop_sigma


def test_identical_drops_divide_the_data_information():
    # one drop: shared parameter s with data information 1/0.1^2 - prior 1/0.3^2 ... built explicitly:
    prior = 0.3
    data_info = 1 / 0.1**2
    cov = np.array([[1 / (data_info + 1 / prior**2)]])
    one = multi_drop_sigma(("s",), cov, ("s",), 1, {"s": prior})["s"]
    four = multi_drop_sigma(("s",), cov, ("s",), 4, {"s": prior})["s"]
    assert one == pytest.approx(np.sqrt(cov[0, 0]))
    # four drops: 4 x data information + the prior once
    assert four == pytest.approx(1 / np.sqrt(4 * data_info + 1 / prior**2))


def test_own_parameters_are_marginalised_before_summing():
    # information matrix of (s, o) with correlation: the Schur complement is what each drop adds
    info = np.array([[400.0, 150.0], [150.0, 100.0]])
    cov = np.linalg.inv(info)
    schur = 400.0 - 150.0**2 / 100.0
    got = multi_drop_sigma(("s", "o"), cov, ("s",), 3, {"s": None})["s"]
    assert got == pytest.approx(1 / np.sqrt(3 * schur))


def test_crossing_interpolates_linearly():
    assert _crossing(np.array([0.0, 1.0, 2.0]), np.array([0.0, 4.0, 16.0]), 9.0) == pytest.approx(1.4166666)


def test_marginal_profile_minimum_is_the_local_parabola_vertex():
    from casrecon.analysis.marginal import MarginalProfile

    x = np.linspace(-2.0, 6.0, 9)
    joint = np.where(np.abs(x - 1.3) < 3.0, (x - 1.3) ** 2, 100.0)  # far points outside the 5-point window
    marginal = (x - 5.5) ** 2  # minimum near the grid's end: the window is clipped to the last 3 points
    prof = MarginalProfile("p", x, joint, marginal, np.ones(9, bool))
    assert prof.joint_minimum == pytest.approx(1.3)
    assert prof.marginal_minimum == pytest.approx(5.5)
