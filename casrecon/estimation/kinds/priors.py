"""The prior kind: a zero-mean Gaussian prior on every parameter whose spec has a prior sigma,
one residual group per parameter group (``prior_aero``, ``prior_atmosphere``, ``prior_imu``,
``prior_clock``, or whatever groups the parameters declare), rows (value - 0) / sigma.

In a joint fit a shared parameter's prior enters once: the joint fit gives the other drops' copies
no prior sigma.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.sixdof.parameters import ParameterSet


def prior_terms(params: ParameterSet, theta_cols: np.ndarray, group_name=lambda g: f"prior_{g}") -> list[Term]:
    """One term per parameter group with priors, groups in order of first appearance.

    Parameters
    ----------
    params : ParameterSet
    theta_cols : int array
        z column of each parameter.
    group_name : callable
        Residual group name of a parameter group.
    """
    groups: dict[str, list[int]] = {}
    for i, spec in enumerate(params.specs):
        if spec.prior_sigma:
            groups.setdefault(spec.group, []).append(i)
    terms = []
    for group, members in groups.items():
        v = ca.SX.sym("v", len(members))
        weights = np.array([params.specs[i].scale / params.specs[i].prior_sigma for i in members])
        kind = BlockKind(f"prior_{group}", v, [], v * ca.DM(weights), None)
        cols = np.asarray(theta_cols)[members][None, :]
        terms.append(Term(group_name(group), (BlockSet(kind, cols),)))
    return terms
