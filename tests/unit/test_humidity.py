"""Humidity from the sounding: the dewpoint read in every format, the moist-air density the
atmosphere makes of it, and the bad dewpoints refused (located)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import PROBLEMS, REALDATA_DIR

from casrecon.io.errors import InputError
from casrecon.io.inspect import inspect_file
from casrecon.io.sounding import read_sounding, write_sounding_csv
from casrecon.physics.atmosphere import (
    EPSILON,
    R_AIR,
    R_VAPOUR,
    Atmosphere,
    level_vapour_pressure,
    moist_density,
    vapour_pressure,
)

SND = REALDATA_DIR / "soundings"
LIST = SND / "20110522_OUN_12Z.txt"
MAY4 = SND / "may4_sounding.txt"
OUN = SND / "OUN_72357_2023-05-22_12Z_wyoming.csv"
IGRA = SND / "USM00070026-data.txt"


def test_vapour_pressure_matches_the_saturation_table():
    # saturation vapour pressure over water (WMO/Buck tables): 611.2 Pa at 0 C, 1228 at 10,
    # 2339 at 20, 3169 at 25, 4246 at 30 C
    table = {0.0: 611.2, 10.0: 1228.0, 20.0: 2339.0, 25.0: 3169.0, 30.0: 4246.0}
    got = vapour_pressure(np.array(list(table)) + 273.15)
    np.testing.assert_allclose(got, list(table.values()), rtol=2e-3)


def test_moist_density_is_dry_air_plus_vapour_at_their_partial_pressures():
    p, t, e = 95_000.0, 300.0, 3_000.0
    two_gases = (p - e) / (R_AIR * t) + e / (R_VAPOUR * t)
    assert moist_density(p, t, e) == pytest.approx(two_gases, rel=1e-12)
    assert moist_density(p, t, e) < p / (R_AIR * t)
    assert moist_density(p, t) == p / (R_AIR * t)  # no vapour: the dry density, to the bit


def test_missing_dewpoints_take_the_mixing_ratio_of_the_levels_around():
    h = np.array([0.0, 500.0, 1000.0, 1500.0, 2000.0])
    p = np.array([100_000.0, 94_000.0, 89_000.0, 84_000.0, 79_000.0])
    dew = np.array([np.nan, 290.0, np.nan, 280.0, np.nan])
    e = level_vapour_pressure(h, p, dew)
    ratio = EPSILON * e / (p - e)
    known = EPSILON * vapour_pressure(dew[[1, 3]]) / (p[[1, 3]] - vapour_pressure(dew[[1, 3]]))
    np.testing.assert_allclose(ratio[[1, 3]], known, rtol=1e-12)
    assert ratio[2] == pytest.approx(known.mean(), rel=1e-12)          # halfway: the mean
    assert ratio[0] == pytest.approx(known[0]) and ratio[4] == pytest.approx(known[1])  # held beyond
    assert np.all(level_vapour_pressure(h, p, np.full(5, np.nan)) == 0.0)
    assert np.all(level_vapour_pressure(h, p, None) == 0.0)


def test_wyoming_list_dewpoint_gives_the_files_own_mixing_ratio():
    """The reader takes DWPT; its mixing ratio, from Bolton's formula here, against the MIXR column
    the University of Wyoming computes from the same dewpoint (given to 0.01 g/kg)."""
    for path in (LIST, MAY4):
        s = read_sounding(path)
        assert s.dewpoint_k is not None and np.isfinite(s.dewpoint_k).all()
        lines = path.read_text().splitlines()
        header = next(k for k, ln in enumerate(lines) if ln.split()[:2] == ["PRES", "HGHT"])
        mixr = {}
        for ln in lines[header + 3:]:
            parts = ln.split()
            if len(parts) == 11:
                mixr[float(parts[1])] = float(parts[5]) / 1000.0
        e = vapour_pressure(s.dewpoint_k)
        ours = EPSILON * e / (s.pressure_pa - e)
        theirs = np.array([mixr[h] for h in s.altitude_msl_m])
        np.testing.assert_allclose(ours, theirs, rtol=0.01, atol=2e-5)


def test_wyoming_csv_and_igra2_dewpoints():
    s = read_sounding(OUN)
    # first level: 977 hPa, 12.8 C, dewpoint 12.8 C (saturated)
    assert s.dewpoint_k[0] == pytest.approx(285.95) and s.dewpoint_k[1] == pytest.approx(285.85)
    g = read_sounding(IGRA)
    # surface: TEMP 0 (0.1 C), RH 1000 (0.1 %), DPDP 0: saturated at 0 C
    assert g.dewpoint_k[0] == pytest.approx(273.15)
    # 925 hPa, 712 m: TEMP -12, DPDP 7 (0.1 C): dewpoint -1.9 C
    k = int(np.flatnonzero(g.altitude_msl_m == 712.0)[0])
    assert g.temperature_k[k] == pytest.approx(271.95) and g.dewpoint_k[k] == pytest.approx(271.25)
    assert np.all(g.dewpoint_k <= g.temperature_k)


def test_humid_air_is_lighter_by_what_the_vapour_says():
    s = read_sounding(LIST)
    moist = Atmosphere.from_sounding(s).levels["density_kgm3"]
    dry = s.pressure_pa / (R_AIR * s.temperature_k)
    # 966 hPa, 22.2 C, dewpoint 21.0 C: e = 2486 Pa, 1 - 0.378 e / p = 0.99027
    assert moist[0] / dry[0] == pytest.approx(1.0 - (1.0 - EPSILON) * 2486.0 / 96600.0, rel=2e-5)
    assert 1.0 - moist[0] / dry[0] == pytest.approx(0.0097, abs=2e-4)
    # a given density is used as given, whatever the dewpoint
    given = Atmosphere(s.altitude_msl_m, s.pressure_pa, s.temperature_k, s.wind_north_mps, s.wind_east_mps,
                       density_kgm3=dry, dewpoint_k=s.dewpoint_k)
    np.testing.assert_array_equal(given.levels["density_kgm3"], dry)


PLAIN = "altitude_msl_m,pressure_pa,temperature_k,wind_north_mps,wind_east_mps,dewpoint_k\n"


def test_plain_csv_dewpoint_optional_per_level_and_round_trip(tmp_path):
    f = tmp_path / "s.csv"
    f.write_text(PLAIN + "100,100000,290,0,0,285\n600,94500,287,1,0,\n1100,89000,284,2,0,284.3\n")
    s = read_sounding(f)
    assert s.n == 3 and s.dropped_levels == 0  # the level without a dewpoint is kept
    np.testing.assert_array_equal(s.dewpoint_k, [285.0, np.nan, 284.0])  # 0.3 K above T: rounding, saturated
    out = tmp_path / "back.csv"
    write_sounding_csv(out, s)
    np.testing.assert_array_equal(read_sounding(out).dewpoint_k, s.dewpoint_k)
    blank = tmp_path / "blank.csv"
    blank.write_text(PLAIN + "100,100000,290,0,0,\n600,94500,287,1,0,\n")
    assert read_sounding(blank).dewpoint_k is None


@pytest.mark.parametrize("row,message", [("600,94500,287,1,0,290", "above the temperature"),
                                         ("600,94500,287,1,0,12", "outside the plausible range"),
                                         ("600,94500,287,1,0,2x5", "dewpoint_k")])
def test_bad_dewpoints_are_located(tmp_path, row, message):
    f = tmp_path / "bad.csv"
    f.write_text(PLAIN + "100,100000,290,0,0,285\n" + row + "\n")
    with pytest.raises(InputError, match=message) as exc:
        read_sounding(f)
    assert exc.value.line == 3 and "bad.csv" in str(exc.value)


def test_wyoming_csv_dewpoint_with_an_unknown_unit_is_refused(tmp_path):
    f = tmp_path / OUN.name
    lines = OUN.read_text().splitlines()
    f.write_text("\n".join([lines[0].replace("dew point temperature_C", "dew point temperature_F"), *lines[1:]]))
    with pytest.raises(InputError, match="unknown unit 'F' for dew point temperature") as exc:
        read_sounding(f)
    assert exc.value.line == 1


def test_inspect_says_what_humidity_the_sounding_gives():
    assert "humidity: dewpoint at 70 of 70 levels" in inspect_file(LIST)
    plain = Path(__file__).resolve().parents[2] / "problems" / "ees-drop-1" / "sounding.csv"
    assert "humidity: no dewpoint (dry air assumed)" in inspect_file(plain)


def test_humidity_false_makes_the_fit_s_air_dry_for_every_problem_kind(problem_copy):
    """``[atmosphere] humidity = false`` ignores the sounding's dewpoints (6-DOF, point-mass and
    kinematic problems alike); a value that is not a boolean is a located error."""
    import dataclasses
    import shutil

    from casrecon.estimation.pointmass.fit import atmosphere_of
    from casrecon.io.kinematic_problem import load_kinematic
    from casrecon.io.pointmass_problem import load_point_mass
    from casrecon.io.problem import load_problem
    from casrecon.scenario import Scenario

    s = read_sounding(LIST)
    dry = s.pressure_pa / (R_AIR * s.temperature_k)
    shutil.copy(LIST, problem_copy.parent / "humid.txt")
    text = problem_copy.read_text().replace('sounding = "sounding.csv"', 'sounding = "humid.txt"')
    for setting, humid in (("", True), ("humidity = true\n", True), ("humidity = false\n", False)):
        problem_copy.write_text(text.replace("[atmosphere]\n", "[atmosphere]\n" + setting))
        cfg = load_problem(problem_copy)
        assert cfg.atmosphere.humidity is humid
        rho = Scenario.from_config(cfg).atmosphere.levels["density_kgm3"]
        assert (rho[0] < 0.995 * dry[0]) if humid else np.array_equal(rho, dry)
    problem_copy.write_text(text.replace("[atmosphere]\n", '[atmosphere]\nhumidity = "no"\n'))
    with pytest.raises(InputError, match="humidity"):
        load_problem(problem_copy)
    pm = load_point_mass(PROBLEMS / "realdata-skyderby-411")
    for humid in (True, False):
        rho = atmosphere_of(dataclasses.replace(pm, sounding=LIST, humidity=humid)).levels["density_kgm3"]
        assert (rho[0] < 0.995 * dry[0]) if humid else np.array_equal(rho, dry)
    kinematic = (PROBLEMS / "realdata-fs2-chicago-kinematic" / "problem.toml").read_text()
    assert "[atmosphere]" not in kinematic
    copy = problem_copy.parent / "kinematic.toml"
    copy.write_text(kinematic.replace('"../realdata-fs2-chicago/', f'"{PROBLEMS}/realdata-fs2-chicago/')
                    + '\n[atmosphere]\nsounding = "humid.txt"\nhumidity = false\n')
    assert load_kinematic(copy).humidity is False
