"""The error models' sizes from the data, together: the atmosphere-profile sigmas and correlation
length (:mod:`.profile_sigma`) and, for a fit with a GPS error model and ``[sensors.gps]
error_model_from_data`` (default), the GPS errors' white and correlated sizes and correlation times
(:mod:`.gps_error_sigma`), by one Laplace evidence on the fit's split quadratic model
(:mod:`casrecon.estimation.numerics.split_evidence`).

The search: Newton steps on the average information
(:mod:`casrecon.estimation.numerics.information_ascent`) over the log ratios of every group's sigma
to the fit's, at the fit's correlation length and GPS correlation times, then at each other profile
length (``profile_sigma.LENGTH_FACTORS`` times the configured one, and longer ones while the
longest wins), then, at the most evident length, at each other position and then velocity
correlation time (``gps_error_sigma.TIME_FACTORS`` times the fit's, and longer ones while the
longest wins: see :func:`time_search`); the most evident candidate wins each round, where it is
more evident by more than WIN_NATS (else the earlier stays). A profile group whose estimate explains
the data better than none of its error by less than ``profile_sigma.ZERO_EVIDENCE_NATS``, or is
below ``profile_sigma.NEGLIGIBLE_RATIO`` of the fit's sigma, is taken as zero, as without the GPS
groups.
"""

from __future__ import annotations

import numpy as np

from casrecon.estimation.engine.covariance import gauss_newton_system
from casrecon.estimation.error_models import profile_sigma as ps
from casrecon.estimation.error_models.gps_error_sigma import (
    BOUND_NATS,
    EXTENSION_FACTOR,
    MAX_RATIO,
    MAX_TIME_FACTOR,
    MIN_RATIO,
    TIME_FACTORS,
    TIME_SEARCH_SHARE,
    GpsErrorEstimate,
    chain_order,
    gps_row_groups,
    model_from,
    part_sigmas,
    variance_parts,
)
from casrecon.estimation.error_models.profile import PROFILE_COMPONENTS
from casrecon.estimation.numerics import information_ascent
from casrecon.estimation.numerics.split_evidence import RowGroup, SplitQuadraticModel
from casrecon.parallel import in_threads, single_threaded_blas
from casrecon.physics.sensor_errors import GpsErrorModel

#: The sizes' search stops where the next Newton step would raise log Z by less than this (nats).
TOLERANCE_NATS = 1e-3
#: A candidate length or correlation time replaces the one chosen so far only where its log Z is
#: higher by more than this (nats): ten times the search's precision, so that a tie (a group whose
#: error the data do not see, its evidence flat in the length) keeps the earlier candidate.
WIN_NATS = 10 * TOLERANCE_NATS


def gps_estimated(result) -> bool:
    """Whether the GPS error model's sizes are estimated on this fit: a MAP fit whose GPS error
    model is on, with ``[sensors.gps] error_model_from_data``."""
    gps = result.scenario.config.gps
    return bool(gps.error_model_from_data and gps.error_model.enabled and result.part.extra("gps") is not None)


