"""Diagonal and first off-diagonal blocks of the inverse of a sparse symmetric matrix that some
ordering makes banded, without the inverse: the block-tridiagonal selected inversion.

The covariance of a fit with latent values at every node (a point-mass track's states, GPS error
and area processes; a 6-DOF fit's disturbance states) is read node by node from the inverse of its
KKT matrix without the parameters' rows and columns (:class:`~casrecon.estimation.engine.
bordered_kkt.BorderedKkt`'s sparse block). One LU solve per requested column costs O(n) each, so
reading every node costs O(n^2): 984 s of a 1027 s GPS-only fit of a 25 Hz track (issue 49). That
block is banded in time order; reverse Cuthill-McKee finds such an order from its pattern alone.
Cut into blocks of the bandwidth b, the matrix is block tridiagonal, and the recursive Green's
function recurrences give every diagonal block of the inverse and those beside it in O(n b^2):

    g_1 = A_11^-1,   g_i = (A_ii - A_i,i-1 g_i-1 A_i-1,i)^-1                  (forward),
    G_NN = g_N,      G_ii = g_i + g_i A_i,i+1 G_i+1,i+1 A_i+1,i g_i,
    G_i+1,i = -G_i+1,i+1 A_i+1,i g_i                                          (backward).

The matrix need not be definite (a KKT matrix is not): each g_i is a dense LU inverse of a
Schur complement, and a singular one (a leading block the ordering left singular) makes the
inverse refuse (:class:`NotBanded`), so the caller falls back to its column solves. Without
pivoting across blocks the recurrences can lose digits where a leading block is nearly singular:
callers check some blocks against column solves (:meth:`.BorderedKkt.inverse_blocks`). On the
GPS-only fit of realdata-fs2-chicago (8,016 rows, bandwidth 28, leading block's condition 4e13)
the blocks agree with column solves to 3e-9 (relative to their largest entry).
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps
from scipy.sparse.csgraph import reverse_cuthill_mckee

#: Widest band (unknowns) inverted this way; wider matrices are left to column solves (the work
#: and the memory grow with its square).
MAX_BANDWIDTH = 600


class NotBanded(ValueError):
    """The matrix is not banded enough, a block is singular, or an index set spans more than two
    neighbouring blocks: no selected inverse (use column solves)."""


def banded_order(matrix: sps.spmatrix) -> tuple[np.ndarray, int]:
    """(reverse Cuthill-McKee permutation, the permuted matrix's bandwidth) of a symmetric pattern."""
    a = sps.csr_matrix(matrix)
    perm = np.asarray(reverse_cuthill_mckee(a, symmetric_mode=True), np.int64)
    position = np.empty(a.shape[0], np.int64)
    position[perm] = np.arange(a.shape[0])
    coo = a.tocoo()
    bandwidth = int(np.max(np.abs(position[coo.row] - position[coo.col]))) if coo.nnz else 0
    return perm, bandwidth


def selected_flops(n: int, block_size: int) -> float:
    """About the floating-point operations of :class:`BandedInverse` on an n x n matrix cut into
    blocks of this size (6 n b^2: an inverse and a few b x b products per block of b)."""
    return 6.0 * n * max(block_size, 1) ** 2


def order_span(order: tuple[np.ndarray, int], sets: list[np.ndarray]) -> int:
    """The widest distance plus one between the positions in ``order`` of one set's indices."""
    position = np.empty(order[0].size, np.int64)
    position[order[0]] = np.arange(order[0].size)
    return max((int(np.ptp(position[s])) + 1 for s in sets if s.size), default=1)


class BandedInverse:
    """The diagonal and first off-diagonal blocks of A^-1 for a sparse symmetric nonsingular A.

    Parameters
    ----------
    matrix : sparse matrix (n, n)
        Symmetric (its pattern and values); need not be definite.
    order : (permutation, bandwidth), optional
        :func:`banded_order` of ``matrix``, when already computed.
    span : int
        Smallest block size: an index set whose positions in the order lie within ``span`` of
        each other falls in one block or two neighbouring ones (:meth:`block_of`).

    Raises
    ------
    NotBanded
        When the reverse Cuthill-McKee bandwidth exceeds MAX_BANDWIDTH or a forward block is
        singular.
    """

    def __init__(self, matrix: sps.spmatrix, order: tuple[np.ndarray, int] | None = None, span: int = 1) -> None:
        a = sps.csr_matrix(matrix)
        n = a.shape[0]
        self.perm, self.bandwidth = banded_order(a) if order is None else order
        self.position = np.empty(n, np.int64)
        self.position[self.perm] = np.arange(n)
        ap = a[self.perm][:, self.perm]
        if self.bandwidth > MAX_BANDWIDTH:
            raise NotBanded(f"bandwidth {self.bandwidth} after reverse Cuthill-McKee, above {MAX_BANDWIDTH}")
        b = max(self.bandwidth, span, 1)
        self.block_size = b
        self.starts = np.arange(0, n + b, b)[: -(-n // b) + 1]
        self.starts[-1] = n
        self.diagonal, self.lower = self._recurrences(ap)

    def _recurrences(self, ap: sps.csr_matrix) -> tuple[list[np.ndarray], list[np.ndarray]]:
        """(G_ii for each block, G_i+1,i for each pair) of the permuted matrix ``ap``."""
        s = self.starts
        n_blocks = s.size - 1

        def block(i: int, j: int) -> np.ndarray:
            return ap[s[i]:s[i + 1], s[j]:s[j + 1]].toarray()

        forward: list[np.ndarray] = []
        below: list[np.ndarray] = []  # A_i+1,i
        for i in range(n_blocks):
            d = block(i, i)
            if i:
                d = d - below[i - 1] @ forward[i - 1] @ below[i - 1].T
            try:
                g = np.linalg.inv(d)
            except np.linalg.LinAlgError:
                raise NotBanded(f"block {i} of {n_blocks} singular") from None
            if not np.all(np.isfinite(g)):
                raise NotBanded(f"block {i} of {n_blocks} singular")
            forward.append(g)
            if i + 1 < n_blocks:
                below.append(block(i + 1, i))
        diagonal: list[np.ndarray] = [np.empty(0)] * n_blocks
        lower: list[np.ndarray] = [np.empty(0)] * (n_blocks - 1)
        diagonal[-1] = forward[-1]
        for i in range(n_blocks - 2, -1, -1):
            g, a_below = forward[i], below[i]
            lower[i] = -diagonal[i + 1] @ a_below @ g
            diagonal[i] = g - g @ a_below.T @ lower[i]
        for i in range(n_blocks):
            diagonal[i] = 0.5 * (diagonal[i] + diagonal[i].T)
        return diagonal, lower

    def block_of(self, idx: np.ndarray) -> np.ndarray:
        """A^-1[idx][:, idx] for an index set whose permuted positions lie in one block or two
        neighbouring ones; NotBanded otherwise."""
        pos = self.position[np.asarray(idx, np.int64)]
        blk = np.searchsorted(self.starts, pos, side="right") - 1
        first = int(blk.min())
        if int(blk.max()) == first:
            local = pos - self.starts[first]
            return self.diagonal[first][np.ix_(local, local)]
        if int(blk.max()) - first > 1:
            raise NotBanded("an index set spans more than two neighbouring blocks")
        lo, mid, hi = self.starts[first], self.starts[first + 1], self.starts[first + 2]
        window = np.empty((hi - lo, hi - lo))
        window[:mid - lo, :mid - lo] = self.diagonal[first]
        window[mid - lo:, mid - lo:] = self.diagonal[first + 1]
        window[mid - lo:, :mid - lo] = self.lower[first]
        window[:mid - lo, mid - lo:] = self.lower[first].T
        local = pos - lo
        return window[np.ix_(local, local)]
