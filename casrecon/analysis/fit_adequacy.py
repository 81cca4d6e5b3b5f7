"""The model-adequacy verdict (:mod:`casrecon.analysis.adequacy`) of a per-drop 6-DOF fit and of a
GPS-only point-mass fit: their residual channels, priors and ground check."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from casrecon.analysis.accel_bias_floor import kinematic_bias
from casrecon.analysis.adequacy import FAMILY_ALPHA, Adequacy, GroundCheck, assess
from casrecon.analysis.process_scale import ProcessPrior
from casrecon.estimation.error_models.profile import PROFILE_COMPONENTS, PROFILE_UNITS
from casrecon.estimation.error_models.profile_sigma import profile_prior_rows
from casrecon.estimation.kinematic.terms import INTERVAL_RESIDUALS
from casrecon.estimation.sixdof import diagnostics as dg

#: Accepted distance (m) between the fitted height at impact and the site's ground altitude, on top
#: of 3 sigma of the fitted height: terrain relief over a landing area of a few kilometres, the
#: vehicle's size and the GPS height error.
GROUND_TOLERANCE_M = 30.0
#: Longest extrapolation (s) from the last node to the detected impact for the impact check.
MAX_EXTRAPOLATION_S = 2.0
#: Report names of the IMU channels (IMU axes) and GPS components (NED).
IMU_NAMES = dict(zip(dg.IMU_CHANNELS, ("IMU accel x", "IMU accel y", "IMU accel z", "IMU gyro x", "IMU gyro y",
                                       "IMU gyro z")))
GPS_NAMES = {"pos_n": "GPS pos n", "pos_e": "GPS pos e", "pos_d": "GPS pos d", "vel_n": "GPS vel n",
             "vel_e": "GPS vel e", "vel_d": "GPS vel d"}


def prior_arrays(specs, values: np.ndarray, covariance: np.ndarray) -> tuple[list[str], np.ndarray, np.ndarray,
                                                                              np.ndarray, list[str]]:
    """Names, estimates, prior sigmas, posterior covariance and units of the parameters with a prior.

    Parameters
    ----------
    specs : sequence of casrecon.estimation.sixdof.parameters.ParameterSpec
    values : ndarray
        Estimates of every spec (SI).
    covariance : ndarray
        Posterior covariance of every spec (SI).
    """
    idx = [i for i, s in enumerate(specs) if s.prior_sigma]
    return ([specs[i].name for i in idx], np.asarray(values)[idx], np.array([specs[i].prior_sigma for i in idx]),
            np.asarray(covariance)[np.ix_(idx, idx)], [specs[i].unit for i in idx])


def impact_check(result) -> tuple[GroundCheck | None, tuple[str, ...]]:
    """Height above the site's ground at the detected impact: the last node's, moved on at its
    vertical speed to the impact time (at most MAX_EXTRAPOLATION_S), against 3 sigma of the last
    node's height plus GROUND_TOLERANCE_M; where the impact was a measurement
    (:mod:`casrecon.estimation.kinds.ground`), above the measured ground, against 3 of its sigmas."""
    h, h_sigma = result.column("h_agl_m")
    dt = float(result.data.impact_imu_s - result.node_time_s[-1])
    if not 0.0 <= dt <= MAX_EXTRAPOLATION_S:
        return None, (f"ground not checked: the fit window ends {dt:.2f} s before the detected impact "
                      f"(checked within 0 to {MAX_EXTRAPOLATION_S:g} s)",)
    vel_d = float(result.states[-1, 5])
    at_impact = float(h[-1] - vel_d * dt)
    ground = result.measurements.get("ground")
    if ground is not None:  # the impact was a measurement: its residual against 3 of its sigmas
        at_impact -= ground.height_agl_m
        limit = 3.0 * ground.sigma_m
        text = (f"height above the measured ground at the detected impact {at_impact:+.2f} m (last node "
                f"{h[-1]:.1f} m above the site's, {dt:.2f} s earlier, descending {vel_d:.1f} m/s); accepted "
                f"within {limit:.2f} m (3 sigma of the impact measurement, [estimation] impact_ground_sigma_m)")
    else:
        limit = float(3 * h_sigma[-1] + GROUND_TOLERANCE_M)
        text = (f"height above the site's ground at the detected impact {at_impact:+.1f} m (last node {h[-1]:.1f} m, "
                f"{dt:.2f} s earlier, descending {vel_d:.1f} m/s); accepted within {limit:.1f} m "
                f"(3-sigma {3 * h_sigma[-1]:.1f} m + {GROUND_TOLERANCE_M:g} m)")
    if abs(at_impact) > limit and abs(vel_d) > 1.0:  # a clock error moves the impact along the descent
        text += (f"; the miss is also what an IMU clock error of {abs(at_impact / vel_d):.2f} s would make "
                 "([sensors.imu.clock] utc_at_zero)")
    return GroundCheck("impact" if ground is None else "measured impact", at_impact, limit, text), ()


def drop_channels(imu: dict, gps: dict, others: dict) -> dict[str, np.ndarray]:
    """Normalised residual series per channel: IMU samples where used, GPS fixes, the barometer.

    Parameters
    ----------
    imu, gps : dict
        :func:`casrecon.estimation.sixdof.diagnostics.imu_residuals` (``residual`` (N, 6), ``valid``,
        ``sigma`` (6,)) and :func:`~casrecon.estimation.sixdof.diagnostics.gps_residuals` (``residual`` and
        ``sigma``, (M, 6)), SI.
    others : dict of str to dict
        Other kinds' residual columns (``"baro"``: ``pressure_residual_pa``, ``pressure_sigma_pa``).
    """
    channels = {}
    for k, name in enumerate(IMU_NAMES.values()):
        used = np.asarray(imu["valid"][:, k], dtype=bool)
        channels[name] = np.asarray(imu["residual"][:, k])[used] / float(imu["sigma"][k])
    for k, name in enumerate(GPS_NAMES.values()):
        if "normalised" in gps:  # whitened under the fit's GPS error model
            channels[name] = np.asarray(gps["normalised"][:, k])
        else:
            channels[name] = np.asarray(gps["residual"][:, k]) / np.asarray(gps["sigma"][:, k])
    baro = others.get("baro")
    if baro is not None:
        channels["baro"] = np.asarray(baro["pressure_residual_pa"]) / np.asarray(baro["pressure_sigma_pa"])
    return channels


def drop_adequacy(result, imu: dict, gps: dict, others: dict, alpha: float = FAMILY_ALPHA) -> Adequacy:
    """Verdict of a 6-DOF fit (or of one drop's part of a joint fit).

    Parameters
    ----------
    result : casrecon.estimation.sixdof.fit.FitResult
    imu, gps, others : dict
        Its residuals, as :func:`drop_channels` takes them.
    alpha : float
        Family-wise level.
    """
    cov = result.correlation * np.outer(result.sigma, result.sigma)
    names, values, prior_sigma, post, units = prior_arrays(result.params.specs, result.values, cov)
    ground, notes = impact_check(result)
    if result.part.n_u:
        notes += ("the Gauss-Markov priors of the disturbance states are not tested",)
    gps_model = result.scenario.config.gps.error_model.enabled
    bias = kinematic_bias(result)
    return assess(drop_channels(imu, gps, others), names, values, prior_sigma, post, units, ground, alpha, notes,
                  gps_model, processes=profile_priors(result), gross=getattr(result, "gross_errors", ()),
                  checks=() if bias is None else (bias.check(),))


def profile_priors(result) -> tuple[ProcessPrior, ...]:
    """The atmosphere-profile corrections of a 6-DOF fit (or of one drop of a joint fit) as prior
    processes, one per corrected component (none without the profile model): the whitened prior
    residuals at the estimate and their posterior covariance W P W^T (the prior is linear in the
    scaled unknowns, so its residual Jacobian W is exact)."""
    grid = result.part.profile
    if grid is None:
        return ()
    prior = profile_prior_rows(result)
    cov = result.covariance.covariance_of(prior.cols)
    priors = []
    for k, (comp, sigma) in enumerate(zip(grid.components, grid.prior)):
        r, c = prior.component_of_row == k, prior.component_of_col == k
        wk = prior.jacobian[np.ix_(r, c)]
        name = PROFILE_COMPONENTS[comp]
        unit, factor = PROFILE_UNITS[name]
        priors.append(ProcessPrior(f"profile {name.replace('_', ' ')}", unit, float(sigma) * factor,
                                   prior.residuals[r], wk @ cov[np.ix_(c, c)] @ wk.T))
    return tuple(priors)


def pointmass_adequacy(result, alpha: float = FAMILY_ALPHA) -> Adequacy:
    """Verdict of a GPS-only fit
    (:class:`~casrecon.estimation.pointmass.fit.PointMassResult`): its six GPS channels, the
    wind-bias priors, and the track's lowest point against the ground (a track that ends in the air
    has no impact to check)."""
    specs = result.params.specs
    col_of = {name: col for col, name in result.nlp.parameter_names.items()}
    cols = np.array([col_of[s.name] for s in specs])
    cov = result.covariance.covariance_of(cols, result.params.scales)
    names, values, prior_sigma, post, units = prior_arrays(specs, result.values, cov)
    series = result.normalized_residuals if result.whitened_residuals is None else result.whitened_residuals
    channels = {name: series[:, i] for i, name in enumerate(GPS_NAMES.values())}
    h = -result.states[:, 2]
    k = int(np.argmin(h))
    limit = float(3 * result.state_sigma[k, 2] + GROUND_TOLERANCE_M)
    ground = GroundCheck("lowest", float(h[k]), limit,
                         f"lowest fitted point {h[k]:.1f} m above the site's ground; accepted down to -{limit:.1f} m "
                         f"(3-sigma {3 * result.state_sigma[k, 2]:.1f} m + {GROUND_TOLERANCE_M:g} m)")
    notes = ("the drag-area smoothness prior is not tested",) if len(names) < len(specs) else ()
    return assess(channels, names, values, prior_sigma, post, units, ground, alpha, notes,
                  result.config.gps_errors.enabled)


#: Why IMU parameters far from their priors matter in a kinematic fit.
KINEMATIC_PRIOR_HINT = ("the IMU error model or its priors do not describe this IMU, or its samples miss motion "
                        "between them (a fast rotation sampled too slowly): the fit bent the IMU parameters to "
                        "make up for it")


def kinematic_adequacy(result, alpha: float = FAMILY_ALPHA) -> Adequacy:
    """Verdict of a kinematic reconstruction
    (:class:`~casrecon.estimation.kinematic.fit.KinematicResult`): the six GPS components, the
    barometer, and the priors of the IMU errors, clock offset and barometer (no ground check: a
    kinematic span need not end on the ground).

    The whitened preintegration residuals are not tested: they are the estimated IMU noise of each
    interval, which the node states absorb almost entirely (leverage near 1; on an exact synthetic
    drop their reduced chi-square is below 0.001 and they look correlated), so neither their scale
    nor their whiteness says anything. An IMU model that does not describe the data shows in the
    GPS channels and in the IMU parameters pushed beyond their priors.
    """
    specs = result.params.specs
    cov = result.covariance.covariance_of(result.parameter_columns, result.params.scales)
    names, values, prior_sigma, post, units = prior_arrays(specs, result.values, cov)
    r = result.nlp.residual_vector(result.z)
    groups = result.nlp.groups
    gps = r[groups["gps"]].reshape(-1, 6)
    gps = np.where(np.isfinite(result.data.fix_sigma[:gps.shape[0]]), gps, np.nan)  # missing: not tested
    channels = {name: gps[:, i] for i, name in enumerate(GPS_NAMES.values())}
    if "baro" in groups:
        channels["barometer"] = r[groups["baro"]]
    per_channel = np.mean(r[groups["imu"]].reshape(-1, len(INTERVAL_RESIDUALS)) ** 2, axis=0)
    notes = (f"the whitened preintegration residuals are not tested (the node states absorb them; their "
             f"reduced chi-square is {result.group_reduced_chi2()['imu']:.3g} on {result.n_measurements['imu']}; "
             "per channel " + ", ".join(f"{n} {v:.2g}" for n, v in zip(INTERVAL_RESIDUALS, per_channel)) + ")",)
    return assess(channels, names, values, prior_sigma, post, units, None, alpha, notes,
                  result.options.gps_errors.enabled, KINEMATIC_PRIOR_HINT)


@dataclass(frozen=True)
class JointAdequacy:
    """The verdict of a joint fit: each drop's own (:class:`Adequacy`, each at the family-wise
    :data:`FAMILY_ALPHA`), trusted only when every drop's is.

    Attributes
    ----------
    trusted : bool
    line : str
        One line naming each drop whose bands are not to be trusted, with its reasons.
    drops : tuple of (str, Adequacy)
        Drop name and verdict, in the joint fit's order.
    """

    trusted: bool
    line: str
    drops: tuple[tuple[str, Adequacy], ...]

    def drop(self, name: str) -> Adequacy:
        """The verdict of drop ``name``."""
        return dict(self.drops)[name]

    def to_dict(self) -> dict:
        """JSON-ready content (joint ``summary.json`` ``adequacy``)."""
        return {"trusted": self.trusted, "line": self.line, "drops": {n: a.to_dict() for n, a in self.drops}}

    @classmethod
    def from_dict(cls, doc: dict) -> JointAdequacy:
        return cls(bool(doc["trusted"]), str(doc["line"]),
                   tuple((n, Adequacy.from_dict(a)) for n, a in doc["drops"].items()))


def joint_adequacy(per_drop: dict[str, Adequacy]) -> JointAdequacy:
    """:class:`JointAdequacy` of the drops' verdicts (drop name -> :class:`Adequacy`)."""
    bad = [(n, a) for n, a in per_drop.items() if not a.trusted]
    if not bad:
        line = (f"bands can be trusted: every drop's tests passed ({len(per_drop)} drops, each at a family-wise "
                f"{100 * FAMILY_ALPHA:g} %)")
        conservative = [n for n, a in per_drop.items() if a.cautions]
        if conservative:
            line += (f"; conservative on {', '.join(conservative)} (residuals smaller than their sigmas: "
                     + "; ".join(f"{n}: {', '.join(a.cautions)}" for n, a in per_drop.items() if a.cautions) + ")")
    else:
        line = "bands NOT to be trusted: " + "; ".join(
            f"{n}: {a.line.removeprefix('bands NOT to be trusted: ')}" for n, a in bad)
    return JointAdequacy(not bad, line, tuple(per_drop.items()))
