"""The Newton maximiser on an information matrix (casrecon.estimation.numerics.information_ascent),
on the split evidence's random fits (tests/unit/test_split_evidence.py), against scipy's L-BFGS-B."""

from __future__ import annotations

import numpy as np
import pytest
import scipy.sparse as sps
from scipy.optimize import brentq, minimize

from casrecon.estimation.numerics.information_ascent import BOUND_TOL, maximised, upper_bounds
from casrecon.estimation.numerics.split_evidence import RowGroup, SplitQuadraticModel
from tests.unit.test_split_evidence import problem

LOWER, UPPER = np.log(1e-4), np.log(20.0)


def larger_problem(seed: int) -> SplitQuadraticModel:
    """A random fit with groups of tens of rows (as a fit's are: hundreds), where the average
    information is close to the curvature: rest rows in (w, z_E), groups in w only, z_E only and
    both, each drawn from its own size (so that the maximum is not at the fit's sizes)."""
    rng = np.random.default_rng(seed)
    n_c, n_e = 6, 10
    rest = rng.normal(size=(40, n_c + n_e))
    groups, grams = [], []
    for n, in_c, in_e, size in [(60, True, False, 0.3), (80, False, True, 2.0), (70, True, True, 1.0)]:
        a = np.zeros((n, n_c + n_e))
        if in_c:
            a[:, :n_c] = rng.normal(size=(n, n_c))
        if in_e:
            a[:, n_c:] = rng.normal(size=(n, n_e)) * (rng.uniform(size=(n, n_e)) > 0.5)
        u = size * rng.normal(size=n)
        grams.append(a.T @ a)
        groups.append(RowGroup(a[:, :n_c] if in_c else None, sps.csr_matrix(a[:, n_c:]) if in_e else None, u, n))
    h = rest.T @ rest + sum(grams)
    return SplitQuadraticModel(h[:n_c, :n_c], h[n_c:, :n_c], sps.csc_matrix(h[n_c:, n_c:]), groups)


def reference_maximum(model, lower, upper):
    return minimize(lambda x: tuple(-v for v in model.log_evidence(x)), np.zeros(3), jac=True,
                    method="L-BFGS-B", bounds=list(zip(lower, upper)), options={"ftol": 1e-12, "gtol": 1e-9})


def counted(model):
    calls = []

    def function(x):
        calls.append(x)
        return model.log_evidence_with_information(x)
    return function, calls


@pytest.mark.parametrize("seed, chains", [(0, False), (1, False), (2, False), (3, True), (4, True)])
def test_the_maximum_is_l_bfgs_b_s(seed, chains):
    """On the small random fits (groups of 3 to 9 rows, where the information is a rough curvature)
    the same maximum, within the tolerance."""
    model, _, _ = problem(seed, chains)
    lower, upper = np.full(3, LOWER), np.full(3, UPPER)
    function, calls = counted(model)
    ours = maximised(function, np.zeros(3), lower, upper, tolerance=1e-6)
    reference = reference_maximum(model, lower, upper)
    assert ours.success, ours.message
    assert ours.nfev == len(calls)
    assert ours.fun <= reference.fun + 1e-5  # as high a log evidence, or higher
    assert np.all(ours.jac[ours.x <= LOWER + 1e-6] >= -1e-6)  # held at a bound by its gradient


@pytest.mark.parametrize("seed", [0, 1, 2, 3])
def test_groups_of_many_rows_take_fewer_evaluations(seed):
    model = larger_problem(seed)
    lower, upper = np.full(3, LOWER), np.full(3, UPPER)
    function, calls = counted(model)
    ours = maximised(function, np.zeros(3), lower, upper, tolerance=1e-6)
    reference = reference_maximum(model, lower, upper)
    assert ours.success, ours.message
    assert ours.fun <= reference.fun + 1e-5
    np.testing.assert_allclose(ours.x, reference.x, atol=2e-3)
    assert ours.nfev < reference.nfev, (ours.nfev, reference.nfev)


def test_the_information_is_symmetric_and_positive_semidefinite():
    model, _, _ = problem(3, True)
    for x in (np.zeros(3), np.array([0.5, -1.0, 0.3])):
        _, _, info = model.log_evidence_with_information(x)
        np.testing.assert_allclose(info, info.T, atol=1e-9 * np.abs(info).max())
        assert np.linalg.eigvalsh(info)[0] >= -1e-9 * np.abs(info).max()


def test_a_bound_holds_and_a_bad_start_is_left():
    """A variable whose maximum lies beyond its bound stays on it; a start where the function
    gives no information (the penalty region) is left along the gradient's signs."""
    peak = np.array([1.0, -3.0])

    def function(x):
        if x[0] > 2.5:  # "not positive definite" there: the value falls, no information
            return -1e12, np.array([-1e12, 0.0]), None
        return -float(np.sum((x - peak) ** 2)), -2.0 * (x - peak), 2.0 * np.eye(2)

    out = maximised(function, np.array([3.0, 0.0]), np.array([-1.0, -2.0]), np.array([4.0, 2.0]))
    assert out.success
    np.testing.assert_allclose(out.x, [1.0, -2.0], atol=1e-6)


