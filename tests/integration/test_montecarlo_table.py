"""The ``[montecarlo]`` table of problem.toml: its 1-sigma sizes are the dispersions actually drawn
(sample standard deviations of the drawn inputs), its cases and seed are the defaults the command
line overrides, and a bad value or an unknown key is one located line with exit status 2."""

from __future__ import annotations

import json

import numpy as np
import pytest

from casrecon.analysis.montecarlo import run_montecarlo
from casrecon.cli import main
from casrecon.io.errors import InputError
from casrecon.io.problem import load_problem

#: Cases of the statistical check: the sample sd of N normals has a relative standard error of
#: 1/sqrt(2 (N - 1)) = 4.1 % at N = 300; 16 % is four of them.
N_CASES, REL_TOL = 300, 0.16
TABLE = f"""
[montecarlo]
cases = {N_CASES}
seed = 7
center = "truth"
h_agl_sigma_m = 20.0
velocity_sigma_mps = 0.5
euler_sigma_deg = 2.0
rate_sigma_dps = 10.0
aero_factor_sigma = 0.1
aero_factors = ["Cmq_mult", "CA_mult"]
wind_bias_sigma_mps = 1.5
density_factor_sigma = 0.02
"""
#: Drawn input column -> the table's 1-sigma.
EXPECTED_SD = {"h_agl_m": 20.0, "vel_n_mps": 0.5, "vel_e_mps": 0.5, "vel_d_mps": 0.5, "roll_deg": 2.0,
               "pitch_deg": 2.0, "yaw_deg": 2.0, "p_dps": 10.0, "q_dps": 10.0, "r_dps": 10.0, "Cmq_mult": 0.1,
               "CA_mult": 0.1, "wind_bias_n_mps": 1.5, "wind_bias_e_mps": 1.5, "density_factor": 0.02}


def with_table(problem_toml, table: str):
    """The problem folder of ``problem_toml`` with its ``[montecarlo]`` table replaced by ``table``."""
    text = problem_toml.read_text()
    text = text[:text.index("[montecarlo]")] if "[montecarlo]" in text else text
    problem_toml.write_text(text + table)
    return problem_toml.parent


def test_table_sets_the_drawn_dispersions(problem_copy):
    folder = with_table(problem_copy, TABLE)
    truth = load_problem(folder).truth
    mc = run_montecarlo(folder, history_dt_s=None)   # cases, seed and dispersions from the table
    assert mc.n_cases == N_CASES and mc.seed == 7
    assert mc.dispersions.h_agl_m == 20.0 and mc.dispersions.aero_factors == ("Cmq_mult", "CA_mult")
    for name, sd in EXPECTED_SD.items():
        assert np.std(mc[name], ddof=1) == pytest.approx(sd, rel=REL_TOL), name
    # factors not listed stay at the centre ([truth]) in every case
    assert np.all(mc["Cm_add"] == truth.dispersions["Cm_add"])
    assert np.all(mc["CN_add"] == truth.dispersions["CN_add"])
    # the code defaults (5 m, 3 deg/s) would be far outside the tolerance: the table is what is drawn
    assert abs(np.std(mc["h_agl_m"], ddof=1) / 5.0 - 1) > 1.0


def test_command_line_overrides_the_table(problem_copy, tmp_path):
    folder = with_table(problem_copy, TABLE)
    out = tmp_path / "mc"
    assert main(["montecarlo", str(folder), "--out", str(out), "--cases", "4", "--seed", "2", "--center",
                 "nominal", "--workers", "1", "--no-figures", "--quiet"]) == 0
    stats = json.loads((out / "statistics.json").read_text())
    assert stats["n_cases"] == 4 and stats["seed"] == 2
    disp = stats["dispersions_1sigma"]
    assert disp["center"] == "nominal" and disp["h_agl_m"] == 20.0 and disp["wind_bias_mps"] == 1.5


@pytest.mark.parametrize("line, field, message", [
    ("h_agl_sigma_m = -1.0", "montecarlo.h_agl_sigma_m", "expected a number >= 0.0, got -1.0"),
    ("rate_sigma_dps = \"3\"", "montecarlo.rate_sigma_dps", "expected a number"),
    ("aero_factors = [\"CA_mult\", \"Cmq_mul\"]", "montecarlo.aero_factors", "unknown factor 'Cmq_mul'"),
    ("cases = 0", "montecarlo.cases", "expected an integer >= 1, got 0"),
    ("center = \"median\"", "montecarlo.center", "expected one of truth, nominal"),
    ("mass_sigma_kg = 0.1", "montecarlo.mass_sigma_kg", "unknown field"),
])
def test_bad_table_is_a_located_error(problem_copy, tmp_path, capsys, line, field, message):
    folder = with_table(problem_copy, f"\n[montecarlo]\n{line}\n")
    with pytest.raises(InputError) as err:
        load_problem(folder)
    assert err.value.field == field and message in err.value.message
    capsys.readouterr()
    assert main(["montecarlo", str(folder), "--out", str(tmp_path / "mc"), "--cases", "3", "--workers", "1"]) == 2
    lines = capsys.readouterr().err.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith(f"casrecon: {problem_copy}: field '{field}': ") and message in lines[0]
    assert not (tmp_path / "mc").exists()
