"""The null-space covariance Z (Z^T H Z)^-1 Z^T equals the z-block of the dense inverse of the KKT
matrix [[H, A^T], [A, 0]] (H = J^T J), on a ~1.5 s window of ees-drop-3 fitted to convergence."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest
import scipy.sparse as sps
from conftest import PROBLEMS

from casrecon.estimation.engine.covariance import compute_covariance
from casrecon.estimation.engine.kkt_covariance import KktCovariance
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.estimation.sixdof.layout import NS
from casrecon.estimation.sixdof.transcription import STATE_SCALE
from casrecon.scenario import Scenario


@pytest.fixture(scope="module")
def short_fit():
    sc = Scenario.load(PROBLEMS / "ees-drop-3")
    cfg = sc.config
    est = replace(cfg.estimation, start_after_release_s=20.0, end_before_impact_s=17.55)
    r = fit_drop(Scenario.from_config(replace(cfg, estimation=est)))
    assert 1.3 <= r.data.window[1] - r.data.window[0] <= 1.7
    return r


@pytest.fixture(scope="module")
def dense_kkt(short_fit):
    nlp, z = short_fit.nlp, short_fit.solver.z
    d = nlp.derivatives
    a = np.asarray(d.jacobian_g(z).toarray())
    d.evaluate(z)
    hu = np.asarray(d.gauss_newton(z).toarray())
    h = hu + np.triu(hu, 1).T
    n_z, n_g = h.shape[0], a.shape[0]
    return np.block([[h, a.T], [a, np.zeros((n_g, n_g))]]), n_z


@pytest.fixture(scope="module")
def dense_kkt_cov(dense_kkt):
    kkt, n_z = dense_kkt
    return np.linalg.inv(kkt)[:n_z, :n_z]


def relative_gap(got: np.ndarray, want: np.ndarray) -> float:
    """Max |got - want| / sqrt(want_ii want_jj): covariance entries relative to their variances."""
    s = np.sqrt(np.diag(want))
    return float(np.max(np.abs(got - want) / np.outer(s, s)))


def test_parameter_block_equals_dense_kkt_inverse(short_fit, dense_kkt_cov):
    nlp = short_fit.nlp
    cov = short_fit.covariance
    idx = np.arange(short_fit.part.n_state_vars, nlp.z.numel())
    got = cov.covariance_of(idx)
    want = dense_kkt_cov[np.ix_(idx, idx)]
    assert relative_gap(got, want) < 1e-6
    # and what FitResult reports is that block in SI units
    s = short_fit.params.scales
    assert short_fit.sigma == pytest.approx(np.sqrt(np.diag(want)) * s, rel=1e-6)


@pytest.mark.parametrize("node", [0, 1, 13, -1])
def test_node_state_blocks_equal_dense_kkt_inverse(short_fit, dense_kkt_cov, node):
    nlp = short_fit.nlp
    cov = short_fit.covariance
    k = short_fit.part.mesh.t_nodes.size
    node = node % k
    # node state and its cross-covariance with the parameters
    idx = np.r_[NS * node + np.arange(NS), np.arange(short_fit.part.n_state_vars, nlp.z.numel())]
    got = cov.covariance_of(idx)
    want = dense_kkt_cov[np.ix_(idx, idx)]
    if node == 0:
        # the unit-norm row makes the initial quaternion's covariance rank-deficient (q0 dq0 = 0):
        # compare entries relative to the largest variance of the block instead
        assert np.max(np.abs(got - want)) / np.max(np.diag(want)) < 1e-6
        q = short_fit.part.states(short_fit.solver.z)[0, 6:10] / STATE_SCALE[6:10]
        assert np.abs(q @ got[6:10, 6:10]).max() < 1e-9 * np.max(np.diag(want))
    else:
        assert relative_gap(got, want) < 1e-6


def test_recomputed_covariance_is_the_reported_one(short_fit):
    nlp, z = short_fit.nlp, short_fit.solver.z
    cov = compute_covariance(nlp, z, 1.0, 1)
    ref = short_fit.covariance
    assert cov.basis @ cov.cov_w @ cov.basis[-5:].T == pytest.approx(ref.basis @ ref.cov_w @ ref.basis[-5:].T,
                                                                     rel=1e-9, abs=1e-15)
    assert cov.reduced_chi2 == 1.0


def test_at_bounds_hand_cases():
    """Within 1e-4 of the bound interval's width of a bound (1e-4 absolute when one-sided)."""
    from casrecon.estimation.engine.convergence import at_bounds

    z = np.array([0.0, 1.0 - 5e-5, 0.5, -1.0, 3.0, 2e-5])
    lo = np.array([0.0, -1.0, 0.0, -np.inf, -np.inf, 0.0])
    hi = np.array([1.0, 1.0, 1.0, np.inf, 3.0 + 2e-4, np.inf])
    np.testing.assert_array_equal(at_bounds(z, (lo, hi)), [0, 1, 5])
    assert at_bounds(z, None).size == 0


