"""A fit the verdict does not trust publishes widened sigmas and bands that cover the truth
(analysis/widened_uncertainty.py; issue 49): ees-drop-1 with its IMU noise stated five times
smaller than the data's, a noise model the data do not follow."""

import shutil
from pathlib import Path

import numpy as np
import pytest

import casrecon
from casrecon.analysis.fit_products import result_adequacy
from casrecon.analysis.position_floor import position_floor_m
from casrecon.analysis.widened_uncertainty import published_result
from casrecon.estimation.sixdof.diagnostics import gps_residuals
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import truth_parameters_by_name

PROBLEMS = Path(__file__).resolve().parents[2] / "problems"


@pytest.fixture(scope="module")
def understated(tmp_path_factory) -> Path:
    root = tmp_path_factory.mktemp("understated")
    for name in ("vehicles", "aero"):
        shutil.copytree(PROBLEMS / name, root / name)
    problem = root / "ees-drop-1"
    shutil.copytree(PROBLEMS / "ees-drop-1", problem)
    toml = problem / "problem.toml"
    text = toml.read_text()
    for old, new in (("accel_noise_mps2 = 0.05", "accel_noise_mps2 = 0.01"),
                     ("gyro_noise_dps = 0.10", "gyro_noise_dps = 0.02")):
        assert old in text
        text = text.replace(old, new)
    toml.write_text(text)
    return problem


def test_widened_sigmas_cover_what_the_model_sigmas_miss(understated):
    scenario = Scenario.load(understated)
    truth = truth_parameters_by_name(scenario)
    model = fit_drop(scenario)
    verdict = result_adequacy(model)
    assert not verdict.trusted
    z_model = np.array([(model.values[i] - truth[n]) / model.sigma[i] for i, n in enumerate(model.params.names)])
    assert np.max(np.abs(z_model)) > 6.0  # the failure: the model's sigmas are five times too narrow
    wide, widening = published_result(model, verdict.trusted)
    assert widening is not None and widening.excess > 5.0
    np.testing.assert_array_equal(wide.values, model.values)  # only the uncertainty changes
    assert wide.uncertainty == "widened" and model.uncertainty == "model"
    assert np.all(wide.sigma >= model.sigma * (1 - 1e-9))
    assert np.all(wide.table_sigma >= model.table_sigma * (1 - 1e-9))
    z = np.array([(wide.values[i] - truth[n]) / wide.sigma[i] for i, n in enumerate(wide.params.names)])
    assert np.max(np.abs(z)) < 4.5
    note = next(n for n in wide.notes if n.startswith("uncertainty widened"))
    assert "the verdict does not trust" in note and "local excess of the gyro and GPS residuals" in note
    # the absolute position's bands at least what the GPS fixes alone say (position_floor): one fix's
    # accuracy at least (the median 1-sigma of the fixes, as the fit weighted them)
    floors = position_floor_m(model)
    fix_sigma = np.nanmedian(gps_residuals(model)["sigma"][:, :3], axis=0)
    assert np.all(floors >= fix_sigma * (1 - 1e-12))
    for column, floor in zip(("pos_n_m", "pos_e_m", "pos_d_m"), floors):
        assert np.all(wide.column(column)[1] >= floor * (1 - 1e-12))
    assert any(n.startswith("absolute position:") for n in wide.notes)
    # a trusted fit publishes what it fitted (unless its sandwich says otherwise: here it does)
    same, again = published_result(model, True)
    assert again is not None and any("the verdict trusts the fit, but" in n for n in same.notes)
    # the pipeline publishes the widened sigmas and says so in its report
    fit = casrecon.fit(understated)
    assert fit.params["CA_mult"].stderr == pytest.approx(wide.sigma[wide.params.index("CA_mult")], rel=1e-6)
    report = fit.report()
    assert "uncertainty widened for errors the model does not contain" in report
    assert "NOT to be trusted" in report
