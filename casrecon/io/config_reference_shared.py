"""Records shared by several file kinds of the TOML key reference (:mod:`casrecon.io.config_reference`):
the key constructor, the [site] and [dynamics] tables and the GPS error-model keys."""

from __future__ import annotations

from casrecon.io.config_records import FROM_FIELD, REQUIRED, Key, Table
from casrecon.physics.dynamics import DynamicsOptions
from casrecon.physics.sensor_errors import GpsErrorModel


def key(name, type_, unit, meaning=None, default=FROM_FIELD, source=None, field=None, attr=None) -> Key:
    """One :class:`Key` record (positional shorthand)."""
    return Key(name, type_, unit, meaning, default, source, field, attr)


def gps_error_keys(prefix: str) -> tuple[Key, ...]:
    """The GPS error-model keys (:class:`~casrecon.physics.sensor_errors.GpsErrorModel`), read into
    ``{prefix}`` (``"gps.error_model"`` or ``"gps_errors"``)."""
    m = prefix
    return (
        key("position_error_time_s", "float", "s", "Correlation time of the correlated part of each GPS position "
           "error component (first-order Gauss-Markov, estimated at every fix); 0: white", source=GpsErrorModel,
           field="position_time_s", attr=f"{m}.position_time_s"),
        key("velocity_error_time_s", "float", "s", "Correlation time of the correlated part of each GPS velocity "
           "error component; 0: white", source=GpsErrorModel, field="velocity_time_s", attr=f"{m}.velocity_time_s"),
        key("position_correlated_fraction", "float", "", "Fraction of the reported position variance (hAcc^2, "
           "vAcc^2) that is correlated, at most 0.999", source=GpsErrorModel, field="position_fraction",
           attr=f"{m}.position_fraction"),
        key("velocity_correlated_fraction", "float", "", "Fraction of the reported velocity variance (sAcc^2) that "
           "is correlated, at most 0.999", source=GpsErrorModel, field="velocity_fraction",
           attr=f"{m}.velocity_fraction"),
        key("position_accuracy_scale", "float", "", "The position error's 1-sigma (white and correlated parts "
           "together) over the reported hAcc, vAcc (> 0; below 1 for a receiver whose accuracies are pessimistic)",
           source=GpsErrorModel, field="position_scale", attr=f"{m}.position_scale"),
        key("velocity_accuracy_scale", "float", "", "The velocity error's 1-sigma over the reported sAcc (or "
           "velocity_sigma_mps), > 0", source=GpsErrorModel, field="velocity_scale", attr=f"{m}.velocity_scale"),
    )


SITE_TABLE = Table("site", required=True, keys=(
    key("lat_deg", "float", "deg", "Geodetic latitude of the NED origin (a ground point near the drop), within +-90",
       REQUIRED),
    key("lon_deg", "float", "deg", "Longitude of the NED origin", REQUIRED),
    key("ground_alt_msl_m", "float", "m", "Ground altitude at the origin above mean sea level; altitude AGL = "
       "altitude MSL - this", REQUIRED),
))

DYNAMICS_TABLE = Table("dynamics", tuple(
    key(k, t, u, source=DynamicsOptions, attr=f"dynamics.{k}") for k, t, u in (
        ("gravity", "string", ""), ("earth_rotation", "bool", ""), ("aerodynamics", "bool", ""),
        ("downwash_length_m", "float", "m"))))
