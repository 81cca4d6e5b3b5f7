"""Checks that turn an NLP's failures into a :class:`FitError` that says why.

Before solving: a parameter that no residual, constraint or prior touches (the KKT matrix is then
singular whatever the data). After solving: Ipopt's verdict (with a diagnosis of the last iterate
when it failed), and the covariance (singular reduced Hessian, with the undetermined combination
named).
"""

from __future__ import annotations

import numpy as np

from casrecon.estimation.engine.covariance import Covariance, compute_covariance
from casrecon.estimation.engine.kkt_covariance import KktCovariance, SingularCovariance
from casrecon.estimation.engine.nlp import Nlp
from casrecon.estimation.engine.solve import SolveResult


class FitError(RuntimeError):
    """The fit did not produce a trustworthy result; the message says why."""


def check_determined(nlp: Nlp, z: np.ndarray) -> None:
    """FitError before solving when a parameter has no effect on any residual or constraint and no
    prior (its column of the KKT matrix is zero, so the matrix is singular whatever the data)."""
    jg = nlp.derivatives.jacobian_g(z).tocoo()
    in_g = np.zeros(nlp.n_z, bool)
    in_g[jg.col[jg.data != 0.0]] = True
    jr = nlp.derivatives.jacobian_r(z)
    diag = np.asarray(jr.multiply(jr).sum(axis=0)).ravel()  # the diagonal of J^T J
    dead = [name for col, name in nlp.parameter_names.items() if diag[col] == 0.0 and not in_g[col]]
    if dead:
        raise FitError(f"KKT matrix singular: {', '.join(dead)} affect(s) no residual or constraint and carry "
                       "no prior, so nothing determines them; fix them or switch their prior on")


def check_converged(sol: SolveResult, nlp: Nlp | None = None) -> None:
    """FitError when Ipopt failed; says whether the KKT matrix at its last iterate is singular."""
    if sol.converged:
        return
    why = ""
    if nlp is not None:
        try:
            compute_covariance(nlp, sol.z, 1.0, 1)
        except SingularCovariance as err:
            why = f"; at the last iterate the {err}"
        except Exception:  # noqa: BLE001 - a diagnosis attempt must not hide the real failure
            pass
    raise FitError(f"Ipopt did not converge: {sol.status} after {sol.iterations} iterations "
                   f"(objective {sol.objective:.6g}){why}; no result written")


def covariance_or_fail(nlp: Nlp, z: np.ndarray, r: np.ndarray, reduced=None, *, information: str = "expected",
                       lam_g: np.ndarray | None = None) -> Covariance | KktCovariance:
    """KKT covariance at ``z`` with the chi-square (group constants included) and dof of ``nlp``
    (``reduced``: the reduced system already formed at ``z``, e.g. ``SolveResult.reduced``;
    ``information`` and the multipliers ``lam_g``: see :func:`.covariance.compute_covariance`);
    FitError when singular."""
    try:
        return compute_covariance(nlp, z, nlp.chi2(r), nlp.dof(), reduced, information=information, lam_g=lam_g)
    except SingularCovariance as err:
        raise FitError(str(err)) from None
