"""casrecon.analysis.kinematic_check.compare_coefficients: the implied coefficients of a kinematic fit
against a dynamic fit's best-fit ones (tables made here; the whole check on a drop is in
tests/slow/test_kinematic_check_cli.py)."""

import numpy as np

from casrecon.analysis import aero_columns as cols
from casrecon.analysis.implied_aero import IMPLIED, implied_columns
from casrecon.analysis.kinematic_check import CHECKED, FLAG_SHARE, check_columns, compare_coefficients


def tables(offset_cm: float, seed: int = 0):
    """Implied and dynamic tables of one truth with independent errors inside their bands; the
    implied Cm shifted by ``offset_cm``."""
    rng = np.random.default_rng(seed)
    t_dyn, t_kin = np.linspace(0.0, 40.0, 2001), np.linspace(0.5, 39.5, 400)
    truth = {c: 0.1 * np.sin(t_dyn * (i + 1)) for i, c in enumerate(cols.COEFFICIENTS)}
    dynamic = {cols.TIME_IMU: t_dyn}
    implied = {name: np.zeros(t_kin.size) for name in implied_columns()}
    implied[cols.TIME_IMU] = t_kin
    for c in cols.COEFFICIENTS:
        dynamic[cols.column(c, cols.BEST_FIT)] = truth[c] + rng.normal(0, 0.001, t_dyn.size)
        dynamic[cols.sigma_column(c, cols.BEST_FIT)] = np.full(t_dyn.size, 0.003)
        at_kin = np.interp(t_kin, t_dyn, truth[c])
        implied[cols.column(c, IMPLIED)] = at_kin + rng.normal(0, 0.002, t_kin.size) + (offset_cm if c == "Cm" else 0)
        implied[cols.sigma_column(c, IMPLIED)] = np.full(t_kin.size, 0.006)
    return implied, dynamic


def test_an_agreeing_model_is_not_flagged():
    check = compare_coefficients(*tables(0.0))
    assert check.flagged == ()
    assert set(check.beyond_share) == set(CHECKED)
    assert max(check.beyond_share.values()) <= FLAG_SHARE
    assert "agrees" in check.verdict()
    assert tuple(check.table) == check_columns() and check.table[cols.TIME_IMU].size == 400


def test_a_model_off_beyond_the_bands_is_flagged_and_named():
    check = compare_coefficients(*tables(0.03))          # 4.5 combined sigma
    assert check.flagged == ("Cm",)
    assert check.beyond_share["Cm"] > 0.5 and check.max_abs_z["Cm"] > 4
    assert "DISAGREES" in check.verdict() and "Cm (" in check.verdict()
    doc = check.document()
    assert doc["flagged"] == ["Cm"] and doc["verdict"] == check.verdict()


def test_only_nodes_inside_the_dynamic_span_are_compared():
    implied, dynamic = tables(0.0)
    for name in dynamic:
        dynamic[name] = dynamic[name][:1001]              # the dynamic fit ends at 20 s
    check = compare_coefficients(implied, dynamic)
    assert check.table[cols.TIME_IMU].max() <= 20.0 + 1e-12
    assert check.table[cols.TIME_IMU].size == np.sum(implied[cols.TIME_IMU] <= 20.0) == 200