@single_threaded_blas()
def estimate_error_sizes(result, configured_length_m: float | None = None, profile: bool = True,
                         configured_times_s: tuple[float, float] | None = None,
                         search: bool = True, configured_model: GpsErrorModel | None = None) -> ps.ProfileSigmaEstimate:
    """The profile sigmas and length (when ``profile`` and the fit has the profile model) and, when
    :func:`gps_estimated`, the GPS error model the data say (the estimate's ``gps``) of a
    converged fit without disturbance states; the GPS correlation times compared are the fit's and
    TIME_FACTORS times ``configured_times_s`` (position, velocity; default the fit's). ``search``
    False: the sizes only, at the fit's length and times (a refit's estimate, after the first
    chose them: each candidate costs 10 to 15 evaluations of 0.1 s on a 1.5 km drop). The GPS
    estimate's ``bounded`` model has each group at :func:`gps_upper_bounds` with the caps of
    ``configured_model`` (the problem's; default the fit's). Raises ValueError as
    :func:`~casrecon.estimation.error_models.profile_sigma.estimate_profile_sigma`."""
    if not gps_estimated(result):
        return ps.estimate_profile_sigma(result, configured_length_m)
    if not hasattr(result.covariance, "cov_w") or result.covariance.elimination is None:
        raise ValueError("the error models' sizes are estimated only for a fit without disturbance states")
    grid = result.part.profile if profile else None
    configured = None if grid is None else (grid.length_m if configured_length_m is None else configured_length_m)
    build, own_model, fallback = _builder(result, grid)
    on_gauss_newton = fallback or not result.covariance.information.startswith("observed")
    errors = result.scenario.config.gps.error_model
    own_times = (errors.position_time_s, errors.velocity_time_s)
    length = None if grid is None else grid.length_m
    best = most_evident(build, [(length, own_times)])
    if search and grid is not None:  # the other lengths, each searched from the sizes at the fit's
        others = [(f * configured, own_times) for f in ps.LENGTH_FACTORS if f * configured != grid.length_m]
        challenger = most_evident(build, others, best[4].x) if others else None
        if challenger is not None and more_evident(challenger, best):
            best = challenger
        if others and np.isclose(best[2], max(ps.LENGTH_FACTORS) * configured):  # longer, while the evidence rises
            longer = ps.extension(max(ps.LENGTH_FACTORS), ps.LENGTH_EXTENSION, ps.MAX_LENGTH_FACTOR)
            best = while_rising(build, best, [(f * configured, own_times) for f in longer])
    base_times = own_times if configured_times_s is None else configured_times_s
    if search:
        best = time_search(build, best, errors, own_times, base_times)
    _, times, length, model, fit, names = best
    at_end = tuple(g for k, g in enumerate(("position", "velocity"))
                   if search and times[k] != own_times[k] and base_times[k] > 0
                   and any(np.isclose(times[k], f * base_times[k]) for f in (min(TIME_FACTORS), MAX_TIME_FACTOR)))
    ratio = np.exp(fit.x)
    value = -fit.fun
    n_profile = len(names) - len([n for n in names if n.startswith("gps ")])
    against_zero = {}
    for k in range(n_profile):
        none = fit.x.copy()
        none[k] = np.log(ps.MIN_RATIO)
        against_zero[names[k]] = float(value - model.log_evidence(none)[0])
        if against_zero[names[k]] < ps.ZERO_EVIDENCE_NATS or ratio[k] < ps.NEGLIGIBLE_RATIO:
            ratio[k] = 0.0
    base, _ = own_model.log_evidence(np.zeros(len(names)))
    gps_ratios = {n: float(r) for n, r in zip(names[n_profile:], ratio[n_profile:])}
    caps = configured_caps(errors if configured_model is None else configured_model, errors)
    bounded_ratios = {n: max(gps_ratios[n], min(float(u), caps[n]))
                      for n, u in zip(names[n_profile:], np.exp(gps_upper_bounds(model, names, fit)[n_profile:]))}
    gps = GpsErrorEstimate(errors, model_from(errors, gps_ratios, times), gps_ratios, at_end,
                           model_from(errors, bounded_ratios, times), bounded_ratios)
    if grid is None:
        return ps.ProfileSigmaEstimate({}, {}, max(0.0, value - base), (), {}, fallback, 0.0, 0.0, gps,
                                       gauss_newton=on_gauss_newton)
    prior = dict(zip([PROFILE_COMPONENTS[c] for c in grid.components], grid.prior))
    fitted = {g: float(prior[ps.GROUPS[g][0]]) for g in names[:n_profile]}
    estimated = {g: fitted[g] * float(r) for g, r in zip(names[:n_profile], ratio[:n_profile])}
    return ps.ProfileSigmaEstimate(fitted, estimated, max(0.0, value - base), tuple(prior), against_zero,
                                   fallback, grid.length_m, length, gps, gauss_newton=on_gauss_newton,
                                   log_ratio_cov=ps.estimate_covariance(lambda x: model.log_evidence(x)[1], fit.x,
                                                                        ratio[:n_profile]))


