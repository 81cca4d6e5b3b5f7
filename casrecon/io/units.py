"""Units in the names of every results-folder column and JSON key, in one place.

The convention (``docs/design.md``, section *Results folder*):

- **A name ends in its unit** (:data:`UNIT_SUFFIXES`): ``t_s``, ``pos_n_m``, ``vel_n_mps``,
  ``accel_mps2``, ``alpha_deg``, ``p_dps``, ``qbar_pa``, ``cda_m2``, ``moment_error_x_nm``,
  ``cases_per_s``; forces end in ``_n`` (newton) and start with ``force`` (``force_error_x_n``),
  because ``_n`` elsewhere means north (``wind_bias_n``). ``<name>_3sigma`` has the unit of
  ``<name>``.
- **Or it is dimensionless** by this list: the names :data:`DIMENSIONLESS_NAMES` (Mach number,
  quaternion, counts and flags, chi-square, condition number, ...), names ending in
  :data:`DIMENSIONLESS_SUFFIXES` (normalised aero factors ``_mult``, ``_add``, ``_coef``,
  ``_factor``, use flags ``_used``, normalised residuals ``_z``, ``_ratio``, ``_autocorrelation``,
  ``_chi2``), starting with :data:`DIMENSIONLESS_PREFIXES` (counts ``n_``, normalised errors ``z_``,
  moment coefficients ``cm_``, ``chi2_``, ``dof_``, ``reduced_chi2_``, aerodynamic coefficients
  ``CA_`` .. ``Cn_``), or containing ``normalised``.
- **Text columns** (:data:`TEXT_COLUMNS`): ``utc``, the UTC instant as ISO 8601 with microseconds
  and a ``Z`` (``pd.read_csv(path, parse_dates=["utc"])`` gives tz-aware timestamps).
- **JSON numbers** are named by their own key as above, else by the nearest key on their path
  that names a unit (``flight_time_s: {mean, sd, p99}``, ``chi2: {imu, gps}``), else by the
  ``unit`` string of the object holding them (a parameter record: ``value``, ``sigma``,
  ``three_sigma``, ``sigma_chi2_scaled``, ``prior_sigma`` are in its ``unit``), else by a sibling
  ``units`` map from their key to a unit (``truth.json``).
- **Output units**: SI inside, but angles and angular rates leave in degrees
  (:func:`output_unit`), as the problem files give them: gyro biases, gyro residuals and gyro
  noise in deg/s.

:func:`unit_of` and :func:`unnamed_json_numbers` apply the rules; the tests walk real results
folders with them.
"""

from __future__ import annotations

import math

import numpy as np

#: Name suffix (after the last underscore) -> unit.
UNIT_SUFFIXES = {"s": "s", "m": "m", "mps": "m/s", "mps2": "m/s^2", "deg": "deg", "dps": "deg/s", "pa": "Pa",
                 "m2": "m^2", "kg": "kg", "kgm2": "kg m^2", "kgm3": "kg/m^3", "nm": "N m", "hz": "Hz", "k": "K",
                 "mb": "MB (1e6 bytes)"}
#: Dimensionless names.
DIMENSIONLESS_NAMES = frozenset({
    "mach", "q0", "q1", "q2", "q3", "case", "index", "impacted", "used", "seed", "iterations", "objective",
    "condition", "dof", "chi2", "reduced_chi2", "nees", "nees_sum", "eigenvalue", "weights", "correlation",
    "matrix", "workers", "chi2_95_interval",
    # the model-adequacy tests (summary.json "adequacy"): counts, autocorrelation, test statistics,
    # probabilities and normalised limits
    "n", "lags", "lag1", "ljung_box_q", "ljung_box_p", "p_value", "alpha", "per_test_alpha", "z", "z_limit",
    "n_tests",
    # fisher.json: a direction's rank and its loadings (components of a unit vector)
    "rank", "loadings"})
#: Dimensionless name endings.
DIMENSIONLESS_SUFFIXES = ("_mult", "_add", "_coef", "_factor", "_used", "_z", "_ratio", "_autocorrelation", "_chi2")
#: Dimensionless name beginnings: counts, normalised errors, moment coefficients, chi-square pieces, and
#: the aerodynamic coefficients of aero_coefficients.csv (``CA_reconstructed``, ``Cm_best_fit_3sigma``,
#: ``CN_crossflow_nominal``: :mod:`casrecon.analysis.aero_columns`).
DIMENSIONLESS_PREFIXES = ("n_", "z_", "cm_", "chi2_", "dof_", "reduced_chi2_", "CA_", "CY_", "CN_", "Cl_", "Cm_",
                          "Cn_")
#: Text columns and what they hold.
TEXT_COLUMNS = {"utc": "UTC, ISO 8601 with microseconds and a Z"}

#: Time columns added wherever a UTC is known (s since 1970-01-01 UTC; ISO 8601 text).
TIME_UNIX = "time_unix_s"
UTC = "utc"
#: The time bases of every results table, the same names in every problem kind: ``time_unix_s`` and
#: ``utc`` wherever the clock is UTC (every 6-DOF and point-mass fit; a kinematic one whose clock is
#: UTC); ``flight_time_s``, s since release, where there is a release (6-DOF); ``segment_time_s``,
#: s since the first row, where there is none (point-mass, kinematic); ``time_imu_s``, the IMU's
#: own clock, where it is not UTC (6-DOF; kinematic on a flight computer's clock).
FLIGHT_TIME = "flight_time_s"
SEGMENT_TIME = "segment_time_s"
IMU_TIME = "time_imu_s"
#: Geodetic columns (WGS-84 latitude and longitude, deg; height above mean sea level, m).
GEODETIC = ("latitude_deg", "longitude_deg", "h_msl_m")

