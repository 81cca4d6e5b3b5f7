"""Transcription pieces: the cubic interpolants, the exact QR compression of the IMU samples, and the
block-assembled derivatives against CasADi's own differentiation of the assembled NLP."""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest
from conftest import PROBLEMS
from hypothesis import given, settings
from hypothesis import strategies as st

from casrecon.estimation.sixdof.drop import build_nlp, parameter_set
from casrecon.estimation.sixdof.fitdata import load_fit_data
from casrecon.estimation.sixdof.initial_guess import initial_guess
from casrecon.estimation.sixdof.transcription import (
    ACCEL_TAU,
    CHANNEL_BASIS,
    D_OFFSETS,
    R_OFFSETS,
    Mesh,
    channel_bases,
    compress_imu,
    hermite,
    hermite_basis,
    lagrange_matrix,
    make_mesh,
)
from casrecon.scenario import Scenario

coef = st.floats(-10, 10, allow_nan=False)


@settings(max_examples=50, deadline=None)
@given(st.tuples(coef, coef, coef, coef))
def test_lagrange_matrix_reproduces_polynomials(c):
    """With 4 nodes it reproduces cubics; with the accelerometer's 3 (ACCEL_TAU) quadratics."""
    tau = np.linspace(-0.2, 1.2, 37)
    nodes = np.array([0.0, 1 / 3, 2 / 3, 1.0])
    p = np.polynomial.Polynomial(c)
    lag = lagrange_matrix(tau, nodes)
    assert lag.shape == (tau.size, 4)
    assert lag @ p(nodes) == pytest.approx(p(tau), abs=1e-9 * (1 + np.abs(c).sum()))
    q = np.polynomial.Polynomial(c[:3])
    lag3 = lagrange_matrix(tau)
    assert lag3 @ q(np.array(ACCEL_TAU)) == pytest.approx(q(tau), abs=1e-9 * (1 + np.abs(c).sum()))
    assert lag3.sum(axis=1) == pytest.approx(np.ones(tau.size))
    assert lagrange_matrix(np.array(ACCEL_TAU)) == pytest.approx(np.eye(3), abs=1e-14)


def test_hermite_basis_matches_hermite():
    tau = np.linspace(0, 1, 9)
    values = np.array([1.3, -0.7, 2.1, 0.4])  # x_k, h f_k, x_k+1, h f_k+1 with h = 1
    direct = np.array([hermite(t, 1.0, values[0], values[1], values[2], values[3]) for t in tau])
    assert hermite_basis(tau) @ values == pytest.approx(direct, abs=1e-14)


@settings(max_examples=50, deadline=None)
@given(st.tuples(coef, coef, coef, coef), st.floats(0.001, 2.0), st.floats(-5, 5))
def test_hermite_reproduces_a_cubic(c, h, t0):
    p = np.polynomial.Polynomial(c)
    dp = p.deriv()
    tau = np.linspace(0, 1, 11)
    got = np.array([hermite(t, h, p(t0), dp(t0), p(t0 + h), dp(t0 + h)) for t in tau])
    scale = 1 + np.abs(p(t0 + tau * h)).max()
    assert got == pytest.approx(p(t0 + tau * h), abs=1e-11 * scale)


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_compress_imu_is_an_exact_rewriting(seed):
    """sum_i w_i (y_i - B_i c)^2 == sum_intervals |d - R c|^2 + const, per channel, for random data,
    masks (including intervals with fewer usable samples than basis functions) and coefficients c."""
    rng = np.random.default_rng(seed)
    k, n_int = 25, 4
    dt = 0.002
    mesh = Mesh(10.0 + dt * k * np.arange(n_int + 1), dt * k, k)
    y = rng.normal(size=(n_int * k, 6)) * 3
    valid = rng.uniform(size=y.shape) > 0.3
    valid[k:2 * k, 2] = False                     # a wholly masked interval
    valid[2 * k:3 * k, 4] = False
    valid[2 * k + 5:2 * k + 7, 4] = True          # an interval with only 2 samples
    sigma = rng.uniform(0.01, 0.2, 6)
    blocks = compress_imu(mesh, y, valid, sigma)
    bases = channel_bases(k)
    for c in range(6):
        nb = CHANNEL_BASIS[c]
        direct = compressed = 0.0
        for i in range(n_int):
            coef_c = rng.normal(size=nb) * 3
            rows = slice(i * k, (i + 1) * k)
            w = valid[rows, c] / sigma[c] ** 2
            direct += np.sum(w * (y[rows, c] - bases[c] @ coef_c) ** 2)
            d = blocks.d[D_OFFSETS[c]:D_OFFSETS[c + 1], i]
            r = blocks.R[R_OFFSETS[c]:R_OFFSETS[c + 1], i].reshape(nb, nb, order="F")
            compressed += np.sum((d - r @ coef_c) ** 2)
        assert compressed + blocks.const_chi2[c] == pytest.approx(direct, rel=1e-10)
        assert blocks.n_used[c] == valid[:, c].sum()
    assert blocks.const_chi2.min() >= 0


