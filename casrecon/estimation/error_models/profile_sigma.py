"""The atmosphere-profile error's size from the data: type-II maximum likelihood of its prior sigmas.

The profile model's sigmas (``[atmosphere] profile_wind_sigma_mps``, ``profile_density_sigma``)
are a guess of how far the air flown is from the sounding. Too large, they make the aero sigmas
pay for wind structure the data do not show (on ``ees-drop-1``, which flies its sounding, 1.5 to
5.7 times the plain fit's); too small, the bands are too narrow. Their maximum-likelihood value
is what the Laplace-approximated evidence of the data says, and at a converged profile fit it
costs only small dense algebra on the fit's reduced system:

with w the reduced coordinates (null-space directions) and H the fit's reduced Hessian, the
profile prior's whitened rows in w are u_k + A_k dw for component group k (wind north and east
together, as one configured sigma; density), A_k = W_k Z_k (W_k the prior's exact residual
Jacobian, Z_k the basis rows of the profile columns). Scaling a group's prior sigma by rho_k
divides its rows by rho_k; the data's part of the objective is the fit's quadratic model,
H_d = H - sum A_k^T A_k with gradient g_d = -sum A_k^T u_k (the fit is stationary). Then

    log Z(rho) = -1/2 chi2(rho) - 1/2 log det H(rho) - sum_k n_k log rho_k + const,

chi2(rho) the minimum of the quadratic model (one dense solve) and H(rho) = H_d + sum A_k^T A_k /
rho_k^2. Its gradient in log rho_k is chi2_k - gamma_k (the group's prior chi-square at the new
minimum, less the values the data determine, n_k - tr(A_k H^-1 A_k^T) / rho_k^2): zero at
MacKay's fixed point. log Z is maximised over log rho in [log MIN_RATIO, log MAX_RATIO] by
L-BFGS-B (this profile-only estimate; with the GPS errors, :mod:`.error_model_sigma`); a group
whose estimate explains the data better than none of its error by less than
:data:`ZERO_EVIDENCE_NATS` (log evidence), or whose estimate is below :data:`NEGLIGIBLE_RATIO` of
the fit's sigma, has no profile error the data can see, and is taken as zero. The quadratic model
is the fit's own (Gauss-Newton or observed information), exact for the prior, which is linear;
where the data's part of an observed information is indefinite, the Gauss-Newton one
(:func:`quadratic_model`). The correlation length is chosen by the same evidence among the fit's
and :data:`LENGTH_FACTORS` times the configured one (and longer ones, :data:`LENGTH_EXTENSION`
times at a time, while the longest wins): only the prior's rows and its normalisation,
-(K - 1)/2 log(1 - phi^2) per process, depend on it (:func:`prior_rows_at`). A refit at the new
sigmas and length (:func:`casrecon.estimation.sixdof.fit.fit_drop`) gives the nonlinear optimum, and
the estimate is made again on it.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np
import scipy.linalg

from casrecon.estimation.engine.covariance import gauss_newton_system
from casrecon.estimation.error_models.gps_error_sigma import GpsErrorEstimate
from casrecon.estimation.error_models.profile import PROFILE_COMPONENTS, PROFILE_UNITS
from casrecon.estimation.numerics.information_ascent import covariance_at_maximum
from casrecon.io.problem import ProblemConfig

#: Smallest and largest ratio of a group's sigma to the fit's that the search considers; an
#: optimum at the smallest means no profile error the data can see (taken as zero).
MIN_RATIO, MAX_RATIO = 1e-4, 20.0
#: A group whose estimate explains the data better than none of its error by less than this (log
#: evidence, nats: a Bayes factor of e^3 = 20, "strong" on Jeffreys' scale) is taken as zero.
ZERO_EVIDENCE_NATS = 3.0
#: A group estimated below this share of the fit's sigma is taken as zero whatever its evidence:
#: the quadratic model of a fit a hundred times off the estimate extrapolates (on exact drop-3 data
#: the fit at 0.5 m/s said 1.8 mm/s, +70.8 nats over none, and the refit at 1.8 mm/s said none; on
#: benchmarks/default_cost.py's drop 2.0 mm/s, +29.4 nats, and again none), and a wind error of
#: 5 mm/s (density 0.005 %) moves a 40 s drop by 0.2 m, far below what its GPS resolves. Zero, the
#: refit is made without that group (without the profile model when both are zero) instead of once
#: more at a size no data can tell from none.
NEGLIGIBLE_RATIO = 0.01
#: Penalty (nats) of a ratio where the quadratic model's Hessian is not positive definite.
NOT_DEFINITE = 1e12
#: A refit is made when a group's estimate differs from the fit's sigma by more than this factor.
REFIT_FACTOR = 1.25
#: Refits at most after the first fit. The estimate is made again on each refit, because the
#: quadratic model of a fit far from the estimate extrapolates: on exact drop-3 data the fit at
#: 0.5 m/s said a 1.8 mm/s wind profile (log evidence +70.8 over none) and the refit at 1.8 mm/s
#: said none, which the refit without the profile model then gives.
MAX_REFITS = 3
#: Correlation lengths the estimate compares, as multiples of the configured one (and the fit's). The
#: Gauss-Markov model at the configured 300 m takes a smooth error (a sounding whose temperature is
#: off by a share growing with height) for a small rough process: on davinci-ztu with a density
#: ramp to 0.3 % over the drop the sigma at 300 m came out 0.09 % and the refit was over-confident
#: (parameter NEES 85 on 19; benchmarks/profile_structure.py). The evidence at longer lengths
#: weighs a larger, smoother process against it.
LENGTH_FACTORS = (1.0, 1.0 / 3.0, 3.0, 10.0)
#: Where the longest of LENGTH_FACTORS is the most evident, longer lengths (this factor at a time,
#: up to MAX_LENGTH_FACTOR times the configured one) while the evidence rises: a density error
#: linear in height (3 % over the drop, error family ``density-ramp``) was sized at 3000 m, the end
#: of the search, and the velocity bands held the truth at 78 to 96 % of the nodes on four of ten
#: drops; at up to 30 km at 100 % (docs/studies/error-families.md).
LENGTH_EXTENSION, MAX_LENGTH_FACTOR = 10.0 ** 0.5, 100.0
#: The configured sigma each component group shares: wind north and east one, density its own.
GROUPS = {"wind": ("wind_n", "wind_e"), "density": ("density",)}


@dataclass(frozen=True)
class ProfileSigmaEstimate:
    """The profile sigmas the data say (see the module docstring).

    Attributes
    ----------
    fitted : dict of str to float
        Group (``"wind"``, ``"density"``) -> the prior sigma the fit used (m/s; fraction).
    estimated : dict of str to float
        Group -> its type-II maximum-likelihood sigma (0: no profile error the data can see).
    log_evidence_gain : float
        log Z at the estimate minus at the fit's sigmas, nats (>= 0).
    components : tuple of str
        The fit's corrected components (PROFILE_COMPONENTS names), in its grid's order.
    against_zero : dict of str to float
        Group -> log evidence of its estimate over none of its error (the others at their
        estimates), nats; below :data:`ZERO_EVIDENCE_NATS` the group is taken as zero.
    gauss_newton_fallback : bool
        The fit's curvature was the observed information, and the estimate was made on the
        Gauss-Newton one because the observed one's data part is indefinite (:func:`quadratic_model`).
    fitted_length_m, length_m : float
        The correlation length in altitude the fit used and the one of the estimate (m; the most
        evident of the fit's and :data:`LENGTH_FACTORS` times the configured one, shared by every
        component); 0: not estimated (the fit's is kept).
    gps : GpsErrorEstimate or None
        The GPS error model estimated with them (:mod:`casrecon.estimation.error_models.error_model_sigma`);
        None: not estimated. Without the profile model the groups above are empty.
    gauss_newton : bool
        The estimate was made on the Gauss-Newton curvature (as a fallback, or because the fit's
        covariance was formed on it: the default path's first fit).
    log_ratio_cov : ndarray or None
        Covariance of the log of each group's estimate (the groups of ``estimated`` above zero, in
        its order): the inverse of the log evidence's negative Hessian at its maximum
        (:func:`~casrecon.estimation.numerics.information_ascent.covariance_at_maximum`,
        conditional on the GPS sizes there); None where no group is above zero or the evidence is
        not curved down there.
    """

    fitted: dict[str, float]
    estimated: dict[str, float]
    log_evidence_gain: float
    components: tuple[str, ...]
    against_zero: dict[str, float]
    gauss_newton_fallback: bool = False
    fitted_length_m: float = 0.0
    length_m: float = 0.0
    gps: GpsErrorEstimate | None = None
    gauss_newton: bool = False
    log_ratio_cov: np.ndarray | None = field(default=None, compare=False)

    @property
    def uncertain_groups(self) -> tuple[str, ...]:
        """The groups ``log_ratio_cov`` is about: those estimated above zero (none without it)."""
        if self.log_ratio_cov is None:
            return ()
        return tuple(g for g in self.fitted if self.estimated[g] > 0.0)

    def log_ratio_sd(self) -> dict[str, float]:
        """Group -> the standard deviation of the log of its estimate (a relative 1-sigma, for
        small values), for the groups of :attr:`uncertain_groups`."""
        if self.log_ratio_cov is None:
            return {}
        return dict(zip(self.uncertain_groups, np.sqrt(np.diag(self.log_ratio_cov)).tolist()))

    @property
    def refit(self) -> bool:
        """Whether some group's estimate is beyond :data:`REFIT_FACTOR` of the fit's sigma."""
        return self.differs_from(self.fitted)

    def differs_from(self, intended: dict[str, float]) -> bool:
        """Whether some group's estimate is beyond :data:`REFIT_FACTOR` of the sigma ``intended``
        for it (group -> m/s or fraction; 0: none of that error, which only an estimate of 0 meets:
        a refit holds such a group at MIN_RATIO of the sigma before it, see :func:`profile_refit`)."""
        def agrees(estimate: float, target: float) -> bool:
            if target == 0.0:
                return estimate == 0.0
            return target / REFIT_FACTOR <= estimate <= target * REFIT_FACTOR

        if any(self.estimated.values()) and self.length_m > 0 and not agrees(self.length_m, self.fitted_length_m):
            return True
        if self.gps is not None and self.gps.refit:
            return True
        return not all(agrees(self.estimated[g], intended.get(g, self.fitted[g])) for g in self.fitted)

    def text(self) -> str:
        """One line: each group's estimate against the fit's sigma (and the GPS error model's)."""
        gps = "" if self.gps is None else self.gps.text()
        if not self.fitted:
            return gps
        return self.profile_text() + ("; " + gps if gps else "")

    def profile_text(self) -> str:
        """One line: each profile group's estimate against the fit's sigma."""
        unit = {g: PROFILE_UNITS[GROUPS[g][0]] for g in self.fitted}
        sd = {g: f" +-{100.0 * v:.1f} % (1 sigma)" for g, v in self.log_ratio_sd().items()}
        parts = [f"{g} {unit[g][1] * self.estimated[g]:.3g} {unit[g][0]}{sd.get(g, '')} (fitted with "
                 f"{unit[g][1] * self.fitted[g]:.3g}; log evidence over none {self.against_zero[g]:+.1f})"
                 for g in self.fitted]
        fallback = (", on the Gauss-Newton curvature: the observed information's data part is indefinite"
                    if self.gauss_newton_fallback else ", on the Gauss-Newton curvature" if self.gauss_newton else "")
        length = ("" if not self.length_m else
                  f", correlation length {self.length_m:.0f} m (fitted with {self.fitted_length_m:.0f} m)"
                  if self.length_m != self.fitted_length_m else f", correlation length {self.length_m:.0f} m")
        return (f"atmosphere-profile sigmas the data say (type-II maximum likelihood{fallback}): {', '.join(parts)}"
                f"{length}; log evidence +{self.log_evidence_gain:.1f}")


@dataclass(frozen=True)
class QuadraticModel:
    """The fit's quadratic model in its reduced coordinates, split into the data's part and each
    group's prior rows (see the module docstring)."""

    h_data: np.ndarray
    g_data: np.ndarray
    rows: tuple[np.ndarray, ...]       # A_k, (n_k, n_w)
    residuals: tuple[np.ndarray, ...]  # u_k, (n_k,)
    gauss_newton: bool = False         # the data's curvature is J^T J (else the observed information)
    log_normaliser: float = 0.0        # log det of the prior's whitening beyond the fit's (other lengths)

    def log_evidence(self, log_ratio: np.ndarray) -> tuple[float, np.ndarray]:
        """(log Z up to a constant, its gradient in ``log_ratio``) at ratios exp(``log_ratio``).
        Where the model's Hessian is not positive definite (an observed information whose data part
        is indefinite, with a weak prior) there is no Laplace evidence: a penalty of -NOT_DEFINITE
        that falls towards smaller ratios is returned, so the search stays where it is defined."""
        inv2 = np.exp(-2.0 * np.asarray(log_ratio, float))
        h = self.h_data + sum(a.T @ a * s for a, s in zip(self.rows, inv2))
        rhs = -(self.g_data + sum(a.T @ u * s for a, u, s in zip(self.rows, self.residuals, inv2)))
        try:
            chol = scipy.linalg.cholesky(h, lower=True)
        except np.linalg.LinAlgError:
            return -NOT_DEFINITE * (1.0 + float(np.sum(1.0 / inv2))), -NOT_DEFINITE * 2.0 / inv2
        dw = scipy.linalg.cho_solve((chol, True), rhs)
        prior = [float(np.sum((u + a @ dw) ** 2)) * s for a, u, s in zip(self.rows, self.residuals, inv2)]
        chi2 = 2.0 * float(self.g_data @ dw) + float(dw @ self.h_data @ dw) + sum(prior)
        n = np.array([a.shape[0] for a in self.rows], float)
        value = (-0.5 * chi2 - float(np.sum(np.log(np.diag(chol)))) - float(n @ np.asarray(log_ratio, float))
                 + self.log_normaliser)
        # tr(A H^-1 A^T) = |L^-1 A^T|_F^2
        gamma = np.array([a.shape[0] - float(np.sum(scipy.linalg.solve_triangular(chol, a.T, lower=True) ** 2)) * s
                          for a, s in zip(self.rows, inv2)])
        return value, np.array(prior) - gamma


@dataclass(frozen=True)
class ProfilePriorRows:
    """The atmosphere-profile prior of a fit's drop at its estimate: the prior is linear in the
    scaled unknowns, so its residual Jacobian is exact.

    Attributes
    ----------
    cols : int array
        The profile's z columns (level-major, component-minor).
    jacobian : ndarray (n_rows, len(cols))
        W, the whitened prior rows' Jacobian in those columns.
    residuals : ndarray (n_rows,)
        u_hat, the whitened prior residuals.
    component_of_col, component_of_row : int arrays
        Index in the grid's ``components`` of each column and of each row (a row involves one).
    """

    cols: np.ndarray
    jacobian: np.ndarray
    residuals: np.ndarray
    component_of_col: np.ndarray
    component_of_row: np.ndarray


def profile_prior_rows(result) -> ProfilePriorRows:
    """:class:`ProfilePriorRows` of a fit with the profile model (a
    :class:`~casrecon.estimation.sixdof.fit.FitResult`, one drop of a joint fit included)."""
    grid, nlp = result.part.profile, result.nlp
    rows = np.concatenate([np.arange(nlp.n_r)[nlp.groups[result.group(g)]] for g in ("profile_start", "profile")])
    cols = result.part.extra("profile").cols
    w = nlp.derivatives.jacobian_r(result.z).tocsr()[rows][:, cols].toarray()
    component_of_col = np.arange(cols.size) % grid.n_components
    return ProfilePriorRows(cols, w, nlp.residual_vector(result.z)[rows], component_of_col,
                            component_of_col[np.argmax(w != 0, axis=1)])


def group_masks(grid, component_of_row: np.ndarray, groups=tuple(GROUPS)) -> list[np.ndarray]:
    """Per sigma group of ``groups`` (names of :data:`GROUPS`), which prior rows are its: a boolean
    mask over the rows, each row's component given by ``component_of_row`` (indices into the grid's
    ``components``, as :class:`ProfilePriorRows` has them)."""
    names = np.array([PROFILE_COMPONENTS[c] for c in grid.components])
    return [np.isin(names[component_of_row], GROUPS[g]) for g in groups]


def prior_rows_at(result, prior: ProfilePriorRows, length_m: float) -> tuple[np.ndarray, np.ndarray, np.ndarray, float]:
    """The fit's profile prior rebuilt with the correlation length ``length_m`` (m): (W, u = W z,
    component of each row, log det of its whitening less the fit's). One process per component,
    rows v_0 then (v_k - phi v_k-1) / sqrt(1 - phi^2) on the level values v (as
    :func:`casrecon.estimation.kinds.disturbance.spline_level_prior_terms`), times the component's
    scale over its prior sigma. ValueError if at the fit's own length they are not the fit's rows."""
    grid = result.part.profile
    k, n_c = grid.n_levels, grid.n_components
    weights = grid.sigma / grid.prior

    def whitening(length: float) -> tuple[np.ndarray, float]:
        phi = float(np.exp(-grid.step_m / length))
        d = np.eye(k) / np.r_[1.0, np.full(k - 1, np.sqrt(1.0 - phi * phi))][:, None]
        d[np.arange(1, k), np.arange(k - 1)] = -phi / np.sqrt(1.0 - phi * phi)
        return d @ grid.level_matrix(), -0.5 * (k - 1) * np.log(1.0 - phi * phi)

    own, own_log_det = whitening(grid.length_m)
    new, log_det = whitening(length_m)
    w = np.zeros((n_c * k, n_c * k))
    for c in range(n_c):
        cols = np.arange(k) * n_c + c
        fit_rows = prior.jacobian[prior.component_of_row == c][:, cols]
        mine = weights[c] * own
        if not np.allclose(fit_rows.T @ fit_rows, mine.T @ mine, rtol=1e-8, atol=1e-10 * np.abs(mine).max() ** 2):
            raise ValueError("the fit's profile prior rows are not the Gauss-Markov level prior")
        w[c * k:(c + 1) * k, cols] = weights[c] * new
    z = result.z[prior.cols]
    return w, w @ z, np.repeat(np.arange(n_c), k), n_c * (log_det - own_log_det)


def quadratic_model(result, lengths_m: tuple[float, ...] = ()) -> tuple[list[QuadraticModel], list[str]]:
    """The :class:`QuadraticModel` of a converged profile fit (a
    :class:`~casrecon.estimation.sixdof.fit.FitResult` with a null-space covariance) with its prior at its
    own correlation length, then at each of ``lengths_m`` (m), and its groups: the fit's own
    curvature, or the Gauss-Newton one (``QuadraticModel.gauss_newton``) where the data's part of
    an observed information is indefinite (its Laplace evidence then exists only for sigmas near
    the fit's: on a drop flying 1 m/s off its sounding, fitted at 0.5 m/s, it ended at 1.1 times
    the fitted sigma and the estimate could not say more). The data's part is the fit's whatever
    the length: only the prior's rows change (:func:`prior_rows_at`)."""
    grid, cov = result.part.profile, result.covariance
    prior = profile_prior_rows(result)
    groups = [g for g, m in zip(GROUPS, group_masks(grid, prior.component_of_row)) if m.any()]

    def model(basis: np.ndarray, h: np.ndarray, gauss_newton: bool) -> list[QuadraticModel]:
        a = prior.jacobian @ basis[prior.cols]
        masks = group_masks(grid, prior.component_of_row, groups)
        h_data = 0.5 * (h + h.T) - sum(a[m].T @ a[m] for m in masks)
        g_data = -sum(a[m].T @ prior.residuals[m] for m in masks)
        out = []
        for length in (grid.length_m, *lengths_m):
            if length == grid.length_m:
                rows, residuals, component_of_row, log_det = a, prior.residuals, prior.component_of_row, 0.0
            else:
                w, residuals, component_of_row, log_det = prior_rows_at(result, prior, length)
                rows = w @ basis[prior.cols]
            at = group_masks(grid, component_of_row, groups)
            out.append(QuadraticModel(h_data, g_data, tuple(rows[m] for m in at), tuple(residuals[m] for m in at),
                                      gauss_newton, log_det))
        return out

    own = model(cov.basis, np.linalg.inv(cov.cov_w), not cov.information.startswith("observed"))
    if own[0].gauss_newton or np.linalg.eigvalsh(own[0].h_data)[0] >= 0:
        return own, groups
    # the solver's Gauss-Newton system when it was formed at the solution itself, else one on the
    # covariance's null space
    system = result.solver.reduced or gauss_newton_system(result.nlp, result.z, cov.split)
    return model(system.basis, system.hessian, True), groups


def estimate_profile_sigma(result, configured_length_m: float | None = None) -> ProfileSigmaEstimate:
    """Type-II maximum-likelihood profile sigmas of a converged profile fit, and the most evident
    correlation length of the fit's and :data:`LENGTH_FACTORS` times ``configured_length_m`` (m;
    longer ones while the longest wins, up to MAX_LENGTH_FACTOR times;
    default the fit's; see the module docstring). Raises ValueError for a fit without a profile or
    with disturbance states (whose covariance is not a reduced system)."""
    from scipy.optimize import minimize

    grid = result.part.profile
    if grid is None or not hasattr(result.covariance, "cov_w"):
        raise ValueError("the profile sigmas are estimated only for a profile fit without disturbance states")
    configured = grid.length_m if configured_length_m is None else float(configured_length_m)
    lengths = tuple(sorted({f * configured for f in LENGTH_FACTORS} - {grid.length_m}))
    try:
        models, groups = quadratic_model(result, lengths)
    except ValueError:  # a prior this module cannot rebuild at other lengths: the fit's alone
        models, groups, lengths = *quadratic_model(result), ()
    prior = dict(zip([PROFILE_COMPONENTS[c] for c in grid.components], grid.prior))
    fitted = {g: float(prior[GROUPS[g][0]]) for g in groups}
    base, _ = models[0].log_evidence(np.zeros(len(groups)))
    bounds = [(np.log(MIN_RATIO), np.log(MAX_RATIO))] * len(groups)

    def fitted_model(m: QuadraticModel):
        return minimize(lambda x: tuple(-v for v in m.log_evidence(x)), np.zeros(len(groups)), jac=True,
                        method="L-BFGS-B", bounds=bounds)

    fits = [fitted_model(m) for m in models]
    pick = int(np.argmin([f.fun for f in fits]))
    if lengths and np.isclose((grid.length_m, *lengths)[pick], max(LENGTH_FACTORS) * configured):
        for factor in extension(max(LENGTH_FACTORS), LENGTH_EXTENSION, MAX_LENGTH_FACTOR):  # while the evidence rises
            longer = quadratic_model(result, (factor * configured,))[0][1]
            challenger = fitted_model(longer)
            if challenger.fun >= fits[pick].fun:
                break
            models, fits, lengths = [*models, longer], [*fits, challenger], (*lengths, factor * configured)
            pick = len(fits) - 1
    model, best = models[pick], fits[pick]
    ratio = np.exp(best.x)
    against_zero = {}
    for k, g in enumerate(groups):  # how much better than none of this group's error the estimate explains the data
        none = best.x.copy()
        none[k] = np.log(MIN_RATIO)
        against_zero[g] = float(-best.fun - model.log_evidence(none)[0])
        if against_zero[g] < ZERO_EVIDENCE_NATS or ratio[k] < NEGLIGIBLE_RATIO:
            ratio[k] = 0.0
    estimated = {g: fitted[g] * float(r) for g, r in zip(groups, ratio)}
    fallback = model.gauss_newton and result.covariance.information.startswith("observed")
    return ProfileSigmaEstimate(fitted, estimated, max(0.0, float(-best.fun - base)), tuple(prior), against_zero,
                                fallback, grid.length_m, (grid.length_m, *lengths)[pick],
                                gauss_newton=model.gauss_newton,
                                log_ratio_cov=estimate_covariance(lambda x: model.log_evidence(x)[1], best.x, ratio))


def estimate_covariance(gradient, x: np.ndarray, ratio: np.ndarray) -> np.ndarray | None:
    """:attr:`ProfileSigmaEstimate.log_ratio_cov` of an estimate at log ratios ``x`` (the profile
    groups first) whose groups' ratios after the zero tests are ``ratio`` (the profile groups'),
    ``gradient`` the gradient of its log evidence (x -> d log Z / d x)."""
    which = [k for k, r in enumerate(ratio) if r > 0.0]
    return covariance_at_maximum(gradient, x, which) if which else None


def extension(longest: float, step: float, limit: float) -> list[float]:
    """The factors beyond ``longest``, ``step`` times at a time, up to ``limit`` (within round-off):
    the candidates of a search that goes on past the end of its range (profile lengths here, GPS
    correlation times in :mod:`.error_model_sigma`)."""
    out, factor = [], longest * step
    while factor <= limit * (1 + 1e-9):
        out.append(factor)
        factor *= step
    return out


def group_of(component: str) -> str:
    """The sigma group (``"wind"``, ``"density"``) of a PROFILE_COMPONENTS name."""
    return next(g for g, comps in GROUPS.items() if component in comps)


def profile_refit(cfg: ProblemConfig, estimate: ProfileSigmaEstimate) -> tuple[ProblemConfig, np.ndarray | None]:
    """The configuration and profile prior sigmas (one per corrected component, or None) of the
    refit with the sigmas the data say: without the profile model when every group is estimated
    at zero (the plain fit); else the same profile unknowns, and so the same compiled code, with
    each group's prior at its estimate, a group at zero held at MIN_RATIO of the fitted sigma. With
    a GPS estimate the configuration's GPS error model is the estimated one (prior None too when
    the fit had no profile model)."""
    if estimate.gps is not None:
        cfg = replace(cfg, gps=replace(cfg.gps, error_model=estimate.gps.refit_model))
        if not estimate.fitted:  # the profile sigmas were not estimated: the configured ones stand
            return cfg, None
    if not any(estimate.estimated.values()):
        atm = replace(cfg.atmosphere, profile_wind_sigma_mps=0.0, profile_density_sigma=0.0)
        return replace(cfg, atmosphere=atm), None
    prior = [max(estimate.estimated[group_of(c)], MIN_RATIO * estimate.fitted[group_of(c)])
             for c in estimate.components]
    if estimate.length_m and estimate.length_m != cfg.atmosphere.profile_length_m:
        cfg = replace(cfg, atmosphere=replace(cfg.atmosphere, profile_length_m=estimate.length_m))
    return cfg, np.array(prior)


def refit_text(estimate: ProfileSigmaEstimate, prior: np.ndarray | None) -> str:
    """How the refit of :func:`profile_refit` was made, for the fit's notes."""
    gps = "" if estimate.gps is None else f" and {estimate.gps.refit_model.describe()}"
    if not estimate.fitted:
        return "with" + gps[4:]
    if prior is None:
        return "without the atmosphere-profile model" + gps
    parts = [f"{c} {PROFILE_UNITS[c][1] * p:.3g} {PROFILE_UNITS[c][0]}" for c, p in zip(estimate.components, prior)]
    length = (f" and the correlation length {estimate.length_m:.0f} m"
              if estimate.length_m and estimate.length_m != estimate.fitted_length_m else "")
    return f"with the profile prior sigmas {', '.join(parts)}{length} (the unknowns scaled as configured){gps}"
