"""``problem.toml`` and the vehicle and aero TOML files it includes, parsed once into frozen
dataclasses and validated. Every error is an :class:`InputError` naming the file and the field.

Layout of a problem folder (see ``problems/ees-drop-1/problem.toml`` for a commented example)::

    [problem]     name, description, vehicle = "vehicle.toml", aero = "aero.toml"
    [site]        lat_deg, lon_deg, ground_alt_msl_m
    [atmosphere]  sounding, launch, wind_3sigma_mps, density_3sigma
    [dynamics]    gravity, earth_rotation
    [release]     time_utc, h_agl_m, vel_ned_mps, euler_deg, rates_dps, pos_ne_m
    [sensors.imu] file, columns, units, limits, noise and bias sigmas, clock
    [sensors.gps] file, rate_hz, accuracy levels of the synthetic receiver
    [truth]       what the simulator uses to make synthetic data (dispersions, biases, seed)
    [simulation]  dt_s, substeps, t_max_s, pre_release_s, post_impact_s
    [estimation]  fit window, mesh, Hessian, linear solver, priors, GPS quality rules
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from casrecon.io.errors import InputError
from casrecon.io.imu import ImuCsvSpec
from casrecon.io.toml_fields import Fields, load_toml
from casrecon.physics.aero import (
    DISPERSION_NAMES,
    AeroDatabase,
    AnalyticCoefficients,
    DispersionSizes,
    SpinVanes,
    TableCoefficients,
)
from casrecon.physics.disturbance import DisturbanceModel
from casrecon.physics.dynamics import DynamicsOptions, Site
from casrecon.physics.vehicle import Vehicle

IDENTITY = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))


@dataclass(frozen=True)
class AtmosphereConfig:
    """Balloon sounding file and its stated uncertainty (3-sigma, as the EES paper gives it)."""

    sounding: Path
    launch: int = 0
    wind_3sigma_mps: float = 1.0
    density_3sigma: float = 0.01


@dataclass(frozen=True)
class ReleaseConfig:
    """Initial conditions at release (EES paper Table 3 style); SI except where named.

    ``time_utc`` is the UTC instant of release; ``pos_ne_m`` the north/east offset of the centre of
    mass from the site reference point, m.
    """

    time_utc: dt.datetime
    h_agl_m: float
    vel_ned_mps: tuple[float, float, float]
    euler_deg: tuple[float, float, float]
    rates_dps: tuple[float, float, float]
    pos_ne_m: tuple[float, float] = (0.0, 0.0)


@dataclass(frozen=True)
class ImuConfig:
    """IMU file layout, noise model and clock.

    ``clock_utc_at_zero`` is the UTC instant of IMU time 0 as recorded; the true relation is
    ``utc = clock_utc_at_zero + t_imu + clock_offset`` with ``clock_offset`` estimated (truth in
    ``[truth]``). Noise and bias sigmas are 1-sigma, SI units.
    """

    file: Path | None
    spec: ImuCsvSpec
    rate_hz: float
    accel_noise_mps2: float
    gyro_noise_radps: float
    accel_bias_sigma_mps2: float
    gyro_bias_sigma_radps: float
    clock_utc_at_zero: dt.datetime


@dataclass(frozen=True)
class GpsConfig:
    """GPS (FlySight) file and the synthetic receiver's accuracy levels (1-sigma)."""

    file: Path | None
    rate_hz: float = 5.0
    h_acc_m: float = 1.5
    v_acc_m: float = 2.5
    s_acc_mps: float = 0.25


@dataclass(frozen=True)
class TruthConfig:
    """True values used to simulate synthetic data. Dispersions are normalised (3-sigma = 1)."""

    seed: int
    dispersions: dict[str, float]
    wind_bias_mps: tuple[float, float]
    density_factor: float
    accel_bias_mps2: tuple[float, float, float]
    gyro_bias_radps: tuple[float, float, float]
    clock_offset_s: float
    downwash_mps: float = 0.0
    disturbance: DisturbanceModel | None = None


