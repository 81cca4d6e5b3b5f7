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
from casrecon.estimation.layout import DropLayout


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
    """The start and step terms of a drop's latent disturbances (empty without them)."""
    if not layout.n_u:
        return []
    phi = np.tile(layout.disturbance.transition(layout.mesh.h), (layout.n_nodes - 1, 1))
    return gauss_markov_terms(layout.u_cols, phi, group("disturbance_start"), group("disturbance"))


def profile_terms(layout: DropLayout, group=lambda g: g) -> list[Term]:
    """The Gauss-Markov-in-altitude prior of a drop's atmosphere-profile corrections (empty
    without them): level 0, then each step of the grid."""
    grid = layout.profile
    if grid is None:
        return []
    cols = layout.extra("profile").cols.reshape(grid.n_levels, grid.n_components)
    phi = np.full((grid.n_levels - 1, grid.n_components), grid.phi)
    return gauss_markov_terms(cols, phi, group("profile_start"), group("profile"))
