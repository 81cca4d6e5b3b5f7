"""The absolute position's floor from the GPS fixes (casrecon.analysis.position_floor)."""

import numpy as np
import pytest

from casrecon.analysis.position_floor import offset_variance


def test_white_errors_give_the_weighted_mean_variance():
    sigma = np.array([2.0, 3.0, 4.0, 2.5])
    assert offset_variance(np.arange(4.0), sigma, 0.0, 0.0) == pytest.approx(1.0 / np.sum(sigma ** -2.0))
    # a correlation time without a correlated share, or a share without a time, is white too
    assert offset_variance(np.arange(4.0), sigma, 0.0, 50.0) == pytest.approx(1.0 / np.sum(sigma ** -2.0))
    assert offset_variance(np.arange(4.0), sigma, 0.9, 0.0) == pytest.approx(1.0 / np.sum(sigma ** -2.0))


def test_a_constant_error_is_not_averaged_away():
    t = np.linspace(0.0, 40.0, 200)
    sigma = np.full(t.size, 2.5)
    # nearly all of the variance correlated over far longer than the drop: the offset is known only
    # to about the correlated part's size, not to sigma / sqrt(n)
    v = offset_variance(t, sigma, 0.99, 1e6)
    assert v == pytest.approx(0.99 * 2.5 ** 2, rel=0.01)
    assert v > 100 * 2.5 ** 2 / t.size
    # the classical result for a Gauss-Markov process of time tau over a span T: 2 tau / (T + 2 tau) of its variance
    tau, span = 100.0, 40.0
    dense = np.linspace(0.0, span, 4001)
    v = offset_variance(dense, np.full(dense.size, 1.0), 0.999999, tau)
    assert v == pytest.approx(2 * tau / (span + 2 * tau), rel=0.02)


def test_no_fix_is_no_information():
    assert offset_variance(np.zeros(0), np.zeros(0), 0.5, 10.0) == np.inf

