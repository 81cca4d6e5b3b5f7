"""docs/tutorial.md's vehicle, aero and problem files, written beside data made by
``casrecon simulate --data`` (the shipped ees-drop-1 data), parse with ``load_problem`` and
describe those data files; ``casrecon inspect`` reads each data file. No fit is run."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from casrecon.cli import main
from casrecon.io.imu import read_imu_csv
from casrecon.io.problem import load_problem

REPO = Path(__file__).resolve().parents[2]
TUTORIAL = REPO / "docs" / "tutorial.md"
DATA = REPO / "problems" / "ees-drop-1"        # data/ made by `casrecon simulate --data`


def tutorial_files() -> dict[str, str]:
    """The fenced blocks marked ``<!-- tutorial-file: NAME -->`` in the tutorial, by file name."""
    text = TUTORIAL.read_text(encoding="utf-8")
    blocks = re.findall(r"<!-- tutorial-file: (\S+) -->\n```toml\n(.*?)```", text, flags=re.S)
    return dict(blocks)


@pytest.fixture()
def drop_folder(tmp_path: Path) -> Path:
    folder = tmp_path / "my-drop"
    folder.mkdir()
    for name, src in (("imu.csv", DATA / "data" / "imu.csv"), ("gps.csv", DATA / "data" / "gps.csv"),
                      ("sounding.csv", DATA / "sounding.csv")):
        shutil.copy(src, folder / name)
    for name, text in tutorial_files().items():
        (folder / name).write_text(text, encoding="utf-8")
    return folder


def test_tutorial_has_the_three_files():
    assert set(tutorial_files()) == {"vehicle.toml", "aero.toml", "problem.toml"}


def test_tutorial_problem_parses_and_names_the_data(drop_folder):
    cfg = load_problem(drop_folder)
    assert cfg.name == "my-drop"
    assert cfg.imu.file == (drop_folder / "imu.csv").resolve() and cfg.imu.file.is_file()
    assert cfg.gps.file == (drop_folder / "gps.csv").resolve() and cfg.gps.file.is_file()
    assert cfg.atmosphere.sounding == (drop_folder / "sounding.csv").resolve()
    assert cfg.vehicle.name == "My capsule" and cfg.aero.coefficients.CA0 == 0.83
    assert cfg.truth is None                       # a real drop: no [truth]
    # the declared columns and units read the IMU file, and the gyro limits flag its clipped samples
    log = read_imu_csv(cfg.imu.file, cfg.imu.spec)
    assert log.time_s.size > 10000 and log.gyro_saturated.any()


@pytest.mark.parametrize("name", ("imu.csv", "gps.csv", "sounding.csv"))
def test_inspect_reads_each_data_file(drop_folder, name, capsys):
    assert main(["inspect", str(drop_folder / name)]) == 0
    assert str(drop_folder / name) in capsys.readouterr().out
