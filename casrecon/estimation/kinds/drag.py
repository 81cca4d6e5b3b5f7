"""The point-mass drag kind: the GPS-only fit's interval block (Hermite-Simpson defects of the
point-mass model with a drag area, and optionally horizontal lift areas, that are B-spline
functions of time; the fixes on the two nodes) and the smoothness and lift priors of the spline
coefficients. The fixes sit on the nodes, so each interval carries the fix at its first node and
the last interval also the one at its last node.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.sixdof.transcription import selection_matrix
from casrecon.io.pointmass_problem import PointMassConfig
from casrecon.physics.pointmass import PointMassModel

#: Scale of the point-mass states (m, m/s): Ipopt sees state / scale.
SCALE = np.array([100.0, 100.0, 100.0, 10.0, 10.0, 10.0])
#: Scale of the drag and lift area coefficients, m^2.
CDA_SCALE = 0.1


def drag_interval_kind(model: PointMassModel, h: float, n_coef: int, n_areas: int, wind_scale: float,
                       active: tuple[int, ...] = (), area_sigmas: tuple[float, ...] = ()) -> BlockKind:
    """Block of one interval: locals [x_k, x_k+1 (scaled), area coefficients (n_coef x n_areas,
    scaled), wind bias north/east (scaled by ``wind_scale``, m/s), with a GPS error model the
    unit-variance correlated errors e_k, e_k+1 of the ``active`` components, with area processes
    (``area_sigmas``: the 1-sigma of the drag area's log, -, and of the lift areas north and east,
    m^2) their unit-variance values a_k, a_k+1 at the two nodes (linear between the nodes; the drag
    area times exp(sigma a), sigma a added to each lift area)]; data: the spline basis at the two
    nodes and the midpoint, the fixes (NED position, velocity) with inverse white sigmas at the two
    nodes, and with errors their amplitudes sigma sqrt(f) at the two nodes. Residuals: the whitened
    fixes (y - x - amplitude e) w; constraints: the scaled defects."""
    n_c, n_e = n_coef * n_areas, len(active)
    n_a = len(area_sigmas)
    v = ca.SX.sym("v", 12 + n_c + 2 + 2 * n_e + 2 * n_a)
    xk, xk1 = v[:6] * ca.DM(SCALE), v[6:12] * ca.DM(SCALE)
    coef, wind = ca.reshape(v[12:12 + n_c] * CDA_SCALE, n_coef, n_areas), v[12 + n_c:14 + n_c] * wind_scale
    bk, bm, bk1 = (ca.SX.sym(n, n_coef) for n in ("bk", "bm", "bk1"))
    yk, wk, yk1, wk1 = ca.SX.sym("yk", 6), ca.SX.sym("wk", 6), ca.SX.sym("yk1", 6), ca.SX.sym("wk1", 6)
    first_a = 14 + n_c + 2 * n_e
    proc_k, proc_k1 = ((ca.DM(area_sigmas) * v[i:i + 3] if n_a else None) for i in (first_a, first_a + 3))

    def area(b, process):
        a = coef.T @ b
        a = ca.vertcat(a, ca.DM.zeros(3 - n_areas)) if n_areas < 3 else a
        if process is None:
            return a
        return ca.vertcat(a[0] * ca.exp(process[0]), a[1:] + process[1:])

    fk, fk1 = model.rhs(xk, area(bk, proc_k), wind), model.rhs(xk1, area(bk1, proc_k1), wind)
    xm = 0.5 * (xk + xk1) + h / 8 * (fk - fk1)
    fm = model.rhs(xm, area(bm, None if proc_k is None else 0.5 * (proc_k + proc_k1)), wind)
    defect = (xk1 - xk - h / 6 * (fk + 4 * fm + fk1)) / ca.DM(SCALE)
    data = [bk, bm, bk1, yk, wk, yk1, wk1]
    if n_e:
        ak, ak1 = ca.SX.sym("ak", n_e), ca.SX.sym("ak1", n_e)
        ek, ek1 = v[14 + n_c:14 + n_c + n_e], v[14 + n_c + n_e:first_a]
        select = selection_matrix(6, active)
        yk, yk1 = yk - select @ (ak * ek), yk1 - select @ (ak1 * ek1)
        data += [ak, ak1]
    residual = ca.vertcat((yk - xk) * wk, (yk1 - xk1) * wk1)
    return BlockKind("pm_interval", v, data, residual, defect)


def drag_prior_terms(n_coef: int, n_areas: int, coef_cols: np.ndarray, cfg: PointMassConfig) -> list[Term]:
    """Smoothness prior on the second differences of each area's spline coefficients (when there
    are more than two), and the zero-mean prior of the lift-area coefficients (with lift).

    ``coef_cols`` are the z columns of the n_coef * n_areas coefficients (area after area).
    """
    terms = []
    if n_coef > 2:
        v = ca.SX.sym("v", n_coef)
        c = v * CDA_SCALE
        rows = ca.vertcat(*[(c[i] - 2 * c[i + 1] + c[i + 2]) / cfg.drag.smoothness_sigma_m2 for i in range(n_coef - 2)])
        kind = BlockKind("drag_smoothness", v, [], rows, None)
        cols = np.asarray(coef_cols).reshape(n_areas, n_coef)
        terms.append(Term("prior_smoothness", (BlockSet(kind, cols),)))
    if n_areas > 1:
        v = ca.SX.sym("v", n_coef * (n_areas - 1))
        kind = BlockKind("lift_prior", v, [], v * CDA_SCALE / cfg.drag.lift_sigma_m2, None)
        terms.append(Term("prior_lift", (BlockSet(kind, np.asarray(coef_cols)[None, n_coef:]),)))
    return terms