def test_a_variable_the_data_hardly_see_does_not_slow_the_others():
    """A size at its lower bound whose Newton step, through its correlation with another, points
    far out of the bounds (its own gradient pointing in) is held there, and does not shorten the
    other's step (found on the default fit's GPS sizes, where a density ratio at its lower bound
    held a velocity ratio to steps of 0.5 % for 17 evaluations)."""
    hessian = np.array([[2.0, 1e-4], [1e-4, 1e-8]])
    peak = np.array([3.0, -1e4])

    def function(x):
        d = x - peak
        return -0.5 * float(d @ hessian @ d), -hessian @ d, hessian

    start = np.array([0.0, -1.0])
    assert function(start)[1][1] > 0  # the bound's variable is pulled inwards by its gradient
    out = maximised(function, start, np.array([-5.0, -1.0]), np.array([5.0, 1.0]), tolerance=1e-9)
    assert out.success, out.message
    assert out.x[1] == -1.0 and out.nfev <= 4
    np.testing.assert_allclose(out.x[0], 3.0 - 1e-4 * (-1.0 - peak[1]) / 2.0, atol=1e-6)


def test_a_step_beyond_the_largest_is_shortened_along_the_least_information():
    """A Newton step with an entry beyond MAX_STEP is shortened by a Levenberg-Marquardt shift: the
    well-determined variable still moves (almost) its full step."""
    def function(x):
        value = -(x[0] - 1.0) ** 2 - 1e-6 * (x[1] - 50.0) ** 2
        return value, np.array([-2.0 * (x[0] - 1.0), -2e-6 * (x[1] - 50.0)]), np.diag([2.0, 2e-6])

    out = maximised(function, np.zeros(2), np.array([-5.0, -100.0]), np.array([5.0, 100.0]), tolerance=1e-12,
                    max_evaluations=2)
    assert abs(out.x[0] - 1.0) < 0.01 and 0.0 < out.x[1] <= 2.0  # one step: x0 there, x1 capped


# --- upper_bounds: each variable's likelihood-ratio upper bound along its profile direction ---

DROP = 1.92


def _quadratic(mu: np.ndarray, a: np.ndarray):
    return lambda x: float(-0.5 * (x - mu) @ a @ (x - mu))


def test_a_well_determined_variable_gets_the_quadratic_bound():
    mu, a = np.array([0.3, -0.2]), np.array([[400.0, 100.0], [100.0, 300.0]])
    bounds = upper_bounds(_quadratic(mu, a), mu, 0.0, a, np.full(2, -10.0), np.full(2, 10.0), np.array([0, 1]), DROP)
    exact = mu + np.sqrt(2 * DROP * np.diag(np.linalg.inv(a)))
    assert bounds == pytest.approx(exact, rel=1e-3)


def test_a_weakly_determined_variable_is_searched_along_its_profile():
    """Correlated with another: the profile bound (the other moving with it) is wider than the
    conditional one, and the search finds it to BOUND_TOL from an information three times too
    large (an average information is not the curvature: the quadratic start is short)."""
    mu, a = np.array([0.0, 0.5]), np.array([[0.5, 0.45], [0.45, 0.5]])
    function = _quadratic(mu, a)
    bounds = upper_bounds(function, mu, 0.0, 3 * a, np.full(2, -20.0), np.full(2, 20.0), np.array([0]), DROP)
    profile = mu[0] + np.sqrt(2 * DROP * np.linalg.inv(a)[0, 0])
    conditional = mu[0] + np.sqrt(2 * DROP / a[0, 0])
    assert profile > conditional + 1.0
    assert abs(bounds[0] - profile) <= BOUND_TOL
    assert bounds[1] == mu[1]  # not asked for


def test_a_flat_variable_is_bounded_by_its_upper_limit_and_an_asymmetric_one_by_the_function():
    flat = upper_bounds(lambda x: 0.0, np.zeros(1), 0.0, np.zeros((1, 1)), np.full(1, -5.0), np.full(1, 3.0),
                        np.array([0]), DROP)
    assert flat[0] == 3.0
    # f(x) = x - e^x, maximum -1 at 0; f = -1 - DROP at the bound
    bound = upper_bounds(lambda x: float(x[0] - np.exp(x[0])), np.zeros(1), -1.0, np.ones((1, 1)),
                         np.full(1, -10.0), np.full(1, 10.0), np.array([0]), DROP)
    root = brentq(lambda t: t - np.exp(t) + 1 + DROP, 0.0, 5.0)
    assert abs(bound[0] - root) <= BOUND_TOL and bound[0] <= root
