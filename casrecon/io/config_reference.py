"""Reference of every key of the TOML files casrecon reads, rendered as ``docs/problem-toml.md``.

Regenerate the page with ``python -m casrecon.io.config_reference > docs/problem-toml.md``;
``tests/unit/test_config_reference.py`` fails when the page differs from :func:`render_markdown`,
when a key the parsers read is missing here, or when a parser's default differs from the one
listed. The record types and the numpydoc parsing are in :mod:`casrecon.io.config_records`.

Where the values come from (one source of truth for each):

- **default**: when a key lands unchanged in a dataclass field (:attr:`Key.source`), the default is
  read from that field's default (``EstimationConfig.interval_s`` and so on); otherwise (keys the
  parser converts, like ``gyro_noise_dps``, or whose default lives only in the parser) it is
  written in the record here;
- **meaning**: for keys whose dataclass documents its fields in a numpydoc ``Parameters`` or
  ``Attributes`` section (:class:`~casrecon.io.estimation_config.EstimationConfig`,
  :class:`~casrecon.physics.dynamics.DynamicsOptions`, :class:`~casrecon.io.imu.ImuCsvSpec`), the
  meaning is that docstring entry, parsed at render time; the other meanings are written here.
"""

from __future__ import annotations

import math

from casrecon.io.atmosphere_config import AtmosphereConfig
from casrecon.io.baro import BaroConfig
from casrecon.io.config_records import FROM_FIELD, REQUIRED, FileKind, Key, Table
from casrecon.io.config_reference_gnss import KINEMATIC, POINT_MASS
from casrecon.io.config_reference_shared import DYNAMICS_TABLE, SITE_TABLE, gps_error_keys, key
from casrecon.io.estimation_config import EstimationConfig
from casrecon.io.imu import ImuCsvSpec
from casrecon.io.montecarlo_config import DISPERSION_KEYS, Dispersions, MonteCarloConfig
from casrecon.io.problem import (
    GpsConfig,
    ReleaseConfig,
    SimulationConfig,
    TruthConfig,
)
from casrecon.io.sample_sensors import sample_sensor_tables
from casrecon.io.truth_errors import TruthErrors
from casrecon.physics.aero import DISPERSION_NAMES, AnalyticCoefficients, DispersionSizes, SpinVanes

_DISTURBANCE = (
    ("gust_sigma_mps", "[float; 3]", "m/s", "1-sigma of the gust (wind perturbation) north, east, down; "
     "a first-order Gauss-Markov process added to the sounding's wind", (0.0, 0.0, 0.0)),
    ("gust_time_s", "float", "s", "Correlation time of the gusts", 3.0),
    ("force_error_sigma_n", "[float; 3]", "N", "1-sigma of the model-error force along body x, y, z "
     "(Gauss-Markov)", (0.0, 0.0, 0.0)),
    ("moment_error_sigma_nm", "[float; 3]", "N m", "1-sigma of the model-error moment about the centre of "
     "mass, body x, y, z (Gauss-Markov)", (0.0, 0.0, 0.0)),
    ("model_error_time_s", "float", "s", "Correlation time of the model-error force and moment", 1.0),
)


def _disturbance_keys(where: str) -> tuple[Key, ...]:
    return tuple(key(k, t, u, f"{m} ({where}; all sigmas zero: none)", d) for k, t, u, m, d in _DISTURBANCE)


#: The [truth] keys of the atmosphere-profile and coloured GPS errors (meanings from TruthErrors).
_TRUTH_ERRORS = tuple(
    key(k, t, u, source=TruthErrors, attr=f"truth.errors.{k}") for k, t, u in (
        ("profile_wind_sigma_mps", "float", "m/s"), ("profile_density_sigma", "float", ""),
        ("profile_length_m", "float", "m"), ("gps_position_time_s", "float", "s"),
        ("gps_velocity_time_s", "float", "s"), ("gps_white_fraction", "float", "")))

