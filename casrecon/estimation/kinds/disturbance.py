"""The disturbance kind (weak constraint): the first-order Gauss-Markov prior of the disturbance
values estimated at every node (gusts, model-error force and moment), exactly whitened: the first
node's u_0 / sigma, and per interval (u_k+1 - phi u_k) / (sigma sqrt(1 - phi^2)), phi = exp(-h/tau).
The node values are scaled by their sigma, so these rows are linear in z.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.layout import DropLayout


def disturbance_terms(layout: DropLayout, group=lambda g: g) -> list[Term]:
    """The start and step terms of a drop's latent disturbances (empty without them)."""
    n_u = layout.n_u
    if not n_u:
        return []
    phi = layout.disturbance.transition(layout.mesh.h)
    u0, v = ca.SX.sym("u0", n_u), ca.SX.sym("v", 2 * n_u)
    step = (v[n_u:] - ca.DM(phi) * v[:n_u]) / ca.DM(np.sqrt(1.0 - phi**2))
    start_kind = BlockKind("disturbance_start", u0, [], u0, None)
    step_kind = BlockKind("disturbance_step", v, [], step, None)
    cols = layout.u_cols
    return [Term(group("disturbance_start"), (BlockSet(start_kind, cols[:1]),)),
            Term(group("disturbance"), (BlockSet(step_kind, np.column_stack([cols[:-1], cols[1:]])),))]
