"""Assembly of a least-squares NLP, min 1/2 |r(z)|^2 s.t. g(z) = 0, from terms made of blocks.

Every derivative Ipopt needs is assembled from the blocks (:mod:`.blocks`): a block sees a few
entries of z (e.g. two neighbouring nodes and the parameters) and its SX functions are mapped over
all blocks of its kind (two threads), so no large expression graph is ever differentiated.

Residual rows stack the terms in the order given, each term's block sets one after another; the
constraint rows are the *determining* constraints first (those that fix the ``dependent`` columns
of z, e.g. collocation defects), in the order given, then the side constraints (e.g. unit norms).
The Hessian given to Ipopt is the Gauss-Newton sigma J^T J or the exact Hessian of the Lagrangian,
both summed from per-block pieces (see :class:`BlockDerivatives`).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np
import scipy.sparse as sps

from casrecon.estimation.engine.blocks import BlockSet, SparseTarget, Term
from casrecon.estimation.engine.buffers import BlockEvaluator
from casrecon.physics.numpy_call import numpy_call


@dataclass(frozen=True)
class Nlp:
    """An assembled NLP: sizes, groups, and the block derivatives that evaluate it.

    The solver never needs a symbolic graph of the whole problem (every value and derivative
    comes from the blocks); :attr:`z`, :attr:`residuals` and :attr:`constraints` build one on
    first use, for checks against CasADi's own differentiation.

    Attributes
    ----------
    n_z, n_g, n_r : int
        Decision variables (every entry scaled to order one by whoever laid it out), constraints
        and residual rows.
    groups : dict of str to slice
        Residual rows of each group (groups with no rows are left out).
    const_chi2 : dict of str to float
        Per group, the chi-square part no unknown changes (see :class:`~.blocks.Term`).
    n_measurements : dict of str to int
        Per group, the measurements its rows stand for.
    derivatives : BlockDerivatives
    dependent : int array
        z columns fixed by the determining constraints given the others (their Jacobian block is
        square and nonsingular): used for the null-space covariance.
    n_determining : int
        Number of determining constraint rows (the first rows of g).
    parameter_names : dict of int to str
        z column -> name of the columns that are model or sensor parameters (used to name
        undetermined combinations and to read parameter covariances).
    latent : bool
        Whether z holds latent process values with their own prior at every node (a weak
        constraint): the null space is then large, the covariance comes from a sparse LU of the
        KKT matrix and the Gauss-Newton-decrement stopping test is not made.
    eliminated : int array
        Columns in no constraint whose Hessian block is sparse (e.g. latent sensor errors with a
        Gauss-Markov prior): the null-space covariance and the decrement test eliminate them by a
        Schur complement instead of carrying them in Z (see :mod:`.covariance`).
    stages : int array or None
        The node (time index, counted on across drops) of each z column, -1 for columns tied to no
        node: the time order of the full-space KKT factorisations
        (:func:`.time_ordered_kkt.time_order`); None where the NLP has no nodes.
    """

    n_z: int
    n_g: int
    n_r: int
    groups: dict[str, slice]
    const_chi2: dict[str, float]
    n_measurements: dict[str, int]
    derivatives: BlockDerivatives
    dependent: np.ndarray
    n_determining: int
    parameter_names: dict[int, str]
    latent: bool = False
    eliminated: np.ndarray = field(default_factory=lambda: np.zeros(0, np.int64))
    stages: np.ndarray | None = None

    @cached_property
    def symbolic(self) -> tuple[ca.MX, ca.MX, ca.MX]:
        """(z, residuals, constraints) as one MX graph of the mapped block value functions."""
        z = ca.MX.sym("z", self.n_z)
        d = self.derivatives
        out = [bs.symbolic_values(z) for bs in d.sets]  # each set's (residuals[, constraints]) once
        r_parts = [ca.vec(o[0]) for _, o in sorted(zip(d.r_rows, out), key=lambda t: t[0])]
        # constrained sets come first in d.sets, in constraint-row order
        g_parts = [ca.vec(o[1]) for o, g_rows in zip(out, d.g_rows) if g_rows is not None]
        return z, ca.vertcat(*r_parts), ca.vertcat(*g_parts) if g_parts else ca.MX(0, 1)

    @property
    def z(self) -> ca.MX:
        """Symbolic decision vector (see :attr:`symbolic`)."""
        return self.symbolic[0]

    @property
    def residuals(self) -> ca.MX:
        """Symbolic whitened residuals (see :attr:`symbolic`)."""
        return self.symbolic[1]

    @property
    def constraints(self) -> ca.MX:
        """Symbolic constraints (see :attr:`symbolic`)."""
        return self.symbolic[2]

    @property
    def parameter_columns(self) -> np.ndarray:
        """The parameters' z columns, ascending (the dense border of the KKT factorisations)."""
        return np.array(sorted(self.parameter_names), np.int64)

    @property
    def n_free(self) -> int:
        """Unknowns minus constraints: the directions the data (and priors) must determine."""
        return self.n_z - self.n_g

    def group_chi2(self, r: np.ndarray, groups=None) -> dict[str, float]:
        """chi-square of each group (of ``groups``, default all) at the residual vector ``r``,
        constants included."""
        names = self.groups if groups is None else groups
        return {g: float(r[self.groups[g]] @ r[self.groups[g]]) + self.const_chi2.get(g, 0.0) for g in names}

    def chi2(self, r: np.ndarray) -> float:
        """Total chi-square at ``r``, constants included."""
        return float(r @ r) + sum(self.const_chi2.values())

    def dof(self) -> int:
        """Measurements (priors included) minus free directions."""
        return sum(self.n_measurements.values()) - self.n_free

    def residual_vector(self, z: np.ndarray) -> np.ndarray:
        """Whitened residual vector at ``z`` (scaled), without derivatives unless they are cached there."""
        return self.derivatives.residuals_only(z)


