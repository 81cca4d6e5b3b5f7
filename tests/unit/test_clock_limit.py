"""The clock offset's plausibility limit in the clock-offset continuation: bounds clamped to 3 sigma
of its prior, a solution on that limit held (not shifted), a user's guess beyond it left alone."""

from __future__ import annotations

from types import SimpleNamespace

import numpy as np
import pytest

from casrecon.estimation.sixdof.continuation import at_limit, clock_bounds, clock_limit_s, held_clock_text


def _part(guess_s: float, prior_sigma_s: float = 0.05, h_s: float = 0.025, scale: float = 0.05):
    spec = SimpleNamespace(prior_sigma=prior_sigma_s, scale=scale)
    params = SimpleNamespace(names=("CA_mult", "clock_offset_s"), specs=(None, spec), scales=np.array([1.0, scale]),
                             index=lambda name: ("CA_mult", "clock_offset_s").index(name))
    return SimpleNamespace(name="drop", params=params, mesh=SimpleNamespace(h=h_s), guess_clock_s=guess_s,
                           theta_cols=np.array([3, 4]))


def _bounds_s(part) -> tuple[float, float]:
    lo, hi = clock_bounds([part], 6)
    return lo[4] * 0.05, hi[4] * 0.05


def test_the_limit_is_three_prior_sigmas_or_the_scale_without_a_prior():
    assert clock_limit_s(_part(0.0)) == pytest.approx(0.15)
    assert clock_limit_s(_part(0.0, prior_sigma_s=None, scale=0.1)) == pytest.approx(0.3)


def test_inside_the_limit_the_bounds_are_one_interval_either_side():
    assert _bounds_s(_part(0.05)) == pytest.approx((0.025, 0.075))
    lo, hi = clock_bounds([_part(0.05)], 6)
    assert np.all(np.isinf(np.delete(lo, 4))) and np.all(np.isinf(np.delete(hi, 4)))


def test_near_the_limit_the_bounds_stop_there():
    assert _bounds_s(_part(0.14)) == pytest.approx((0.115, 0.15))
    assert _bounds_s(_part(-0.14)) == pytest.approx((-0.15, -0.115))


def test_a_guess_beyond_the_limit_is_not_clamped():
    """A user's clock_offset_guess_s beyond 3 sigma: the interval around it, as before the limit."""
    assert _bounds_s(_part(0.4)) == pytest.approx((0.375, 0.425))


def test_only_a_solution_on_the_limit_is_held():
    fit_nlp = SimpleNamespace(parts=[_part(0.14)])
    assert at_limit(fit_nlp, "drop", 0.15)
    assert not at_limit(fit_nlp, "drop", 0.115)  # the interval's lower bound: a shift, not a hold
    beyond = SimpleNamespace(parts=[_part(0.4)])
    assert not at_limit(beyond, "drop", 0.425)  # a guess beyond the limit moves as before


def test_the_finding_names_the_offset_the_limit_and_the_causes():
    text = held_clock_text(_part(0.0), 0.15)
    assert "held at +0.150 s" in text and "3 sigma of its prior, 0.150 s" in text
    assert "does not fit the data" in text and "utc_at_zero" in text