@pytest.mark.parametrize("bordered", [False, True])
def test_variance_of_a_combination_matches_the_dense_inverse(short_fit, dense_kkt, dense_kkt_cov, bordered):
    """The variance of a weighted sum (here the window mean of the pitch rate, then arbitrary
    weights on pitch rate and two parameters) from the null-space covariance and from one sparse-LU
    solve of the KKT matrix (the disturbance-state path, with and without the parameters as a
    bordered block) equals w^T C w of the dense inverse."""
    k = short_fit.part.mesh.t_nodes.size
    q_idx = NS * np.arange(k) + 11
    n_sv = short_fit.part.n_state_vars
    cases = [(q_idx, np.full(k, 1.0 / k)),
             (np.r_[q_idx[:3], n_sv, n_sv + 4], np.array([1.0, -2.0, 0.5, 3.0, -1.0]))]
    kkt, n_z = dense_kkt
    border = np.arange(short_fit.part.n_state_vars, n_z) if bordered else None
    lu_cov = KktCovariance(sps.csc_matrix(kkt), n_z, chi2=1.0, dof=1, border=border)
    for idx, w in cases:
        want = w @ dense_kkt_cov[np.ix_(idx, idx)] @ w
        assert short_fit.covariance.variance_of_combination(idx, w) == pytest.approx(want, rel=1e-6)
        assert lu_cov.variance_of_combination(idx, w) == pytest.approx(want, rel=1e-6)


@pytest.mark.parametrize("bordered", [False, True])
def test_kkt_blocks_equal_the_dense_inverse_and_are_kept(short_fit, dense_kkt, dense_kkt_cov, monkeypatch, bordered):
    """The sparse-LU blocks (the disturbance-state path, with and without the parameters as a
    bordered block) equal the dense inverse; asking again for the same index sets (trajectory
    bands, then coefficient bands) solves nothing."""
    kkt, n_z = dense_kkt
    theta = np.arange(short_fit.part.n_state_vars, n_z)
    lu_cov = KktCovariance(sps.csc_matrix(kkt), n_z, chi2=1.0, dof=1, border=theta if bordered else None)
    sets = [np.r_[NS * node + np.arange(NS), theta] for node in (1, 7, 13)]
    first = lu_cov.blocks(sets)
    for idx, got in zip(sets, first):
        assert relative_gap(got, dense_kkt_cov[np.ix_(idx, idx)]) < 1e-6
    solves = []
    monkeypatch.setattr(lu_cov, "_columns", lambda idx: solves.append(idx))
    again = lu_cov.blocks(sets[::-1])
    assert solves == [] and all(a is b for a, b in zip(again, first[::-1]))


