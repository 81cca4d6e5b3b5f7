"""The atmosphere-profile sizes' own uncertainty, carried into a fit's covariance.

A fit refitted with the profile sigmas the data say (:mod:`.profile_sigma`, :mod:`.error_model_sigma`)
would otherwise treat them as known: a point value estimated from one drop. To first order the
estimate's uncertainty adds to the covariance of everything else (Kass and Steffey's correction of
an empirical-Bayes posterior, 1989):

    cov(w) = H^-1 + D V D^T,    D_k = dw_hat / d log rho_k = 2 H^-1 A_k^T u_k,

with w the fit's reduced coordinates (:class:`~casrecon.estimation.engine.covariance.Covariance`:
cov_w = H^-1), rho_k the ratio of group k's sigma (wind, density) to the fit's, A_k and u_k the
group's whitened prior rows and residuals at the fit (the stationarity condition H dw = -g
differentiated in log rho_k: the group's prior gradient A_k^T u_k / rho_k^2 changes by
-2 A_k^T u_k), and V the covariance of the log ratios the estimate made on this fit reports
(:attr:`~.profile_sigma.ProfileSigmaEstimate.log_ratio_cov`: the inverse of the log evidence's
negative Hessian at its maximum, conditional on the GPS error sizes there; the GPS sizes the refit
uses are their upper bounds, not estimates to be integrated). Everything read from the covariance
afterwards (parameter sigmas and correlations, trajectory bands, the verdict's tests, a widening)
carries it. The correlation length is a choice among a few candidates, not a continuous estimate:
its uncertainty is not carried. First order:
where a size is poorly determined (a standard deviation of its log near 1) the estimate's
dependence on it is far from linear over that range (it levels off towards the plain fit's as the
size goes to zero, and towards the unconstrained profile's as it grows), and the linear term only
indicates the spread; on the drops measured the logs' standard deviations are 0.04 to 0.07.

Measured on three error-family drops (docs/studies/error-families.md, fourteenth session) the
sizes are determined to 4 to 7 % (hundreds of profile levels under thousands of GPS fixes and IMU
samples) and the correction widens the parameter sigmas by 2 % at most: the plug-in value is not
where those drops' misses come from. Computed on every such fit, it makes that a statement about
the fit at hand (its note says by how much) instead of an assumption.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Sequence

import numpy as np

from casrecon.estimation.error_models.profile_sigma import ProfileSigmaEstimate, group_masks, profile_prior_rows


def sensitivity(cov_w: np.ndarray, rows: Sequence[np.ndarray], residuals: Sequence[np.ndarray]) -> np.ndarray:
    """D (n_w, n_groups): the change of the estimate in reduced coordinates per unit change of each
    group's log ratio, 2 cov_w A_k^T u_k (see the module docstring); ``rows`` A_k (n_k, n_w) and
    ``residuals`` u_k (n_k,) of each group, whitened at the fit's sigmas."""
    return np.column_stack([2.0 * cov_w @ (a.T @ u) for a, u in zip(rows, residuals)])


def added_covariance(cov_w: np.ndarray, rows: Sequence[np.ndarray], residuals: Sequence[np.ndarray],
                     log_ratio_cov: np.ndarray) -> np.ndarray:
    """D V D^T (n_w, n_w): what the groups' size uncertainty ``log_ratio_cov`` V adds to cov_w."""
    d = sensitivity(cov_w, rows, residuals)
    return d @ log_ratio_cov @ d.T


def with_size_uncertainty(result, estimate: ProfileSigmaEstimate):
    """The profile fit ``result`` (a :class:`~casrecon.estimation.sixdof.fit.FitResult` whose profile
    sigmas are ``estimate``'s, made on it) with its covariance, parameter sigmas and correlations
    carrying the estimate's size uncertainty (module docstring) and a note saying how much it
    widened them (its bands dropped, for :func:`~casrecon.estimation.sixdof.fit.with_bands` to make
    again); ``result`` itself where the estimate has no such uncertainty (no group above
    zero, an evidence not curved down) or the fit has no null-space covariance."""
    groups = estimate.uncertain_groups
    cov = result.covariance
    if not groups or result.part.profile is None or not hasattr(cov, "cov_w"):
        return result
    prior = profile_prior_rows(result)
    a = prior.jacobian @ cov.basis[prior.cols]
    masks = group_masks(result.part.profile, prior.component_of_row, groups)
    if not all(m.any() for m in masks):  # a group the fit does not have (estimated, then dropped)
        return result
    added = added_covariance(cov.cov_w, [a[m] for m in masks], [prior.residuals[m] for m in masks],
                             estimate.log_ratio_cov)
    carried = dataclasses.replace(cov, cov_w=cov.cov_w + 0.5 * (added + added.T))
    cov_theta = carried.covariance_of(result.part.theta_cols, result.part.params.scales)
    sigma = np.sqrt(np.diag(cov_theta))
    ratio = sigma / np.where(result.sigma > 0, result.sigma, np.inf)
    worst = int(np.argmax(ratio))
    sd = ", ".join(f"{g} +-{100.0 * v:.1f} %" for g, v in estimate.log_ratio_sd().items())
    note = (f"atmosphere-profile sizes' uncertainty ({sd}, 1 sigma of the estimate) carried into the covariance "
            f"and bands: parameter sigmas x{ratio.min():.3f} to x{ratio.max():.3f} "
            f"(largest {result.params.names[worst]}); the correlation length's is not")
    return dataclasses.replace(result, covariance=carried, sigma=sigma, correlation=cov_theta / np.outer(sigma, sigma),
                               table_sigma=None, notes=result.notes + (note,))
