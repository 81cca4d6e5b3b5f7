"""``problem.toml`` of an IMU-driven (kinematic) reconstruction, ``[problem] kind = "kinematic"``:
any rigid body with an IMU and a GNSS receiver (and optionally a barometer), no vehicle or aero
file. Parsed once into frozen dataclasses and validated like the other problems (same field
helpers, located errors).

    [problem]     kind = "kinematic", name, description
    [site]        lat_deg, lon_deg, ground_alt_msl_m
    [atmosphere]  sounding = "standard" (ICAO) or a sounding file (the barometer's pressure-altitude)
    [dynamics]    gravity, earth_rotation
    [imu]         file (FlySight 2 SENSOR.CSV or an IMU CSV), columns/units/axes of a CSV, saturation
                  limits (accel_limits, gyro_limits: a CSV's units; g and deg/s for a SENSOR.CSV),
                  utc_at_zero_s, noise and bias sigmas, scale-factor sigmas, gyro_senses_earth_rate
    [gps]         file (FlySight, NMEA 0183 or GNSS CSV), lever_arm_m, quality limits, error model,
                  velocity_sigma_mps, date
    [baro]        file, noise_pa, bias_sigma_pa, height_scale_sigma (optional table)
    [segment]     start_s, end_s (optional; on the common clock, UTC seconds or the flight computer's)
    [estimation]  max_node_spacing_s, clock_sigma_s, linear_solver, max_iter, tol

Time base: every file is put on one clock, seconds since 1970 UTC where the files are stamped in UTC
(FlySight tracks and SENSOR.CSV, NMEA), or the flight computer's own seconds where they share it
(``utc_at_zero_s = 0``, the default: the IMU CSV's time column plus ``[imu] utc_at_zero_s``, a GNSS
CSV's ``ts`` plus the same, a barometer CSV with an IMU-clock ``ts``/``time_s`` column likewise).
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io.baro import HEIGHT_SCALE_SIGMA, BaroConfig
from casrecon.io.errors import InputError
from casrecon.io.gps_rules import GpsQuality, gps_date, gps_error_model, velocity_sigma
from casrecon.io.imu import ImuCsvSpec
from casrecon.io.problem import parse_dynamics, parse_limits, parse_site
from casrecon.io.problem_file import problem_document
from casrecon.io.sample_sensors import parse_sample_sensors
from casrecon.io.toml_fields import Fields, TomlDocument
from casrecon.physics.dynamics import DynamicsOptions, Site
from casrecon.physics.sensor_errors import GpsErrorModel


@dataclass(frozen=True)
class KinematicImu:
    """The IMU of a kinematic problem (SI units).

    Attributes
    ----------
    file : Path
        FlySight 2 SENSOR.CSV (its IMU rows, on UTC) or an IMU CSV laid out as ``spec``.
    spec : ImuCsvSpec or None
        None for a SENSOR.CSV.
    utc_at_zero_s : float
        Clock value (s) of the CSV's time 0 (0: the file's own clock).
    gyro_noise_radps, accel_noise_mps2 : float
        White noise 1-sigma of one sample.
    gyro_bias_sigma_radps, accel_bias_sigma_mps2 : float
        Prior 1-sigma of the constant biases.
    gyro_scale_sigma, accel_scale_sigma : float
        Prior 1-sigma of the scale-factor errors (fraction; 0: not estimated).
    gyro_misalignment_sigma, accel_misalignment_sigma : float
        Prior 1-sigma of each axis's sensitivity to the other two (rad; 0: not estimated).
    gyro_senses_earth_rate : bool
        A real gyro measures the rate against inertial space (true, default).
    accel_limits, gyro_limits : tuple of 3 (low, high) or None
        Saturation limits of the x, y, z axes as the file writes them: in ``spec``'s ``accel_unit`` and
        ``gyro_unit`` for an IMU CSV, in g and deg/s for a SENSOR.CSV; a sample at or beyond one is
        masked. None: no saturation flagging.
    """

    file: Path
    spec: ImuCsvSpec | None
    utc_at_zero_s: float
    gyro_noise_radps: float
    accel_noise_mps2: float
    gyro_bias_sigma_radps: float
    accel_bias_sigma_mps2: float
    gyro_scale_sigma: float
    accel_scale_sigma: float
    gyro_misalignment_sigma: float = 0.0
    accel_misalignment_sigma: float = 0.0
    gyro_senses_earth_rate: bool = True
    accel_limits: tuple[tuple[float, float], ...] | None = None
    gyro_limits: tuple[tuple[float, float], ...] | None = None


@dataclass(frozen=True)
class KinematicConfig:
    """A validated kinematic problem. Times (``start_s``, ``end_s``) are on the common clock of the
    module docstring; ``gps_lever_m`` is the antenna minus the IMU position in IMU axes, m."""

    path: Path
    name: str
    description: str
    site: Site
    sounding: Path | None
    dynamics: DynamicsOptions
    imu: KinematicImu
    gps_file: Path
    gps_lever_m: tuple[float, float, float]
    quality: GpsQuality
    gps_errors: GpsErrorModel
    gps_date: dt.date | None
    velocity_sigma_mps: tuple[float, float, float] | None
    baro_file: Path | None
    baro_noise_pa: float
    baro_bias_sigma_pa: float
    baro_height_scale_sigma: float
    start_s: float | None
    end_s: float | None
    max_node_spacing_s: float
    clock_sigma_s: float
    linear_solver: str
    max_iter: int
    tol: float
    humidity: bool = True  # the sounding's dewpoints in its density (false: dry air)
    sample_sensors: tuple[tuple[str, object], ...] = ()  # registered [X] tables: io.sample_sensors


def _imu_spec(t: Fields, accel_limits, gyro_limits) -> ImuCsvSpec | None:
    cols = t.table("columns")
    if cols is None and not t.has("gyro_unit") and not t.has("accel_unit"):
        return None
    cols = cols or Fields({}, t.path, t.name("columns."))
    try:
        spec = ImuCsvSpec(time_column=cols.string("time", "time_s"),
                          accel_columns=tuple(cols.raw("accel", ["ax", "ay", "az"])),
                          gyro_columns=tuple(cols.raw("gyro", ["wx", "wy", "wz"])),
                          time_unit=t.string("time_unit", "s"), accel_unit=t.string("accel_unit", "m/s^2"),
                          gyro_unit=t.string("gyro_unit", "rad/s"), axes=t.raw("axes", None),
                          accel_limits=accel_limits, gyro_limits=gyro_limits)
    except (ValueError, TypeError) as err:
        raise InputError(t.path, str(err), field=t.name("columns/units/axes")) from None
    cols.reject_unknown()
    return spec


def _imu(t: Fields) -> KinematicImu:
    limits = {key: parse_limits(t, key) for key in ("accel_limits", "gyro_limits")}
    return KinematicImu(
        file=t.path_of("file", required=True), spec=_imu_spec(t, **limits),
        utc_at_zero_s=t.number("utc_at_zero_s", 0.0),
        gyro_noise_radps=float(np.radians(t.number("gyro_noise_dps", required=True, positive=True))),
        accel_noise_mps2=t.number("accel_noise_mps2", required=True, positive=True),
        gyro_bias_sigma_radps=float(np.radians(t.number("gyro_bias_sigma_dps", 1.0, positive=True))),
        accel_bias_sigma_mps2=t.number("accel_bias_sigma_mps2", 0.2, positive=True),
        gyro_scale_sigma=t.number("gyro_scale_sigma", 0.02, minimum=0.0),
        accel_scale_sigma=t.number("accel_scale_sigma", 0.02, minimum=0.0),
        gyro_misalignment_sigma=t.number("gyro_misalignment_sigma", 0.005, minimum=0.0),
        accel_misalignment_sigma=t.number("accel_misalignment_sigma", 0.005, minimum=0.0),
        gyro_senses_earth_rate=t.boolean("gyro_senses_earth_rate", True), **limits)


def load_kinematic(source: str | Path | TomlDocument) -> KinematicConfig:
    """Parse and validate a kinematic ``problem.toml`` (file or folder, or its parsed document)."""
    document = problem_document(source)
    path, f = document.path, document.fields()
    head = f.table("problem", required=True)
    if head.string("kind", "six-dof", choices=("six-dof", "point-mass", "kinematic")) != "kinematic":
        raise head.error("kind", 'expected kind = "kinematic" for a kinematic problem')
    empty = {k: Fields({}, path, f"{k}.") for k in ("segment", "estimation", "dynamics", "atmosphere")}
    atm = f.table("atmosphere") or empty["atmosphere"]
    imu, gps = f.table("imu", required=True), f.table("gps", required=True)
    baro, seg = f.table("baro"), f.table("segment") or empty["segment"]
    est = f.table("estimation") or empty["estimation"]
    sounding = atm.string("sounding", "standard")
    lever = gps.vector("lever_arm_m", 3) or (0.0, 0.0, 0.0)
    start, end = (seg.number(k, None) if seg.has(k) else None for k in ("start_s", "end_s"))
    if start is not None and end is not None and end <= start:
        raise seg.error("end_s", f"must be after start_s ({start})")
    cfg = KinematicConfig(
        path=path.resolve(), name=head.string("name", required=True), description=head.string("description", ""),
        site=parse_site(f.table("site", required=True)),
        sounding=None if sounding == "standard" else atm.path_of("sounding"), humidity=atm.boolean("humidity", True),
        dynamics=parse_dynamics(f.table("dynamics") or empty["dynamics"]), imu=_imu(imu),
        gps_file=gps.path_of("file", required=True), gps_lever_m=tuple(float(x) for x in lever),
        quality=GpsQuality(gps.number("max_h_acc_m", 10.0, positive=True),
                           gps.number("max_v_acc_m", 10.0, positive=True),
                           gps.number("max_s_acc_mps", 1.0, positive=True), gps.integer("min_num_sv", 6, 0)),
        gps_errors=gps_error_model(gps), gps_date=gps_date(gps), velocity_sigma_mps=velocity_sigma(gps),
        baro_file=baro.path_of("file", required=True) if baro is not None else None,
        baro_noise_pa=baro.number("noise_pa", BaroConfig.noise_pa, positive=True) if baro else BaroConfig.noise_pa,
        baro_bias_sigma_pa=(baro.number("bias_sigma_pa", BaroConfig.bias_sigma_pa, positive=True) if baro
                            else BaroConfig.bias_sigma_pa),
        baro_height_scale_sigma=(baro.number("height_scale_sigma", HEIGHT_SCALE_SIGMA, positive=True) if baro
                                 else HEIGHT_SCALE_SIGMA),
        start_s=start, end_s=end, max_node_spacing_s=est.number("max_node_spacing_s", 0.5, positive=True),
        clock_sigma_s=est.number("clock_sigma_s", 0.0, minimum=0.0),
        linear_solver=est.string("linear_solver", "mumps", choices=("mumps", "spral")),
        max_iter=est.integer("max_iter", 100, 1), tol=est.number("tol", 1e-8, positive=True),
        sample_sensors=parse_sample_sensors(f))
    for t in (head, atm, imu, gps, seg, est, f, *([baro] if baro is not None else [])):
        t.reject_unknown()
    return cfg