def test_side_null_basis_keeps_groups_of_side_rows_apart():
    """Unit norms of two drops' quaternions (columns 2..5 and 9..12 of 14): the basis is
    orthonormal, annihilates the side rows, has n - 2 columns, and no column mixes the drops."""
    from casrecon.estimation.engine.constraint_split import side_null_basis

    rng = np.random.default_rng(8)
    a = np.zeros((2, 14))
    a[0, 2:6], a[1, 9:13] = rng.normal(size=4), rng.normal(size=4)
    n = side_null_basis(a).toarray()
    assert n.shape == (14, 12)
    np.testing.assert_allclose(n.T @ n, np.eye(12), atol=1e-12)
    np.testing.assert_allclose(a @ n, 0.0, atol=1e-12)
    first, second = np.any(n[2:6] != 0, axis=0), np.any(n[9:13] != 0, axis=0)
    assert not np.any(first & second)
    assert first.sum() == 3 and second.sum() == 3
    np.testing.assert_array_equal(side_null_basis(np.zeros((0, 3))).toarray(), np.eye(3))


def test_output_variances_of_a_block_sparse_basis_equal_the_full_products():
    """A joint fit's Z: each drop's rows reach its own directions and the shared ones only. The
    bands' variances, computed on the directions the sets reach, equal diag(J Z_s C Z_s^T J^T)
    with every direction, for sets within one drop and for a set spanning two."""
    from casrecon.estimation.engine.covariance import Covariance

    rng = np.random.default_rng(11)
    basis = np.zeros((40, 9))
    basis[:20, 0:4] = rng.normal(size=(20, 4))   # drop 1's rows: its directions 0..3 ...
    basis[20:, 4:7] = rng.normal(size=(20, 3))   # drop 2's: 4..6
    basis[:, 7:] = rng.normal(size=(40, 2))      # ... and both the shared 7, 8
    f = rng.normal(size=(9, 9))
    cov = Covariance(basis, f @ f.T + np.eye(9), 1.0, 1.0)
    sets = [np.array([1, 5]), np.array([25, 21]), np.array([3, 30])]
    jac = rng.normal(size=(3, 4, 2))
    want = np.array([np.diag(j @ basis[s] @ cov.cov_w @ basis[s].T @ j.T) for j, s in zip(jac, sets)])
    np.testing.assert_allclose(cov.output_variances(sets, jac), want, rtol=1e-12)
    np.testing.assert_allclose(cov.output_variances(sets[1:2], jac[1:2]), want[1:2], rtol=1e-12)
    assert cov.output_variances([], np.zeros((0, 4, 2))).shape == (0, 4)


def test_scaled_condition_judges_determinacy_not_stiffness():
    from casrecon.estimation.engine.covariance import scaled_condition
    from casrecon.estimation.engine.kkt_covariance import MAX_CONDITION

    # a stiff unknown next to one held only by its prior: condition 1.01e13 unscaled, 1 scaled
    stiff = np.diag([3.44e11, 0.0341])  # the measured extremes of a model-error drop
    cond, _ = scaled_condition(stiff)
    assert cond == pytest.approx(1.0) and np.linalg.cond(stiff) > MAX_CONDITION
    # two unknowns that only their sum determines: undetermined however they are scaled
    h = np.array([[1.0, 1.0], [1.0, 1.0 + 1e-15]]) * np.array([[1e6, 1e3], [1e3, 1.0]])
    cond, weakest = scaled_condition(h)
    assert cond > MAX_CONDITION
    d = np.sqrt(np.diag(h))
    np.testing.assert_allclose(np.abs(weakest * d) / np.linalg.norm(weakest * d), [2**-0.5, 2**-0.5], rtol=1e-6)
    assert scaled_condition(np.array([[1.0, 2.0], [2.0, 1.0]]))[0] == float("inf")


def lagrangian_gradient(nlp, z: np.ndarray, lam_g: np.ndarray) -> np.ndarray:
    """grad of |r|^2 / 2 + lam_g^T g at z (scaled), from the residual and constraint Jacobians."""
    d = nlp.derivatives
    return d.jacobian_r(z).T @ d.residuals(z) + d.jacobian_g(z).T @ lam_g