@dataclass(frozen=True)
class SimulationConfig:
    """Integrator settings and how much data to make before release and after impact."""

    dt_s: float = 0.002
    substeps: int = 1
    t_max_s: float = 300.0
    pre_release_s: float = 2.0
    post_impact_s: float = 2.0


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
    interval_s : float
        Target collocation interval; the mesh takes the nearest whole number of IMU samples (at
        least 4). 25 ms keeps the Hermite-Simpson discretisation error of a 500 Hz drop well below
        the reported sigmas (at 50 ms a noise-free fit of ees-drop-3 is off by 4.4 sigma along its
        best-determined CA/Cmn combination; at 24 ms by 0.23 sigma).
    samples_per_interval : int, optional
        IMU samples per collocation interval; overrides ``interval_s`` when given.
    hessian : {"auto", "gauss-newton", "exact"}
        Hessian given to Ipopt (the covariance always uses J^T J). "auto": Gauss-Newton for the
        strong-constraint fit, exact with disturbance states, where Gauss-Newton was measured to
        converge only linearly (200 iterations without converging on a 24 s window of ees-drop-3
        with gust states; exact: 27).
    linear_solver : {"mumps", "spral"}
        Ipopt's linear solver.
    max_iter : int
        Ipopt iteration limit.
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
        Estimate the rotor-downwash magnitude (m/s, the hypothesis of DESIGN / the EES paper),
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
    """

    start_after_release_s: float = 3.5
    end_before_impact_s: float = 0.05
    release_imu_s: float | None = None
    impact_imu_s: float | None = None
    interval_s: float = 0.025
    samples_per_interval: int | None = None
    hessian: str = "auto"
    linear_solver: str = "mumps"
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

    def resolved_hessian(self) -> str:
        """The Hessian "auto" stands for with these settings."""
        if self.hessian != "auto":
            return self.hessian
        return "gauss-newton" if self.disturbance is None else "exact"

    def mesh_samples(self, imu_rate_hz: float) -> int:
        """IMU samples per collocation interval at an IMU rate of ``imu_rate_hz`` (Hz)."""
        if self.samples_per_interval is not None:
            return self.samples_per_interval
        return max(4, int(np.floor(self.interval_s * imu_rate_hz + 0.5)))


@dataclass(frozen=True)
class ProblemConfig:
    """Everything in one problem folder, validated."""

    path: Path
    name: str
    description: str
    vehicle: Vehicle
    aero: AeroDatabase
    site: Site
    atmosphere: AtmosphereConfig
    dynamics: DynamicsOptions
    release: ReleaseConfig
    imu: ImuConfig
    gps: GpsConfig
    truth: TruthConfig | None
    simulation: SimulationConfig
    estimation: EstimationConfig = EstimationConfig()
    sources: dict[str, str] = field(default_factory=dict)

    @property
    def folder(self) -> Path:
        return self.path.parent


def load_problem(path: str | Path) -> ProblemConfig:
    """Parse and validate ``problem.toml`` (a file, or a folder containing one)."""
    path = Path(path)
    if path.is_dir():
        path = path / "problem.toml"
    f = load_toml(path)
    head = f.table("problem", required=True)
    if head.string("kind", "six-dof", choices=("six-dof", "point-mass")) != "six-dof":
        raise head.error("kind", "this is a point-mass problem: load it with casrecon.io.pointmass_problem")
    vehicle_path = head.path_of("vehicle", required=True)
    aero_path = head.path_of("aero", required=True)
    sensors = f.table("sensors", required=True)
    cfg = ProblemConfig(
        path=path.resolve(), name=head.string("name", required=True),
        description=head.string("description", default=""),
        vehicle=load_vehicle(vehicle_path), aero=load_aero(aero_path),
        site=_site(f.table("site", required=True)),
        atmosphere=_atmosphere(f.table("atmosphere", required=True)),
        dynamics=_dynamics(f.table("dynamics") or Fields({}, path, "dynamics.")),
        release=_release(f.table("release", required=True)),
        imu=_imu(sensors.table("imu", required=True)), gps=_gps(sensors.table("gps", required=True)),
        truth=_truth(f.table("truth")),
        simulation=_simulation(f.table("simulation") or Fields({}, path, "simulation.")),
        estimation=_estimation(f.table("estimation") or Fields({}, path, "estimation.")),
        sources={"problem": str(path.resolve()), "vehicle": str(vehicle_path), "aero": str(aero_path)},
    )
    for t in (head, sensors, f):
        t.reject_unknown()
    return cfg


def _utc(t: Fields, key: str) -> dt.datetime:
    value = t.raw(key, required=True)
    if isinstance(value, dt.datetime):
        parsed = value
    elif isinstance(value, str):
        try:
            parsed = dt.datetime.fromisoformat(value.replace("Z", "+00:00"))
        except ValueError:
            raise t.error(key, f"expected an ISO-8601 UTC time like 2023-10-03T16:05:12.3Z, got {value!r}") from None
    else:
        raise t.error(key, f"expected an ISO-8601 UTC time, got {value!r}")
    if parsed.tzinfo is None:
        raise t.error(key, "the time must say its zone (end it with Z for UTC)")
    return parsed.astimezone(dt.UTC)


def _site(t: Fields) -> Site:
    site = Site(lat_deg=t.number("lat_deg", required=True), lon_deg=t.number("lon_deg", required=True),
                ground_alt_msl_m=t.number("ground_alt_msl_m", required=True))
    if abs(site.lat_deg) > 90:
        raise t.error("lat_deg", f"expected a latitude within +-90 deg, got {site.lat_deg}")
    t.reject_unknown()
    return site


def _atmosphere(t: Fields) -> AtmosphereConfig:
    cfg = AtmosphereConfig(sounding=t.path_of("sounding", required=True), launch=t.integer("launch", 0, 0),
                           wind_3sigma_mps=t.number("wind_3sigma_mps", 1.0, positive=True),
                           density_3sigma=t.number("density_3sigma", 0.01, positive=True))
    t.reject_unknown()
    return cfg


def _dynamics(t: Fields) -> DynamicsOptions:
    opts = DynamicsOptions(gravity=t.string("gravity", "wgs84", choices=("wgs84", "constant", "off")),
                           earth_rotation=t.boolean("earth_rotation", True),
                           aerodynamics=t.boolean("aerodynamics", True),
                           downwash_length_m=t.number("downwash_length_m", 30.0, positive=True))
    t.reject_unknown()
    return opts


def _release(t: Fields) -> ReleaseConfig:
    cfg = ReleaseConfig(time_utc=_utc(t, "time_utc"), h_agl_m=t.number("h_agl_m", required=True, positive=True),
                        vel_ned_mps=t.vector("vel_ned_mps", 3, required=True),
                        euler_deg=t.vector("euler_deg", 3, required=True),
                        rates_dps=t.vector("rates_dps", 3, required=True),
                        pos_ne_m=t.vector("pos_ne_m", 2, (0.0, 0.0)))
    t.reject_unknown()
    return cfg


def _limits(t: Fields, key: str):
    value = t.raw(key)
    if value is None:
        return None
    try:
        pairs = tuple((float(lo), float(hi)) for lo, hi in value)
    except (TypeError, ValueError):
        raise t.error(key, f"expected three [low, high] pairs, got {value!r}") from None
    if len(pairs) != 3 or any(not lo < hi for lo, hi in pairs):
        raise t.error(key, f"expected three [low, high] pairs with low < high, got {value!r}")
    return pairs


def _imu(t: Fields) -> ImuConfig:
    cols = t.table("columns") or Fields({}, t.path, t.name("columns."))
    try:
        spec = ImuCsvSpec(
            time_column=cols.string("time", "time_s"),
            accel_columns=tuple(cols.raw("accel", ["ax", "ay", "az"])),
            gyro_columns=tuple(cols.raw("gyro", ["wx", "wy", "wz"])),
            time_unit=t.string("time_unit", "s"), accel_unit=t.string("accel_unit", "m/s^2"),
            gyro_unit=t.string("gyro_unit", "rad/s"),
            accel_limits=_limits(t, "accel_limits"), gyro_limits=_limits(t, "gyro_limits"),
            axes=t.raw("axes", None))
    except (ValueError, TypeError) as err:
        raise InputError(t.path, str(err), field=t.name("columns/units/limits")) from None
    cols.reject_unknown()
    clock = t.table("clock", required=True)
    cfg = ImuConfig(
        file=t.path_of("file", must_exist=False), spec=spec, rate_hz=t.number("rate_hz", 500.0, positive=True),
        accel_noise_mps2=t.number("accel_noise_mps2", required=True, positive=True),
        gyro_noise_radps=np.radians(t.number("gyro_noise_dps", required=True, positive=True)),
        accel_bias_sigma_mps2=t.number("accel_bias_sigma_mps2", required=True, positive=True),
        gyro_bias_sigma_radps=np.radians(t.number("gyro_bias_sigma_dps", required=True, positive=True)),
        clock_utc_at_zero=_utc(clock, "utc_at_zero"))
    clock.reject_unknown()
    t.reject_unknown()
    return cfg


def _gps(t: Fields) -> GpsConfig:
    cfg = GpsConfig(file=t.path_of("file", must_exist=False), rate_hz=t.number("rate_hz", 5.0, positive=True),
                    h_acc_m=t.number("h_acc_m", 1.5, positive=True), v_acc_m=t.number("v_acc_m", 2.5, positive=True),
                    s_acc_mps=t.number("s_acc_mps", 0.25, positive=True))
    t.reject_unknown()
    return cfg


def _truth(t: Fields | None) -> TruthConfig | None:
    if t is None:
        return None
    disp = t.table("dispersions") or Fields({}, t.path, t.name("dispersions."))
    values = {n: disp.number(n, 0.0) for n in DISPERSION_NAMES}
    disp.reject_unknown()
    cfg = TruthConfig(
        seed=t.integer("seed", 0, 0), dispersions=values,
        wind_bias_mps=t.vector("wind_bias_mps", 2, (0.0, 0.0)), density_factor=t.number("density_factor", 0.0),
        accel_bias_mps2=t.vector("accel_bias_mps2", 3, (0.0, 0.0, 0.0)),
        gyro_bias_radps=tuple(np.radians(t.vector("gyro_bias_dps", 3, (0.0, 0.0, 0.0)))),
        clock_offset_s=t.number("clock_offset_s", 0.0), downwash_mps=t.number("downwash_mps", 0.0),
        disturbance=_disturbance(t))
    t.reject_unknown()
    return cfg


#: Keys of the Gauss-Markov disturbance settings, in [truth] (what is simulated) and [estimation]
#: (the prior of the estimated node values); see casrecon.physics.disturbance.
DISTURBANCE_KEYS = ("gust_sigma_mps", "gust_time_s", "force_error_sigma_n", "moment_error_sigma_nm",
                    "model_error_time_s")


def _disturbance(t: Fields) -> DisturbanceModel | None:
    """Gusts (NED, m/s, correlation time gust_time_s) and model-error force (body, N) and moment
    (body, N m) with correlation time model_error_time_s; None when every sigma is zero."""
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


def _simulation(t: Fields) -> SimulationConfig:
    cfg = SimulationConfig(dt_s=t.number("dt_s", 0.002, positive=True), substeps=t.integer("substeps", 1, 1),
                           t_max_s=t.number("t_max_s", 300.0, positive=True),
                           pre_release_s=t.number("pre_release_s", 2.0, minimum=0.0),
                           post_impact_s=t.number("post_impact_s", 2.0, minimum=0.0))
    t.reject_unknown()
    return cfg


def _samples_per_interval(t: Fields) -> int | None:
    if t.raw("samples_per_interval") is None:
        return None
    if t.raw("interval_s") is not None:
        raise t.error("samples_per_interval", "give interval_s or samples_per_interval, not both")
    return t.integer("samples_per_interval", 0, 4)


def _estimation(t: Fields) -> EstimationConfig:
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
        interval_s=t.number("interval_s", d.interval_s, positive=True),
        samples_per_interval=_samples_per_interval(t),
        hessian=t.string("hessian", d.hessian, choices=("auto", "gauss-newton", "exact")),
        linear_solver=t.string("linear_solver", d.linear_solver, choices=("mumps", "spral")),
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
        min_num_sv=t.integer("min_num_sv", d.min_num_sv, 0), disturbance=_disturbance(t))
    t.reject_unknown()
    return cfg


def load_vehicle(path: str | Path) -> Vehicle:
    """Parse a vehicle TOML (mass properties in native axes, mounts, ``native_to_body``)."""
    f = load_toml(path)
    inertia = f.table("inertia_kgm2", required=True)
    moments = {k: inertia.number(k, required=k in ("Ixx", "Iyy", "Izz"), default=0.0)
               for k in ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")}
    inertia.reject_unknown()
    imu = f.table("imu") or Fields({}, f.path, "imu.")
    gps = f.table("gps") or Fields({}, f.path, "gps.")
    d = f.number("ref_length_m", required=True, positive=True)
    kw = dict(name=f.string("name", required=True), mass_kg=f.number("mass_kg", required=True, positive=True),
              ref_length_m=d, ref_area_m2=f.number("ref_area_m2", np.pi * d * d / 4, positive=True))
    try:
        vehicle = Vehicle.from_native(
            f.matrix("native_to_body", IDENTITY), inertia_kgm2=Vehicle.inertia_from_moments(**{
                k.lower(): v for k, v in moments.items()}),
            cm_m=f.vector("cm_m", 3, required=True), mrp_m=f.vector("mrp_m", 3, required=True),
            imu_position_m=imu.vector("position_m", 3, (0.0, 0.0, 0.0)),
            imu_to_native=imu.matrix("to_native", IDENTITY),
            gps_position_m=gps.vector("position_m", 3, (0.0, 0.0, 0.0)), **kw)
    except ValueError as err:
        raise InputError(path, str(err)) from None
    for t in (imu, gps, f):
        t.reject_unknown()
    return vehicle


def load_aero(path: str | Path) -> AeroDatabase:
    """Parse an aero database TOML: ``model = "analytic"`` with ``[coefficients]``, or
    ``model = "table"`` with ``table = "file.csv"`` (columns mach, alpha_t_deg, CA, CN, Cm, Cmq);
    ``[dispersion_sizes]`` (3-sigma sizes U) and optional ``[vanes]``."""
    f = load_toml(path)
    model = f.string("model", required=True, choices=("analytic", "table"))
    sources = (str(Path(path).resolve()),)
    if model == "analytic":
        coeffs = _analytic(f.table("coefficients", required=True))
    else:
        table_path = f.path_of("table", required=True)
        coeffs = _table(table_path, f.number("Clp", 0.0), f.number("Cl0", 0.0))
        sources += (str(table_path),)
    sizes_t = f.table("dispersion_sizes", required=True)
    sizes = DispersionSizes(**{n: sizes_t.number(n, 0.0, minimum=0.0) for n in DISPERSION_NAMES})
    sizes_t.reject_unknown()
    vanes_t = f.table("vanes")
    vanes = None
    if vanes_t is not None:
        vanes = SpinVanes(count=vanes_t.integer("count", 0, 1),
                          radius_m=vanes_t.number("radius_m", required=True, positive=True),
                          area_m2=vanes_t.number("area_m2", required=True, positive=True),
                          incidence_deg=vanes_t.number("incidence_deg", required=True),
                          lift_slope_per_rad=vanes_t.number("lift_slope_per_rad", 2 * np.pi / 5, positive=True))
        vanes_t.reject_unknown()
    db = AeroDatabase(name=f.string("name", required=True), coefficients=coeffs, sizes=sizes, vanes=vanes,
                      description=f.string("description", ""), source_files=sources)
    f.reject_unknown()
    return db


def _analytic(t: Fields) -> AnalyticCoefficients:
    names = ("CA0", "CA2", "CNa", "Cma", "Cmq0", "Cmq2", "Clp", "Cl0")
    c = AnalyticCoefficients(**{n: t.number(n, required=(n == "CA0"), default=0.0) for n in names})
    t.reject_unknown()
    return c


TABLE_COLUMNS = ("mach", "alpha_t_deg", "CA", "CN", "Cm", "Cmq")


def _table(path: Path, clp: float, cl0: float) -> TableCoefficients:
    """Read a (Mach, alpha_T) table CSV laid out as a full grid, one row per point."""
    try:
        with open(path, encoding="utf-8") as fh:
            header = fh.readline().strip().split(",")
        data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2)
    except (OSError, ValueError, UnicodeDecodeError) as err:
        raise InputError(path, f"cannot read aero table: {err}") from None
    if tuple(header) != TABLE_COLUMNS:
        raise InputError(path, f"header must be {','.join(TABLE_COLUMNS)}, got {','.join(header)}", line=1)
    if not np.all(np.isfinite(data)):
        raise InputError(path, "aero table holds a non-finite value")
    mach, alpha = np.unique(data[:, 0]), np.unique(data[:, 1])
    if data.shape[0] != mach.size * alpha.size or min(mach.size, alpha.size) < 4:
        raise InputError(path, "aero table must be a full grid of at least 4 Mach x 4 alpha_T points")
    order = np.lexsort((data[:, 1], data[:, 0]))
    grid = data[order].reshape(mach.size, alpha.size, len(TABLE_COLUMNS))
    cols = {name: tuple(map(tuple, grid[:, :, i])) for i, name in enumerate(TABLE_COLUMNS) if i >= 2}
    return TableCoefficients(mach=tuple(mach), alpha_t_deg=tuple(alpha), Clp=clp, Cl0=cl0, **cols)