_ESTIMATION_KEYS = (
    ("start_after_release_s", "float", "s"), ("end_before_impact_s", "float", "s"),
    ("release_imu_s", "float", "s"), ("impact_imu_s", "float", "s"), ("interval_s", "float", "s"),
    ("samples_per_interval", "int", ""), ("hessian", "string", ""), ("information", "string", ""),
    ("linear_solver", "string", ""),
    ("solver", "string", ""), ("method", "string", ""),
    ("max_iter", "int", ""), ("tol", "float", ""), ("saturation", "string", ""),
    ("estimate", "[string]", ""), ("dispersion_prior", "bool", ""), ("atmosphere_prior", "bool", ""),
    ("imu_bias_prior", "bool", ""), ("clock_prior", "bool", ""), ("clock_sigma_s", "float", "s"),
    ("estimate_clock", "bool", ""), ("clock_offset_guess_s", "float", "s"), ("estimate_downwash", "bool", ""),
    ("downwash_sigma_mps", "float", "m/s"), ("max_h_acc_m", "float", "m"), ("max_v_acc_m", "float", "m"),
    ("max_s_acc_mps", "float", "m/s"), ("min_num_sv", "int", ""), ("impact_ground_sigma_m", "float", "m"),
    ("impact_ground_alt_msl_m", "float", "m"),
)