def test_solver_multipliers_make_the_lagrangian_stationary(short_fit):
    nlp, z, lam = short_fit.nlp, short_fit.solver.z, short_fit.solver.lam_g
    grad_f = nlp.derivatives.jacobian_r(z).T @ nlp.derivatives.residuals(z)
    assert np.abs(grad_f).max() > 1.0  # the constraints do hold the data back here
    grad_l = lagrangian_gradient(nlp, z, lam)
    # exactly zero (to the LU's round-off) in the dependent columns, which fix the multipliers
    assert np.abs(grad_l[nlp.dependent]).max() < 1e-9 * np.abs(grad_f).max()
    # and what is left is the converged fit's last step, far inside every sigma
    cov = short_fit.covariance
    step = cov.basis @ (cov.cov_w @ (cov.basis.T @ grad_l))
    sigma = np.sqrt(np.einsum("ij,jk,ik->i", cov.basis, cov.cov_w, cov.basis))
    moving = sigma > 0
    assert np.abs(step[moving] / sigma[moving]).max() < 1e-3


def test_observed_information_is_the_lagrangian_hessian_and_its_covariance_the_kkt_inverse(short_fit, dense_kkt):
    """The assembled exact Hessian of the Lagrangian equals central differences of its gradient,
    and the observed-information covariance equals the z-block of the dense inverse of
    [[H_exact, A^T], [A, 0]]; it differs from the expected-information one."""
    nlp, z, lam = short_fit.nlp, short_fit.solver.z, short_fit.solver.lam_g
    h = nlp.derivatives.observed_information(z, lam).toarray()
    eps = 1e-6
    cols = np.r_[np.arange(0, z.size, 7), np.arange(short_fit.part.n_state_vars, z.size)]
    for j in cols:
        e = np.zeros(z.size)
        e[j] = eps
        fd = (lagrangian_gradient(nlp, z + e, lam) - lagrangian_gradient(nlp, z - e, lam)) / (2 * eps)
        np.testing.assert_allclose(h[:, j], fd, rtol=1e-5, atol=1e-5 * max(1.0, np.abs(h[:, j]).max()))
    _, n_z = dense_kkt
    a = nlp.derivatives.jacobian_g(z).toarray()
    kkt = np.block([[h, a.T], [a, np.zeros((a.shape[0], a.shape[0]))]])
    want = np.linalg.inv(kkt)[:n_z, :n_z]
    cov = compute_covariance(nlp, z, 1.0, 1, information="observed", lam_g=lam)
    assert cov.information == "observed"
    idx = np.r_[NS * 5 + np.arange(NS), np.arange(short_fit.part.n_state_vars, n_z)]
    assert relative_gap(cov.covariance_of(idx), want[np.ix_(idx, idx)]) < 1e-6
    expected = short_fit.covariance.covariance_of(idx)
    assert relative_gap(expected, want[np.ix_(idx, idx)]) > 1e-4


def test_observed_information_falls_back_where_it_is_not_positive_definite(short_fit):
    """Multipliers that make the Lagrangian's curvature indefinite: the expected information is
    inverted, and the covariance says why."""
    nlp, z, lam = short_fit.nlp, short_fit.solver.z, short_fit.solver.lam_g
    cov = compute_covariance(nlp, z, 1.0, 1, information="observed", lam_g=-1e6 * lam)
    assert cov.information.startswith("expected (the observed information is not positive definite")
    ref = short_fit.covariance
    np.testing.assert_allclose(cov.cov_w, ref.cov_w, rtol=1e-9, atol=0)
    with pytest.raises(ValueError, match="information must be one of"):
        compute_covariance(nlp, z, 1.0, 1, information="fisher")


def test_information_text_names_the_matrix_and_the_reason_for_a_fallback():
    from casrecon.estimation.engine.information import information_text

    assert information_text("observed").startswith("observed information (exact Hessian")
    text = information_text("expected (the observed information is not positive definite at the solution)")
    assert text.startswith("expected information (Gauss-Newton J^T J") and text.endswith("at the solution")
