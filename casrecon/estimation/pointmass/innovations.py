"""Kalman-filter innovations of a GPS-only fit with an area process (``[model_error]``): the residual
series the model-adequacy tests need when the fit is a smoother.

With latent processes at every node the fit's residuals y - x_hat are those of a smoother: it
bends the trajectory towards every fix, so they are small and correlated however right the model
(on a real skydive with a 2 m/s^2, 2 s process: position reduced chi-square 0.06, lag-1 +0.5). The
test of such a model is its one-step prediction errors: the innovations of a Kalman filter run
forward through the fixes, independent N(0, 1) when the model holds.

The filter runs on the fit's own linearisation about its estimate z_hat (scaled units), the
parameters (drag and lift areas, wind bias) held at their estimates:

- state: the deviations of the node's position and velocity, of the area process a and
  of the correlated GPS errors e from the estimate (s = [dx, da, de]);
- transition over interval k from its Hermite-Simpson defects D0 dx_k + D1 dx_k+1 + Da0 da_k +
  Da1 da_k+1 = 0 (the NLP's constraint Jacobian) and the processes' Gauss-Markov steps
  a_k+1 = phi a_k + sqrt(1 - phi^2) w, written for the deviations (their known input is
  phi a_hat_k - a_hat_k+1);
- start: dx_0 diffuse, a_0 and e_0 at their prior N(0, 1) (deviation mean -a_hat_0);
- measurements: each fix's whitened residual rows r_hat + J ds = v (v white, unit variance),
  processed one component at a time, so each gives one scalar innovation.

An innovation whose prediction variance is still dominated by the diffuse start (the first fix) is
NaN, like a node without a fix.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps

#: Variance (scaled units) of the diffuse start of the node state.
DIFFUSE_VARIANCE = 1e10
#: An innovation whose prediction variance exceeds this (whitened units) is left out (NaN): it still
#: carries the diffuse start.
DIFFUSE_LIMIT = 1e6


def _gather(m: sps.spmatrix, rows: np.ndarray, cols: np.ndarray) -> np.ndarray:
    """Dense blocks m[rows[b]][:, cols[b]] for every b: (B, n_rows, n_cols), from (B, n_rows) and
    (B, n_cols) index arrays."""
    r = np.broadcast_to(rows[:, :, None], rows.shape + (cols.shape[1],))
    c = np.broadcast_to(cols[:, None, :], r.shape)
    if not r.size:
        return np.zeros(r.shape)
    values = np.asarray(sps.csr_matrix(m)[r.ravel(), c.ravel()]).ravel()
    return values.reshape(r.shape)


def filter_innovations(jr: sps.spmatrix, jg: sps.spmatrix, r_hat: np.ndarray, z_hat: np.ndarray, *,
                       x_cols: np.ndarray, a_cols: np.ndarray, e_cols: np.ndarray, phi_a: float,
                       phi_e: np.ndarray, defect_rows: np.ndarray, fix_rows: np.ndarray) -> np.ndarray:
    """Standardised innovations (K, 6) of the fixes under the linearised model (see the module
    docstring); NaN where a node has no fix in a component or the prediction is still diffuse.

    Parameters
    ----------
    jr, jg : sparse matrices
        Residual and constraint Jacobians at ``z_hat`` (scaled).
    r_hat : array
        Residuals at ``z_hat``.
    z_hat : array
        The estimate (scaled).
    x_cols : (K, 6) int array
        z columns of each node's position and velocity.
    a_cols : (K, n_a) int array
        z columns of the unit-variance area process (n_a 3, or 0 without one).
    e_cols : (K, n_e) int array
        z columns of the unit-variance correlated GPS errors of the active components.
    phi_a : float
        Transition of the area process over one interval.
    phi_e : (n_e,) array
        Transition of each correlated GPS error over one interval.
    defect_rows : (K - 1, 6) int array
        Constraint rows of each interval's defects.
    fix_rows : (K, 6) int array
        Residual rows of each node's whitened fix components, -1 where the node has none.
    """
    k_nodes, n_a, n_e = x_cols.shape[0], a_cols.shape[1], e_cols.shape[1]
    n = 6 + n_a + n_e
    trans_cols = np.column_stack([x_cols[:-1], x_cols[1:], a_cols[:-1], a_cols[1:]])
    blocks = _gather(jg, defect_rows, trans_cols)  # (K-1, 6, 12 + 2 n_a)
    d0, d1 = blocks[:, :, :6], blocks[:, :, 6:12]
    da0, da1 = blocks[:, :, 12:12 + n_a], blocks[:, :, 12 + n_a:]
    safe_rows = np.where(fix_rows >= 0, fix_rows, 0)
    h = np.zeros((k_nodes, 6, n))  # J in [dx, da, de]; the fixes do not see a
    h_xe = _gather(jr, safe_rows, np.column_stack([x_cols, e_cols]))
    h[:, :, :6], h[:, :, 6 + n_a:] = h_xe[:, :, :6], h_xe[:, :, 6:]
    d = -r_hat[safe_rows]
    a_hat, e_hat = z_hat[a_cols], z_hat[e_cols]
    q_a, q_e = np.sqrt(1 - phi_a ** 2), np.sqrt(1 - np.asarray(phi_e, float) ** 2)
    m = np.zeros(n)
    m[6:6 + n_a], m[6 + n_a:] = -a_hat[0], -e_hat[0]
    p = np.diag(np.r_[np.full(6, DIFFUSE_VARIANCE), np.ones(n_a + n_e)])
    out = np.full((k_nodes, 6), np.nan)
    for k in range(k_nodes):
        for c in range(6):
            if fix_rows[k, c] < 0:
                continue
            hc = h[k, c]
            ph = p @ hc
            s = float(hc @ ph) + 1.0
            nu = float(d[k, c] - hc @ m)
            if s - 1.0 < DIFFUSE_LIMIT:
                out[k, c] = nu / np.sqrt(s)
            gain = ph / s
            m = m + gain * nu
            p = p - np.outer(gain, ph)
            p = 0.5 * (p + p.T)
        if k == k_nodes - 1:
            break
        # to k+1: dx' = M dx + Na da + Na1 da', da' = phi_a da + c_a + q_a w_a, de' = phi_e de + c_e + q_e w_e
        solve = np.linalg.solve(d1[k], np.column_stack([d0[k], da0[k], da1[k]]))
        big_m, na, na1 = -solve[:, :6], -solve[:, 6:6 + n_a], -solve[:, 6 + n_a:]
        f = np.zeros((n, n))
        f[:6, :6] = big_m
        f[:6, 6:6 + n_a] = na + phi_a * na1
        f[6:6 + n_a, 6:6 + n_a] = phi_a * np.eye(n_a)
        f[6 + n_a:, 6 + n_a:] = np.diag(phi_e)
        c_a = phi_a * a_hat[k] - a_hat[k + 1]
        c_e = phi_e * e_hat[k] - e_hat[k + 1]
        g = np.zeros((n, n_a + n_e))
        g[:6, :n_a] = q_a * na1
        g[6:6 + n_a, :n_a] = q_a * np.eye(n_a)
        g[6 + n_a:, n_a:] = np.diag(q_e)
        m = f @ m
        m[:6] += na1 @ c_a
        m[6:6 + n_a] += c_a
        m[6 + n_a:] += c_e
        p = f @ p @ f.T + g @ g.T
    return out


def measurement_rows(jr: sps.spmatrix, rows: slice, x_cols: np.ndarray) -> np.ndarray:
    """(K, 6) residual row, within the group ``rows``, of each node's fix component: the row whose
    derivative with respect to that node state (``x_cols`` (K, 6)) is non-zero (a fix without
    weight has none); -1 where there is none."""
    sub = sps.csc_matrix(jr[rows])
    sub.eliminate_zeros()
    out = np.full(x_cols.shape, -1, np.int64)
    for idx, col in np.ndenumerate(x_cols):
        hit = sub.indices[sub.indptr[col]:sub.indptr[col + 1]]
        if hit.size > 1:
            raise ValueError(f"z column {col} is measured by {hit.size} residual rows, expected one")
        if hit.size:
            out[idx] = rows.start + hit[0]
    return out