SIX_DOF = FileKind(
    "problem.toml (6-DOF problem)",
    "A problem folder holds `problem.toml`, its data files and (usually by relative path) the vehicle "
    "and aero files. Paths are relative to the file that names them. Read by "
    "`casrecon.io.problem.load_problem`; an unknown key anywhere is an error naming it.",
    (
        Table("problem", (
            key("kind", "string", "", '"six-dof" or "point-mass" (the GPS-only problem below)', "six-dof"),
            key("name", "string", "", "Name used in reports", REQUIRED),
            key("description", "string", "", "One line for reports", ""),
            key("vehicle", "path", "", "Vehicle TOML file (see Vehicle file)", REQUIRED),
            key("aero", "path", "", "Aero database TOML file (see Aero file)", REQUIRED),
        ), required=True),
        SITE_TABLE,
        Table("atmosphere", (
            key("sounding", "path", "", "Balloon sounding: Wyoming TEXT:CSV or TEXT:LIST, IGRA2, or plain CSV "
               "(see docs/design.md, Input files)", REQUIRED, AtmosphereConfig),
            key("launch", "int", "", "Which launch of a multi-launch file (IGRA2), counted from 0",
               source=AtmosphereConfig, attr="atmosphere.launch"),
            key("wind_3sigma_mps", "float", "m/s", "3-sigma of the balloon's wind, the prior of the estimated wind "
               "bias north and east", source=AtmosphereConfig, attr="atmosphere.wind_3sigma_mps"),
            key("density_3sigma", "float", "", "3-sigma of the balloon's density as a fraction, the prior of the "
               "estimated density factor", source=AtmosphereConfig, attr="atmosphere.density_3sigma"),
            key("profile_wind_sigma_mps", "float", "m/s", "1-sigma of the difference between the wind the vehicle "
               "flew through and the sounding's (plus the wind bias), each of north and east: a Gauss-Markov process "
               "in altitude estimated on a grid; 0: none", source=AtmosphereConfig,
               attr="atmosphere.profile_wind_sigma_mps"),
            key("profile_density_sigma", "float", "", "1-sigma of the relative difference between the density flown "
               "through and the sounding's (times 1 + density factor), Gauss-Markov in altitude; 0: none",
               source=AtmosphereConfig, attr="atmosphere.profile_density_sigma"),
            key("profile_length_m", "float", "m", "Correlation length in altitude of the profile errors",
               source=AtmosphereConfig, attr="atmosphere.profile_length_m"),
            key("profile_step_m", "float", "m", "Altitude step of the grid the profile errors are estimated on "
               "(the knots of the cubic B-spline the corrections are), at most profile_length_m",
               source=AtmosphereConfig, attr="atmosphere.profile_step_m"),
            key("profile_sigma_from_data", "bool", "", "Estimate the two profile sigmas and their correlation length "
               "(1/3 to 10 times profile_length_m, and longer, up to 100 times, while the evidence rises) from the "
               "data after the fit (type-II maximum likelihood) and fit again with them where they differ from the "
               "configured ones by more than 25 % (without the profile model when the data show none); per-drop MAP "
               "fits without disturbance states. An estimate at the top of a sigma's search, or correlated over 10 "
               "times profile_length_m or more with a sigma over 1.25 times the configured, is a gross input error (a "
               "sounding of another day or place, a datum, the IMU clock): not fitted again with, the verdict not "
               "trusted",
               source=AtmosphereConfig, attr="atmosphere.profile_sigma_from_data"),
            key("sounding_shift_sigma_m", "float", "m", "1-sigma of the prior on the sounding's altitude shift "
               "(the estimated sounding_shift_m: the air at altitude h is the sounding's, and the profile "
               "corrections', at h - shift); 0: held at zero, the fit then takes its absolute altitude from the "
               "sounding's wind shape (its published altitude bands floored by what the GPS heights say). "
               "Estimated, the shift absorbs air the profile grid cannot place (docs/design/error-models.md)",
               source=AtmosphereConfig, attr="atmosphere.sounding_shift_sigma_m"),
            key("humidity", "bool", "", "Moist-air density from the sounding's dewpoints where it has them (levels "
               "without one take the mixing ratio interpolated in altitude); false: dry air, p / (R_d T), as a "
               "sounding without dewpoints", source=AtmosphereConfig, attr="atmosphere.humidity"),
        ), required=True),
        DYNAMICS_TABLE,
        Table("release", (
            key("time_utc", "datetime or string", "UTC", "Release instant, ISO-8601 with its zone "
               "(2023-10-03T15:32:10.25Z)", REQUIRED),
            key("h_agl_m", "float", "m", "Release height of the centre of mass above ground (AGL)", REQUIRED),
            key("vel_ned_mps", "[float; 3]", "m/s", "Release velocity north, east, down", REQUIRED),
            key("euler_deg", "[float; 3]", "deg", "Release attitude: roll, pitch, yaw (ZYX Euler angles, body to "
               "NED)", REQUIRED),
            key("rates_dps", "[float; 3]", "deg/s", "Release body angular rate p, q, r", REQUIRED),
            key("pos_ne_m", "[float; 2]", "m", "North, east offset of the centre of mass from the site origin",
               source=ReleaseConfig, attr="release.pos_ne_m"),
        ), note="The release state is where the simulator starts. The fit finds release on the IMU clock "
                "(or takes [estimation] release_imu_s); of [release] it uses only h_agl_m, the reference "
                "altitude of the rotor-downwash hypothesis.", required=True),
        Table("sensors.imu", (
            key("file", "path", "", "IMU CSV (need not exist for `casrecon simulate --data`, which writes it)",
               None, attr="imu.file"),
            key("rate_hz", "float", "Hz", "Nominal IMU sample rate", 500.0, attr="imu.rate_hz"),
            key("time_unit", "string", "", source=ImuCsvSpec, attr="imu.spec.time_unit"),
            key("accel_unit", "string", "", source=ImuCsvSpec, attr="imu.spec.accel_unit"),
            key("gyro_unit", "string", "", source=ImuCsvSpec, attr="imu.spec.gyro_unit"),
            key("accel_limits", "[[float; 2]; 3]", "accel_unit", "Saturation limits [low, high] of the x, y, z "
               "accelerometer columns, in the file's unit; a sample at or beyond one is masked; absent: no "
               "saturation flagging", source=ImuCsvSpec, attr="imu.spec.accel_limits"),
            key("gyro_limits", "[[float; 2]; 3]", "gyro_unit", "Saturation limits [low, high] of the x, y, z gyro "
               "columns, in the file's unit (see accel_limits)", source=ImuCsvSpec, attr="imu.spec.gyro_limits"),
            key("axes", "string or [[float; 3]; 3]", "", source=ImuCsvSpec, attr="imu.spec.axes"),
            key("accel_noise_mps2", "float", "m/s^2", "Accelerometer white noise per sample, 1-sigma", REQUIRED),
            key("gyro_noise_dps", "float", "deg/s", "Gyro white noise per sample, 1-sigma", REQUIRED),
            key("accel_bias_sigma_mps2", "float", "m/s^2", "Prior 1-sigma of each constant accelerometer bias",
               REQUIRED),
            key("gyro_bias_sigma_dps", "float", "deg/s", "Prior 1-sigma of each constant gyro bias", REQUIRED),
        ), required=True),
        Table("sensors.imu.columns", (
            key("time", "string", "", "Name of the time column", source=ImuCsvSpec, field="time_column",
               attr="imu.spec.time_column"),
            key("accel", "[string; 3]", "", "Names of the x, y, z accelerometer columns (file axes)", source=ImuCsvSpec,
               field="accel_columns", attr="imu.spec.accel_columns"),
            key("gyro", "[string; 3]", "", "Names of the x, y, z gyro columns (file axes)", source=ImuCsvSpec,
               field="gyro_columns", attr="imu.spec.gyro_columns"),
        )),
        Table("sensors.imu.clock", (
            key("utc_at_zero", "datetime or string", "UTC", "UTC of IMU time 0 as recorded; the true relation is "
               "utc = utc_at_zero + t_imu + clock_offset, clock_offset estimated", REQUIRED),
        ), required=True),
        Table("sensors.gps", (
            key("file", "path", "", "FlySight 1 CSV or FlySight 2 TRACK.CSV (need not exist for `casrecon "
               "simulate --data`)", None, attr="gps.file"),
            key("rate_hz", "float", "Hz", "Fix rate of the synthetic receiver", source=GpsConfig, attr="gps.rate_hz"),
            key("h_acc_m", "float", "m", "Horizontal accuracy (1-sigma) the synthetic receiver reports",
               source=GpsConfig, attr="gps.h_acc_m"),
            key("v_acc_m", "float", "m", "Vertical accuracy (1-sigma) the synthetic receiver reports",
               source=GpsConfig, attr="gps.v_acc_m"),
            key("s_acc_mps", "float", "m/s", "Speed accuracy (1-sigma) the synthetic receiver reports",
               source=GpsConfig, attr="gps.s_acc_mps"),
            key("velocity_sigma_mps", "[float; 3]", "m/s", "1-sigma of the velocity north, east, down (each > 0), "
               "replacing the file's sAcc on every axis", None, attr="gps.velocity_sigma_mps"),
            *gps_error_keys("gps.error_model"),
            key("error_model_from_data", "bool", "", "After a MAP fit with a GPS error model, estimate its white "
               "and correlated sizes (position and velocity) and correlation times from the data (type-II maximum "
               "likelihood, with the atmosphere-profile sigmas) and refit with each size at its upper bound (the "
               "largest the data allow, log evidence 1.92 nats below its maximum; at most the configured model's "
               "size of that part unless the most likely one is larger) while they change by more than 25 %; "
               "false: the model as configured. The correlation times compared (for a correlated part of 10 % of "
               "the variance or more) are 0.2, 1 and 5 times the configured, and longer ones (up to 125 times) "
               "while the evidence rises. An accuracy scale "
               "outside 1/3 to 3 times the receiver's accuracies is a gross input error (the IMU clock, a datum, "
               "units): not refitted with, the verdict not trusted", source=GpsConfig,
               attr="gps.error_model_from_data"),
        ), note="The fit weights each real fix by the accuracies the receiver reported (hAcc, vAcc, sAcc); the "
                "error-model keys split that variance into a white and a time-correlated part.",
            required=True),
        Table("sensors.baro", (
            key("file", "path", "", "FlySight 2 SENSOR.CSV (its BARO rows, on UTC) or a plain CSV with a time column "
               "(time_unix_s: UTC; time_s: IMU clock) and pressure_pa or pressure_hpa (need not exist for "
               "`casrecon simulate --data`)", None, attr="baro.file"),
            key("noise_pa", "float", "Pa", "1-sigma white noise of one pressure sample", source=BaroConfig,
               attr="baro.noise_pa"),
            key("bias_sigma_pa", "float", "Pa", "1-sigma of the constant pressure bias (estimated as baro_bias_pa)",
               source=BaroConfig, attr="baro.bias_sigma_pa"),
            key("bias_prior", "bool", "", "Give the bias its zero-mean prior", source=BaroConfig,
               attr="baro.bias_prior"),
            key("rate_hz", "float", "Hz", "Sample rate of the synthetic barometer", source=BaroConfig,
               attr="baro.rate_hz"),
            key("position_error_sigma", "float", "", "1-sigma prior of the static-port position-error coefficient k "
               "(the sensor reads p + k qbar; estimated as baro_qbar_coef); 0: not estimated", source=BaroConfig,
               attr="baro.position_error_sigma"),
        ), note="Optional. A barometer adds static-pressure residuals against the sounding's pressure at the "
                "reconstructed altitude, optionally with a static-port position error proportional to qbar."),
        Table("truth", (
            key("seed", "int", "", "Seed of the synthetic data's noise", 0, attr="truth.seed"),
            key("wind_bias_mps", "[float; 2]", "m/s", "True wind bias north, east added to the sounding",
               (0.0, 0.0), attr="truth.wind_bias_mps"),
            key("density_factor", "float", "", "True density factor: rho = rho_sounding (1 + factor)", 0.0,
               attr="truth.density_factor"),
            key("accel_bias_mps2", "[float; 3]", "m/s^2", "True accelerometer bias, IMU axes", (0.0, 0.0, 0.0),
               attr="truth.accel_bias_mps2"),
            key("gyro_bias_dps", "[float; 3]", "deg/s", "True gyro bias, IMU axes", (0.0, 0.0, 0.0)),
            key("clock_offset_s", "float", "s", "True IMU-to-GPS clock offset", 0.0, attr="truth.clock_offset_s"),
            key("downwash_mps", "float", "m/s", "True rotor downwash at release (decays with the distance fallen)",
               source=TruthConfig, attr="truth.downwash_mps"),
            key("sounding_shift_m", "float", "m", "True altitude shift of the air flown against the sounding's levels: "
               "the air at altitude h is the sounding's at h - shift", source=TruthConfig,
               attr="truth.sounding_shift_m"),
            key("baro_bias_pa", "float", "Pa", "True barometer bias (with [sensors.baro])", source=TruthConfig,
               attr="truth.baro_bias_pa"),
            key("baro_qbar_coef", "float", "", "True static-port position error of the barometer: it reads p + k qbar",
               source=TruthConfig, attr="truth.baro_qbar_coef"),
        ) + _disturbance_keys("what the simulator flies") + _TRUTH_ERRORS,
            note="Optional: what `casrecon simulate` uses to make synthetic data, and what the tests "
                 "compare the fit with. A real drop has no [truth]."),
        Table("truth.dispersions", tuple(
            key(n, "float", "", f"True normalised dispersion factor {n} (3-sigma = 1)", 0.0,
               attr=f"truth.dispersions.{n}") for n in DISPERSION_NAMES)),
        Table("simulation", (
            key("dt_s", "float", "s", "Integrator step (also the IMU sample spacing of the synthetic data)",
               source=SimulationConfig, attr="simulation.dt_s"),
            key("substeps", "int", "", "Integrator substeps per step", source=SimulationConfig,
               attr="simulation.substeps"),
            key("t_max_s", "float", "s", "Give up if the ground is not reached by then", source=SimulationConfig,
               attr="simulation.t_max_s"),
            key("pre_release_s", "float", "s", "Data made before release (vehicle hanging still)",
               source=SimulationConfig, attr="simulation.pre_release_s"),
            key("post_impact_s", "float", "s", "Data made after impact", source=SimulationConfig,
               attr="simulation.post_impact_s"),
        )),
        Table("estimation", tuple(
            key(k, t, u, source=EstimationConfig, attr=f"estimation.{k}") for k, t, u in _ESTIMATION_KEYS)
            + _disturbance_keys("the prior of the disturbance estimated at every node: the weak-constraint "
                                "option"),
            note="Every key optional; the defaults fit a 500 Hz drop."),
        Table("montecarlo", (
            key("cases", "int", "", source=MonteCarloConfig, attr="montecarlo.cases"),
            key("seed", "int", "", source=MonteCarloConfig, attr="montecarlo.seed"),
            key("center", "string", "", source=Dispersions, attr="montecarlo.dispersions.center"),
        ) + tuple(
            key(name, "float", unit, default=default, source=Dispersions, field=DISPERSION_KEYS[name],
                attr=None if default is not FROM_FIELD else f"montecarlo.dispersions.{DISPERSION_KEYS[name]}")
            for name, unit, default in (
                ("h_agl_sigma_m", "m", FROM_FIELD), ("velocity_sigma_mps", "m/s", FROM_FIELD),
                ("euler_sigma_deg", "deg", FROM_FIELD), ("rate_sigma_dps", "deg/s", FROM_FIELD),
                ("aero_factor_sigma", "", FROM_FIELD),
                ("wind_bias_sigma_mps", "m/s", "<[atmosphere] wind_3sigma_mps / 3>"),
                ("density_factor_sigma", "", "<[atmosphere] density_3sigma / 3>"))
        ) + (key("aero_factors", "[string]", "", source=Dispersions, attr="montecarlo.dispersions.aero_factors"),),
            note="Optional: the dispersed Monte Carlo of `casrecon montecarlo` (not `--estimator`), each "
                 "dispersion a zero-mean Gaussian of this 1-sigma about the centre; `--cases`, `--seed` and "
                 "`--center` override the table."),
    ) + sample_sensor_tables("sensors."),
)

