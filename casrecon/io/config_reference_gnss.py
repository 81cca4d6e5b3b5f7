"""The TOML key reference of the problems without a vehicle model (:mod:`casrecon.io.config_reference`):
the GPS-only point-mass problem and the IMU-driven kinematic problem."""

from __future__ import annotations

from casrecon.io.config_records import REQUIRED, FileKind, Table
from casrecon.io.config_reference_shared import DYNAMICS_TABLE, SITE_TABLE, gps_error_keys, key
from casrecon.io.imu import ImuCsvSpec
from casrecon.io.pointmass_problem import DragConfig, GpsQuality, ModelErrorConfig, PointMassConfig, SegmentConfig
from casrecon.io.sample_sensors import sample_sensor_tables

#: The fix-quality and GPS error-model keys of the [gps] table of both problems.
_QUALITY_KEYS = (
    key("max_h_acc_m", "float", "m", "Fixes reporting a worse horizontal accuracy are dropped", source=GpsQuality,
        attr="quality.max_h_acc_m"),
    key("max_v_acc_m", "float", "m", "Fixes reporting a worse vertical accuracy are dropped", source=GpsQuality,
        attr="quality.max_v_acc_m"),
    key("max_s_acc_mps", "float", "m/s", "Fixes reporting a worse speed accuracy are dropped", source=GpsQuality,
        attr="quality.max_s_acc_mps"),
    key("min_num_sv", "int", "", "Fixes with fewer satellites are dropped", source=GpsQuality,
        attr="quality.min_num_sv"),
    *gps_error_keys("gps_errors"),
)

POINT_MASS = FileKind(
    "problem.toml (point-mass problem, `kind = \"point-mass\"`)",
    "A GPS-only problem (no IMU): a point mass with a drag area fitted to one GPS track. Read by "
    "`casrecon.io.pointmass_problem.load_point_mass`. [site] and [dynamics] are as in the 6-DOF problem.",
    (
        Table("problem", (
            key("kind", "string", "", 'Must be "point-mass"', REQUIRED),
            key("name", "string", "", "Name used in reports", REQUIRED),
            key("description", "string", "", "One line for reports", ""),
        ), required=True),
        SITE_TABLE,
        Table("atmosphere", (
            key("sounding", "string or path", "", '"standard" (ICAO standard atmosphere, no wind) or a sounding '
               "file", REQUIRED),
            key("wind_3sigma_mps", "float", "m/s", "3-sigma prior of the estimated constant wind bias", 3.0,
               attr="wind_3sigma_mps"),
            key("humidity", "bool", "", "Moist-air density from the sounding's dewpoints where it has them; false: dry "
               "air, p / (R_d T)", True, attr="humidity"),
        ), required=True),
        Table("vehicle", (key("mass_kg", "float", "kg", "Mass of the body", REQUIRED),), required=True),
        Table("drag", (
            key("model", "string", "", '"constant" (one CdA) or "spline" (cubic B-spline in time)',
               source=DragConfig, attr="drag.model"),
            key("knot_spacing_s", "float", "s", "Spline knot spacing", source=DragConfig, attr="drag.knot_spacing_s"),
            key("smoothness_sigma_m2", "float", "m^2", "1-sigma prior of the spline's second differences",
               source=DragConfig, attr="drag.smoothness_sigma_m2"),
            key("lift", "bool", "", "Also estimate horizontal lift areas north and east", source=DragConfig,
               attr="drag.lift"),
            key("lift_sigma_m2", "float", "m^2", "1-sigma prior of each lift-area coefficient", source=DragConfig,
               attr="drag.lift_sigma_m2"),
        )),
        Table("gps", (
            key("file", "path", "", "FlySight 1 CSV, FlySight 2 TRACK.CSV, NMEA 0183 log (GGA, RMC, VTG, GSA: "
               "accuracies from DOP, no vertical velocity) or GNSS CSV (ts,latitude,longitude,satellites: horizontal "
               "position only); a component the file does not give has zero weight", REQUIRED),
            key("date", "date or string", "UTC", "UTC date (YYYY-MM-DD) of the first fix of an NMEA log without RMC "
               "sentences (GGA carries no date)", None, attr="gps_date"),
            key("velocity_sigma_mps", "[float; 3]", "m/s", "1-sigma of the velocity north, east, down (each > 0), "
               "replacing the file's sAcc on every axis", None, attr="velocity_sigma_mps"),
            *_QUALITY_KEYS,
            key("error_model_from_data", "bool", "", "After the fit, with a GPS error model, estimate its white and "
               "correlated sizes (position and velocity) and correlation times from the data (type-II maximum "
               "likelihood on the fit's KKT matrix) and refit with them while they change by more than 25 %. Off "
               "by default here (on in the 6-DOF fit): it costs 3 to 20 times the fit (10 to 75 s on the shipped "
               "tracks), and on the shipped real tracks it did not make every innovation channel's chi-square "
               "better (README, GPS-only fits)", source=PointMassConfig, field="gps_error_model_from_data",
               attr="gps_error_model_from_data"),
        ), required=True),
        Table("segment", (
            key("start_utc", "datetime or string", "UTC", "Start of the fitted segment", "<found from the data>"),
            key("end_utc", "datetime or string", "UTC", "End of the fitted segment; refused when the fall's final drop "
               "(canopy opening, impact) began before it", "<found from the data>"),
            key("min_speed_mps", "float", "m/s", "Descent speed that defines the segment when start/end are not "
               "given", source=SegmentConfig, attr="segment.min_speed_mps"),
            key("end_margin_s", "float", "s", "The found segment ends this long before the final drop began",
               source=SegmentConfig, attr="segment.end_margin_s"),
            key("deploy_drop_mps", "float", "m/s", "The final drop (canopy opening, impact): the last fixes each this "
               "far below the running maximum of the vertical speed over the preceding 2 s",
               source=SegmentConfig, attr="segment.deploy_drop_mps"),
        )),
        Table("model_error", (
            key("drag_area_fraction", "float", "", "1-sigma of a first-order Gauss-Markov process a that multiplies "
               "the drag area by exp(fraction a), estimated at every node (changes of body position faster than the "
               "spline follows); with either sigma non-zero the adequacy tests run on the Kalman innovations of the "
               "fixes; 0: none", source=ModelErrorConfig, attr="model_error.drag_area_fraction"),
            key("lift_area_sigma_m2", "float", "m^2", "1-sigma of the same process added to each horizontal lift "
               "area (north, east), with or without [drag] lift; 0: none", source=ModelErrorConfig,
               attr="model_error.lift_area_sigma_m2"),
            key("time_s", "float", "s", "Correlation time of the area processes", source=ModelErrorConfig,
               attr="model_error.time_s"),
        )),
        DYNAMICS_TABLE,
        Table("estimation", (
            key("linear_solver", "string", "", 'Ipopt\'s linear solver, "mumps" or "spral"', source=PointMassConfig,
               attr="linear_solver"),
            key("max_iter", "int", "", "Ipopt iteration limit", source=PointMassConfig, attr="max_iter"),
            key("tol", "float", "", "Ipopt tolerance", source=PointMassConfig, attr="tol"),
        )),
    ),
)

