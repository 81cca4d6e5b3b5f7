"""The truth trajectory reader (issue 52): ``flight_time_s`` in the files ``casrecon simulate`` writes
now, ``time_s`` in older ones (the shipped problems' ``data/trajectory.csv``), both read as
``flight_time_s``; anything else a located InputError."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest
from conftest import PROBLEMS

from casrecon.io.errors import InputError
from casrecon.io.truth_trajectory import read_truth_trajectory


def test_an_older_folder_with_time_s_loads_under_the_new_name():
    path = PROBLEMS / "ees-drop-1" / "data" / "trajectory.csv"
    assert pd.read_csv(path, nrows=1).columns[0] == "time_s"  # written before issue 52
    tr = read_truth_trajectory(path)
    raw = pd.read_csv(path)
    assert "time_s" not in tr and tr.columns[0] == "flight_time_s"
    np.testing.assert_array_equal(tr["flight_time_s"], raw["time_s"])
    np.testing.assert_array_equal(tr["pos_d_m"], raw["pos_d_m"])
    assert tr["utc"].dt.tz is not None
    seconds = (tr["utc"] - pd.Timestamp(0, tz="UTC")).dt.total_seconds()
    np.testing.assert_allclose(seconds, tr["time_unix_s"], rtol=0, atol=1e-6)


def test_the_new_name_loads_as_written(tmp_path):
    path = tmp_path / "trajectory.csv"
    path.write_text("flight_time_s,time_unix_s,pos_d_m\n0,100.5,-10\n0.5,101,-12.5\n")
    tr = read_truth_trajectory(path)
    assert list(tr.columns) == ["flight_time_s", "time_unix_s", "pos_d_m"]
    np.testing.assert_array_equal(tr["pos_d_m"], [-10.0, -12.5])


@pytest.mark.parametrize(("text", "match"), [
    ("t,pos_d_m\n0,1\n", r"trajectory.csv:1: no flight-time column: expected 'flight_time_s' \(or 'time_s'"),
    ("flight_time_s,pos_d_m\n0,1\n0.5,x\n", r"trajectory.csv:3: field 'pos_d_m': expected a number, got 'x'"),
])
def test_a_file_without_a_flight_time_or_with_a_bad_cell_is_refused_naming_where(tmp_path, text, match):
    path = tmp_path / "trajectory.csv"
    path.write_text(text)
    with pytest.raises(InputError, match=match):
        read_truth_trajectory(path)
