"""The aerodynamic coefficient histories of a fit against the synthetic truth (ees-drop-1).

The truth coefficients are the aero database with the [truth] dispersions and atmosphere
corrections, evaluated along the simulated truth trajectory at the fit's nodes (the simulation that
made the data, on the IMU clock). Criteria, per coefficient and for the best-fit database and the
reconstruction from the IMU:

- the truth lies inside the 3-sigma band at >= 95 % of the nodes that have a value. With correct
  Gaussian bands 99.7 % would; the margin allows for the bands' node-to-node correlation (a few
  correlated excursions) and the linearisation, while bands half as wide would leave 12 to 15 % of
  every noise-dominated coefficient outside (measured: >= 99.3 % inside with the bands as computed,
  86 to 88 % with half of them);
- the bands are informative: for C_A and the crossflow-plane C_N and C_m the median 3-sigma is
  below 5 % of the truth's RMS (measured: 0.1 % to 3 %);
- the bands discriminate: the nominal database (dispersions 0; the truth has C_A 1.6 % above it)
  lies outside the best-fit C_A band at most nodes;
- the reconstruction has a value at >= 95 % of the nodes (drop 1's gyros saturate in its first
  second: the nodes whose filter window holds a saturated sample have none).
"""

from __future__ import annotations

import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.analysis import aero_columns as cols
from casrecon.analysis.aero_coefficients import aero_coefficients, coefficient_functions
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import simulate_truth

MIN_INSIDE = 0.95
MAX_BAND_OVER_RMS = 0.05
BANDED = ((cols.BEST_FIT, "best-fit database"), (cols.RECONSTRUCTED, "reconstruction"))


@pytest.fixture(scope="module")
def drop1():
    """(aero_coefficients columns, truth coefficients (K, 8)) of a fit of ees-drop-1."""
    scenario = Scenario.load(PROBLEMS / "ees-drop-1")
    result = fit_drop(scenario)
    table = aero_coefficients(result)
    traj, t_zero = simulate_truth(scenario)
    t = t_zero + traj.time_s
    idx = np.searchsorted(t, result.node_time_s - 1e-6)
    assert np.all(np.abs(t[idx] - result.node_time_s) < 1e-6), "nodes not on the truth grid"
    database, _ = coefficient_functions(scenario.model)
    k = idx.size
    truth = np.asarray(database.map(k)(traj.states[idx].T, np.tile(scenario.truth_parameters()[:, None], k),
                                       np.zeros((9, k)))).T
    return table, truth


@pytest.mark.parametrize("coefficient", cols.COEFFICIENTS)
def test_truth_inside_the_3_sigma_bands(drop1, coefficient):
    table, truth = drop1
    i = cols.COEFFICIENTS.index(coefficient)
    for variant, label in BANDED:
        value, three = table[cols.column(coefficient, variant)], table[cols.sigma_column(coefficient, variant)]
        ok = np.isfinite(value)
        inside = np.abs(value[ok] - truth[ok, i]) <= three[ok]
        assert inside.mean() >= MIN_INSIDE, (
            f"{coefficient} {label}: truth inside 3 sigma at {inside.mean():.1%} of {ok.sum()} nodes")


@pytest.mark.parametrize("coefficient", ["CA", "CN_crossflow", "Cm_crossflow"])
def test_bands_are_informative(drop1, coefficient):
    table, truth = drop1
    rms = np.sqrt(np.mean(truth[:, cols.COEFFICIENTS.index(coefficient)] ** 2))
    for variant, label in BANDED:
        median = np.nanmedian(table[cols.sigma_column(coefficient, variant)])
        assert median < MAX_BAND_OVER_RMS * rms, f"{coefficient} {label}: median 3 sigma {median:.3g}, rms {rms:.3g}"


def test_nominal_database_is_outside_the_best_fit_band(drop1):
    table, _ = drop1
    best, three = table[cols.column("CA", cols.BEST_FIT)], table[cols.sigma_column("CA", cols.BEST_FIT)]
    inside = np.abs(table[cols.column("CA", cols.NOMINAL)] - best) <= three
    assert inside.mean() < 0.5


def test_reconstruction_covers_the_window(drop1):
    table, _ = drop1
    ok = np.isfinite(table[cols.column("CA", cols.RECONSTRUCTED)])
    assert ok.mean() >= 0.95 and not ok.all()  # drop 1's saturated first second has no value
    assert set(table) == set(cols.all_columns())
