"""Progress of the dispersed Monte Carlo: the bar counts each case as it lands inside its chunk (in
this process and on spawned workers), and at DEBUG each finished case is one log line instead."""

from __future__ import annotations

import logging
import re

import pytest
from conftest import PROBLEMS

import casrecon.progress as progress
from casrecon.analysis.montecarlo import LOG, run_cases

DROP1 = PROBLEMS / "ees-drop-1"


def bar_counts(err: str) -> list[int]:
    """The case counts of every progress line in ``err`` (stderr is not a terminal here: plain lines)."""
    return [int(n) for n in re.findall(r"^montecarlo: (\d+)/\d+ cases", err, flags=re.M)]


@pytest.mark.parametrize("workers, chunk", [(1, 24), (2, 12)])
def test_bar_moves_per_case_not_per_chunk(capsys, monkeypatch, workers, chunk):
    monkeypatch.setattr(progress, "PLAIN_INTERVAL_S", 0.0)  # a line at every count
    cols = run_cases(DROP1, range(24), 3, workers=workers, chunk_size=chunk, progress=True)
    assert cols["impacted"].all()
    counts = bar_counts(capsys.readouterr().err)
    assert counts[-1] == 24 and counts == sorted(counts)
    assert len(set(counts)) > 24 // chunk + 2   # per chunk would give one redraw per chunk


def test_debug_logs_one_line_per_case_instead_of_the_bar(capsys, caplog):
    with caplog.at_level(logging.DEBUG, logger=LOG.name):
        cols = run_cases(DROP1, range(5), 3, chunk_size=5, progress=True)
    lines = [r.getMessage() for r in caplog.records if r.name == LOG.name]
    assert [line.split(":")[0] for line in lines] == [f"montecarlo case {i}" for i in range(5)]
    assert lines[0] == (f"montecarlo case 0: impact after {cols['flight_time_s'][0]:.3f} s at "
                        f"{cols['impact_speed_mps'][0]:.2f} m/s")
    assert "\r" not in capsys.readouterr().err


def test_a_redirected_log_has_no_carriage_returns(capsys):
    cols = run_cases(DROP1, range(6), 3, chunk_size=6, progress=True)
    assert cols["impacted"].all()
    err = capsys.readouterr().err
    assert "\r" not in err
    assert bar_counts(err)[-1] == 6   # the last line says all cases are done