VEHICLE = FileKind(
    "Vehicle file (`[problem] vehicle`)",
    "Mass properties, reference quantities and sensor mounts, in the vehicle's native axes (body axes "
    "unless `native_to_body` says otherwise), positions from a reference point of your choice. Read by "
    "`casrecon.io.vehicle_files.load_vehicle`.",
    (
        Table("", (
            key("name", "string", "", "Vehicle name", REQUIRED),
            key("mass_kg", "float", "kg", "Mass", REQUIRED),
            key("ref_length_m", "float", "m", "Aerodynamic reference length d (the maximum diameter)", REQUIRED),
            key("ref_area_m2", "float", "m^2", "Aerodynamic reference area S", "<pi d^2 / 4>"),
            key("cm_m", "[float; 3]", "m", "Centre of mass, native axes", REQUIRED),
            key("mrp_m", "[float; 3]", "m", "Aerodynamic moment reference point, native axes", REQUIRED),
            key("native_to_body", "[[float; 3]; 3]", "", "Rotation from native to body axes, v_body = R v_native "
               "(body x out of the leading face)", "<identity>"),
        )),
        Table("inertia_kgm2", tuple(
            key(n, "float", "kg m^2", f"{'Moment' if n[1] == n[2] else 'Product'} of inertia about the centre of "
               "mass, native axes" + ("" if n[1] == n[2] else f" ({n} = integral of {n[1].lower()} {n[2].lower()} "
                                                              "dm; enters the tensor negated)"),
               REQUIRED if n[1] == n[2] else 0.0) for n in ("Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")),
            required=True),
        Table("imu", (
            key("position_m", "[float; 3]", "m", "IMU position, native axes", (0.0, 0.0, 0.0), attr="imu_position_m"),
            key("to_native", "[[float; 3]; 3]", "", "Rotation from IMU axes to native axes, v_native = R v_imu",
               "<identity>"),
        )),
        Table("gps", (key("position_m", "[float; 3]", "m", "GPS antenna position, native axes", (0.0, 0.0, 0.0),
                         attr="gps_position_m"),)),
    ),
)

