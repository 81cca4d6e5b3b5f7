"""The full-space solver's slow-mode extrapolation (kkt_gauss_newton.SlowMode): the rate is given only
when the last three steps are parallel and shrink at one rate, and the extrapolated step sums what
such a sequence has still to go."""

import numpy as np

from casrecon.estimation.engine.kkt_gauss_newton import SLOW_MODE_MAX_RATE, SlowMode


def record(*steps: np.ndarray) -> SlowMode:
    mode = SlowMode()
    for s in steps:
        mode = mode.after(s, restart=False)
    return mode


def test_a_linearly_converging_sequence_gives_its_rate_and_the_extrapolation_its_limit():
    rng = np.random.default_rng(0)
    direction, rho = rng.standard_normal(50), 0.45
    z_star, e0 = rng.standard_normal(50), 3.0 * direction
    # z_k = z* + rho^k e0: steps (rho - 1) rho^k e0, with a little of a fast mode in each
    z = [z_star + rho ** k * e0 + 0.1 ** k * 1e-4 * rng.standard_normal(50) for k in range(5)]
    steps = np.diff(z, axis=0)
    mode = record(steps[0], steps[1])
    rate = mode.rate(steps[2])
    assert rate is not None and abs(rate - rho) < 1e-3
    extrapolated = z[2] + steps[2] / (1.0 - rate)
    assert np.abs(extrapolated - z_star).max() < 1e-3 * np.abs(z[2] - z_star).max()


def test_turning_or_changing_steps_give_no_rate():
    rng = np.random.default_rng(1)
    a, b = rng.standard_normal(20), rng.standard_normal(20)
    assert record(a, 0.5 * a).rate(0.25 * b) is None  # the new step turns
    assert record(a, 0.5 * a).rate(0.1 * a) is None  # the rate changes from 0.5 to 0.2
    assert record(a, 0.95 * a).rate(0.95 ** 2 * a) is None  # too slow: 1 / (1 - rate) beyond 10
    assert 0.95 > SLOW_MODE_MAX_RATE
    assert record(a).rate(0.5 * a) is None  # two steps are not enough
    assert record(a, 0.5 * a).rate(np.r_[0.25 * a, 0.0]) is None  # a rebuilt NLP: other unknowns


def test_an_extrapolated_or_shortened_step_starts_the_count_again():
    a = np.ones(10)
    mode = record(a, 0.5 * a).after(0.25 * a / 0.5, restart=True)
    assert mode.rate(0.01 * a) is None


def test_two_alternating_modes_give_their_rate_every_two_steps_and_the_extrapolation_its_limit():
    """Steps that turn between two modes (eigenvalues +-sqrt(rho2) of the iteration's map, as on a
    sounding-pair drop's refit) are not one slow mode, but every step is the one two before times
    rho2: the paired rate, and the extrapolated step lands on the limit."""
    rng = np.random.default_rng(2)
    u, v = rng.standard_normal(40), rng.standard_normal(40)
    rho2 = 0.7
    root = np.sqrt(rho2)
    z_star = rng.standard_normal(40)
    # e_k = (+root)^k a u + (-root)^k b v: the even and odd steps parallel, neighbours turning
    z = [z_star + root ** k * 2.0 * u + (-root) ** k * 1.5 * v for k in range(6)]
    steps = np.diff(z, axis=0)
    mode = record(steps[0], steps[1], steps[2])
    assert mode.rate(steps[3]) is None  # neighbours are not parallel
    paired = mode.paired_rate(steps[3])
    assert paired is not None and abs(paired - rho2) < 1e-9
    step, what = mode.extrapolated(steps[3], steps[3])  # every step on the null space here
    assert "two alternating modes" in what
    assert np.abs(z[3] + step - z_star).max() < 1e-9 * np.abs(z[3] - z_star).max()


def test_steps_that_do_not_repeat_every_two_give_no_paired_rate():
    rng = np.random.default_rng(3)
    a, b, c = rng.standard_normal(20), rng.standard_normal(20), rng.standard_normal(20)
    assert record(a, b, 0.5 * a).paired_rate(c) is None  # the new step does not repeat the one two before
    assert record(a, b, 0.5 * a).paired_rate(0.2 * b) is None  # the rates differ (0.5 and 0.2)
    assert record(b, 0.5 * a).paired_rate(0.25 * b) is None  # three steps are needed before the new one
    assert record(a, b, 0.5 * a).extrapolated(c, c) is None
