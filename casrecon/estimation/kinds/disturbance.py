"""Gauss-Markov priors of latent values, exactly whitened: the first value's u_0 / sigma, and per
step (u_k+1 - phi_k u_k) / (sigma sqrt(1 - phi_k^2)). Used for the disturbance values estimated at
every node (weak constraint: gusts, model-error force and moment; phi = exp(-h/tau)) and for the
correlated GPS errors estimated at every fix (phi from the time between fixes). The values are
scaled by their sigma, so these rows are linear in z.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.sixdof.layout import DropLayout


def gauss_markov_terms(cols: np.ndarray, phi: np.ndarray, start_group: str, step_group: str) -> list[Term]:
    """Start and step terms of unit-variance Gauss-Markov values at the z columns ``cols`` (K, n).

    Parameters
    ----------
    cols : (K, n) int array
        z columns of the values at K successive times, n processes.
    phi : (K - 1, n) array
        Transition of each step, in (0, 1).
    start_group, step_group : str
        Residual group names of the first values and of the steps.
    """
    n = cols.shape[1]
    u0, v, ph = ca.SX.sym("u0", n), ca.SX.sym("v", 2 * n), ca.SX.sym("phi", n)
    step = (v[n:] - ph * v[:n]) / ca.sqrt(1.0 - ph * ph)
    start_kind = BlockKind(start_group.rsplit("/", 1)[-1], u0, [], u0, None)
    step_kind = BlockKind(step_group.rsplit("/", 1)[-1], v, [ph], step, None)
    terms = [Term(start_group, (BlockSet(start_kind, cols[:1]),))]
    if cols.shape[0] > 1:
        terms.append(Term(step_group, (BlockSet(step_kind, np.column_stack([cols[:-1], cols[1:]]),
                                                [ca.DM(np.asarray(phi, float).T)]),)))
    return terms


def disturbance_terms(layout: DropLayout, group=lambda g: g) -> list[Term]:
    """The start and step terms of a drop's latent disturbances (empty without them): one
    Gauss-Markov chain through the node and midpoint values in time order, steps of half an
    interval; and the sub-grid integrals' independent unit-variance rows (they are scaled by their
    sigma)."""
    if not layout.n_u:
        return []
    cols = layout.u_chain_cols
    phi = np.tile(layout.disturbance.transition(0.5 * layout.mesh.h), (cols.shape[0] - 1, 1))
    n = layout.n_u
    u = ca.SX.sym("u", n)
    white = BlockKind("disturbance_subgrid", u, [], u, None)
    return gauss_markov_terms(cols, phi, group("disturbance_start"), group("disturbance")) + [
        Term(group("disturbance_subgrid"), (BlockSet(white, layout.u_sub_cols),))]


def linear_rows(name: str, cols: np.ndarray, weights: np.ndarray) -> BlockSet:
    """Residual rows sum_j weights[b, j] u[cols[b, j], c] for each block b and each of the n
    processes c (``cols`` (B, m, n) z columns, ``weights`` (B, m))."""
    n_blocks, m, n = cols.shape
    u, w = ca.SX.sym("u", m * n), ca.SX.sym("w", m)
    rows = sum(w[j] * u[j * n:(j + 1) * n] for j in range(m))
    kind = BlockKind(name, u, [w], rows, None)
    return BlockSet(kind, cols.reshape(n_blocks, m * n), [ca.DM(np.asarray(weights, float).T)])


def spline_level_prior_terms(cols: np.ndarray, phi: float, start_group: str, step_group: str,
                             weights: np.ndarray | None = None) -> list[Term]:
    """Gauss-Markov prior, exactly whitened, of the values at the levels of a cubic B-spline whose
    coefficients are at the z columns ``cols`` (K levels, n unit-variance processes, K >= 3): the
    value at level k is v_k = (g_k-1 + 4 g_k + g_k+1) / 6, a coefficient beyond the grid being 0.
    Rows: v_0, then (v_k - phi v_k-1) / sqrt(1 - phi^2); each step involves the coefficients k-2
    to k+1, fewer at the grid's ends. ``weights`` (n,): each process's rows times its weight
    (its scale over its prior sigma; default 1), one block set per process when they differ."""
    if weights is not None and np.any(np.asarray(weights) != 1.0):
        parts = [_level_prior_terms(cols[:, k:k + 1], phi, start_group, step_group, float(w))
                 for k, w in enumerate(weights)]
        return [Term(t.group, tuple(s for p in parts for s in p[i].sets)) for i, t in enumerate(parts[0])]
    return _level_prior_terms(cols, phi, start_group, step_group, 1.0)


def _level_prior_terms(cols: np.ndarray, phi: float, start_group: str, step_group: str, weight: float) -> list[Term]:
    """:func:`spline_level_prior_terms` with every row times ``weight``."""
    n_levels = cols.shape[0]
    level = np.zeros((n_levels, n_levels + 2))  # v = level @ [0, g_0 .. g_K-1, 0]
    for k in range(n_levels):
        level[k, k:k + 3] = (1 / 6, 4 / 6, 1 / 6)
    steps = (level[1:] - phi * level[:-1]) / np.sqrt(1.0 - phi * phi)
    first_rows = linear_rows(start_group.rsplit("/", 1)[-1], cols[None, :2], weight * level[None, 0, 1:3])
    terms = [Term(start_group, (first_rows,))]
    sets = []
    # step k (1..K-1) reaches coefficients k-2..k+1: 3 at k = 1 and k = K-1, 4 in between
    for ks, first, width in ((np.array([1]), 0, 3), (np.arange(2, n_levels - 1), None, 4),
                             (np.array([n_levels - 1]), n_levels - 3, 3)):
        if not ks.size:
            continue
        lo = ks - 2 if first is None else np.full(ks.size, first)
        idx = lo[:, None] + np.arange(width)[None, :]
        weights = np.take_along_axis(steps[ks - 1], idx + 1, axis=1)  # +1: the padded column 0
        sets.append(linear_rows(step_group.rsplit("/", 1)[-1], cols[idx], weight * weights))
    terms.append(Term(step_group, tuple(sets)))
    return terms


def profile_terms(layout: DropLayout, group=lambda g: g) -> list[Term]:
    """The Gauss-Markov-in-altitude prior of a drop's atmosphere-profile corrections (empty
    without them), on the corrections themselves at the grid levels (not on the spline's
    coefficients: that prior is smoother than the process, see :func:`spline_level_prior_terms`)."""
    grid = layout.profile
    if grid is None:
        return []
    cols = layout.extra("profile").cols.reshape(grid.n_levels, grid.n_components)
    return spline_level_prior_terms(cols, grid.phi, group("profile_start"), group("profile"), grid.sigma / grid.prior)
