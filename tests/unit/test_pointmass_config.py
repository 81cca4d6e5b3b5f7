"""``problem.toml`` of GPS-only (point-mass) problems: the shipped real-data problems load, every
malformed copy is an InputError naming problem.toml and the dotted field, ``problem_kind``
dispatches, and each loader refuses the other kind by naming ``problem.kind``."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from casrecon.cli import main
from casrecon.io.errors import InputError
from casrecon.io.pointmass_problem import (
    DragConfig,
    GpsQuality,
    ModelErrorConfig,
    SegmentConfig,
    load_point_mass,
)
from casrecon.io.problem import load_problem
from casrecon.io.problem_file import problem_kind

REPO = Path(__file__).resolve().parents[2]
PROBLEMS = REPO / "problems"
REALDATA = ("realdata-fs1-byron", "realdata-skyderby-411", "realdata-fs2-chicago")


@pytest.mark.parametrize("name", REALDATA)
def test_shipped_realdata_problems_load(name):
    cfg = load_point_mass(PROBLEMS / name)
    assert cfg.name == name
    assert cfg.path == (PROBLEMS / name / "problem.toml").resolve()
    assert cfg.gps_file.is_file() and cfg.gps_file.parent == cfg.path.parent
    assert cfg.sounding is None and cfg.wind_3sigma_mps == 3.0
    assert cfg.mass_kg == 80.0
    assert cfg.drag == DragConfig(model="spline", knot_spacing_s=2.0, smoothness_sigma_m2=0.02, lift=True)
    assert cfg.quality == GpsQuality()
    assert cfg.segment == SegmentConfig()
    assert abs(cfg.site.lat_deg) < 90
    assert problem_kind(PROBLEMS / name) == "point-mass"
    assert problem_kind(PROBLEMS / name / "problem.toml") == "point-mass"
    # the file form and the folder form are the same problem
    assert load_point_mass(PROBLEMS / name / "problem.toml") == cfg


def test_problem_kind_of_six_dof_problems():
    assert problem_kind(PROBLEMS / "ees-drop-1") == "six-dof"     # no kind: six-dof


MINIMAL = """\
[problem]
kind = "point-mass"
name = "t"

[site]
lat_deg = 40.0
lon_deg = -105.0
ground_alt_msl_m = 1500.0

[atmosphere]
sounding = "standard"

[vehicle]
mass_kg = 80.0

[drag]
model = "constant"
knot_spacing_s = 2.0

[gps]
file = "track.csv"

