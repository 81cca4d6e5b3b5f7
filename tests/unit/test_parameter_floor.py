"""The widened covariance's floor: every parameter direction widened at least a share of the most
widened one's factor (casrecon.analysis.widened_uncertainty.parameter_floor)."""

import numpy as np

from casrecon.analysis.widened_uncertainty import combination_floor, parameter_floor
from casrecon.estimation.engine.block_sandwich import covering, grown_along, grown_to


def random_covariance(rng, n):
    a = rng.normal(size=(n, n))
    return a @ a.T + n * np.eye(n)


def test_floor_widens_every_parameter_direction_by_a_share_of_the_largest_factor():
    rng = np.random.default_rng(3)
    n_w, theta = 12, np.array([1, 4, 7])
    model = random_covariance(rng, n_w)
    rows = np.eye(n_w)[theta]
    widened = model + 40.0 * np.outer(model @ rows.T @ [1.0, 0.0, 0.0], model @ rows.T @ [1.0, 0.0, 0.0]) / model[1, 1]
    k, floor = parameter_floor(model, widened, rows, share=0.5)
    m_t, w_t = rows @ model @ rows.T, rows @ widened @ rows.T
    lam = np.linalg.eigvals(np.linalg.solve(m_t, w_t)).real
    assert np.isclose(k, 0.5 * np.max(lam)) and k > 10.0  # one direction widened by the sandwich, 41 times
    np.testing.assert_allclose(rows @ floor @ rows.T, k * m_t, rtol=1e-10)  # every direction k times
    # the states grow only by what the parameters explain: their covariance given the parameters stays
    rest = np.setdiff1d(np.arange(n_w), theta)

    def conditional(c):
        cross = c[np.ix_(rest, theta)]
        return c[np.ix_(rest, rest)] - cross @ np.linalg.solve(c[np.ix_(theta, theta)], cross.T)

    np.testing.assert_allclose(conditional(floor), conditional(model), rtol=1e-8, atol=1e-10)
    both = covering(widened, [floor])
    for c in (widened, floor):
        assert np.min(np.linalg.eigvalsh(both - c)) > -1e-8 * np.max(np.abs(both))


def test_no_floor_when_nothing_was_widened():
    rng = np.random.default_rng(4)
    model = random_covariance(rng, 6)
    k, floor = parameter_floor(model, model, np.eye(6)[[0, 2]])
    assert k == 1.0
    np.testing.assert_allclose(floor, model)


def test_floor_is_one_when_the_largest_factor_is_below_the_share():
    rng = np.random.default_rng(5)
    model = random_covariance(rng, 5)
    rows = np.eye(5)[[0, 1]]
    k, floor = parameter_floor(model, 3.0 * model, rows, share=0.1)  # widened x3 everywhere: 0.3 < 1
    assert k == 1.0
    np.testing.assert_allclose(floor, model)


def test_grown_along_scales_the_combinations_and_keeps_the_rest_given_them():
    rng = np.random.default_rng(3)
    a = rng.normal(size=(6, 6))
    c = a @ a.T + 0.1 * np.eye(6)
    rows = rng.normal(size=(2, 6))
    f = grown_along(c, rows, 5.0)
    np.testing.assert_allclose(rows @ f @ rows.T, 5.0 * rows @ c @ rows.T, rtol=1e-10)
    assert np.min(np.linalg.eigvalsh(f - c)) > -1e-10  # it only grows

    def given_rows(m):
        return m - m @ rows.T @ np.linalg.solve(rows @ m @ rows.T, rows @ m)

    np.testing.assert_allclose(given_rows(f), given_rows(c), atol=1e-10)
    np.testing.assert_allclose(grown_along(c, rows, 1.0), c)


def test_grown_to_sets_the_combinations_covariance_and_keeps_the_rest_given_them():
    rng = np.random.default_rng(8)
    a = rng.normal(size=(7, 7))
    c = a @ a.T + 0.1 * np.eye(7)
    rows = rng.normal(size=(3, 7))
    p = rows @ c @ rows.T
    b = rng.normal(size=(3, 3))
    target = p + b @ b.T
    f = grown_to(c, rows, target)
    np.testing.assert_allclose(rows @ f @ rows.T, target, rtol=1e-10)
    assert np.min(np.linalg.eigvalsh(f - c)) > -1e-10
    np.testing.assert_allclose(grown_to(c, rows, 5.0 * p), grown_along(c, rows, 5.0), rtol=1e-10)


def test_combination_floor_raises_only_the_near_degenerate_combination():
    rng = np.random.default_rng(9)
    n_w, theta = 10, np.array([0, 3, 5, 8])
    rows = np.eye(n_w)[theta]
    vec, _ = np.linalg.qr(rng.normal(size=(4, 4)))
    corr = vec @ np.diag([5e-4, 0.6, 1.2, 2.2]) @ vec.T
    scale = np.diag(1.0 / np.sqrt(np.diag(corr)) * [1.0, 3.0, 0.2, 7.0])
    p_theta = scale @ corr @ scale  # one combination known to about 2 % of its parts' sigmas
    gain = rng.normal(size=(n_w - 4, 4))  # the states: their regression on the parameters, plus their own
    rest = np.setdiff1d(np.arange(n_w), theta)
    c = np.zeros((n_w, n_w))
    c[np.ix_(theta, theta)] = p_theta
    c[np.ix_(rest, theta)] = gain @ p_theta
    c[np.ix_(theta, rest)] = p_theta @ gain.T
    c[np.ix_(rest, rest)] = gain @ p_theta @ gain.T + random_covariance(rng, n_w - 4)
    p = rows @ c @ rows.T
    s = np.sqrt(np.diag(p))
    lam_before = np.linalg.eigvalsh(p / np.outer(s, s))
    assert lam_before[0] < 1e-3 < lam_before[1]
    m, f = combination_floor(c, rows, smallest=1e-3)
    assert m == 1
    q = rows @ f @ rows.T
    sq = np.sqrt(np.diag(q))
    lam_after = np.linalg.eigvalsh(q / np.outer(s, s))  # in the sigmas before
    np.testing.assert_allclose(lam_after[0], 1e-3, rtol=1e-6)
    np.testing.assert_allclose(lam_after[1:], lam_before[1:], rtol=1e-8)
    assert np.all(sq >= s) and np.all(sq <= s * np.sqrt(1 + 1e-3) + 1e-12)
    plain = random_covariance(rng, n_w)  # correlations far from degenerate: nothing raised
    m0, same = combination_floor(plain, rows, smallest=1e-3)
    assert m0 == 0
    np.testing.assert_array_equal(same, plain)