AERO = FileKind(
    "Aero file (`[problem] aero`)",
    "Aerodynamic coefficients about the vehicle's moment reference point, with reference area S and length "
    "d, the 3-sigma sizes of the dispersion factors and optional spin vanes. Read by "
    "`casrecon.io.vehicle_files.load_aero`.",
    (
        Table("", (
            key("name", "string", "", "Database name", REQUIRED),
            key("description", "string", "", "One line for reports", "", attr="description"),
            key("model", "string", "", '"analytic" (with [coefficients]) or "table" (with `table`)', REQUIRED),
            key("table", "path", "", 'CSV with header mach,alpha_t_deg,CA,CN,Cm,Cmq, a full grid of at least 4 '
               'Mach x 4 alpha_T points (required when model = "table")', REQUIRED),
            key("Clp", "float", "", 'Roll damping coefficient (per p d / 2V), model = "table"', 0.0),
            key("Cl0", "float", "", 'Static roll coefficient, model = "table"', 0.0),
        )),
        Table("coefficients", (
            key("CA0", "float", "", "Axial force coefficient at alpha_T = 0", REQUIRED),
            key("CA2", "float", "", "C_A = CA0 + CA2 sin^2 alpha_T", source=AnalyticCoefficients,
               attr="coefficients.CA2"),
            key("CNa", "float", "", "C_N = CNa sin alpha_T", source=AnalyticCoefficients,
               attr="coefficients.CNa"),
            key("Cma", "float", "", "C_m = Cma sin alpha_T (about the MRP; < 0 restoring)",
               source=AnalyticCoefficients,
               attr="coefficients.Cma"),
            key("Cmq0", "float", "", "Pitch/yaw damping C_mq = Cmq0 + Cmq2 sin^2 alpha_T (per q d / 2V)",
               source=AnalyticCoefficients,
               attr="coefficients.Cmq0"),
            key("Cmq2", "float", "", "See Cmq0", source=AnalyticCoefficients,
               attr="coefficients.Cmq2"),
            key("Clp", "float", "", "Roll damping (per p d / 2V)", source=AnalyticCoefficients,
               attr="coefficients.Clp"),
            key("Cl0", "float", "", "Static roll coefficient", source=AnalyticCoefficients,
               attr="coefficients.Cl0"),
        ), note='model = "analytic" only.'),
        Table("dispersion_sizes", tuple(
            key(n, "float", "fraction" if n.endswith("_mult") else "coefficient",
               f"3-sigma size U of {n}; 0 disables the factor", source=DispersionSizes, attr=f"sizes.{n}")
            for n in DISPERSION_NAMES),
            note="Multipliers are fractions of the coefficient, adders coefficient units; the factors "
                 "estimated by default are those with a non-zero size.", required=True),
        Table("vanes", (
            key("count", "int", "", "Number of spin vanes K", REQUIRED),
            key("radius_m", "float", "m", "Radius R of the vanes' centre of pressure", REQUIRED),
            key("area_m2", "float", "m^2", "Area S_k of one vane", REQUIRED),
            key("incidence_deg", "float", "deg", "Incidence alpha_k of each vane", REQUIRED),
            key("lift_slope_per_rad", "float", "1/rad", "Vane lift-curve slope C_La", source=SpinVanes,
               attr="vanes.lift_slope_per_rad"),
        ), note="Optional: the spin-vane roll model; `CLa_mult` scales C_La."),
    ),
)

