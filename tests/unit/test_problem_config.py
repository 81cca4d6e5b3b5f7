"""problem.toml parsing: the shipped problems load, and bad copies fail naming file and field."""

from __future__ import annotations

import math

import numpy as np
import pytest
from conftest import ALL_PROBLEMS, PROBLEMS

from casrecon.io.errors import InputError
from casrecon.io.problem import load_problem


@pytest.mark.parametrize("name", ALL_PROBLEMS)
def test_shipped_problem_loads(name):
    cfg = load_problem(PROBLEMS / name)
    assert cfg.name == name
    assert cfg.imu.rate_hz == 500.0 and cfg.truth is not None
    assert cfg.atmosphere.sounding.is_file()


def test_ees_drop1_values_and_units():
    cfg = load_problem(PROBLEMS / "ees-drop-1" / "problem.toml")
    # Table 3 initial conditions as written; rates and noise stay in the units named in the file
    assert cfg.release.h_agl_m == 1618.04
    assert cfg.release.euler_deg == (-99.71, -76.81, -102.38)
    assert cfg.imu.gyro_noise_radps == pytest.approx(math.radians(0.10))
    assert cfg.truth.gyro_bias_radps == pytest.approx(np.radians([0.171, 0.1061, 0.0708]))
    # EES paper Table 2 mass properties, CM from the nose
    v = cfg.vehicle
    assert v.mass_kg == 98.58 and v.cm_m == pytest.approx((-0.25704, 0.00152, 0.00046))
    assert np.diag(v.inertia_kgm2) == pytest.approx([11.535, 7.39, 7.397])
    # ref area defaults to pi d^2 / 4 = pi * 1.620529 / 4 = 1.2727605 m^2
    assert v.ref_area_m2 == pytest.approx(1.2727605, rel=1e-6)
    assert cfg.imu.spec.gyro_limits[2] == (-183.65, 157.4)


def test_zephyr_native_axes():
    v = load_problem(PROBLEMS / "davinci-ztu").vehicle
    # body x = native Z: roll inertia 29.793, CM 154 mm along body x
    assert v.inertia_kgm2[0][0] == pytest.approx(29.793)
    assert v.cm_m == pytest.approx((0.154, -0.002, 0.004))
    # products non-zero: native Iyz = 0.253 becomes body I_xz (body x = Z, body z = Y): entry -0.253
    assert v.inertia_kgm2[0][2] == pytest.approx(-0.253)


def edit(path, old: str, new: str) -> None:
    text = path.read_text()
    assert old in text, f"test setup: {old!r} not in {path}"
    path.write_text(text.replace(old, new, 1))


CASES = {
    "missing required field": ("h_agl_m = 1618.04\n", "", "release.h_agl_m", "required"),
    "wrong type": ("h_agl_m = 1618.04", 'h_agl_m = "high"', "release.h_agl_m", "expected a number"),
    "misspelt key": ("h_agl_m = 1618.04", "h_agl_m = 1618.04\nvel_ned = [1, 2, 3]", "release.vel_ned",
                     "unknown field"),
    "misspelt sub-table key": ("gyro_noise_dps = 0.10", "gyro_noise_dps = 0.10\ngyro_nosie_dps = 0.1",
                               "sensors.imu.gyro_nosie_dps", "unknown field"),
    "bad gravity choice": ('gravity = "wgs84"', 'gravity = "flat"', "dynamics.gravity", "expected one of"),
    "missing sounding file": ('sounding = "sounding.csv"', 'sounding = "nothere.csv"',
                              "atmosphere.sounding", "not found"),
    "bad UTC time": ("2023-10-03T15:32:10.250Z", "2023-13-03T15:32:10.250Z", "release.time_utc", "ISO-8601"),
    "UTC time without zone": ("2023-10-03T15:32:10.250Z", "2023-10-03T15:32:10.250", "release.time_utc",
                              "zone"),
    "wrong vector length": ("rates_dps = [-22.48, -3, 0.07]", "rates_dps = [-22.48, -3]",
                            "release.rates_dps", "list of 3"),
    "negative noise": ("accel_noise_mps2 = 0.05", "accel_noise_mps2 = -0.05",
                       "sensors.imu.accel_noise_mps2", "positive"),
    "GPS error fully correlated": ("velocity_error_time_s = 0.0", "velocity_error_time_s = 2.0\n"
                                   "velocity_correlated_fraction = 1.0", "sensors.gps.velocity_correlated_fraction",
                                   "some white"),
    "zero GPS accuracy scale": ("position_error_time_s = 0.0", "position_error_time_s = 0.0\n"
                                "position_accuracy_scale = 0.0", "sensors.gps.position_accuracy_scale", "positive"),
    "negative GPS correlation time": ("position_error_time_s = 0.0", "position_error_time_s = -1.0",
                                      "sensors.gps.position_error_time_s", ">="),
    "profile grid coarser than its correlation": ("profile_density_sigma = 0.0", "profile_density_sigma = 0.0\n"
                                                  "profile_step_m = 400.0", "atmosphere.profile_step_m",
                                                  "correlation length"),
    "negative profile sigma": ("profile_wind_sigma_mps = 0.0", "profile_wind_sigma_mps = -0.5",
                               "atmosphere.profile_wind_sigma_mps", ">="),
}


@pytest.mark.parametrize("case", list(CASES))
def test_error_names_file_and_field(problem_copy, case):
    old, new, field, words = CASES[case]
    edit(problem_copy, old, new)
    with pytest.raises(InputError) as err:
        load_problem(problem_copy)
    e = err.value
    assert e.path == str(problem_copy) and e.field == field
    assert str(e).startswith(f"{problem_copy}: field '{field}': ") and words in str(e)
    assert "\n" not in str(e)


def test_negative_mass_names_the_vehicle_file(problem_copy):
    vehicle = problem_copy.parents[1] / "vehicles" / "ees-test-article.toml"
    edit(vehicle, "mass_kg = 98.58", "mass_kg = -98.58")
    with pytest.raises(InputError) as err:
        load_problem(problem_copy)
    assert err.value.path == str(vehicle) and err.value.field == "mass_kg"
    assert "positive" in str(err.value)


def test_bad_aero_size_names_the_aero_file(problem_copy):
    aero = problem_copy.parents[1] / "aero" / "ees-sphere-cone.toml"
    edit(aero, "CN_add = 0.01", "CN_add = -0.01")
    with pytest.raises(InputError) as err:
        load_problem(problem_copy)
    assert err.value.path == str(aero) and err.value.field == "dispersion_sizes.CN_add"


def test_toml_syntax_error_has_a_line(problem_copy):
    edit(problem_copy, "[site]", "[site")
    with pytest.raises(InputError) as err:
        load_problem(problem_copy)
    line = 1 + next(k for k, ln in enumerate(problem_copy.read_text().splitlines()) if ln.startswith("[site"))
    assert err.value.path == str(problem_copy) and err.value.line == line
    assert str(err.value).startswith(f"{problem_copy}:{line}: not valid TOML")


def test_missing_problem_file(tmp_path):
    with pytest.raises(InputError, match="file not found"):
        load_problem(tmp_path)
