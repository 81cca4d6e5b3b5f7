"""The impact as a measurement of altitude (``[estimation] impact_ground_sigma_m``,
:mod:`casrecon.estimation.kinds.ground`).

ees-drop-1 (synthetic, flies its sounding; the simulated impact is the centre of mass at the site's
ground): with the ground known to 0.5 m the measurement agrees with the fit (residual within its
sigma) and the verdict trusts it; with the ground said to be 20 m higher than it is, the verdict
names the impact against the measured ground, and the reasons name the cause; a fit window ending
more than 2 s before the impact, and an altitude without its sigma, are errors naming the key.
Measured on adding it: residual +0.16 m (sigma 0.51 m), trusted; 20 m off: "impact 20.1 m below the
measured ground (limit 1.5 m)".
"""

from __future__ import annotations

import dataclasses

import pytest
from conftest import PROBLEMS

from casrecon.analysis.fit_products import other_kind_residuals, result_adequacy
from casrecon.estimation.sixdof.fit import FitError, fit_drop
from casrecon.io.errors import InputError
from casrecon.io.problem import load_problem
from casrecon.scenario import Scenario

SIGMA_M = 0.5


def _with(**estimation) -> Scenario:
    cfg = Scenario.load(PROBLEMS / "ees-drop-1").config
    return Scenario.from_config(dataclasses.replace(cfg, estimation=dataclasses.replace(cfg.estimation, **estimation)))


@pytest.fixture(scope="module")
def measured():
    return fit_drop(_with(impact_ground_sigma_m=SIGMA_M))


def test_the_impact_agrees_with_an_exact_drop(measured):
    columns = other_kind_residuals(measured)["ground"]
    assert columns["height_sigma_m"][0] == pytest.approx(SIGMA_M, rel=0.05)   # plus one IMU sample of timing
    assert abs(columns["height_residual_m"][0]) < columns["height_sigma_m"][0]
    verdict = result_adequacy(measured)
    assert verdict.trusted, verdict.line


def test_a_wrong_ground_is_named():
    site = Scenario.load(PROBLEMS / "ees-drop-1").config.site.ground_alt_msl_m
    result = fit_drop(_with(impact_ground_sigma_m=SIGMA_M, impact_ground_alt_msl_m=site + 20.0))
    verdict = result_adequacy(result)
    assert not verdict.trusted
    assert any("below the measured ground" in r for r in verdict.reasons), verdict.reasons
    assert "impact_ground_sigma_m" in verdict.line


def test_a_window_ending_long_before_the_impact_is_an_error():
    with pytest.raises(FitError, match=r"impact_ground_sigma_m: the fit window ends 3\.00 s before the impact"):
        fit_drop(_with(impact_ground_sigma_m=SIGMA_M, end_before_impact_s=3.0))


def test_an_altitude_without_its_sigma_is_an_input_error(problem_copy):
    text = problem_copy.read_text().replace("[estimation]\n", "[estimation]\nimpact_ground_alt_msl_m = 1310.0\n")
    assert "impact_ground_alt_msl_m" in text
    problem_copy.write_text(text)
    with pytest.raises(InputError, match=r"impact_ground_alt_msl_m.*give impact_ground_sigma_m with it"):
        load_problem(problem_copy.parent)


def test_a_sigma_that_is_not_positive_is_an_input_error(problem_copy):
    text = problem_copy.read_text().replace("[estimation]\n", "[estimation]\nimpact_ground_sigma_m = 0.0\n")
    problem_copy.write_text(text)
    with pytest.raises(InputError, match=r"impact_ground_sigma_m"):
        load_problem(problem_copy.parent)
