"""A fit's Gauss-Newton KKT matrix factorised in time order, for the full-space Gauss-Newton solver.

SuperLU's own orderings do not see the time structure of a fit's KKT matrix
K = [[J^T J, A^T], [A, 0]]. With an atmosphere-profile grid (ees-drop-1, 10 m grid: 41,653 rows,
3.7M nonzeros) each profile coefficient reaches every node of the second or so the capsule spends
near its level, and even with the parameters taken out as a border (:mod:`.bordered_kkt`) COLAMD
gives 33M LU nonzeros and 5.0 s; threshold pivoting in a time order 26M or more. Eliminated in
time order instead (:func:`time_order`: each node's states, the defects reaching them, every other
unknown right after the last node it reaches, the parameters last) the fronts stay the size of a
node's states plus the profile coefficients and GPS errors active at that time, as in a Riccati
recursion: 4 to 6M nonzeros, about 0.15 s.

That order is only usable without pivoting, and then every pivot must be nonzero; a node's
Gauss-Newton block can be singular (its states seen only through the next node). So the primal
diagonal is shifted by REGULARIZATION and each solve refined against the unshifted matrix
(iterative refinement, while each step shrinks the worst row's residual at least CONTRACTION times
and at most MAX_REFINEMENTS steps, until every row's residual is below REFINEMENT_TOL times that
row's (|K| |x| + |f|)_i: two to four steps on ees-drop-1, twelve on a fit with latent GPS errors
correlated over 400 s). A matrix on which that does not converge is factorised again with the larger
shift RETRY_REGULARIZATION (0.25 s there, against 8 s for a pivoting factor), and only if that
does not converge either with SuperLU's pivoting order, the parameters as a border
(:class:`.bordered_kkt.BorderedKkt`), so a solve returns the same answer either way, only slower.

The matrix's values come from the NLP's fixed-pattern sources (the blocks' triu(J^T J) and the
constraint Jacobian's nonzeros): :class:`OrderedPattern` works out once per NLP where each lands.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps
from scipy.sparse.linalg import splu

from casrecon.estimation.engine.bordered_kkt import BorderedKkt

#: Shift of the primal diagonal (z is scaled to order one). Larger than round-off needs: the pivots'
#: growth, not the shift, limits the refinement (on ees-drop-1's KKT matrix the first solve's worst
#: row was 2.4e3 times its bound with 1e-8 and converged in 4 steps, 27 times with 1e-6 and
#: converged in 2; 1e-10 did not converge, 1e-4 took 3 steps).
REGULARIZATION = 1e-6
#: The shift of a second factor when the first one's refinement does not converge. On a default fit
#: with latent GPS errors correlated over 400 s (benchmarks/default_cost.py's case, the matrix of
#: 37,059 rows where the first factor failed in every fit), the worst row's residual over its bound
#: after each step: with 1e-6 2e9, 4e8, ... 4.5, 0.8 (twelve steps), with 1e-4 9e7, 3e5, 2e3, 10,
#: 0.05 (five), with 1e-8 5e10 without shrinking. Larger than REGULARIZATION: more steps where
#: both converge, but convergence where the pivots' growth defeats the small shift.
RETRY_REGULARIZATION = 1e-4
#: Iterative-refinement steps at most per solve (each costs a solve and a product, 10 to 20 ms on
#: ees-drop-1; the pivoting factorisation it avoids, 5 to 13 s).
MAX_REFINEMENTS = 30
#: Each refinement step must shrink the worst row's residual relative to its bound at least this
#: much (a factor of 1 / CONTRACTION), else the factor is given up (on the matrix above the steps
#: that converge shrink it 2 to 80 times; the ones that do not, by less than 2 or not at all).
CONTRACTION = 0.5
#: Largest residual of a refined solve in each row, relative to that row's (|K| |x| + |f|)_i: row by
#: row and with the row's own entries of x, because a norm over the whole matrix or over x lets a
#: constraint row keep a residual of 1e-7 (the stiff IMU rows' entries are 1e6; with a small
#: profile prior the multipliers reach 1e6), and the Gauss-Newton iteration then stalled at a
#: constraint violation of 1e-8 to 4e-8 for 30 iterations on ees-drop-1's profile refit.
REFINEMENT_TOL = 1e-12
#: Each row's bound is at least this fraction of the largest row's (for rows whose |K| |x| + |f| is 0).
FLOOR = 1e-8
#: Refining against this matrix with an earlier matrix's factor (a chord step), a step that does not
#: shrink the worst row's residual by CONTRACTION has this matrix factorised. On ees-drop-1's profile
#: fit, after steps of 0.01 to 0.1: where the earlier factor converges it shrinks 3 to 1000 times a
#: step (5 to 9 steps, against 3 with the matrix's own factor); where it does not, the residual grows
#: at the second step.


def time_order(kkt: sps.spmatrix, n_z: int, stages: np.ndarray, last: np.ndarray) -> np.ndarray:
    """The rows of the symmetric matrix ``kkt`` in time order.

    ``stages`` gives the node (time index) of each of the first ``n_z`` rows (the unknowns), -1 for
    unknowns tied to no node. A node's unknowns come at their node, in row order; a constraint row
    just after the last node it reaches (before it, its zero diagonal would be a pivot: SuperLU
    would then pick another row, a parameter's if it is the largest, and the factor fills: 565M
    nonzeros); every other unknown (profile coefficients, GPS errors) after those, or first when it
    reaches no node; the rows ``last`` (the parameters, which reach every node) at the end.
    """
    csc = sps.csc_matrix(kkt)
    n = csc.shape[0]
    node = np.full(n, -1.0)
    node[:n_z] = stages
    reach = np.full(n, -1.0)  # the last node each row (column: K is symmetric) reaches
    np.maximum.at(reach, np.repeat(np.arange(n), np.diff(csc.indptr)), node[csc.indices])
    key = np.where(node >= 0, node, np.where(np.arange(n) < n_z, reach + 0.75, reach + 0.25))
    key[(node < 0) & (reach < 0)] = -1.0
    key[np.asarray(last, np.int64)] = np.inf
    return np.argsort(key, kind="stable")  # stable: a node's unknowns in row order


class OrderedPattern:
    """Where the nonzeros of a KKT matrix assembled from fixed-pattern sources land in its
    time-ordered form with the shifted primal diagonal; worked out once per NLP, so that each
    iterate's matrix is a gather of the source values.

    Parameters
    ----------
    marker : sparse matrix (n, n)
        The KKT matrix whose every nonzero is 1 + the index of its entry in the source vector.
    n_z : int
        Number of primal rows (the first ones).
    stages : int array
        Node of each primal row (see :func:`time_order`).
    last : int array
        Rows ordered last (the parameters).
    """

    def __init__(self, marker: sps.spmatrix, n_z: int, stages: np.ndarray, last: np.ndarray) -> None:
        csc = sps.csc_matrix(marker)
        self.shape = csc.shape
        self.order = time_order(csc, n_z, stages, last)
        self.n_last = int(np.asarray(last).size)
        primal = self.order < n_z
        permuted = csc[self.order][:, self.order].tocsc()
        # +0.5 on the primal diagonal puts it in the pattern; flooring gives back the markers
        permuted = (permuted + sps.diags(np.where(primal, 0.5, 0.0))).tocsc()
        permuted.sort_indices()
        self.indptr, self.indices = permuted.indptr, permuted.indices
        self.source = np.floor(permuted.data).astype(np.int64) - 1  # -1: the shifted diagonal alone
        cols = np.repeat(np.arange(self.shape[1]), np.diff(self.indptr))
        #: 1 on the primal diagonal's entries, 0 elsewhere (times the shift of the factor made)
        self.shift = np.where((self.indices == cols) & primal[self.indices], 1.0, 0.0)

    def matrix(self, source: np.ndarray) -> sps.csc_matrix:
        """The time-ordered matrix (unshifted) from the source values."""
        values = np.append(np.asarray(source, float), 0.0)[self.source]  # index -1 reads the appended zero
        return sps.csc_matrix((values, self.indices, self.indptr), shape=self.shape)


class TimeOrderedKkt:
    """Factor of the KKT matrix with these source values (see :class:`OrderedPattern` and the module
    docstring): solves K x = rhs in the original row order.

    Raises
    ------
    RuntimeError
        When even SuperLU's pivoting factorisation finds the matrix singular.
    """

    def __init__(self, pattern: OrderedPattern, source: np.ndarray, earlier: TimeOrderedKkt | None = None) -> None:
        self.order, self._n_last, self._pattern = pattern.order, pattern.n_last, pattern
        self._matrix = pattern.matrix(source)
        self._magnitude = abs(self._matrix)
        #: Whether the factor in use is ``earlier``'s (a chord step; see :meth:`_solve_ordered`).
        self.stale = earlier is not None and earlier.refined and earlier._pattern is pattern
        #: The primal diagonal's shift of the factor in use (REGULARIZATION or RETRY_REGULARIZATION).
        self.shift = earlier.shift if self.stale else REGULARIZATION
        self._lu = earlier._lu if self.stale else self._factorised(self.shift)
        self.refined = True  # False once the pivoting factorisation had to be used

    def _factorised(self, shift: float):
        """SuperLU factor of this matrix with the primal diagonal shifted by ``shift``, in time order,
        no pivoting."""
        p = self._pattern
        shifted = sps.csc_matrix((self._matrix.data + shift * p.shift, p.indices, p.indptr), shape=p.shape)
        return splu(shifted, permc_spec="NATURAL", diag_pivot_thresh=0.0, options={"SymmetricMode": True})

    def _solve_ordered(self, f: np.ndarray) -> np.ndarray:
        """The solution in time order for a right-hand side ``f`` in time order.

        The refinement stops as soon as a step shrinks the worst row's residual (relative to its
        bound) by less than CONTRACTION: with an earlier matrix's factor (``stale``) this matrix is
        then factorised and the solve made again; with this matrix's own, it is factorised again
        with RETRY_REGULARIZATION, and if that does not converge either, with pivoting."""
        x = self._lu.solve(f)
        if not self.refined:
            return x
        worst_before = np.inf
        for _ in range(MAX_REFINEMENTS + 1):
            residual = f - self._matrix @ x
            size = self._magnitude @ np.abs(x) + np.abs(f)
            bound = REFINEMENT_TOL * (size + FLOOR * size.max(axis=0, initial=0.0))
            if np.all(np.abs(residual) <= bound):
                return x
            worst = float(np.max(np.abs(residual) / np.maximum(bound, np.finfo(float).tiny)))
            if worst > CONTRACTION * worst_before:
                break
            worst_before = worst
            x = x + self._lu.solve(np.ascontiguousarray(residual))
        if self.stale:  # the earlier factor converges too slowly here: this matrix's own
            self._lu, self.stale = self._factorised(self.shift), False
            return self._solve_ordered(f)
        if self.shift != RETRY_REGULARIZATION:  # the pivots' growth defeats the small shift: the other one
            self.shift = RETRY_REGULARIZATION
            self._lu = self._factorised(self.shift)
            return self._solve_ordered(f)
        # the shifted factor does not converge here: SuperLU's pivoting order, the parameters as a border
        n = self._matrix.shape[0]
        self._lu = BorderedKkt(self._matrix, np.arange(n - self._n_last, n))
        self.refined = False
        return self._lu.solve(f)

    @property
    def fill(self) -> int:
        """Nonzeros of the factors in use (read when asked: SuperLU copies them out, 0.05 s on an
        atmosphere-profile fit's matrix, too much to pay at every iterate)."""
        if isinstance(self._lu, BorderedKkt):
            return self._lu.fill
        return int(self._lu.L.nnz + self._lu.U.nnz)

    def solve(self, rhs: np.ndarray) -> np.ndarray:
        """K^-1 rhs for a vector or the columns of a matrix ``rhs``."""
        rhs = np.asarray(rhs, float)
        out = np.empty_like(rhs)
        out[self.order] = self._solve_ordered(np.ascontiguousarray(rhs[self.order]))
        return out

    def solve_fixed(self, rhs: np.ndarray, fixed: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The solution of K x = rhs with the entries ``fixed`` of x held at ``values`` and those rows
        of the system dropped, and the dropped rows' residual rhs - K x (the force holding each):
        x = K^-1 (rhs - E mu), mu chosen so that x_fixed = values (one more solve per fixed entry)."""
        fixed = np.asarray(fixed, np.int64)
        x0 = self.solve(rhs)
        if not fixed.size:
            return x0, np.zeros(0)
        unit = np.zeros((x0.size, fixed.size))
        unit[fixed, np.arange(fixed.size)] = 1.0
        columns = self.solve(unit)
        mu = np.linalg.solve(columns[fixed], x0[fixed] - np.asarray(values, float))
        return x0 - columns @ mu, mu