class BlockDerivatives:
    """Gradient, constraint Jacobian and Hessian of the NLP at z, from the block functions.

    The three, and the residuals and constraints themselves, are computed by one evaluation of
    each set's mapped derivative function and cached for the last z, because Ipopt asks for all of
    them at each new iterate. ``hessian="gauss-newton"`` gives sigma triu(J^T J) (the constraint
    curvature is left out); ``"exact"`` the exact Hessian of the Lagrangian, block by block.

    Parameters
    ----------
    sets : list of BlockSet
    g_rows : list of int array or None
        For each set with constraints, the global row of each block's first constraint.
    r_rows : list of int
        For each set, the global row of its first residual.
    n_z, n_g, n_r : int
        Decision variables, constraints and residuals.
    hessian : {"gauss-newton", "exact"}
    """

    def __init__(self, sets: list[BlockSet], g_rows: list, r_rows: list[int], n_z: int, n_g: int, n_r: int,
                 hessian: str):
        self.sets, self.g_rows, self.n_z, self.n_g, self.hessian = sets, g_rows, n_z, n_g, hessian
        self.r_rows, self.n_r = r_rows, n_r
        jg_rows, jg_cols = self._stack("jg")
        self.jac_target = SparseTarget((n_g, n_z), jg_rows, jg_cols)
        self._z = None

    @cached_property
    def jtj_target(self) -> SparseTarget:
        """Where the blocks' triu(J_r^T J_r) nonzeros land in the global upper triangle (built at
        first use: the Gauss-Newton solver never assembles J^T J)."""
        rows, cols = self._stack("jtj")
        # a block's upper triangle maps to the global upper triangle once each pair is ordered
        return SparseTarget((self.n_z, self.n_z), np.minimum(rows, cols), np.maximum(rows, cols))

    def hess_target(self, hessian: str | None = None) -> SparseTarget:
        """Where the nonzeros of the Hessian given to Ipopt land: :attr:`jtj_target` for the
        Gauss-Newton Hessian, the blocks' exact Hessians' pattern for the exact one (``hessian``:
        "gauss-newton" or "exact", default the NLP's)."""
        return self.jtj_target if (hessian or self.hessian) == "gauss-newton" else self.exact_target

    @cached_property
    def exact_target(self) -> SparseTarget:
        """Where the blocks' exact-Hessian nonzeros land in the global upper triangle (built at
        first use: fits whose covariance takes the expected information never assemble it)."""
        rows, cols = self._stack("hess")
        return SparseTarget((self.n_z, self.n_z), np.minimum(rows, cols), np.maximum(rows, cols))

    @cached_property
    def evaluator(self) -> BlockEvaluator:
        """Every set's mapped (compiled) derivative function at one z, into numpy arrays."""
        # the sets' mapped (compiled) functions made one after the other: making CasADi functions is
        # not thread-safe (casadi#1355: evaluation is, symbolics are not); they are evaluated on threads
        return BlockEvaluator([bs.derivs for bs in self.sets], [bs.cols for bs in self.sets],
                              [bs.data for bs in self.sets], self.n_z)

    def residuals_only(self, z: np.ndarray) -> np.ndarray:
        """Whitened residual vector at ``z`` (a new array), without derivatives unless they are
        cached there (see :meth:`values_only`)."""
        return self.values_only(z)[0]

    @cached_property
    def value_evaluator(self) -> BlockEvaluator:
        """Every set's mapped value function (residuals and constraints, no derivatives) at one z."""
        return BlockEvaluator([bs.value_function for bs in self.sets], [bs.cols for bs in self.sets],
                              [bs.data for bs in self.sets], self.n_z)

    def values_only(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(whitened residuals, constraints) at ``z`` (new arrays): from the cache when ``evaluate``
        last ran at z, else from the value functions alone (a line search's trial points)."""
        z = np.asarray(z, float).ravel()
        if self._z is not None and np.array_equal(z, self._z):
            return self._r.copy(), self._g.copy()
        r, g = np.zeros(self.n_r), np.zeros(self.n_g)
        for g_rows, r_row, out in zip(self.g_rows, self.r_rows, self.value_evaluator(z)):
            r[r_row:r_row + out[0].size] = out[0].ravel()
            if len(out) > 1:
                g[(g_rows[:, None] + np.arange(out[1].shape[1])[None, :]).ravel()] = out[1].ravel()
        return r, g

    def _stack(self, key: str) -> tuple[np.ndarray, np.ndarray]:
        rows, cols = [np.zeros(0, np.int64)], [np.zeros(0, np.int64)]
        for bs, g_rows in zip(self.sets, self.g_rows):
            pattern = bs.kind.pattern(key)
            if pattern is None:
                continue
            lr, lc = pattern
            rows.append((g_rows[:, None] + lr[None, :]).ravel() if key == "jg" else bs.cols[:, lr].ravel())
            cols.append(bs.cols[:, lc].ravel())
        return np.concatenate(rows), np.concatenate(cols)

    def evaluate(self, z: np.ndarray) -> None:
        """Compute and cache the residuals, constraints, gradient, J_g nonzeros and J^T J nonzeros
        at z (scaled)."""
        z = np.asarray(z, float).ravel()
        if self._z is not None and np.array_equal(z, self._z):
            return
        grad, jr, jg = np.zeros(self.n_z), [], [np.zeros(0)]
        r, g = np.zeros(self.n_r), np.zeros(self.n_g)
        for bs, g_rows, r_row, out in zip(self.sets, self.g_rows, self.r_rows, self.evaluator(z)):
            # out[k] has one row per block
            grad += np.bincount(bs.cols.ravel(), weights=out[0].ravel(), minlength=self.n_z)
            jr.append(out[1])
            r[r_row:r_row + out[2].size] = out[2].ravel()
            if len(out) > 3:
                jg.append(out[3].ravel())
                g[(g_rows[:, None] + np.arange(out[4].shape[1])[None, :]).ravel()] = out[4].ravel()
        self._z, self.grad, self._jr, self._jg = z.copy(), grad, jr, np.concatenate(jg)  # a copy: callers mutate z
        self._r, self._g, self._jtj_at = r, g, None

    @property
    def _jtj(self) -> np.ndarray:
        """Every block's triu(J_r^T J_r) nonzeros at the last evaluated z, stacked (computed at
        first use: the Gauss-Newton solver never needs them, it works with J_r itself)."""
        if self._jtj_at is None:
            self._jtj_at = np.concatenate([np.zeros(0)] + [bs.kind.jtj_values(jr).ravel()
                                                           for bs, jr in zip(self.sets, self._jr)])
        return self._jtj_at

    @cached_property
    def jr_layout(self) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """(order, column indices, row pointers) of the global (n_r, n_z) residual Jacobian in CSR
        form: entry ``order[k]`` of the stacked block J_r nonzeros is the k-th stored entry. A
        residual row belongs to one block and a set's blocks own consecutive rows, so sorting each
        kind's few local entries by row (stably) and taking the sets in row order sorts them all:
        the same order as a stable sort of every entry by row, without sorting millions."""
        orders, counts, start = [], np.zeros(self.n_r, np.int64), 0
        for bs, r_row in zip(self.sets, self.r_rows):
            lr, lc = bs.kind.pattern("jr")
            local = np.argsort(lr, kind="stable")
            n_res, nnz = bs.kind.n_residuals, lr.size
            orders.append((r_row, (start + nnz * np.arange(bs.n_blocks)[:, None] + local[None, :]).ravel(),
                           bs.cols[:, lc[local]].ravel()))
            counts[r_row:r_row + n_res * bs.n_blocks] = np.tile(np.bincount(lr, minlength=n_res), bs.n_blocks)
            start += nnz * bs.n_blocks
        orders.sort(key=lambda item: item[0])
        order = np.concatenate([np.zeros(0, np.int64)] + [o for _, o, _ in orders])
        col = np.concatenate([np.zeros(0, np.int64)] + [c for _, _, c in orders])
        indptr = np.concatenate([[0], np.cumsum(counts)])
        return order, col, indptr

    def jacobian_r(self, z) -> sps.csr_matrix:
        """The whitened residuals' Jacobian J_r at z, (n_r, n_z), CSR (column indices within a row
        unsorted; see :attr:`jr_layout`)."""
        self.evaluate(z)
        order, indices, indptr = self.jr_layout
        values = np.concatenate([np.zeros(0)] + [jr.ravel() for jr in self._jr])[order]
        return sps.csr_matrix((values, indices, indptr), shape=(self.n_r, self.n_z))

    def residuals(self, z) -> np.ndarray:
        """Whitened residual vector at z."""
        self.evaluate(z)
        return self._r

    def constraints(self, z) -> np.ndarray:
        """Constraint vector at z."""
        self.evaluate(z)
        return self._g

    def gradient(self, z) -> np.ndarray:
        self.evaluate(z)
        return self.grad

    def jacobian_g_values(self, z) -> np.ndarray:
        """Nonzeros of J_g at z (in ``jac_target.sparsity`` order)."""
        self.evaluate(z)
        return self.jac_target.values(self._jg)

    def jacobian_g(self, z) -> sps.csc_matrix:
        """J_g at z."""
        return self.jac_target.matrix(self.jacobian_g_values(z))

    def gauss_newton(self, z) -> sps.csc_matrix:
        """Upper triangle of J^T J at z (the Fisher information the covariance uses)."""
        self.evaluate(z)
        return self.jtj_target.assemble(self._jtj)

    def hessian_values(self, z, sigma: float, lam_g: np.ndarray, hessian: str | None = None) -> np.ndarray:
        """Nonzeros (in ``hess_target(hessian).sparsity`` order) of the upper triangle of the Hessian
        of sigma f + lam_g^T g (``hessian``: "gauss-newton" or "exact", default the NLP's)."""
        if (hessian or self.hessian) == "gauss-newton":
            self.evaluate(z)
            return self.jtj_target.values(sigma * self._jtj)
        return self._exact_values(z, sigma, lam_g)

    def _exact_values(self, z, sigma: float, lam_g: np.ndarray) -> np.ndarray:
        """Nonzeros (in ``exact_target.sparsity`` order) of the upper triangle of the exact Hessian
        of sigma f + lam_g^T g, assembled from the blocks' exact Hessians (:attr:`.BlockSet.hess`)."""
        z = np.asarray(z, float).ravel()
        lam_g = np.asarray(lam_g, float).ravel()
        parts = [np.zeros(0)]
        for bs, g_rows in zip(self.sets, self.g_rows):
            n_c = bs.kind.n_constraints
            lam = lam_g[g_rows[:, None] + np.arange(n_c)[None, :]].T if n_c else np.zeros((0, bs.n_blocks))
            sigmas = np.full(bs.n_blocks, float(sigma))  # numpy_call passes no DM copies (0.68 -> 0.6 s, profile fit)
            parts.append(numpy_call(bs.hess, bs.local(z), *bs.data, sigmas, lam)[0].T.ravel())
        return self.exact_target.values(np.concatenate(parts))

    def observed_information(self, z, lam_g: np.ndarray) -> sps.csc_matrix:
        """The full symmetric exact Hessian of the Lagrangian f + lam_g^T g at ``z`` (f = |r|^2 / 2),
        whatever Hessian Ipopt is given: the observed information (see
        :func:`~casrecon.estimation.engine.covariance.compute_covariance`). ``lam_g``: the
        constraint multipliers at ``z`` (grad f + J_g^T lam_g = 0)."""
        upper = self.exact_target.matrix(self._exact_values(z, 1.0, lam_g))
        return (upper + sps.triu(upper, 1).T).tocsc()

    def hessian_lagrangian(self, z, sigma: float, lam_g: np.ndarray) -> sps.csc_matrix:
        """Upper triangle of the Hessian of sigma f + lam_g^T g (Gauss-Newton or exact)."""
        return self.hess_target().matrix(self.hessian_values(z, sigma, lam_g))


def assemble_nlp(terms: list[Term], n_z: int, *, dependent: np.ndarray, parameter_names: dict[int, str],
                 hessian: str = "gauss-newton", latent: bool = False,
                 eliminated: np.ndarray = (), stages: np.ndarray | None = None) -> Nlp:
    """The NLP made of ``terms`` over a decision vector of ``n_z`` scaled entries.

    Parameters
    ----------
    terms : list of Term
        Residual groups in row order; a group name may appear in several terms (their rows are
        then one group only if they are consecutive).
    n_z : int
    dependent : int array
        Columns the determining constraints fix (see :class:`Nlp`).
    parameter_names : dict of int to str
    hessian : {"gauss-newton", "exact"}
    latent : bool
        See :class:`Nlp`.
    eliminated : int array
        See :class:`Nlp`.
    stages : int array, optional
        See :class:`Nlp`.
    """
    groups, const, counts, start = {}, {}, {}, 0
    determining, side, r_row = [], [], {}
    for term in terms:
        rows = 0
        for bs in term.sets:
            r_row[id(bs)] = start + rows
            rows += bs.kind.n_residuals * bs.n_blocks
            if bs.kind.n_constraints:
                (determining if bs.determining else side).append(bs)
        if rows:
            if term.group in groups:
                raise ValueError(f"residual group {term.group!r} appears in two terms")
            groups[term.group] = slice(start, start + rows)
            const[term.group] = term.const_chi2
            counts[term.group] = rows if term.n_measurements is None else term.n_measurements
        start += rows
    sets, g_rows, row = [], [], 0
    constrained = {id(bs) for bs in determining + side}
    for bs in determining + side:
        sets.append(bs)
        g_rows.append(row + bs.kind.n_constraints * np.arange(bs.n_blocks))
        row += bs.kind.n_constraints * bs.n_blocks
    for term in terms:  # residual-only sets
        for bs in term.sets:
            if id(bs) not in constrained:
                sets.append(bs)
                g_rows.append(None)
    n_determining = sum(bs.kind.n_constraints * bs.n_blocks for bs in determining)
    derivs = BlockDerivatives(sets, g_rows, [r_row[id(bs)] for bs in sets], n_z, row, start, hessian)
    return Nlp(n_z, row, start, groups, const, counts, derivs, np.asarray(dependent, np.int64), n_determining,
               dict(sorted(parameter_names.items())), latent, np.unique(np.asarray(eliminated, np.int64)),
               None if stages is None else np.asarray(stages, np.int64))
