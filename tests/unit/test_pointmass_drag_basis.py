"""The GPS-only fit's drag-area spline: nodes and interval midpoints use one knot vector.

Issue 14: the midpoint basis used to be built from its own knots over the midpoints' span (one step
shorter than the nodes'), so for some segment lengths it had one coefficient fewer than the node
basis (a raw CasADi shape error) and otherwise evaluated a spline with shifted knots.
"""

from __future__ import annotations

import numpy as np
import pytest
from scipy.interpolate import BSpline

from casrecon.estimation.pointmass.fit import drag_basis, interval_bases
from casrecon.io.pointmass_problem import DragConfig


class _Cfg:
    """The one field drag_basis reads."""

    def __init__(self, knot_spacing_s: float):
        self.drag = DragConfig(knot_spacing_s=knot_spacing_s)


def _old_node_basis(t: np.ndarray, spacing: float) -> np.ndarray:
    """The node basis as casrecon built it before the fix (right at the nodes)."""
    span = t[-1] - t[0]
    n_inner = max(int(np.floor(span / spacing)), 1)
    knots = np.r_[[t[0]] * 3, np.linspace(t[0], t[-1], n_inner + 1), [t[-1]] * 3]
    return BSpline.design_matrix(t, knots, 3).toarray()


CASES = [(period, k, spacing) for period in (0.1, 0.2) for spacing in (1.0, 2.0, 3.0)
         for k in range(12, 320, 7)] + [(0.2, 201, 2.0), (0.2, 211, 2.0), (0.2, 221, 2.0), (0.1, 302, 2.0)]


@pytest.mark.parametrize("period, k, spacing", CASES)
def test_midpoints_on_the_nodes_spline(period, k, spacing):
    cfg = _Cfg(spacing)
    t = period * np.arange(k)
    nodes, mids = interval_bases(cfg, "spline", t)
    assert nodes.shape[1] == mids.shape[1]
    assert mids.shape[0] == k - 1
    # the node basis is as before the fix
    np.testing.assert_allclose(nodes, _old_node_basis(t, spacing), atol=1e-12)
    # nodes and midpoints are rows of one basis over all of them (the same knots: same first and last time)
    both = np.empty(2 * k - 1)
    both[0::2], both[1::2] = t, 0.5 * (t[:-1] + t[1:])
    one = drag_basis(cfg, "spline", both)
    np.testing.assert_allclose(one[0::2], nodes, atol=1e-12)
    np.testing.assert_allclose(one[1::2], mids, atol=1e-12)
    # a spline through random coefficients: the midpoint value is the spline's, not one of shifted knots
    c = np.random.default_rng(k).uniform(0.2, 0.8, nodes.shape[1])
    n_inner = max(int(np.floor(t[-1] / spacing)), 1)
    knots = np.r_[[0.0] * 3, np.linspace(0.0, t[-1], n_inner + 1), [t[-1]] * 3]
    np.testing.assert_allclose(mids @ c, BSpline(knots, c, 3)(both[1::2]), atol=1e-12)


def test_constant_model_is_one_column():
    t = 0.2 * np.arange(50)
    nodes, mids = interval_bases(_Cfg(2.0), "constant", t)
    assert nodes.shape == (50, 1) and mids.shape == (49, 1)
    assert np.all(nodes == 1.0) and np.all(mids == 1.0)


def test_old_midpoint_knots_differ_in_count_for_some_spans():
    """The cases of the issue: with knots built from the midpoints' own span the counts differed."""
    cfg, mismatched = _Cfg(2.0), []
    for k in (201, 211, 221):
        t = 0.2 * np.arange(k)
        old_mid = drag_basis(cfg, "spline", t[:-1] + 0.1)           # the old call: its own span
        nodes, mids = interval_bases(cfg, "spline", t)
        mismatched.append(old_mid.shape[1] != nodes.shape[1])
        assert mids.shape[1] == nodes.shape[1]
    assert all(mismatched)