def time_search(build, best, errors, own_times: tuple[float, float], base_times: tuple[float, float]):
    """The most evident of ``best`` (as :func:`most_evident` returns) and the candidates at each other
    position and then velocity correlation time (TIME_FACTORS times ``base_times``, at the length and
    times chosen so far), for each group the fit's model (``errors``, times ``own_times``) has
    correlated and whose estimated correlated share is at least TIME_SEARCH_SHARE. Where the longest time is
    the most evident, longer ones (EXTENSION_FACTOR times, up to MAX_TIME_FACTOR times
    ``base_times``) while the evidence rises."""
    for g in (0, 1):
        ratios = dict(zip(best[5], np.exp(best[4].x)))
        if own_times[g] > 0 and variance_parts(errors, ratios, g)[1] >= TIME_SEARCH_SHARE:
            def at(factor: float, g=g, other=best[1]) -> tuple[float, float]:
                return tuple(factor * base_times[g] if i == g else other[i] for i in (0, 1))

            times = {at(f) for f in (1.0, *TIME_FACTORS)}
            times.discard(best[1])
            challenger = most_evident(build, [(best[2], t) for t in sorted(times)], best[4].x)
            if more_evident(challenger, best):
                best = challenger
            if np.isclose(best[1][g], max(TIME_FACTORS) * base_times[g]):  # longer, while the evidence rises
                longer = ps.extension(max(TIME_FACTORS), EXTENSION_FACTOR, MAX_TIME_FACTOR)
                best = while_rising(build, best, [(best[2], at(f)) for f in longer])
    return best


def while_rising(build, best, candidates):
    """``best`` (as :func:`most_evident` returns), replaced by each of ``candidates`` in turn while
    each is more evident than the one before: the search past the end of a range, stopped where
    the evidence stops rising. The candidates are searched side by side from ``best``'s sizes (on
    two threads: the wall time of one where there are two)."""
    for candidate in evaluated(build, candidates, best[4].x):
        if not more_evident(candidate, best):
            break
        best = candidate
    return best


def evaluated(build, candidates, start: np.ndarray | None = None) -> list[tuple]:
    """(-log Z, times, length, model, optimiser result, group names) of each candidate (length,
    (position, velocity) correlation times), each searched from ``start`` (log ratios; default the
    fit's sizes), side by side on two threads (numpy's products, LAPACK and SuperLU release the
    GIL; each candidate's factors are made and dropped in its thread), in the candidates' order."""

    def searched(candidate):
        model, names = build(candidate)
        return model, names, maximised(model, names, start)

    return [(fit.fun, times, length, model, fit, names)
            for (length, times), (model, names, fit) in zip(candidates, in_threads(searched, candidates))]


def more_evident(candidate, other) -> bool:
    """Whether ``candidate`` (as :func:`evaluated` returns) is more evident than ``other`` by more
    than WIN_NATS."""
    return bool(candidate[0] < other[0] - WIN_NATS)


def most_evident(build, candidates, start: np.ndarray | None = None):
    """The most evident of :func:`evaluated`'s candidates (the first of those within WIN_NATS of
    each other)."""
    out = None
    for candidate in evaluated(build, candidates, start):
        if out is None or more_evident(candidate, out):
            out = candidate
    return out


def maximised(model: SplitQuadraticModel, names: list[str], start: np.ndarray | None = None):
    """The maximum of log Z over the groups' log ratios (:func:`log_ratio_bounds`) from ``start``
    (default the fit's sizes), by Newton steps on the model's average information
    (:func:`casrecon.estimation.numerics.information_ascent.maximised`, to TOLERANCE_NATS): a
    scipy OptimizeResult, its ``fun`` -log Z, its ``information`` the average information there."""
    x0 = np.zeros(len(names)) if start is None else np.asarray(start, float)
    lower, upper = log_ratio_bounds(names)
    return information_ascent.maximised(model.log_evidence_with_information, x0, lower, upper, TOLERANCE_NATS)


def log_ratio_bounds(names: list[str]) -> tuple[np.ndarray, np.ndarray]:
    """(lower, upper) log ratio of each group: gps_error_sigma's MIN_RATIO, MAX_RATIO for the GPS
    groups, profile_sigma's for the others."""
    gps = np.array([n.startswith("gps ") for n in names])
    return (np.where(gps, np.log(MIN_RATIO), np.log(ps.MIN_RATIO)),
            np.where(gps, np.log(MAX_RATIO), np.log(ps.MAX_RATIO)))


