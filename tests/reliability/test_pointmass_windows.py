"""Hand-chosen segments of a GPS-only fit (issue 50) on the shipped Skydive Chicago track: a window that
runs past the canopy opening is refused, located at [segment] end_utc and naming when the opening
began (it fitted with exit 0, a wind of -20.9 m/s and a drag area up to 8.2 m^2); a window that never
reaches a steady fall (a hop-and-pop) says so in its notes."""

from __future__ import annotations

from pathlib import Path

import pytest

from casrecon.estimation.pointmass.fit import prepare_data
from casrecon.io.errors import InputError
from casrecon.io.pointmass_problem import load_point_mass

from .conftest import PROBLEMS, assert_clean_failure, call_cli

FOLDER = PROBLEMS / "realdata-fs2-chicago"
#: The automatic segment of the shipped problem (its notes: 38.1 s ending 0.5 s before the final drop
#: began) and the fix where that drop began, UTC.
START, END, OPENING = "2024-09-17T19:25:22.700Z", "2024-09-17T19:26:00.800Z", "2024-09-17T19:26:01.300Z"


def windowed(tmp_path: Path, start: str, end: str) -> Path:
    text = (FOLDER / "problem.toml").read_text().replace('file = "TRACK.CSV"', f'file = "{FOLDER / "TRACK.CSV"}"')
    (tmp_path / "problem.toml").write_text(text + f'\n[segment]\nstart_utc = "{start}"\nend_utc = "{end}"\n')
    return tmp_path


def test_a_window_4_s_past_the_opening_is_refused_naming_it(tmp_path, capsys):
    folder = windowed(tmp_path, START, "2024-09-17T19:26:05.300Z")
    with pytest.raises(InputError) as err:
        prepare_data(load_point_mass(folder))
    e = err.value
    assert e.field == "segment.end_utc" and e.path == str((folder / "problem.toml").resolve())
    assert f"began at {OPENING}" in e.message and "4.0 s after" in e.message, e.message
    assert "at or before 2024-09-17T19:26:00.800Z" in e.message
    proc = call_cli(capsys, "fit", folder, "--out", tmp_path / "out", "--no-figures")
    assert_clean_failure(proc, 2, "segment.end_utc", OPENING)
    assert not (tmp_path / "out").exists()
    # the segment the data give, given by hand, ends before the opening: it passes, with no other note
    data = prepare_data(load_point_mass(windowed(tmp_path, START, END)))
    assert not any("steady fall" in n for n in data.notes)


def test_a_hop_and_pop_window_says_its_drag_area_is_the_exit_transient(tmp_path):
    """The jump's first 8 s after exit: still accelerating at 0.8 g at the end."""
    data = prepare_data(load_point_mass(windowed(tmp_path, START, "2024-09-17T19:25:30.700Z")))
    note = next(n for n in data.notes if n.startswith("the segment never reaches a steady fall"))
    assert "dominated by the exit transient" in note
    assert float(note.split("is at least ")[1].split(" m/s^2")[0]) > 5.0