JOINT = FileKind(
    "Joint file (`casrecon joint FILE`)",
    "Several drops in one fit sharing aero dispersion factors. Read by "
    "`casrecon.estimation.sixdof.joint.load_joint`.",
    (
        Table("joint", (
            key("name", "string", "", "Name of the joint fit", REQUIRED),
            key("drops", "[path]", "", "At least two problem folders (or problem.toml files), relative to this file",
               REQUIRED),
            key("shared", "[string]", "", "Dispersion factors common to all drops", "<every factor the drops "
               "estimate>"),
            key("per_drop", "[string]", "", "Factors each drop estimates for itself", ()),
            key("fixed", "[string]", "", "Factors held at 0", ()),
        ), required=True),
    ),
)

#: Every file kind, in the order of the page.
FILE_KINDS = (SIX_DOF, POINT_MASS, KINEMATIC, VEHICLE, AERO, JOINT)


def format_default(value: object) -> str:
    """A default as written in the table: TOML syntax, "required", or the text of a computed default."""
    if value is REQUIRED:
        return "required"
    if value is None:
        return "none"
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return value[1:-1] if value.startswith("<") and value.endswith(">") else f'"{value}"'
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)
    if isinstance(value, (tuple, list)):
        return "[" + ", ".join(format_default(v) for v in value) + "]"
    return str(value)


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def render_markdown() -> str:
    """The whole ``docs/problem-toml.md`` page."""
    out = ["# TOML reference", "",
           "<!-- Generated by `python -m casrecon.io.config_reference > docs/problem-toml.md`; do not edit. -->", "",
           "Every key casrecon reads, per file kind and table. Units are SI unless the unit column or the key's "
           "suffix says otherwise (`_deg`, `_dps`); angles in degrees at input, radians inside. "
           "A key not listed here is an error.", ""]
    for kind in FILE_KINDS:
        out += [f"## {kind.title}", "", kind.intro, ""]
        for table in kind.tables:
            title = f"[{table.name}]" if table.name else "top level"
            out += [f"### {title}" + (" (required)" if table.required and table.name else ""), ""]
            if table.note:
                out += [table.note, ""]
            out += ["| key | type | unit | default | meaning |", "|---|---|---|---|---|"]
            for k in table.keys:
                cells = (f"`{k.key}`", k.resolved_type, k.unit, format_default(k.resolved_default), k.resolved_meaning)
                out.append("| " + " | ".join(_cell(c) for c in cells) + " |")
            out.append("")
    return "\n".join(out)


if __name__ == "__main__":
    print(render_markdown(), end="")
