"""A drop flown through the sounding's air lying 25 m higher than its file says (a radiosonde's
height error, or its profile risen between balloon and drop): with the sounding's altitude shift
estimated (``[atmosphere] sounding_shift_sigma_m``) the shift, the aero and the absolute altitude
are recovered within their sigmas; held at zero (the default), the fit cannot follow the data and
runs its clock to its plausibility limit, where it is held, and the verdict says so.

ees-drop-1 (no profile-error model, white GPS), seed 5. Measured on adding the parameter:
estimated, the shift 25.24 +- 0.26 m (z 0.9), pos_d 0.22 to 0.27 m off with a band sigma of 0.26 m,
the largest parameter |z| 2.9 (CN_add); held, the clock offset ran to +0.156 s and the fit
stopped (a FitError); now it is held at +0.150 s (3 sigma of its prior) and the verdict names it.
"""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest
from conftest import PROBLEMS

from casrecon.analysis.fit_products import result_adequacy
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.io.sounding import read_sounding
from casrecon.physics.atmosphere import Atmosphere, AtmosphereCorrections
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import synthetic_scenario, truth_parameters_by_name

SHIFT_M = 25.0


def _with(scenario: Scenario, shift_sigma_m: float) -> Scenario:
    cfg = scenario.config
    atm = dataclasses.replace(cfg.atmosphere, sounding_shift_sigma_m=shift_sigma_m)
    return Scenario.from_config(dataclasses.replace(cfg, atmosphere=atm))


@pytest.fixture(scope="module")
def fits(tmp_path_factory):
    folder = tmp_path_factory.mktemp("shift")
    plain = Scenario.load(PROBLEMS / "ees-drop-1")
    cfg = plain.config
    truth = dataclasses.replace(cfg.truth, sounding_shift_m=SHIFT_M)
    flown = Scenario.from_config(dataclasses.replace(cfg, truth=truth))
    data, syn = synthetic_scenario(flown, folder, seed=5)
    release = float(syn.truth["release_imu_time_s"])
    return {"truth": truth_parameters_by_name(data), "trajectory": syn.trajectory, "release": release,
            "estimated": fit_drop(_with(data, 20.0)), "held": _with(data, 0.0)}


def _pos_d(fits, result) -> tuple[np.ndarray, np.ndarray]:
    """(fitted minus true pos_d at the nodes, m; its band sigma, m)."""
    t = result.node_time_s - fits["release"]
    truth = np.interp(t, fits["trajectory"].time_s, fits["trajectory"].states[:, 2])
    value, sigma = result.column("pos_d_m")
    return value - truth, sigma


def test_the_shift_moves_the_sounding_up():
    atm = Atmosphere.from_sounding(read_sounding(Scenario.load(PROBLEMS / "ees-drop-1").config.atmosphere.sounding))
    shifted = atm.at(2000.0, AtmosphereCorrections(altitude_shift_m=SHIFT_M))
    plain = atm.at(2000.0 - SHIFT_M)
    for a, b in ((shifted.density, plain.density), (shifted.wind_ned, plain.wind_ned),
                 (shifted.temperature, plain.temperature)):
        assert np.allclose(np.asarray(a, float), np.asarray(b, float), rtol=0, atol=1e-12)


def test_estimated_the_shift_and_the_altitude_are_recovered(fits):
    r, truth = fits["estimated"], fits["truth"]
    z = {n: (r.parameter(n)[0] - truth[n]) / r.parameter(n)[1] for n in r.params.names}
    assert abs(z["sounding_shift_m"]) < 3.0, z
    assert max(abs(v) for v in z.values()) < 3.5, z
    diff, sigma = _pos_d(fits, r)
    assert np.mean(np.abs(diff) <= 3 * sigma) >= 0.98, (diff.min(), diff.max(), sigma.min())


def test_held_at_zero_the_clock_is_held_at_its_limit_and_the_verdict_says_so(fits):
    result = fit_drop(fits["held"])
    clock, _ = result.parameter("clock_offset_s")
    assert clock == pytest.approx(0.15, abs=1e-6)  # 3 sigma of its 0.05 s prior
    verdict = result_adequacy(result)
    assert not verdict.trusted
    assert any("clock offset is held at +0.150 s" in r and "does not fit the data" in r for r in verdict.reasons), \
        verdict.reasons