[segment]
start_utc = "2024-06-01T12:00:05Z"
end_utc = "2024-06-01T12:00:40Z"
"""


@pytest.fixture()
def write(tmp_path):
    (tmp_path / "track.csv").write_text("not read by the loader\n")

    def _write(text: str) -> Path:
        p = tmp_path / "problem.toml"
        p.write_text(text)
        return p

    return _write


def test_minimal_problem_and_defaults(write):
    cfg = load_point_mass(write(MINIMAL))
    assert cfg.drag.model == "constant" and cfg.drag.lift is False
    assert cfg.segment.end_unix_s - cfg.segment.start_unix_s == pytest.approx(35.0)
    assert cfg.segment.start_unix_s == pytest.approx(1717243205.0)
    assert (cfg.linear_solver, cfg.max_iter, cfg.tol) == ("mumps", 200, 1e-8)
    # [drag] and [segment] may be left out entirely
    text = MINIMAL.split("[drag]")[0] + '[gps]\nfile = "track.csv"\n'
    cfg = load_point_mass(write(text))
    assert cfg.drag == DragConfig() and cfg.segment == SegmentConfig()
    assert cfg.model_error == ModelErrorConfig() and not cfg.model_error.enabled
    cfg = load_point_mass(write(MINIMAL + "\n[model_error]\ndrag_area_fraction = 0.3\ntime_s = 1.5\n"))
    assert cfg.model_error == ModelErrorConfig(0.3, 0.0, 1.5) and cfg.model_error.enabled


def _replace(old: str, new: str) -> str:
    assert old in MINIMAL, old
    return MINIMAL.replace(old, new)


BAD = [
    # (what, text, dotted field, words of the message)
    ("missing mass", _replace("mass_kg = 80.0\n", ""), "vehicle.mass_kg", "required"),
    ("negative mass", _replace("mass_kg = 80.0", "mass_kg = -80.0"), "vehicle.mass_kg", "positive|> 0|greater"),
    ("unknown drag model", _replace('model = "constant"', 'model = "quadratic"'), "drag.model", "quadratic"),
    ("negative knot spacing", _replace("knot_spacing_s = 2.0", "knot_spacing_s = -2.0"), "drag.knot_spacing_s",
     "positive|> 0|greater"),
    ("zero knot spacing", _replace("knot_spacing_s = 2.0", "knot_spacing_s = 0"), "drag.knot_spacing_s",
     "positive|> 0|greater"),
    ("bad start_utc", _replace('"2024-06-01T12:00:05Z"', '"yesterday noon"'), "segment.start_utc", "ISO-8601"),
    ("start_utc without zone", _replace('"2024-06-01T12:00:05Z"', '"2024-06-01T12:00:05"'), "segment.start_utc",
     "zone"),
    ("end before start", _replace('"2024-06-01T12:00:40Z"', '"2024-06-01T12:00:01Z"'), "segment.end_utc",
     "after start_utc"),
    ("end equal to start", _replace('"2024-06-01T12:00:40Z"', '"2024-06-01T12:00:05Z"'), "segment.end_utc",
     "after start_utc"),
    ("unknown key in drag", _replace("knot_spacing_s = 2.0", "knot_spacing = 2.0"), "drag.knot_spacing", ""),
    ("unknown key in segment", _replace('end_utc = "2024-06-01T12:00:40Z"', 'stop_utc = "2024-06-01T12:00:40Z"'),
     "segment.stop_utc", ""),
    ("unknown key in vehicle", _replace("mass_kg = 80.0", "mass_kg = 80.0\ncda_m2 = 0.3"), "vehicle.cda_m2", ""),
    ("unknown table", MINIMAL + "\n[aero]\ncd = 1.0\n", "aero", ""),
    ("missing gps file", _replace('file = "track.csv"', 'file = "nowhere.csv"'), "gps.file", ""),
    ("missing gps table", _replace('[gps]\nfile = "track.csv"\n', ""), "gps", "required"),
    ("missing site latitude", _replace("lat_deg = 40.0\n", ""), "site.lat_deg", "required"),
    ("latitude out of range", _replace("lat_deg = 40.0", "lat_deg = 140.0"), "site.lat_deg", "90"),
    ("no sounding", _replace('sounding = "standard"\n', ""), "atmosphere.sounding", "required"),
    ("negative min_speed", MINIMAL + "min_speed_mps = -3.0\n", "segment.min_speed_mps", ""),
    ("negative end margin", MINIMAL + "end_margin_s = -0.5\n", "segment.end_margin_s", ""),
    ("negative max_h_acc", _replace('file = "track.csv"', 'file = "track.csv"\nmax_h_acc_m = -1.0'),
     "gps.max_h_acc_m", ""),
    ("string mass", _replace("mass_kg = 80.0", 'mass_kg = "80"'), "vehicle.mass_kg", ""),
    ("unknown kind", _replace('kind = "point-mass"', 'kind = "four-dof"'), "problem.kind", "four-dof"),
    ("unknown linear solver", MINIMAL + '\n[estimation]\nlinear_solver = "ma57"\n', "estimation.linear_solver",
     "ma57"),
    ("negative drag-area fraction", MINIMAL + "\n[model_error]\ndrag_area_fraction = -0.1\n",
     "model_error.drag_area_fraction", ">= 0"),
    ("negative lift-area sigma", MINIMAL + "\n[model_error]\nlift_area_sigma_m2 = -0.01\n",
     "model_error.lift_area_sigma_m2", ">= 0"),
    ("zero model-error time", MINIMAL + "\n[model_error]\ndrag_area_fraction = 0.3\ntime_s = 0\n",
     "model_error.time_s", "positive|> 0|greater"),
    ("unknown key in model_error", MINIMAL + "\n[model_error]\nsigma = 1.0\n", "model_error.sigma", ""),
]


@pytest.mark.parametrize("what, text, field, words", BAD, ids=[b[0] for b in BAD])
def test_malformed_problem_is_a_located_input_error(write, what, text, field, words):
    path = write(text)
    with pytest.raises(InputError) as info:
        load_point_mass(path)
    err = info.value
    assert err.field == field, (what, str(err))
    assert Path(err.path).name == "problem.toml"
    assert str(err).startswith(str(path)) or str(err).startswith(err.path)
    assert f"'{field}'" in str(err) and "\n" not in str(err)
    if words:
        assert re.search(words, err.message), (what, err.message)


def test_toml_syntax_error_is_located(write):
    with pytest.raises(InputError) as info:
        load_point_mass(write(MINIMAL.replace("mass_kg = 80.0", "mass_kg = = 80.0")))
    assert Path(info.value.path).name == "problem.toml"
    assert info.value.line is not None


def test_six_dof_loader_refuses_a_point_mass_problem():
    with pytest.raises(InputError) as info:
        load_problem(PROBLEMS / "realdata-fs1-byron")
    assert info.value.field == "problem.kind"
    assert "point-mass" in info.value.message
    assert Path(info.value.path).name == "problem.toml"


def test_scenario_refuses_a_point_mass_problem():
    from casrecon.scenario import Scenario

    with pytest.raises(InputError, match="problem.kind"):
        Scenario.load(PROBLEMS / "realdata-fs1-byron")


def test_point_mass_loader_refuses_a_six_dof_problem():
    with pytest.raises(InputError) as info:
        load_point_mass(PROBLEMS / "ees-drop-1")
    assert info.value.field == "problem.kind"
    assert "six-dof" in info.value.message


def test_cli_simulate_of_a_point_mass_problem_is_exit_2(tmp_path, capsys):
    assert main(["simulate", str(PROBLEMS / "realdata-fs1-byron"), "--out", str(tmp_path / "x")]) == 2
    err = capsys.readouterr().err
    assert err.startswith("casrecon: ") and "problem.kind" in err and err.count("\n") == 1
    assert not (tmp_path / "x").exists()


def test_cli_fit_of_a_malformed_point_mass_problem_is_exit_2(write, tmp_path, capsys):
    path = write(_replace('model = "constant"', 'model = "quadratic"'))
    assert main(["fit", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "drag.model" in err and "problem.toml" in err
    assert not (tmp_path / "out").exists()
