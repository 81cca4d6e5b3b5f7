"""Blocks: the pieces an NLP is made of, and the sparse targets their derivatives land in.

A block depends on a few local variables (two neighbouring nodes and the parameters). Its value
function (residuals, constraints), its derivative function (J_r^T r, J_g nonzeros and the
Gauss-Newton Hessian nonzeros triu(J_r^T J_r)) and its exact-Hessian function are small SX
functions built once and evaluated for every block by ``map`` on two threads. :class:`SparseTarget`
sums the mapped nonzeros into one global sparse matrix with a precomputed index (neighbouring
intervals share a node; every block shares the parameters).

Because the local variables of a block are a fixed set of entries of z, a block's Hessian in local
upper-triangular order lands in the global upper triangle (the local-to-global map is increasing).
"""

from __future__ import annotations

from dataclasses import dataclass, field
from functools import cached_property

import casadi as ca
import numpy as np
import scipy.sparse as sps

from casrecon.physics.compiled import compiled


class SparseTarget:
    """Where each source entry lands in a global sparse matrix (duplicates are summed).

    Parameters
    ----------
    shape : (int, int)
    rows, cols : int arrays
        Global row and column of every source entry, in the order the source vector stacks them.
    """

    def __init__(self, shape: tuple[int, int], rows: np.ndarray, cols: np.ndarray) -> None:
        lin = np.asarray(cols, np.int64) * shape[0] + np.asarray(rows, np.int64)
        # a stable sort (timsort: the blocks' entries come in long increasing runs) and the first of
        # each run of equal entries; np.unique's quicksort takes 3 to 5 times as long (0.25 s
        # against 0.08 s for the 2.9M entries of an atmosphere-profile fit's J^T J)
        order = np.argsort(lin, kind="stable")
        ordered = lin[order]
        first = np.ones(ordered.size, bool)
        np.not_equal(ordered[1:], ordered[:-1], out=first[1:])
        unique = ordered[first]
        self.target = np.empty(lin.size, np.int64)
        self.target[order] = np.cumsum(first) - 1
        self.nnz, self.shape = unique.size, shape
        # column-major order of the unique entries is CSC order
        self.row_index = np.asarray(unique % shape[0], np.int64)
        self.col_start = np.searchsorted(unique // shape[0], np.arange(shape[1] + 1)).astype(np.int64)

    @cached_property
    def sparsity(self) -> ca.Sparsity:
        """The global matrix's CasADi sparsity (built at first use: only Ipopt's callbacks need it)."""
        cols = np.repeat(np.arange(self.shape[1]), np.diff(self.col_start))
        return ca.Sparsity.triplet(self.shape[0], self.shape[1], self.row_index.tolist(), cols.tolist())

    def values(self, source: np.ndarray) -> np.ndarray:
        """Nonzeros (in :attr:`sparsity`'s order) of the global matrix from the stacked source values."""
        return np.bincount(self.target, weights=source, minlength=self.nnz)

    def assemble(self, source: np.ndarray) -> sps.csc_matrix:
        """Global sparse matrix from the stacked source values."""
        return self.matrix(self.values(source))

    def matrix(self, nonzeros: np.ndarray) -> sps.csc_matrix:
        """The global sparse matrix with these nonzeros (in :attr:`sparsity`'s order)."""
        return sps.csc_matrix((nonzeros, self.row_index, self.col_start), shape=self.shape)


def _triplet(m: ca.SX) -> tuple[np.ndarray, np.ndarray]:
    r, c = m.sparsity().get_triplet()
    return np.array(r, np.int64), np.array(c, np.int64)


class BlockKind:
    """One kind of block: SX functions of its local (scaled) variables and per-block data.

    Parameters
    ----------
    name : str
    local : SX column
        The block's local decision variables.
    data : list of SX
        Per-block data inputs (measurements, weights).
    residual : SX column
        Whitened residuals of the block.
    constraint : SX column or None
        Equality constraints of the block (= 0).

    Attributes
    ----------
    values : Function
        ``(local, *data) -> (r[, g])``.
    derivatives : Function
        ``(local, *data) -> (J_r^T r, J_r nonzeros, r[, J_g nonzeros, g])``: with the values, so
        one evaluation per iterate serves the objective, the constraints and their derivatives.
    patterns : dict
        Local (row, col) triplets of "jtj", "jr", "jg" (see :meth:`pattern`).
    """

    def __init__(self, name: str, local: ca.SX, data: list, residual: ca.SX, constraint) -> None:
        jr = ca.jacobian(residual, local)
        jtj = ca.triu(ca.mtimes(jr.T, jr))  # only its sparsity is used: values come from jtj_values
        self.n_constraints = 0 if constraint is None else constraint.numel()
        self.patterns = {"jtj": _triplet(jtj), "jr": _triplet(jr)}
        self.n_residuals = residual.numel()
        outs = [ca.mtimes(jr.T, residual), ca.vec(jr.nz[:]), residual]  # made dense below
        plain = [residual]
        if constraint is not None:
            jg = ca.jacobian(constraint, local)
            outs += [ca.vec(jg.nz[:]), constraint]
            plain.append(constraint)
            self.patterns["jg"] = _triplet(jg)
        self.values = ca.Function(f"{name}_values", [local, *data], [ca.densify(p) for p in plain])
        self.derivatives = ca.Function(f"{name}_derivatives", [local, *data], [ca.densify(o) for o in outs])
        self.n_local = local.numel()
        self._symbols = (name, local, data, residual, constraint)

    @cached_property
    def exact_hessian(self) -> ca.Function:
        """``(local, *data, sigma, lam) -> triu(Hessian of sigma |r|^2 / 2 + lam^T g) nonzeros``,
        built at first use (fits with the Gauss-Newton Hessian never need it); its local pattern
        is then in ``patterns["hess"]``."""
        name, local, data, residual, constraint = self._symbols
        lam, sigma = ca.SX.sym("lam", self.n_constraints), ca.SX.sym("sigma")
        lagr_g = 0 if constraint is None else ca.dot(lam, constraint)
        hess = ca.triu(ca.hessian(sigma * 0.5 * ca.sumsqr(residual) + lagr_g, local)[0])
        self.patterns["hess"] = _triplet(hess)
        return ca.Function(f"{name}_hess", [local, *data, sigma, lam], [ca.vec(hess.nz[:])])

    def pattern(self, key: str) -> tuple[np.ndarray, np.ndarray] | None:
        """Local (row, col) triplets of "jtj", "jr", "jg" (None without constraints) or "hess"."""
        if key == "hess":
            _ = self.exact_hessian
        return self.patterns.get(key)

    def jtj_values(self, jr_nz: np.ndarray) -> np.ndarray:
        """Nonzeros of triu(J_r^T J_r) of every block (n_blocks, nnz) from J_r's nonzeros
        (n_blocks, nnz_jr), by one batched matrix product (cheaper than in the SX function)."""
        rows, cols = self.patterns["jr"]
        j = np.zeros((jr_nz.shape[0], self.n_residuals, self.n_local))
        j[:, rows, cols] = jr_nz
        jtj = np.matmul(j.transpose(0, 2, 1), j)
        h_rows, h_cols = self.patterns["jtj"]
        return jtj[:, h_rows, h_cols]


#: Threads over which the block functions of one set are evaluated.
MAP_THREADS = 2
#: Instructions (per block times blocks) from which a set's function is compiled: below it the
#: interpreter's cost is smaller than the compiler's (the interval derivatives of a 40 s drop at
#: 100 Hz are about 6e7; a GPS set of 200 fixes about 1e6).
COMPILE_MIN_WORK = 5_000_000


class BlockSet:
    """All blocks of one kind in an NLP: the kind, each block's global columns and its data.

    Parameters
    ----------
    kind : BlockKind
    cols : (n_blocks, kind.n_local) int array
        Global z index of every local variable of every block (increasing along a row).
    data : list of DM
        Per-block data inputs of ``kind``, one column per block.
    determining : bool
        Whether the block's constraints (if any) are among those that fix the dependent columns
        of the NLP (collocation defects), or side constraints (e.g. a unit norm).
    """

    def __init__(self, kind: BlockKind, cols: np.ndarray, data: list | None = None, determining: bool = True) -> None:
        self.kind, self.cols, self.data = kind, np.asarray(cols, np.int64), list(data or [])
        self.determining = determining
        self._derivs: ca.Function | None = None
        self._values: ca.Function | None = None

    def mapped(self, function: ca.Function, in_background: bool = True) -> ca.Function:
        """``function`` mapped over every block, compiled (see :mod:`.compiled`) when one
        evaluation over all blocks is at least COMPILE_MIN_WORK instructions (compiled functions
        have no derivatives: for symbolic work use :meth:`symbolic_values`). ``in_background``
        (the default, and what every fit uses): a library not built yet is built in a detached
        process and the interpreted function mapped meanwhile, so no fit waits for a compiler; a
        later fit (a refit, the next fit of the same vehicle and mesh) loads the library. False:
        compile first."""
        n = self.n_blocks
        if function.n_instructions() * n >= COMPILE_MIN_WORK:
            function = compiled(function, in_background)
        return function.map(n, "thread", MAP_THREADS) if n > 1 else function

    @property
    def derivs(self) -> ca.Function:
        """The kind's derivative function over all blocks (built at first use; several sets' may be
        built at once on threads, which ``functools.cached_property``'s class-wide lock would
        serialise in Python 3.11)."""
        if self._derivs is None:
            self._derivs = self.mapped(self.kind.derivatives)
        return self._derivs

    @property
    def value_function(self) -> ca.Function:
        """The kind's value function (residuals[, constraints], no derivatives) over all blocks
        (built at first use, as :attr:`derivs`)."""
        if self._values is None:
            self._values = self.mapped(self.kind.values)
        return self._values

    @cached_property
    def hess(self) -> ca.Function:
        """The kind's exact-Hessian function over all blocks, for a solver that evaluates it at
        every iterate and for the observed-information covariance (built at first use; compiled if
        its library is built, else interpreted while the library is built in the background, as
        every block function: its -O1 build takes longer than a fit, see
        :mod:`casrecon.physics.compiled`)."""
        return self.mapped(self.kind.exact_hessian)

    def symbolic_values(self, z: ca.MX) -> list:
        """The blocks' (residuals[, constraints]) as MX of the global ``z``, with the interpreted
        (differentiable) value function."""
        local = ca.reshape(z[self.cols.ravel().tolist()], self.kind.n_local, self.n_blocks)
        values = self.kind.values.map(self.n_blocks, "thread", MAP_THREADS) if self.n_blocks > 1 else self.kind.values
        out = values(local, *self.data)
        return list(out) if isinstance(out, (list, tuple)) else [out]

    @property
    def n_blocks(self) -> int:
        return int(self.cols.shape[0])

    def local(self, z: np.ndarray) -> np.ndarray:
        """The blocks' local variables (n_local, n_blocks) from the global z."""
        return z[self.cols].T


@dataclass(frozen=True)
class Term:
    """One named residual group of an NLP: its block sets and what its rows stand for.

    Parameters
    ----------
    group : str
        Residual group name (chi-square is reported per group), e.g. ``"imu"``, ``"gps"``,
        ``"prior_aero"``; a term with no residual rows (constraints only) reports nothing.
    sets : tuple of BlockSet
    const_chi2 : float
        Part of the group's chi-square that no unknown changes (e.g. the constant of an exact QR
        compression of many samples into few rows).
    n_measurements : int or None
        Measurements the rows stand for (None: one per residual row).
    """

    group: str
    sets: tuple[BlockSet, ...] = field(default_factory=tuple)
    const_chi2: float = 0.0
    n_measurements: int | None = None


def unit_norm_term(cols: np.ndarray, group: str = "unit_norm") -> Term:
    """Side constraints |z[c]|^2 = 1 for each row ``c`` of ``cols`` (e.g. a quaternion per drop)."""
    cols = np.asarray(cols, np.int64)
    v = ca.SX.sym("v", cols.shape[1])
    kind = BlockKind(group, v, [], ca.SX(0, 1), ca.dot(v, v) - 1)
    return Term(group, (BlockSet(kind, cols, determining=False),))
