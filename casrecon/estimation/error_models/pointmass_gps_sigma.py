"""The GPS error model's sizes from the data for the GPS-only point-mass fit: type-II maximum
likelihood of the white and correlated parts of the position and velocity errors and the most evident
of a few correlation times, as for the 6-DOF fit (:mod:`.gps_error_sigma`, same groups, bounds and
refit rule), by the Laplace evidence on the KKT matrix of the fit's Gauss-Newton model
(:mod:`casrecon.estimation.numerics.kkt_evidence`: the point-mass fit with area processes has no null-space covariance).

Why: the shipped real FlySight tracks fitted with the error model the problems describe (position
errors 99.9 % correlated over 1000 s, velocity errors 94 % over 0.6 s, at the reported accuracies)
left position innovations of one track at 0.46 of their sigmas and of another at 1.6; no single
configured model suits every receiver and flight.
"""

from __future__ import annotations

import numpy as np
import scipy.sparse as sps

from casrecon.estimation.error_models.error_model_sigma import most_evident, time_search
from casrecon.estimation.error_models.gps_error_sigma import GpsErrorEstimate, chain_rows, model_from
from casrecon.estimation.numerics.kkt_evidence import KktQuadraticModel, ScaledRows

#: Residual rows of one point-mass interval block: the fixes at its two nodes (the second weighed
#: only on the last interval; :func:`casrecon.estimation.kinds.drag.drag_interval_kind`).
ROWS_PER_INTERVAL = 12


def estimated(result) -> bool:
    """Whether the GPS error model's sizes are estimated on this point-mass fit: its GPS error model
    is on, with ``[gps] error_model_from_data``."""
    cfg = result.config
    return bool(cfg.gps_error_model_from_data and cfg.gps_errors.enabled)


def estimate_gps_model(result, configured_times_s: tuple[float, float] | None = None,
                       search: bool = True) -> GpsErrorEstimate:
    """The GPS error model the data say of a converged point-mass fit with a GPS error model: the
    groups' sizes at the fit's correlation times, then (``search``) at each other position and then
    velocity correlation time (TIME_FACTORS times ``configured_times_s``, default the fit's)."""
    errors = result.config.gps_errors
    build = model_builder(result)
    own_times = (errors.position_time_s, errors.velocity_time_s)
    best = most_evident(build, [(None, own_times)])
    if search:
        base_times = own_times if configured_times_s is None else configured_times_s
        best = time_search(build, best, errors, own_times, base_times)
    _, times, _, _, fit, names = best
    ratios = {n: float(r) for n, r in zip(names, np.exp(fit.x))}
    return GpsErrorEstimate(errors, model_from(errors, ratios, times), ratios)


def fix_rows(result) -> np.ndarray:
    """(K, 6) residual rows of each node's fix (NED position, velocity) in a point-mass fit."""
    k = result.t_unix.size
    rows = np.arange(result.nlp.n_r)[result.nlp.groups["gps"]].reshape(k - 1, ROWS_PER_INTERVAL)
    return np.vstack([rows[:, :6], rows[-1:, 6:]])


def model_builder(result):
    """A function (length, (position, velocity) correlation times) -> (KktQuadraticModel, group
    names) of a point-mass fit with a GPS error model (length unused: no profile model here); its
    Gauss-Markov prior rows rebuilt at those times. ValueError when the fit's prior rows are not the
    rebuilt ones at its own times."""
    nlp, z, errors = result.nlp, result.z, result.config.gps_errors
    jacobian = nlp.derivatives.jacobian_r(z).tocsr()
    residuals = nlp.residual_vector(z)
    constraints = nlp.derivatives.jacobian_g(z).tocsr()
    k = result.t_unix.size
    active = errors.active
    chains = np.sort(np.asarray(nlp.eliminated)).reshape(k, active.size)  # (K, n_active) z columns
    rows = fix_rows(result)
    given = result.inv_sigma > 0
    groups: dict[str, ScaledRows] = {}
    for name, comps in (("gps position white", [0, 1, 2]), ("gps velocity white", [3, 4, 5])):
        chosen = rows[:, comps][given[:, comps]]
        if chosen.size:
            groups[name] = ScaledRows(jacobian[chosen], residuals[chosen], int(chosen.size))
    prior_rows = np.concatenate([np.arange(nlp.n_r)[nlp.groups[g]] for g in ("gps_error_start", "gps_error")])
    time = result.t_unix - result.t_unix[0]
    position = active < 3
    own = (errors.position_time_s, errors.velocity_time_s)
    fit_prior = jacobian[prior_rows]
    rebuilt, own_det = _prior(time, own, chains, position, nlp.n_z)
    gram_fit, gram_own = fit_prior.T @ fit_prior, rebuilt.T @ rebuilt
    if abs(gram_fit - gram_own).max() > 1e-8 * max(1.0, abs(gram_own).max()):
        raise ValueError("the fit's GPS error prior rows are not the Gauss-Markov chains rebuilt here")
    held = np.setdiff1d(np.arange(nlp.n_r), np.concatenate([rows[given], prior_rows]))
    base = KktQuadraticModel(jacobian[held], residuals[held], constraints, [])

    def build(key):
        _, times = key
        out, names = dict(groups), list(groups)
        for name, mask, g in (("gps position correlated", position, 0), ("gps velocity correlated", ~position, 1)):
            if mask.any():
                w, _ = _prior(time, times, chains[:, mask], np.full(mask.sum(), g == 0), nlp.n_z)
                out[name] = ScaledRows(w, w @ z, int(w.shape[0]))
                names.append(name)
        det = _prior(time, times, chains, position, nlp.n_z)[1]
        return base.with_groups([out[n] for n in names], det - own_det), names

    return build


def _prior(time_s: np.ndarray, times: tuple[float, float], chains: np.ndarray, position: np.ndarray,
           n_z: int) -> tuple[sps.csr_matrix, float]:
    """(The unit Gauss-Markov prior rows of the error chains ``chains`` (K, n) in the full z columns,
    each at the position or velocity correlation time of ``times`` by ``position`` (n,), the log
    det of their whitening)."""
    blocks, log_det = [], 0.0
    for j in range(chains.shape[1]):
        w, det = chain_rows(time_s, times[0] if position[j] else times[1], chains.shape[0])
        blocks.append(sps.csr_matrix((w.data, chains[w.indices, j], w.indptr), shape=(w.shape[0], n_z)))
        log_det += det
    return sps.vstack(blocks).tocsr(), log_det
