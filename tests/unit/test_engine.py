"""The generic engine on problems that are not drops: a straight-line fit with a prior, and a
constrained one, solved by Ipopt and compared with the closed-form least-squares answers."""

from __future__ import annotations

from dataclasses import replace

import casadi as ca
import numpy as np
import pytest

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term, unit_norm_term
from casrecon.estimation.engine.checks import FitError, check_determined, covariance_or_fail
from casrecon.estimation.engine.nlp import assemble_nlp
from casrecon.estimation.engine.solve import solve


def line_terms(t: np.ndarray, y: np.ndarray, sigma: float) -> list[Term]:
    """One block per sample: r = (y - a - b t) / sigma over z = [a, b]."""
    v, tt, yy = ca.SX.sym("v", 2), ca.SX.sym("t"), ca.SX.sym("y")
    kind = BlockKind("line", v, [tt, yy], (yy - v[0] - v[1] * tt) / sigma, None)
    cols = np.tile([0, 1], (t.size, 1))
    return [Term("samples", (BlockSet(kind, cols, [ca.DM(t).T, ca.DM(y).T]),))]


def test_line_fit_matches_closed_form():
    rng = np.random.default_rng(1)
    t = np.linspace(0.0, 1.0, 40)
    y = 0.3 + 1.7 * t + 0.05 * rng.normal(size=t.size)
    nlp = assemble_nlp(line_terms(t, y, 0.05), 2, dependent=np.zeros(0, int), parameter_names={0: "a", 1: "b"})
    sol = solve(nlp, np.zeros(2))
    assert sol.converged
    design = np.column_stack([np.ones_like(t), t]) / 0.05
    want = np.linalg.lstsq(design, y / 0.05, rcond=None)[0]
    assert sol.z == pytest.approx(want, abs=1e-9)
    r = nlp.residual_vector(sol.z)
    cov = covariance_or_fail(nlp, sol.z, r)
    assert cov.covariance_of([0, 1]) == pytest.approx(np.linalg.inv(design.T @ design), rel=1e-9)
    assert nlp.dof() == t.size - 2
    assert nlp.group_chi2(r)["samples"] == pytest.approx(float(r @ r))


def test_unit_norm_side_constraint_and_null_space_covariance():
    """Fit a direction (x, y) with |(x, y)| = 1 to noisy points on the unit circle's tangent: the
    covariance is the null-space one (the radial direction has zero variance)."""
    rng = np.random.default_rng(2)
    v, yy = ca.SX.sym("v", 2), ca.SX.sym("y", 2)
    kind = BlockKind("point", v, [yy], (yy - v) / 0.1, None)
    obs = np.array([0.6, 0.8]) + 0.1 * rng.normal(size=(30, 2))
    terms = [Term("points", (BlockSet(kind, np.tile([0, 1], (30, 1)), [ca.DM(obs.T)]),)),
             unit_norm_term(np.array([[0, 1]]))]
    nlp = assemble_nlp(terms, 2, dependent=np.zeros(0, int), parameter_names={0: "x", 1: "y"})
    assert "unit_norm" not in nlp.groups and nlp.n_g == 1
    sol = solve(nlp, np.array([1.0, 0.0]))
    mean = obs.mean(axis=0)
    assert sol.z == pytest.approx(mean / np.linalg.norm(mean), abs=1e-7)
    cov = covariance_or_fail(nlp, sol.z, nlp.residual_vector(sol.z))
    c = cov.covariance_of([0, 1])
    radial = sol.z / np.linalg.norm(sol.z)
    assert radial @ c @ radial == pytest.approx(0.0, abs=1e-12)
    tangent = np.array([-radial[1], radial[0]])
    assert tangent @ c @ tangent == pytest.approx(0.01 / 30, rel=0.05)  # 1-D mean, sigma 0.1, 30 points


def test_undetermined_parameter_is_named_before_solving():
    t = np.linspace(0.0, 1.0, 10)
    terms = line_terms(t, 2 * t, 0.1)
    nlp = assemble_nlp(terms, 3, dependent=np.zeros(0, int), parameter_names={0: "a", 1: "b", 2: "unused"})
    with pytest.raises(FitError, match="unused"):
        check_determined(nlp, np.zeros(3))


def test_duplicate_group_is_refused():
    t = np.linspace(0.0, 1.0, 5)
    terms = line_terms(t, t, 0.1)
    with pytest.raises(ValueError, match="appears in two terms"):
        assemble_nlp(terms + [replace(terms[0])], 2, dependent=np.zeros(0, int), parameter_names={})


def test_an_interrupt_casadi_reports_as_text_stops_the_solve_like_one():
    """CasADi turns a KeyboardInterrupt caught by its own signal check inside a nested call into a
    RuntimeError whose text ends in 'KeyboardInterrupt': the solver must treat it as the interrupt
    (else Ipopt takes it for a failed evaluation and goes on), and an ordinary error must stay one."""
    from casrecon.estimation.engine.convergence import Interruption

    caught = Interruption()
    raised = caught.keep(RuntimeError("Error in Function::call for 'block_evaluator' [MXFunction]:\nKeyboardInterrupt"))
    assert isinstance(raised, KeyboardInterrupt) and caught.error is raised
    with pytest.raises(KeyboardInterrupt):
        caught.check()
    ordinary = Interruption()
    err = RuntimeError("Error in Function::call: NaN detected")
    assert ordinary.keep(err) is err and ordinary.error is None


def test_block_evaluator_returns_each_sets_outputs_one_row_per_block():
    """The buffered evaluation equals CasADi's own call: per set, (n_blocks, n_rows) arrays, with
    each block's local variables gathered from z by its columns."""
    from casrecon.estimation.engine.buffers import BlockEvaluator

    x, d = ca.SX.sym("x", 2), ca.SX.sym("d", 3)
    fn = ca.Function("f", [x, d], [ca.densify(x * 2), ca.densify(ca.vertcat(x[0] * d, ca.sum1(x)))])
    cols = [np.array([[4, 0], [1, 5], [2, 3]]), np.array([[5, 1]])]
    data = [[ca.DM(np.arange(9.0).reshape(3, 3))], [ca.DM([[1.0], [2.0], [3.0]])]]
    evaluator = BlockEvaluator([fn.map(3, "serial"), fn], cols, data, 6)
    z = np.arange(6.0) + 0.5
    out = evaluator(z)
    for set_out, c, dd, f in zip(out, cols, data, [fn.map(3, "serial"), fn]):
        expected = f(z[c].T, dd[0])
        for got, want in zip(set_out, expected):
            assert got.shape == (c.shape[0], want.shape[0])
            np.testing.assert_array_equal(got, np.asarray(want).T)