KINEMATIC = FileKind(
    "problem.toml (kinematic problem, `kind = \"kinematic\"`)",
    "An IMU-driven reconstruction of any rigid body (no vehicle or aero file): the measured specific force and "
    "rates drive the states, GNSS fixes and a barometer observe them. Read by "
    "`casrecon.io.kinematic_problem.load_kinematic`. [site] and [dynamics] are as in the 6-DOF problem. All times "
    "are on one clock: UTC seconds for files stamped in UTC (FlySight, NMEA), the flight computer's seconds for "
    "files that share its clock.",
    (
        Table("problem", (
            key("kind", "string", "", 'Must be "kinematic"', REQUIRED),
            key("name", "string", "", "Name used in reports", REQUIRED),
            key("description", "string", "", "One line for reports", ""),
        ), required=True),
        SITE_TABLE,
        Table("atmosphere", (
            key("sounding", "string or path", "", '"standard" (ICAO standard atmosphere) or a sounding file: the '
                "barometer's pressure-altitude relation", "standard"),
            key("humidity", "bool", "", "Moist-air density from the sounding's dewpoints where it has them; false: dry "
               "air, p / (R_d T)", True, attr="humidity"),
        )),
        DYNAMICS_TABLE,
        Table("imu", (
            key("file", "path", "", "FlySight 2 SENSOR.CSV (its IMU rows, on UTC) or an IMU CSV (give its columns "
                "and units)", REQUIRED),
            key("time_unit", "string", "", "Unit of a CSV's time column", source=ImuCsvSpec, attr="imu.spec.time_unit"),
            key("accel_unit", "string", "", "Unit of a CSV's accelerometer columns", source=ImuCsvSpec,
                attr="imu.spec.accel_unit"),
            key("gyro_unit", "string", "", "Unit of a CSV's gyro columns", source=ImuCsvSpec,
                attr="imu.spec.gyro_unit"),
            key("axes", "string or [[float; 3]; 3]", "", "Rotation from the file's axes to the IMU axes", None,
                attr="imu.spec.axes"),
            key("accel_limits", "[[float; 2]; 3]", "accel_unit (g)", "Saturation limits [low, high] of the x, y, z "
                "accelerometer axes as the file writes them (a CSV's accel_unit; g for a SENSOR.CSV); a sample at or "
                "beyond one is masked: bridged and given a large noise; absent: no saturation flagging", None,
                attr="imu.accel_limits"),
            key("gyro_limits", "[[float; 2]; 3]", "gyro_unit (deg/s)", "Saturation limits [low, high] of the x, y, z "
                "gyro axes (a CSV's gyro_unit; deg/s for a SENSOR.CSV; see accel_limits)", None,
                attr="imu.gyro_limits"),
            key("utc_at_zero_s", "float", "s", "Clock value of a CSV's time 0 (0: the flight computer's own clock)",
                0.0, attr="imu.utc_at_zero_s"),
            key("gyro_noise_dps", "float", "deg/s", "White noise 1-sigma of one gyro sample, per axis", REQUIRED),
            key("accel_noise_mps2", "float", "m/s^2", "White noise 1-sigma of one accelerometer sample, per axis",
                REQUIRED, attr="imu.accel_noise_mps2"),
            key("gyro_bias_sigma_dps", "float", "deg/s", "Prior 1-sigma of each constant gyro bias", 1.0),
            key("accel_bias_sigma_mps2", "float", "m/s^2", "Prior 1-sigma of each constant accelerometer bias", 0.2,
                attr="imu.accel_bias_sigma_mps2"),
            key("gyro_scale_sigma", "float", "", "Prior 1-sigma of each gyro scale-factor error (fraction; 0: not "
                "estimated)", 0.02, attr="imu.gyro_scale_sigma"),
            key("accel_scale_sigma", "float", "", "Prior 1-sigma of each accelerometer scale-factor error "
                "(fraction; 0: not estimated)", 0.02, attr="imu.accel_scale_sigma"),
            key("gyro_misalignment_sigma", "float", "rad", "Prior 1-sigma of each gyro axis's sensitivity to the "
                "other two (0: not estimated)", 0.005, attr="imu.gyro_misalignment_sigma"),
            key("accel_misalignment_sigma", "float", "rad", "Prior 1-sigma of each accelerometer axis's "
                "sensitivity to the other two (0: not estimated)", 0.005, attr="imu.accel_misalignment_sigma"),
            key("gyro_senses_earth_rate", "bool", "", "The gyros measure the rate against inertial space "
                "(a real gyro; casrecon's simulator gives the rate against NED)", True,
                attr="imu.gyro_senses_earth_rate"),
        ), required=True),
        Table("imu.columns", (
            key("time", "string", "", "Name of a CSV's time column", source=ImuCsvSpec, field="time_column",
                attr="imu.spec.time_column"),
            key("accel", "[string; 3]", "", "Names of the x, y, z accelerometer columns (file axes)",
                source=ImuCsvSpec, field="accel_columns", attr="imu.spec.accel_columns"),
            key("gyro", "[string; 3]", "", "Names of the x, y, z gyro columns (file axes)", source=ImuCsvSpec,
                field="gyro_columns", attr="imu.spec.gyro_columns"),
        ), note="Only for an IMU CSV (absent, with no unit keys, for a FlySight 2 SENSOR.CSV)."),
        Table("gps", (
            key("file", "path", "", "FlySight 1 CSV, FlySight 2 TRACK.CSV, NMEA 0183 log or GNSS CSV; a component "
                "the file does not give has zero weight", REQUIRED),
            key("lever_arm_m", "[float; 3]", "m", "Antenna minus IMU position, IMU axes", (0.0, 0.0, 0.0)),
            key("date", "date or string", "UTC", "UTC date of an NMEA log without RMC sentences", None,
                attr="gps_date"),
            key("velocity_sigma_mps", "[float; 3]", "m/s", "1-sigma of the velocity north, east, down, replacing the "
                "file's sAcc", None, attr="velocity_sigma_mps"),
            *_QUALITY_KEYS,
        ), required=True),
        Table("baro", (
            key("file", "path", "", "FlySight 2 SENSOR.CSV or a barometer CSV", REQUIRED, attr="baro_file"),
            key("noise_pa", "float", "Pa", "White noise 1-sigma of one sample", 3.0, attr="baro_noise_pa"),
            key("bias_sigma_pa", "float", "Pa", "Prior 1-sigma of the constant pressure bias", 50.0,
                attr="baro_bias_sigma_pa"),
            key("height_scale_sigma", "float", "", "Prior 1-sigma of k: the barometer reads the profile at the "
                "ground altitude plus (1 + k) times the height above it (about 0.035 per 10 K between the day's air "
                "and the profile's)", 0.03, attr="baro_height_scale_sigma"),
        )),
        Table("segment", (
            key("start_s", "float", "s", "Start of the reconstructed span on the common clock (default: where IMU "
                "and fixes overlap)", None, attr="start_s"),
            key("end_s", "float", "s", "End of the span", None, attr="end_s"),
        )),
        Table("estimation", (
            key("max_node_spacing_s", "float", "s", "Longest interval between nodes (nodes sit on the fixes and "
                "fill longer gaps)", 0.5, attr="max_node_spacing_s"),
            key("clock_sigma_s", "float", "s", "Prior 1-sigma of an IMU-to-fix clock offset to estimate (0: none)",
                0.0, attr="clock_sigma_s"),
            key("linear_solver", "string", "", 'Ipopt\'s linear solver, "mumps" or "spral"', "mumps",
                attr="linear_solver"),
            key("max_iter", "int", "", "Ipopt iteration limit", 100, attr="max_iter"),
            key("tol", "float", "", "Ipopt tolerance", 1e-8, attr="tol"),
        )),
    ) + sample_sensor_tables(""),
)
