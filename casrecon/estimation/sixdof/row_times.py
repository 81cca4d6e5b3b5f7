"""When each residual row of a per-drop fit happens: the time blocks of the sandwich widening
(:mod:`casrecon.estimation.engine.block_sandwich`).

A row that involves node states happens at the mean time of those nodes (an IMU interval's
samples, a GPS fix between two nodes). Other unknowns take the time of the rows that involve them
when those rows lie within a quarter of the window (a latent GPS error of one fix, a profile level
passed at one time); their own prior rows then happen then too. Unknowns seen all along the window
(the parameters, a whole-drop constant) have no time, and a row that involves nothing else, a
prior on a constant, belongs to no block.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps

#: Unknowns whose rows span more than this share of the window have no time of their own.
LOCAL_SHARE = 0.25


def _mean_known(pattern: sps.csr_matrix, column_time_s: np.ndarray) -> np.ndarray:
    """Per row, the mean time of the columns with a time it touches (nan when none)."""
    known = np.isfinite(column_time_s)
    count = pattern @ known.astype(float)
    total = pattern @ np.where(known, column_time_s, 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(count > 0, total / count, np.nan)


def residual_row_times(jacobian_r: sps.spmatrix, node_columns: np.ndarray, node_time_s: np.ndarray) -> np.ndarray:
    """Time of every residual row (the nodes' clock, s; nan for rows in no block).

    Parameters
    ----------
    jacobian_r : sparse (n_r, n_z)
        The whitened residuals' Jacobian (only its pattern is used).
    node_columns : (K, n_states) int array
        The z columns of each node's states.
    node_time_s : (K,) array
        The nodes' times.
    """
    pattern = sps.csr_matrix(jacobian_r, copy=True)
    pattern.data[:] = 1.0
    n_z = pattern.shape[1]
    column_time = np.full(n_z, np.nan)
    node_columns = np.asarray(node_columns, np.int64)
    column_time[node_columns.ravel()] = np.repeat(np.asarray(node_time_s, float), node_columns.shape[1])
    row_time = _mean_known(pattern, column_time)
    window = float(np.ptp(node_time_s)) or 1.0
    by_column = sps.csc_matrix(pattern)
    t = row_time[by_column.indices]
    finite = np.isfinite(t)
    starts = by_column.indptr[:-1]
    has = np.diff(by_column.indptr) > 0
    lo = np.full(n_z, np.inf)
    hi = np.full(n_z, -np.inf)
    s = np.zeros(n_z)
    c = np.zeros(n_z)
    if t.size:
        idx = starts[has]
        lo[has] = np.minimum.reduceat(np.where(finite, t, np.inf), idx)
        hi[has] = np.maximum.reduceat(np.where(finite, t, -np.inf), idx)
        s[has] = np.add.reduceat(np.where(finite, t, 0.0), idx)
        c[has] = np.add.reduceat(finite.astype(float), idx)
    local = (c > 0) & (hi - lo < LOCAL_SHARE * window) & ~np.isfinite(column_time)
    column_time[local] = s[local] / c[local]
    global_columns = ~np.isfinite(column_time)
    # rows touching nodes keep their node time; the others take their local columns' mean time,
    # unless they touch a column with no time only
    later = _mean_known(pattern, column_time)
    only_global = (pattern @ (~global_columns).astype(float)) == 0
    later[only_global] = np.nan
    return np.where(np.isfinite(row_time), row_time, later)


def time_blocks(row_time_s: np.ndarray, block_s: float) -> np.ndarray:
    """Block index of every row for blocks of ``block_s`` seconds (equal blocks over the rows'
    span, as many as fit, at least 2); -1 for rows without a time."""
    ok = np.isfinite(row_time_s)
    out = np.full(row_time_s.shape, -1, np.int64)
    if not ok.any():
        return out
    lo, hi = float(np.min(row_time_s[ok])), float(np.max(row_time_s[ok]))
    n = max(2, int(round((hi - lo) / block_s)))
    out[ok] = np.minimum(((row_time_s[ok] - lo) / max(hi - lo, 1e-12) * n).astype(np.int64), n - 1)
    return out
