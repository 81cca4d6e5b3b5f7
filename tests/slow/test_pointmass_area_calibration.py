"""Calibration of the GPS-only fit with area processes over 30 seeds of its own model
(``pointmass_truth``: drag area 0.25 m^2 times exp(0.12 u), lift areas 0.03 m^2 u, 1 s), with white
GPS noise and with the default Gauss-Markov GPS errors (drawn and modelled), about 45 s each.

Measured when written, white noise (seeds 100-129): 30 of 30 verdicts trusted; the innovations' reduced
chi-square per channel, pooled, 0.99 to 1.02 and their lag-1 -0.03 to +0.01; the mean drag area's z
RMS 0.97; the drawn areas inside their 3-sigma bands at 99.6 % of node components. Default
Gauss-Markov GPS errors (same seeds): 30 of 30 trusted, pooled chi-square 1.00 to 1.03, lag-1 -0.02
to +0.01, CdA z RMS 0.99, areas inside at 99.6 % (an exploration on seeds 200-233 had one untrusted
of 32: Ljung-Box p 1.2e-5 on east position). Bounds: the
verdict is built to be wrong at most 1 % of the time on an exact model, so at most 2 of 30 untrusted
(3 would have probability about 0.3 %); a pooled chi-square over about 6600 innovations has a
standard deviation of 0.017, so [0.93, 1.07] is 4 of them; the z RMS of 30 values is 1 +- 0.13.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from pointmass_truth import CDA, SIGMA_M2, write_problem

from casrecon.analysis.fit_adequacy import pointmass_adequacy
from casrecon.estimation.pointmass.fit import fit_point_mass
from casrecon.io.pointmass_problem import load_point_mass
from casrecon.physics.sensor_errors import GpsErrorModel

SEEDS = range(100, 130)


@pytest.mark.slow
@pytest.mark.parametrize("gps_errors", [None, GpsErrorModel()], ids=["white", "gauss-markov"])
def test_innovations_sigmas_and_bands_are_calibrated(tmp_path: Path, gps_errors):
    trusted, chi2, lag1, z_cda, inside = 0, [], [], [], []
    for seed in SEEDS:
        path, _, areas = write_problem(tmp_path / f"s{seed}", seed, SIGMA_M2, gps_errors)
        r = fit_point_mass(load_point_mass(path))
        assert r.solver.converged, (seed, r.solver.status)
        verdict = pointmass_adequacy(r)
        trusted += verdict.trusted
        chi2.append([c.reduced_chi2 * c.n for c in verdict.channels])
        lag1.append([c.lag1 for c in verdict.channels])
        n = [c.n for c in verdict.channels]
        names = [s.name for s in r.params.specs]
        z_cda.append((r.values[names.index("CdA")] - CDA) / r.sigma[names.index("CdA")])
        inside.append(np.abs((r.areas - areas) / r.area_sigma) < 3)
    pooled = np.sum(chi2, axis=0) / (np.array(n) * len(SEEDS))
    z_rms = float(np.sqrt(np.mean(np.square(z_cda))))
    coverage = float(np.mean(np.concatenate(inside)))
    print(f"trusted {trusted} of {len(SEEDS)}; pooled innovation reduced chi2 {np.round(pooled, 3)}; mean lag-1 "
          f"{np.round(np.mean(lag1, axis=0), 3)}; CdA z RMS {z_rms:.2f}; areas inside 3 sigma {coverage:.4f}")
    assert trusted >= len(SEEDS) - 2
    assert np.all(np.abs(pooled - 1) < 0.07), pooled
    assert np.all(np.abs(np.mean(lag1, axis=0)) < 0.05)
    assert 0.6 < z_rms < 1.4
    assert coverage >= 0.99