@pytest.fixture(scope="module")
def tiny():
    """A ~1.5 s window of ees-drop-3: 30 intervals, the full parameter set."""
    sc = Scenario.load(PROBLEMS / "ees-drop-3")
    cfg = sc.config
    cfg = replace(cfg, estimation=replace(cfg.estimation, start_after_release_s=20.0, end_before_impact_s=17.55,
                                          samples_per_interval=25))
    sc = Scenario.from_config(cfg)
    data = load_fit_data(cfg)
    mesh = make_mesh(data.imu_time_s, cfg.estimation.mesh_samples(cfg.imu.rate_hz))
    params = parameter_set(cfg)
    x0 = initial_guess(data, mesh, cfg.vehicle, sc.atmosphere, cfg.site.ground_alt_msl_m)
    out = {}
    for hess in ("gauss-newton", "exact"):
        out[hess] = build_nlp(sc.model, data, mesh, params, cfg, hess)
    rng = np.random.default_rng(3)
    z0 = out["exact"].pack(x0, rng.normal(size=params.n) * params.scales)
    out = {hess: fit_nlp.nlp for hess, fit_nlp in out.items()}
    out["mesh"] = mesh
    z = z0 + 1e-3 * rng.normal(size=z0.size)
    return out, z


def test_tiny_problem_size(tiny):
    nlp, mesh = tiny[0]["gauss-newton"], tiny[0]["mesh"]
    assert 25 <= mesh.n_intervals <= 35
    assert nlp.constraints.numel() == 13 * mesh.n_intervals + 1


def test_block_gradient_and_jacobian_match_casadi(tiny):
    nlps, z = tiny
    nlp = nlps["gauss-newton"]
    jr = ca.Function("jr", [nlp.z], [ca.jacobian(nlp.residuals, nlp.z), nlp.residuals])
    jg = ca.Function("jg", [nlp.z], [ca.jacobian(nlp.constraints, nlp.z)])
    j_r, r = (np.asarray(ca.DM(m).full()) for m in jr(z))
    j_g = np.asarray(jg(z).full())
    d = nlp.derivatives
    grad = d.gradient(z)
    assert grad == pytest.approx(j_r.T @ r.ravel(), rel=1e-9, abs=1e-9 * np.abs(grad).max())
    got_jg = np.asarray(d.jacobian_g(z).toarray())
    assert got_jg == pytest.approx(j_g, rel=1e-9, abs=1e-12)
    # Gauss-Newton Hessian: upper triangle of J^T J
    hgn = np.asarray(d.hessian_lagrangian(z, 1.0, np.zeros(j_g.shape[0])).toarray())
    jtj = np.triu(j_r.T @ j_r)
    assert hgn == pytest.approx(jtj, rel=1e-9, abs=1e-9 * np.abs(jtj).max())


def test_exact_hessian_matches_casadi(tiny):
    nlps, z = tiny
    nlp = nlps["exact"]
    rng = np.random.default_rng(5)
    lam = rng.normal(size=nlp.constraints.numel())
    sigma = 0.7
    lag = sigma * 0.5 * ca.sumsqr(nlp.residuals) + ca.dot(ca.DM(lam), nlp.constraints)
    h_fn = ca.Function("h", [nlp.z], [ca.hessian(lag, nlp.z)[0]])
    want = np.triu(np.asarray(h_fn(z).full()))
    got = np.asarray(nlp.derivatives.hessian_lagrangian(z, sigma, lam).toarray())
    assert got == pytest.approx(want, rel=1e-8, abs=1e-9 * np.abs(want).max())
