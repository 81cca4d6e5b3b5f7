"""The time-ordered KKT factor against dense linear algebra, on a KKT matrix shaped like a fit's:
node states chained by defects, unknowns that reach a window of nodes (like atmosphere-profile
coefficients), a few parameters that reach every node, and node blocks whose Hessian is singular."""

import numpy as np
import pytest
import scipy.sparse as sps

from casrecon.estimation.engine import time_ordered_kkt
from casrecon.estimation.engine.time_ordered_kkt import OrderedPattern, TimeOrderedKkt, time_order

N_NODES, N_STATES, N_WINDOW, N_PARAMS = 40, 3, 6, 2


def fit_like_kkt(seed: int = 0):
    """(K, n_z, stages, parameter columns): z = [node states, window unknowns, parameters]."""
    rng = np.random.default_rng(seed)
    n_x = N_NODES * N_STATES
    n_w = N_NODES // 4
    n_z = n_x + n_w + N_PARAMS
    params = np.arange(n_x + n_w, n_z)
    rows = []
    for k in range(N_NODES):  # one measurement of the first state at each node, and the window unknowns
        r = np.zeros(n_z)
        r[k * N_STATES] = 1.0
        r[n_x + min(k // 4, n_w - 1)] = 0.3
        r[params] = 0.1 * rng.standard_normal(N_PARAMS)
        rows.append(r)
    prior = np.zeros((n_w + N_PARAMS, n_z))  # priors on the window unknowns and the parameters
    prior[:, n_x:] = np.eye(n_w + N_PARAMS)
    jac = np.vstack([np.array(rows), prior])
    h = jac.T @ jac  # the other states of a node are unmeasured: singular node blocks
    a = np.zeros(((N_NODES - 1) * N_STATES, n_z))
    for k in range(N_NODES - 1):  # x_k+1 = M x_k + window + parameters
        i, j = k * N_STATES, (k + 1) * N_STATES
        a[i:i + N_STATES, j:j + N_STATES] = np.eye(N_STATES)
        a[i:i + N_STATES, i:i + N_STATES] = -(np.eye(N_STATES) + 0.1 * rng.standard_normal((N_STATES, N_STATES)))
        a[i:i + N_STATES, n_x + min(k // 4, n_w - 1)] = rng.standard_normal(N_STATES)
        a[i:i + N_STATES, params] = 0.1 * rng.standard_normal((N_STATES, N_PARAMS))
    kkt = np.block([[h, a.T], [a, np.zeros((a.shape[0], a.shape[0]))]])
    stages = np.r_[np.repeat(np.arange(N_NODES), N_STATES), -np.ones(n_w + N_PARAMS, int)]
    return sps.csc_matrix(kkt), n_z, stages, params


def factor(kkt: sps.csc_matrix, n_z: int, stages, params) -> TimeOrderedKkt:
    marker = kkt.copy()
    marker.data = np.arange(1.0, kkt.nnz + 1)
    return TimeOrderedKkt(OrderedPattern(marker, n_z, stages, params), kkt.data)


def test_solves_equal_the_dense_ones_without_pivoting():
    kkt, n_z, stages, params = fit_like_kkt()
    f = factor(kkt, n_z, stages, params)
    rhs = np.random.default_rng(1).standard_normal((kkt.shape[0], 3))
    want = np.linalg.solve(kkt.toarray(), rhs)
    np.testing.assert_allclose(f.solve(rhs), want, rtol=1e-9, atol=1e-9 * np.abs(want).max())
    np.testing.assert_allclose(f.solve(rhs[:, 0]), want[:, 0], rtol=1e-9, atol=1e-9 * np.abs(want).max())
    assert f.refined
    # the fronts stay small: far below the dense factor's n^2
    assert f.fill < 0.15 * kkt.shape[0] ** 2


def test_the_order_is_time_then_parameters():
    kkt, n_z, stages, params = fit_like_kkt()
    order = time_order(kkt, n_z, stages, params)
    assert sorted(order) == list(range(kkt.shape[0]))
    assert set(order[-N_PARAMS:]) == set(params)
    position = np.argsort(order)
    node_rows = position[:N_NODES * N_STATES].reshape(N_NODES, N_STATES)
    assert np.all(np.diff(node_rows.ravel()) > 0)  # nodes in time order, a node's states in row order
    for k in range(N_NODES - 1):  # the defect rows of interval k come after node k+1's states
        assert position[n_z + k * N_STATES] > node_rows[k + 1].max()


def test_a_held_entry_gives_the_reduced_systems_solution():
    kkt, n_z, stages, params = fit_like_kkt()
    f = factor(kkt, n_z, stages, params)
    rhs = np.random.default_rng(2).standard_normal(kkt.shape[0])
    fixed, value = np.array([params[1]]), np.array([0.25])
    x, force = f.solve_fixed(rhs, fixed, value)
    dense = kkt.toarray()
    keep = np.setdiff1d(np.arange(kkt.shape[0]), fixed)
    want = np.empty(kkt.shape[0])
    want[fixed] = value
    want[keep] = np.linalg.solve(dense[np.ix_(keep, keep)], rhs[keep] - dense[np.ix_(keep, fixed)] @ value)
    np.testing.assert_allclose(x, want, rtol=1e-9, atol=1e-9 * np.abs(want).max())
    assert force == pytest.approx(rhs[fixed] - dense[fixed] @ want, rel=1e-8)


@pytest.mark.parametrize("retry_shift, refined", [(1e4, False), (1e-4, True)])
def test_a_factor_whose_shift_does_not_converge_retries_then_pivots(monkeypatch, retry_shift, refined):
    """A first shift far too large for the refinement to converge: the factor is made again with the
    retry's shift, which converges when small enough (no pivoting) and else falls back to SuperLU's
    pivoting factorisation. Either way the solve returns the dense solution."""
    monkeypatch.setattr(time_ordered_kkt, "REGULARIZATION", 1e3)
    monkeypatch.setattr(time_ordered_kkt, "RETRY_REGULARIZATION", retry_shift)
    kkt, n_z, stages, params = fit_like_kkt()
    f = factor(kkt, n_z, stages, params)
    rhs = np.random.default_rng(3).standard_normal(kkt.shape[0])
    want = np.linalg.solve(kkt.toarray(), rhs)
    np.testing.assert_allclose(f.solve(rhs), want, rtol=1e-8, atol=1e-8 * np.abs(want).max())
    assert f.refined == refined
    if refined:
        assert f.shift == retry_shift


def test_a_chord_solve_with_the_factor_before_equals_the_dense_solve():
    """A matrix near the one factorised is solved with that factor (refined against the new one);
    one far from it is factorised for itself. Both give the dense solution."""
    kkt, n_z, stages, params = fit_like_kkt()
    marker = kkt.copy()
    marker.data = np.arange(1.0, kkt.nnz + 1)
    pattern = OrderedPattern(marker, n_z, stages, params)
    first = TimeOrderedKkt(pattern, kkt.data)
    rhs = np.random.default_rng(4).standard_normal(kkt.shape[0])
    rng = np.random.default_rng(5)
    for size, stays_stale in ((1e-4, True), (0.5, False)):
        changed = kkt.copy()
        changed.data = kkt.data * (1.0 + size * rng.standard_normal(kkt.nnz))
        changed = (sps.triu(changed) + sps.triu(changed, 1).T).tocsc()  # symmetric, same pattern
        values = np.asarray(changed[kkt.nonzero()]).ravel()
        chord = TimeOrderedKkt(pattern, values, earlier=first)
        assert chord.stale
        want = np.linalg.solve(sps.csc_matrix((values, kkt.nonzero()), shape=kkt.shape).toarray(), rhs)
        np.testing.assert_allclose(chord.solve(rhs), want, rtol=1e-9, atol=1e-9 * np.abs(want).max())
        assert chord.stale == stays_stale and chord.refined