def configured_caps(configured: GpsErrorModel, fitted: GpsErrorModel) -> dict[str, float]:
    """Group -> the configured model's sigma of that part over the fitted model's (inf where the
    fitted has none): how far a size the data cannot tell from smaller ones is raised at most."""
    a, b = part_sigmas(configured), part_sigmas(fitted)
    where = {"gps position white": (0, 1), "gps position correlated": (0, 2),
             "gps velocity white": (1, 1), "gps velocity correlated": (1, 2)}
    return {g: float(a[ij] / b[ij]) if b[ij] > 0 else np.inf for g, ij in where.items()}


def gps_upper_bounds(model: SplitQuadraticModel, names: list[str], fit) -> np.ndarray:
    """The log ratios of :func:`maximised`'s ``fit`` with each GPS group's at its upper bound: the
    largest at which log Z, along the group's profile direction, is BOUND_NATS below its maximum
    (:func:`casrecon.estimation.numerics.information_ascent.upper_bounds`; the profile groups
    stay at the maximum). Where the maximum has no information (its quadratic model not definite
    there), the maximum itself."""
    if fit.information is None:
        return np.asarray(fit.x, float)
    lower, upper = log_ratio_bounds(names)
    gps = np.flatnonzero([n.startswith("gps ") for n in names])
    return information_ascent.upper_bounds(lambda x: model.log_evidence(x)[0], fit.x, -fit.fun, fit.information,
                                           lower, upper, gps, BOUND_NATS)


def _builder(result, grid):
    """(A function (length, times) -> (SplitQuadraticModel, group names), the model at the fit's
    own length and times, whether it falls back): on the fit's own curvature, or on the
    Gauss-Newton one where the held part of the observed information is not positive semidefinite
    (its evidence would exist only near the fit's sizes)."""
    nlp, cov = result.nlp, result.covariance
    jacobian = nlp.derivatives.jacobian_r(result.z).tocsr()
    residuals = nlp.residual_vector(result.z)
    elim = chain_order(result)  # H_EE tridiagonal in this order
    j_e = jacobian[:, elim]
    h_ee = (j_e.T @ j_e).tocsc()
    prior = ps.profile_prior_rows(result) if grid is not None else None

    def blocks(basis: np.ndarray, schur: np.ndarray):
        m = -basis[elim]
        b = np.asarray(h_ee @ m)
        return basis, schur + m.T @ b, b

    def make(system, key, own=None):
        basis, h_cc, b = system
        length, times = key
        groups: list[RowGroup] = []
        names: list[str] = []
        log_det = 0.0
        if prior is not None:
            if length == grid.length_m:
                w, u, comp, det = prior.jacobian, prior.residuals, prior.component_of_row, 0.0
            else:
                w, u, comp, det = ps.prior_rows_at(result, prior, length)
            a = w @ basis[prior.cols]
            log_det += det
            for g, mask in zip(ps.GROUPS, ps.group_masks(grid, comp)):
                if mask.any():
                    groups.append(RowGroup(a[mask], None, u[mask], int(mask.sum())))
                    names.append(g)
        gps_groups, det = gps_row_groups(result, jacobian, residuals, basis, elim, times)
        log_det += det
        groups += list(gps_groups.values())
        names += list(gps_groups)
        if own is None:  # the fit's own rows: the held part is the Hessian less them
            return SplitQuadraticModel(h_cc, b, h_ee, groups), names
        return own.with_groups(groups, log_det), names

    errors = result.scenario.config.gps.error_model
    own_key = (None if grid is None else grid.length_m, (errors.position_time_s, errors.velocity_time_s))
    own_system = blocks(cov.basis, np.linalg.inv(cov.cov_w))
    own, _ = make(own_system, own_key)
    fallback = cov.information.startswith("observed") and not own.rest_is_semidefinite
    if fallback:
        reduced = result.solver.reduced or gauss_newton_system(nlp, result.z, cov.split)
        own_system = blocks(reduced.basis, reduced.hessian)
        own, _ = make(own_system, own_key)
    return (lambda key: make(own_system, key, own)), own, fallback
