"""A barometer error the default model does not contain: a static-port position error, the sensor
reading p + k qbar with k = 0.01 (under 10 Pa at drop 1's 950 Pa peak qbar), on ees-drop-1-baro's
truth (about 1 min: one synthetic data set, two fits).

Without the position-error term the fit converges with white-looking pressure residuals, but the
clock offset and the bias absorb the error: this test records that the clock comes out more than
3 sigma off (measured 10.6 sigma with the shipped noise), so the failure is documented and cannot
silently disappear. With ``position_error_sigma`` set, the coefficient is estimated and every
parameter is back within 3 sigma of the truth.

Run: pytest -m slow tests/slow/test_baro_port_error.py -s
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import truth_parameters_by_name, with_synthetic_data


def z_scores(result, truth) -> dict[str, float]:
    return {n: (v - truth[n]) / s for n, v, s in zip(result.params.names, result.values, result.sigma)}


@pytest.mark.slow
def test_port_error_biases_the_clock_unless_estimated(tmp_path):
    base = Scenario.load(PROBLEMS / "ees-drop-1-baro")
    cfg = base.config
    truth_cfg = dataclasses.replace(cfg.truth, baro_qbar_coef=0.01)
    scenario = with_synthetic_data(Scenario.from_config(dataclasses.replace(cfg, truth=truth_cfg)), tmp_path,
                                   seed=cfg.truth.seed)
    truth = truth_parameters_by_name(scenario)

    plain = fit_drop(scenario)
    z_plain = z_scores(plain, truth)
    n = plain.n_measurements["baro"]
    print("without the term:", {k: round(v, 2) for k, v in z_plain.items()},
          "baro chi2/n", plain.chi2["baro"] / n)
    assert plain.converged
    assert abs(z_plain["clock_offset_s"]) > 3.0  # the documented failure: biased, and chi2 does not say so
    assert plain.chi2["baro"] / n < 1 + 4 * np.sqrt(2.0 / n)

    cfg2 = scenario.config
    with_term = Scenario.from_config(dataclasses.replace(
        cfg2, baro=dataclasses.replace(cfg2.baro, position_error_sigma=0.05)))
    fitted = fit_drop(with_term)
    z = z_scores(fitted, truth)
    print("with the term:", {k: round(v, 2) for k, v in z.items()})
    assert fitted.converged and "baro_qbar_coef" in z
    assert max(abs(v) for v in z.values()) < 3.0, z
