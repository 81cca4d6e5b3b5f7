"""The GPS error model's sizes from the data: type-II maximum likelihood of the white and the
correlated (Gauss-Markov) part of the position and of the velocity errors, and the most evident of a
few correlation times, by the Laplace evidence of the fit
(:mod:`casrecon.estimation.numerics.split_evidence`), made with the atmosphere-profile sigmas
(:func:`casrecon.estimation.error_models.profile_sigma.estimate_profile_sigma`).

Why: the fit's bands are honest only if its GPS error model describes the receiver, and no single
default does. Measured (README, Correlated GPS errors): the acceptance drop's GPS errors
(Gauss-Markov over 20 s and 2 s) fitted with the default model (1 % white over 100 s, 30 % white
over 0.6 s) held the truth in the bands at only 91 to 96 % of nodes; fitted with the shipped real
FlySight tracks' description, at 8 to 67 %; the real tracks with the default, position innovations
at a fifth of their sigmas.

The groups (sigma ratios to the fit's): ``gps position white`` and ``gps velocity white`` scale the
fix rows (their sigma is the white part), ``gps position correlated`` and ``gps velocity
correlated`` the Gauss-Markov prior rows of the error values. A group's rows are those of the fixes
whose component the file gives. A refit's model (:func:`model_from`) keeps the correlation times
(or takes the estimated ones) and sets each accuracy scale and correlated fraction so that its white
and correlated variances are the estimated ones.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.sparse as sps

from casrecon.estimation.kinds.gps import fix_sigma
from casrecon.estimation.numerics.split_evidence import RowGroup
from casrecon.physics.sensor_errors import MAX_CORRELATED_FRACTION, GpsErrorModel

#: The groups, by the error part they size.
GROUPS = ("gps position white", "gps position correlated", "gps velocity white", "gps velocity correlated")
#: Smallest and largest ratio of a group's sigma to the fit's the search considers.
MIN_RATIO, MAX_RATIO = 0.02, 50.0
#: Correlation times the estimate compares, as multiples of the fit's (position and velocity each).
TIME_FACTORS = (0.2, 5.0)
#: Where the longest of TIME_FACTORS is the most evident, the search goes on to longer times, this
#: factor at a time, while the evidence rises, up to MAX_TIME_FACTOR times the configured time: GPS
#: errors correlated over 40 s (velocity) were sized at the search's end of 3 s, and the fit's
#: velocity bands held the truth at 60 to 81 % of the nodes on three of ten drops
#: (docs/studies/error-families.md).
EXTENSION_FACTOR, MAX_TIME_FACTOR = 5.0, 125.0
#: A refit is made when a group's ratio is beyond this factor of 1, or a correlation time changed.
REFIT_FACTOR = 1.25
#: How far below its maximum the log evidence lies at a group's upper bound, nats: the one-sided
#: 97.5 % likelihood-ratio bound of one size (chi-square(1) 3.84 / 2). A refit is made with every
#: group at its upper bound, not its most likely value: the size of an error a 40 s drop sees once
#: is poorly determined, and a correlated part the data cannot tell from none (estimated at zero:
#: the trajectory absorbs it) still moves the absolute position. Measured (error family
#: ``gps-random-walk``, EES, seed 223: position errors a random walk of 0.15 m/sqrt(s)): the
#: most likely model was white, the trusted fit's position bands held the truth at 44 % of
#: nodes (north 1.84 m off, band sigma 0.16 m); at the position correlated sigma's bound
#: (0.8 times the accuracies over 100 s) 100 %, the aero sigmas within 3 % of the white fit's.
BOUND_NATS = 1.92
#: A group's correlation time is searched only where its estimated correlated share of the error
#: variance is at least this: a smaller correlated part is one the data hardly see, and its time
#: is then chosen by hundredths of a nat (error family ``gps-random-walk``, EES, seed 223: a share
#: of 2 % chose 20 s over the configured 100 s, and the upper bound of the correlated sigma at 20 s,
#: a time the data reject more easily, left the position bands at 70 % of nodes).
TIME_SEARCH_SHARE = 0.1
#: A group (position, velocity) whose estimated correlated share of the error variance is below this
#: is white in the refit's model (no correlation time to choose, no error values to carry): white
#: errors at the stated accuracies came out 0.02 to 0.03 % on ees-drop-1.
MIN_SHARE = 0.01


@dataclass(frozen=True)
class GpsErrorEstimate:
    """The GPS error model the data say.

    Attributes
    ----------
    fitted, estimated : GpsErrorModel
        The model the fit used and the one of the estimate (:func:`model_from`).
    ratios : dict of str to float
        Group (:data:`GROUPS`) -> the ratio of its estimated sigma to the fit's.
    at_search_end : tuple of str
        The groups ("position", "velocity") whose estimated correlation time is the shortest or
        longest searched: a time the data do not size (with white errors the correlated share is not
        identifiable and its time lands anywhere); the line says so, it is no gross error.
    bounded : GpsErrorModel or None
        The model at each group's upper bound (the largest sigma the data allow: see
        :mod:`casrecon.estimation.error_models.error_model_sigma`), the one a refit is made with;
        None: the estimated one.
    bounded_ratios : dict of str to float
        Group -> the ratio of its upper bound to the fit's sigma (empty without ``bounded``).
    """

    fitted: GpsErrorModel
    estimated: GpsErrorModel
    ratios: dict[str, float]
    at_search_end: tuple[str, ...] = ()
    bounded: GpsErrorModel | None = None
    bounded_ratios: dict[str, float] = field(default_factory=dict)

    @property
    def refit_model(self) -> GpsErrorModel:
        """The model a refit is made with: ``bounded``, else ``estimated``."""
        return self.estimated if self.bounded is None else self.bounded

    @property
    def refit(self) -> bool:
        """Whether the refit's model differs from the fitted one: a correlation time, or the total,
        white or correlated 1-sigma of position or velocity beyond :data:`REFIT_FACTOR` (compared
        on the models, so a white part the estimate would make smaller than the correlated
        fraction's cap allows does not ask for refit after refit)."""
        return models_differ(self.fitted, self.refit_model)

    def text(self) -> str:
        """One line: the estimated model against the fit's (and the bounded one, if any)."""
        ratios = ", ".join(f"{g[4:]} sigma x {r:.3g}" for g, r in self.ratios.items())
        edges = "".join(f"; the {g} correlation time is at the end of its search: not sized by the data"
                        for g in self.at_search_end)
        bounded = ""
        if self.bounded is not None:
            ups = ", ".join(f"{g[4:]} x {r:.3g}" for g, r in self.bounded_ratios.items())
            bounded = (f"; at the sizes' upper bounds (the largest the data allow, log evidence "
                       f"{BOUND_NATS:g} nats below its maximum: {ups}): {self.bounded.describe()}")
        return (f"GPS error model the data say (type-II maximum likelihood; {ratios}): "
                f"{self.estimated.describe()}{bounded} (fitted with {self.fitted.describe()}){edges}")


def part_sigmas(model: GpsErrorModel) -> np.ndarray:
    """(position, velocity) x (total, white, correlated) 1-sigma of a model, in units of the
    reported accuracies."""
    out = []
    for k, g in ((0, "position"), (3, "velocity")):
        scale, f = getattr(model, f"{g}_scale"), float(model.fraction[k])
        out.append([scale, scale * np.sqrt(1.0 - f), scale * np.sqrt(f)])
    return np.array(out)


def models_differ(a: GpsErrorModel, b: GpsErrorModel) -> bool:
    """Whether two GPS error models differ by a correlation time or by more than :data:`REFIT_FACTOR`
    in a 1-sigma of :func:`part_sigmas` (one that is zero in both does not count)."""
    if (a.position_time_s, a.velocity_time_s) != (b.position_time_s, b.velocity_time_s):
        return True
    sa, sb = part_sigmas(a), part_sigmas(b)
    both = (sa > 0) & (sb > 0)
    if np.any((sa > 0) != (sb > 0)):
        return True
    ratio = sb[both] / sa[both]
    return bool(np.any((ratio > REFIT_FACTOR) | (ratio < 1 / REFIT_FACTOR)))


def model_from(fitted: GpsErrorModel, ratios: dict[str, float],
               times_s: tuple[float, float] | None = None) -> GpsErrorModel:
    """The GPS error model whose white and correlated variances of position and velocity are the
    fitted model's times the squared ``ratios`` (groups of :data:`GROUPS`; missing: 1), with the
    correlation times ``times_s`` (position, velocity; default the fitted ones). The correlated
    fraction is capped at MAX_CORRELATED_FRACTION, the white part then a little larger; a group
    whose correlated share is below :data:`MIN_SHARE` is white (time and fraction 0)."""
    out = {}
    times = (fitted.position_time_s, fitted.velocity_time_s) if times_s is None else times_s
    for k, (g, tau) in enumerate(zip(("position", "velocity"), times)):
        f = float(fitted.fraction[3 * k])
        total, share = variance_parts(fitted, ratios, k)
        out[f"{g}_scale"] = getattr(fitted, f"{g}_scale") * float(np.sqrt(total))
        out[f"{g}_fraction"] = min(share, MAX_CORRELATED_FRACTION) if f > 0 else getattr(fitted, f"{g}_fraction")
        out[f"{g}_time_s"] = float(tau)
        if f > 0 and share < MIN_SHARE:  # white: no correlated part the data can see
            out[f"{g}_fraction"], out[f"{g}_time_s"] = 0.0, 0.0
    return replace(fitted, **out)


def variance_parts(fitted: GpsErrorModel, ratios: dict[str, float], group: int) -> tuple[float, float]:
    """(total variance over the fitted model's, correlated share of it) of the position (``group``
    0) or velocity (1) error whose white and correlated 1-sigma are the fitted model's times
    ``ratios`` (groups of :data:`GROUPS`; missing: 1)."""
    g = ("position", "velocity")[group]
    f = float(fitted.fraction[3 * group])
    correlated = ratios.get(f"gps {g} correlated", 1.0) ** 2 * f
    total = ratios.get(f"gps {g} white", 1.0) ** 2 * (1.0 - f) + correlated
    return total, correlated / total


def error_chains(result) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(fix times (K,), s; the z columns of the error values (K, n_active); the active component
    of each chain (n_active,), 0..5) of a fit with a GPS error model."""
    errors = result.scenario.config.gps.error_model
    cols = result.part.extra("gps").cols.reshape(-1, errors.active.size)
    return np.asarray(result.data.gps_time_s, float), cols, errors.active


def chain_rows(time_s: np.ndarray, tau_s: float, n_chain: int) -> tuple[sps.csr_matrix, float]:
    """The exactly whitened unit Gauss-Markov prior of one chain of ``n_chain`` values at ``time_s``
    with correlation time ``tau_s``: rows v_0 and (v_k+1 - phi_k v_k) / sqrt(1 - phi_k^2) (as
    :func:`casrecon.estimation.kinds.disturbance.gauss_markov_terms`), and the log det of that
    whitening (sum of -1/2 log(1 - phi_k^2))."""
    phi = np.exp(-np.diff(time_s) / tau_s)
    root = np.sqrt(1.0 - phi * phi)
    k = np.arange(1, n_chain)
    rows = np.r_[0, k, k]
    cols = np.r_[0, k, k - 1]
    vals = np.r_[1.0, 1.0 / root, -phi / root]
    return sps.csr_matrix((vals, (rows, cols)), shape=(n_chain, n_chain)), float(-0.5 * np.sum(np.log(root * root)))


def chain_order(result) -> np.ndarray:
    """The eliminated z columns of a fit with a GPS error model, chain by chain (each component's
    values in fix order), so that the eliminated block of its Hessian is tridiagonal."""
    _, chains, _ = error_chains(result)
    if not np.array_equal(np.sort(chains.ravel()), np.sort(np.asarray(result.nlp.eliminated))):
        raise ValueError("the fit's eliminated columns are not its GPS error values")
    return chains.T.ravel()


def gps_row_groups(result, jacobian: sps.csr_matrix, residuals: np.ndarray, basis: np.ndarray,
                   elim: np.ndarray, times_s: tuple[float, float] | None = None) -> tuple[dict[str, RowGroup], float]:
    """The :data:`GROUPS` of a fit with a GPS error model as :class:`RowGroup` (``jacobian`` the
    residual Jacobian and ``residuals`` the residuals at the fit, ``basis`` the covariance's Z with
    -M in the eliminated rows, ``elim`` the eliminated columns in the model's order, e.g.
    :func:`chain_order`), the Gauss-Markov prior rebuilt at the correlation times ``times_s``
    (position, velocity; default the fit's), and the log det of that prior's whitening less the
    fit's. ValueError when the fit's prior rows are not the rebuilt ones at its own times."""
    nlp, errors = result.nlp, result.scenario.config.gps.error_model
    time, chains, active = error_chains(result)
    position = active < 3
    out: dict[str, RowGroup] = {}
    given = np.isfinite(fix_sigma(result.data, errors))
    fix_rows = np.arange(nlp.n_r)[nlp.groups[result.group("gps")]].reshape(-1, 6)
    for name, comps in (("gps position white", [0, 1, 2]), ("gps velocity white", [3, 4, 5])):
        rows = fix_rows[:, comps][given[:, comps]]
        if not rows.size:
            continue
        j = jacobian[rows]
        j_e = j[:, elim]
        out[name] = RowGroup(np.asarray(j @ basis) - np.asarray(j_e @ basis[elim]), sps.csr_matrix(j_e),
                             residuals[rows], int(rows.size))
    prior_rows = np.concatenate([np.arange(nlp.n_r)[nlp.groups[result.group(g)]]
                                 for g in ("gps_error_start", "gps_error")])
    fit_prior = jacobian[prior_rows][:, elim]
    z_e = result.z[elim]
    lookup = np.full(nlp.n_z, -1, np.int64)
    lookup[elim] = np.arange(elim.size)
    position_in_e = lookup[chains]
    gram_fit_all = (fit_prior.T @ fit_prior).tocsr()
    log_det = 0.0
    for name, mask, g in (("gps position correlated", position, 0), ("gps velocity correlated", ~position, 1)):
        if not mask.any():
            continue
        own_tau = errors.time_s[active[mask][0]]
        tau = own_tau if times_s is None else times_s[g]
        w, det = chain_rows(time, tau, chains.shape[0])  # every chain has the fixes' times
        w_own, det_own = chain_rows(time, own_tau, chains.shape[0])
        log_det += int(mask.sum()) * (det - det_own)

        def placed(rows: sps.csr_matrix, cols: np.ndarray) -> sps.csr_matrix:
            return sps.csr_matrix((rows.data, cols[rows.indices], rows.indptr), shape=(rows.shape[0], elim.size))

        chain_cols = [position_in_e[:, j] for j in np.flatnonzero(mask)]
        blocks = [placed(w, cols) for cols in chain_cols]
        rebuilt_own = sps.vstack([placed(w_own, cols) for cols in chain_cols]).tocsr()
        mine = position_in_e[:, mask].ravel()
        gram_fit = gram_fit_all[mine][:, mine]
        gram_own = (rebuilt_own.T @ rebuilt_own).tocsr()[mine][:, mine]
        if abs(gram_fit - gram_own).max() > 1e-8 * max(1.0, abs(gram_own).max()):
            raise ValueError("the fit's GPS error prior rows are not the Gauss-Markov chain rebuilt here")
        a_e = sps.vstack(blocks).tocsr()
        out[name] = RowGroup(None, a_e, a_e @ z_e, int(a_e.shape[0]))
    return out, log_det