#: Units converted on output (SI inside): unit -> (output unit, factor).
OUTPUT_UNITS = {"rad/s": ("deg/s", 180.0 / math.pi), "rad": ("deg", 180.0 / math.pi)}

#: IMU channels and the suffix and factor (from SI) of their output unit.
IMU_CHANNEL_UNITS = {"ax": ("mps2", 1.0), "ay": ("mps2", 1.0), "az": ("mps2", 1.0),
                     "wx": ("dps", 180.0 / math.pi), "wy": ("dps", 180.0 / math.pi), "wz": ("dps", 180.0 / math.pi)}
#: GPS components (antenna position NED, m; velocity NED, m/s) and their unit suffixes.
GPS_COMPONENT_UNITS = {"pos_n": "m", "pos_e": "m", "pos_d": "m", "vel_n": "mps", "vel_e": "mps", "vel_d": "mps"}


def unit_of(name: str) -> str | None:
    """The unit a column or key name states (``"-"`` when dimensionless by the list, the text
    description for :data:`TEXT_COLUMNS`), or None when it states none."""
    base = name.removesuffix("_3sigma")
    if base in TEXT_COLUMNS:
        return TEXT_COLUMNS[base]
    if (base in DIMENSIONLESS_NAMES or base.endswith(DIMENSIONLESS_SUFFIXES) or base.startswith(DIMENSIONLESS_PREFIXES)
            or "normalised" in base):
        return "-"
    head, _, token = base.rpartition("_")
    if not head:
        return None
    if token == "s" and head.endswith("_per"):
        return "1/s"
    if token == "n" and base.startswith("force"):
        return "N"
    return UNIT_SUFFIXES.get(token)


def output_unit(unit: str) -> tuple[str, float]:
    """The unit a quantity in ``unit`` (SI) is written in, and the factor from SI to it."""
    return OUTPUT_UNITS.get(unit, (unit, 1.0))


def imu_residual_column(channel: str) -> str:
    """``residuals_imu.csv`` column of an IMU channel (``ax_residual_mps2``, ``wx_residual_dps``)."""
    return f"{channel}_residual_{IMU_CHANNEL_UNITS[channel][0]}"


def imu_sigma_key(channel: str) -> str:
    """``imu_sigma.json`` key of an IMU channel's noise 1-sigma (``ax_sigma_mps2``, ``wx_sigma_dps``)."""
    return f"{channel}_sigma_{IMU_CHANNEL_UNITS[channel][0]}"


def gps_residual_column(component: str) -> str:
    """``residuals_gps.csv`` residual column of a GPS component (``pos_n_residual_m``)."""
    return f"{component}_residual_{GPS_COMPONENT_UNITS[component]}"


def gps_sigma_column(component: str) -> str:
    """``residuals_gps.csv`` 1-sigma column of a GPS component (``vel_d_sigma_mps``)."""
    return f"{component}_sigma_{GPS_COMPONENT_UNITS[component]}"


def utc_text(time_unix_s) -> np.ndarray:
    """ISO 8601 UTC strings with microseconds and a ``Z`` of Unix times (s), with the same digits as
    the ``time_unix_s`` column shows (:func:`column_format`: both round the same decimal text)."""
    t = np.asarray(time_unix_s, dtype=np.float64)
    us = np.array([int(f"{x:.6f}".replace(".", "")) for x in t.ravel()], dtype=np.int64)
    text = np.array([s + "Z" for s in np.datetime_as_string(us.astype("datetime64[us]"), unit="us")], dtype=str)
    return text.reshape(t.shape)


def column_format(name: str) -> str:
    """printf format of a numeric CSV column: Unix times to the microsecond, latitude and longitude
    to 1e-9 deg (0.1 mm), else 9 significant digits."""
    if name.endswith("unix_s"):
        return "%.6f"
    return "%.9f" if name in GEODETIC[:2] else "%.9g"


def unnamed_columns(names) -> list[str]:
    """The column names among ``names`` that state no unit."""
    return [n for n in names if unit_of(n) is None]


def unnamed_json_numbers(doc, path: tuple[str, ...] = (), unit: str | None = None,
                         units: dict | None = None) -> list[str]:
    """Dotted paths of the numbers in a JSON document that no rule of this module names a unit for."""
    if isinstance(doc, dict):
        if isinstance(doc.get("unit"), str):
            unit = doc["unit"]
        if isinstance(doc.get("units"), dict):
            units = doc["units"]
        out = []
        for key, value in doc.items():
            if key not in ("unit", "units"):
                out += unnamed_json_numbers(value, path + (str(key),), unit, units)
        return out
    if isinstance(doc, list):
        return [p for item in doc for p in unnamed_json_numbers(item, path, unit, units)]
    if isinstance(doc, bool) or not isinstance(doc, (int, float)):
        return []
    named = unit is not None or any(unit_of(k) is not None for k in path) or (
        units is not None and bool(path) and path[-1] in units)
    return [] if named else [".".join(path) or "<document>"]
