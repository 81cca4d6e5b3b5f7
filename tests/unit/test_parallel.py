"""casrecon.parallel: input order, chunking, in-process and spawned runners, the progress bar."""

from __future__ import annotations

import math
import os

import pytest

from casrecon.parallel import Progress, parallel_map


def test_in_process_keeps_order_and_chunking_changes_nothing():
    items = list(range(11))
    assert parallel_map(math.sqrt, items) == [math.sqrt(i) for i in items]
    assert parallel_map(math.sqrt, items, chunksize=4) == [math.sqrt(i) for i in items]
    assert parallel_map(math.sqrt, []) == []


def test_spawned_processes_return_in_input_order():
    items = list(range(7))
    assert parallel_map(math.factorial, items, workers=2, chunksize=2) == [math.factorial(i) for i in items]


def test_one_worker_runs_in_this_process():
    assert parallel_map(lambda _: os.getpid(), range(3)) == [os.getpid()] * 3


def test_progress_counts_weighted_units(capsys):
    parallel_map(len, [(1, 2), (3,), ()], progress="demo", weight=len)
    err = capsys.readouterr().err
    assert "demo [" in err and "3/3 cases" in err and err.endswith("\n")
    bar = Progress(4, enabled=False)
    bar.update(3)
    assert bar.done == 3 and capsys.readouterr().err == ""


def test_bad_chunksize_is_rejected():
    with pytest.raises(ValueError, match="chunksize"):
        parallel_map(abs, [1], chunksize=0)
