"""The ``[estimation]`` table of a 6-DOF problem: how the fit is set up and solved
(:class:`EstimationConfig`, parsed and checked by :func:`parse_estimation`), and the Gauss-Markov
disturbance settings it shares with ``[truth]`` (:func:`parse_disturbance`)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from casrecon.io.gps_rules import GpsQuality
from casrecon.io.toml_fields import Fields
from casrecon.physics.aero import DISPERSION_NAMES
from casrecon.physics.disturbance import DisturbanceModel

#: Default collocation interval, s (see :attr:`EstimationConfig.interval_s`).
INTERVAL_S = 0.025


@dataclass(frozen=True)
class EstimationConfig:
    """Settings of the per-drop fit (``[estimation]``); times in seconds.

    Parameters
    ----------
    start_after_release_s : float
        Fit window start after release (the EES paper skipped 3.5 s of rotor downwash).
    end_before_impact_s : float
        Fit window end before impact.
    release_imu_s, impact_imu_s : float, optional
        Release and impact on the IMU clock; found from the IMU when not given.
    interval_s : float, optional
        Target collocation interval; the mesh takes the nearest whole number of IMU samples (at
        least 4). Not given: 25 ms (:meth:`EstimationConfig.resolved_interval_s`), which keeps the
        Hermite-Simpson discretisation error of a 500 Hz drop well below the reported sigmas (at
        50 ms a noise-free fit of ees-drop-3 is off by 4.4 sigma along its best-determined CA/Cmn
        combination; at 24 ms by 0.23 sigma). With disturbance states the same: what a gust does
        between the nodes is modelled (:mod:`casrecon.estimation.sixdof.subgrid`), and the whole-drop gust
        calibration passes on 25 ms (README, issue 13).
    samples_per_interval : int, optional
        IMU samples per collocation interval; overrides ``interval_s`` when given.
    hessian : {"auto", "gauss-newton", "exact"}
        Hessian given to Ipopt (the covariance's curvature is ``information``). "auto": Gauss-Newton for the
        strong-constraint fit, exact with disturbance states, where Gauss-Newton was measured to
        converge only linearly (200 iterations without converging on a 24 s window of ees-drop-3
        with gust states; exact: 27).
    information : {"auto", "observed", "expected"}
        Curvature the covariance inverts. "observed": the exact Hessian of the Lagrangian at the
        solution (the objective's own curvature, as a Laplace approximation takes it); falls back
        to "expected" where that is not positive definite, and for fits with disturbance states,
        saying so. "expected": the Gauss-Newton J^T J (the Fisher information). They differ
        where the data pull against a model that is curved along a weakly determined direction:
        on a model-error drop whose heading is held mostly through the wind, "expected" put two
        gyro biases 3 sigma off the truth although holding them there raised the objective by
        only 3.2; over 30 such drops it held the truth attitude at 87.5 % of nodes ("observed":
        100 %). On data the model fits they agree (ees-drop-1: sigmas to 1e-4), and "observed"
        costs 0.3 to 0.7 s a fit. "auto" (default): "observed" for fits with atmosphere-profile
        or GPS-error unknowns, "expected" for the others.
    linear_solver : {"mumps", "spral"}
        Ipopt's linear solver.
    solver : {"auto", "ipopt"}
        "auto": the null-space constrained Gauss-Newton solver for fits without disturbance
        states (its iteration never factorises the whole KKT matrix; 2 to 3 times faster than Ipopt
        on the EES drops, same estimate), Ipopt for the others and to finish a Gauss-Newton run
        that stops unconverged; "ipopt": always Ipopt.
    method : {"map", "marginal"}
        "map": the joint maximum a posteriori over states, disturbances and parameters. "marginal":
        the parameters maximise their Laplace-approximated marginal likelihood, the latent unknowns
        (node states, gusts, model-error, atmosphere-profile and GPS-error values) integrated out;
        unbiased where a parameter scales the disturbances' effect (a slope multiplier under gusts),
        which the joint MAP is not (:mod:`casrecon.estimation.engine.laplace`). Starts from the MAP
        estimate and adds a few Newton steps, each costing 2 sparse factorisations per parameter
        (the latent KKT matrix and the defects' Jacobian at a perturbed point).
    max_iter : int
        Iteration limit (Ipopt's; the Gauss-Newton solver stops at the smaller of this and 50
        and hands its iterate to Ipopt).
    tol : float
        Ipopt convergence tolerance (scaled optimality error). A dual infeasibility d moves a
        scaled unknown of standard deviation s by about s^2 d, so 1e-6 is far inside every sigma;
        tighter values mostly chase round-off on long meshes.
    saturation : {"mask", "polynomial"}
        Saturated IMU samples are left out of the likelihood ("mask"), or replaced by a
        second-order polynomial through the neighbouring good samples ("polynomial", the EES paper's patch).
    estimate : tuple of str
        Dispersion factors to estimate; default every factor whose 3-sigma size is non-zero.
    dispersion_prior, atmosphere_prior, imu_bias_prior, clock_prior : bool
        Switch each prior group on or off.
    clock_sigma_s : float
        1-sigma prior of the IMU-to-GPS clock offset.
    estimate_clock : bool
        Estimate the IMU-to-GPS clock offset (else it is held at clock_offset_guess_s).
    disturbance : DisturbanceModel, optional
        Weak-constraint option: estimate gusts and/or model-error force and moment at every node,
        with their Gauss-Markov prior (keys gust_sigma_mps, gust_time_s, force_error_sigma_n,
        moment_error_sigma_nm, model_error_time_s). None (every sigma zero): strong constraint.
    estimate_downwash : bool
        Estimate the rotor-downwash magnitude (m/s, a hypothesis of the EES paper),
        with a N(0, downwash_sigma_mps^2) prior.
    downwash_sigma_mps : float
        1-sigma prior of the downwash magnitude.
    clock_offset_guess_s : float
        Starting value of the clock offset; the fit keeps the offset within one collocation
        interval of it (so each GPS fix stays on its interval) and says so if it ends on that bound.
    max_h_acc_m, max_v_acc_m, max_s_acc_mps : float
        GPS fixes reporting worse accuracy are dropped.
    min_num_sv : int
        GPS fixes with fewer satellites are dropped.
    impact_ground_sigma_m : float, optional
        1-sigma (m) of the ground's altitude where the vehicle hit it. Given, the impact becomes a
        measurement of altitude (:mod:`casrecon.estimation.kinds.ground`): at the impact instant
        (detected from the IMU, or ``impact_imu_s``) the centre of mass was at
        ``impact_ground_alt_msl_m``. Not given (default): the impact is only checked, within 30 m
        (the verdict's ground test). Include in it how far above the first contact point the centre
        of mass was and how well the ground's altitude is known (a survey: decimetres; a terrain
        model: metres).
    impact_ground_alt_msl_m : float, optional
        Altitude (m above mean sea level) of the centre of mass at the impact instant; default the
        site's ``ground_alt_msl_m``. Only with ``impact_ground_sigma_m``.
    """

    start_after_release_s: float = 3.5
    end_before_impact_s: float = 0.05
    release_imu_s: float | None = None
    impact_imu_s: float | None = None
    interval_s: float | None = None
    samples_per_interval: int | None = None
    hessian: str = "auto"
    information: str = "auto"
    linear_solver: str = "mumps"
    solver: str = "auto"
    method: str = "map"
    max_iter: int = 200
    tol: float = 1e-6
    saturation: str = "mask"
    estimate: tuple[str, ...] | None = None
    dispersion_prior: bool = True
    atmosphere_prior: bool = True
    imu_bias_prior: bool = True
    clock_prior: bool = True
    clock_sigma_s: float = 0.05
    clock_offset_guess_s: float = 0.0
    estimate_downwash: bool = False
    downwash_sigma_mps: float = 2.0
    estimate_clock: bool = True
    disturbance: DisturbanceModel | None = None
    max_h_acc_m: float = 10.0
    max_v_acc_m: float = 10.0
    max_s_acc_mps: float = 1.0
    min_num_sv: int = 6
    impact_ground_sigma_m: float | None = None
    impact_ground_alt_msl_m: float | None = None

    @property
    def gps_quality(self) -> GpsQuality:
        """The GPS quality rules of ``max_h_acc_m``, ``max_v_acc_m``, ``max_s_acc_mps``, ``min_num_sv``."""
        return GpsQuality(self.max_h_acc_m, self.max_v_acc_m, self.max_s_acc_mps, self.min_num_sv)

    def resolved_hessian(self) -> str:
        """The Hessian "auto" stands for with these settings."""
        if self.hessian != "auto":
            return self.hessian
        return "gauss-newton" if self.disturbance is None else "exact"

    def resolved_interval_s(self) -> float:
        """The collocation interval in s: ``interval_s`` when given, else :data:`INTERVAL_S`."""
        return INTERVAL_S if self.interval_s is None else self.interval_s

    def mesh_samples(self, imu_rate_hz: float) -> int:
        """IMU samples per collocation interval at an IMU rate of ``imu_rate_hz`` (Hz)."""
        if self.samples_per_interval is not None:
            return self.samples_per_interval
        return max(4, int(np.floor(self.resolved_interval_s() * imu_rate_hz + 0.5)))


#: Keys of the Gauss-Markov disturbance settings, in [truth] (what is simulated) and [estimation]
#: (the prior of the estimated node values); see casrecon.physics.disturbance.
DISTURBANCE_KEYS = ("gust_sigma_mps", "gust_time_s", "force_error_sigma_n", "moment_error_sigma_nm",
                    "model_error_time_s")


def parse_disturbance(t: Fields) -> DisturbanceModel | None:
    """Gusts (NED, m/s, correlation time gust_time_s) and model-error force (body, N) and moment
    (body, N m) with correlation time model_error_time_s; None when every sigma is zero. Read from
    ``[truth]`` (what is simulated) and ``[estimation]`` (the prior of the estimated values)."""
    zero = (0.0, 0.0, 0.0)
    sigma = []
    for key in ("gust_sigma_mps", "force_error_sigma_n", "moment_error_sigma_nm"):
        values = t.vector(key, 3, zero)
        if min(values) < 0:
            raise t.error(key, f"expected three sigmas >= 0, got {list(values)}")
        sigma += values
    gust_tau = t.number("gust_time_s", 3.0, positive=True)
    error_tau = t.number("model_error_time_s", 1.0, positive=True)
    if max(sigma) == 0:
        return None
    return DisturbanceModel(tuple(sigma), (gust_tau,) * 3 + (error_tau,) * 6)


def _samples_per_interval(t: Fields) -> int | None:
    if t.raw("samples_per_interval") is None:
        return None
    if t.raw("interval_s") is not None:
        raise t.error("samples_per_interval", "give interval_s or samples_per_interval, not both")
    return t.integer("samples_per_interval", 0, 4)


def parse_estimation(t: Fields) -> EstimationConfig:
    """The ``[estimation]`` table, checked (unknown keys and bad values are errors naming the key)."""
    d = EstimationConfig()
    estimate = t.raw("estimate")
    if estimate is not None:
        if not isinstance(estimate, list) or any(e not in DISPERSION_NAMES for e in estimate):
            raise t.error("estimate", f"expected a list of dispersion names from {', '.join(DISPERSION_NAMES)}")
        estimate = tuple(estimate)
    cfg = EstimationConfig(
        start_after_release_s=t.number("start_after_release_s", d.start_after_release_s, minimum=0.0),
        end_before_impact_s=t.number("end_before_impact_s", d.end_before_impact_s, minimum=0.0),
        release_imu_s=t.number("release_imu_s"), impact_imu_s=t.number("impact_imu_s"),
        interval_s=t.number("interval_s", positive=True),
        samples_per_interval=_samples_per_interval(t),
        hessian=t.string("hessian", d.hessian, choices=("auto", "gauss-newton", "exact")),
        information=t.string("information", d.information, choices=("auto", "observed", "expected")),
        linear_solver=t.string("linear_solver", d.linear_solver, choices=("mumps", "spral")),
        solver=t.string("solver", d.solver, choices=("auto", "ipopt")),
        method=t.string("method", d.method, choices=("map", "marginal")),
        max_iter=t.integer("max_iter", d.max_iter, 1), tol=t.number("tol", d.tol, positive=True),
        saturation=t.string("saturation", d.saturation, choices=("mask", "polynomial")), estimate=estimate,
        dispersion_prior=t.boolean("dispersion_prior", True), atmosphere_prior=t.boolean("atmosphere_prior", True),
        imu_bias_prior=t.boolean("imu_bias_prior", True), clock_prior=t.boolean("clock_prior", True),
        clock_sigma_s=t.number("clock_sigma_s", d.clock_sigma_s, positive=True),
        clock_offset_guess_s=t.number("clock_offset_guess_s", d.clock_offset_guess_s),
        estimate_downwash=t.boolean("estimate_downwash", False), estimate_clock=t.boolean("estimate_clock", True),
        downwash_sigma_mps=t.number("downwash_sigma_mps", d.downwash_sigma_mps, positive=True),
        max_h_acc_m=t.number("max_h_acc_m", d.max_h_acc_m, positive=True),
        max_v_acc_m=t.number("max_v_acc_m", d.max_v_acc_m, positive=True),
        max_s_acc_mps=t.number("max_s_acc_mps", d.max_s_acc_mps, positive=True),
        min_num_sv=t.integer("min_num_sv", d.min_num_sv, 0), disturbance=parse_disturbance(t),
        impact_ground_sigma_m=t.number("impact_ground_sigma_m", positive=True),
        impact_ground_alt_msl_m=t.number("impact_ground_alt_msl_m"))
    if cfg.impact_ground_alt_msl_m is not None and cfg.impact_ground_sigma_m is None:
        raise t.error("impact_ground_alt_msl_m", "give impact_ground_sigma_m with it (how well that altitude is "
                      "known, m): without it the impact is not a measurement")
    t.reject_unknown()
    return cfg
