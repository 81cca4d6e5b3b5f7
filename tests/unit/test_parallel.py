"""casrecon.parallel: input order, chunking, in-process and spawned runners, the progress bar (moved by
the items themselves before they return), the per-item callback."""

from __future__ import annotations

import io
import math
import os
import re
import time

import numpy as np
import pytest

import casrecon.progress as progress
from casrecon.parallel import Forked, Progress, ProgressCounter, parallel_map, report_progress


def line_counts(err: str) -> list[int]:
    """The unit counts of every plain progress line (``label: done/total units, ...``) in ``err``."""
    return [int(n) for n in re.findall(r"^\w[\w -]*: (\d+)/\d+ ", err, flags=re.M)]


class Terminal(io.StringIO):
    """A stream that says it is a terminal (as stderr on a console)."""

    def isatty(self) -> bool:
        return True


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
    assert "demo: 3/3 cases" in err and err.endswith("\n")
    bar = Progress(4, enabled=False)
    bar.update(3)
    assert bar.done == 3 and capsys.readouterr().err == ""


def test_a_redirected_log_gets_plain_lines_at_an_interval_without_carriage_returns(capsys, monkeypatch):
    monkeypatch.setattr(progress, "PLAIN_INTERVAL_S", 0.1)
    assert parallel_map(units_slowly, [12], progress="demo", weight=lambda n: n) == [12]  # 30 ms a unit
    err = capsys.readouterr().err
    counts = line_counts(err)
    assert "\r" not in err and err.count("\n") == len(counts)
    assert counts[0] == 1 and counts[-1] == 12      # the first finished unit, and the end
    assert 3 <= len(counts) < 12                     # every 0.1 s, not every unit
    assert "left" not in err.splitlines()[0]         # no ETA from a single unit


def test_a_terminal_gets_a_tqdm_bar_and_no_eta_before_the_first_unit():
    out = Terminal()
    bar = Progress(200, label="demo", stream=out)
    time.sleep(0.3)                                  # a slow start (spawning workers) ...
    bar.update(1)                                    # ... then the first case
    first = out.getvalue()
    assert "\r" in first and "demo" in first and "1/200" in first
    assert "<?" in first                             # ETA unknown from one unit, not 0.3 s x 199
    for _ in range(199):
        bar.update(1)
    assert out.getvalue().endswith("\n") and "200/200" in out.getvalue() and Progress.active is None


def test_end_progress_line_closes_a_bar_cut_short():
    out = Terminal()
    bar = Progress(10, label="demo", stream=out)
    bar.update(3)
    assert Progress.active is bar and not out.getvalue().endswith("\n")
    progress.end_progress_line()
    assert out.getvalue().endswith("\n") and Progress.active is None


def test_bad_chunksize_is_rejected():
    with pytest.raises(ValueError, match="chunksize"):
        parallel_map(abs, [1], chunksize=0)


def units_slowly(n: int) -> int:
    """Report ``n`` units one by one, 30 ms apart (top level: spawned workers import it)."""
    for _ in range(n):
        time.sleep(0.03)
        report_progress(1)
    return n


@pytest.mark.parametrize("workers", [1, 2])
def test_items_move_the_bar_before_they_return(capsys, monkeypatch, workers):
    monkeypatch.setattr(progress, "PLAIN_INTERVAL_S", 0.0)  # a line at every count
    assert parallel_map(units_slowly, [6, 6], workers=workers, progress="demo", weight=lambda n: n) == [6, 6]
    err = capsys.readouterr().err
    counts = line_counts(err)
    assert counts[-1] == 12 and err.endswith("\n")
    assert counts == sorted(counts) and len(set(counts)) > 4  # two chunks, but more than two steps


def test_counter_ends_at_the_total_whatever_the_reports():
    bar = Progress(10, enabled=False)
    counter = ProgressCounter(bar, [4, 6])
    counter.partial(0, 3)
    counter.partial(0, 5)          # more than the item weighs: clipped
    counter.finished(0)
    counter.partial(0, 2)          # after the item finished: ignored
    counter.partial(1, 2)
    counter.finished(1)
    assert bar.done == 10 and counter.reported == [4, 2]
    report_progress(3)             # outside parallel_map: nothing happens


def test_on_done_sees_every_item_and_result():
    seen = []
    parallel_map(math.sqrt, [4, 9, 16], chunksize=2, on_done=lambda item, value: seen.append((item, value)))
    assert sorted(seen) == [(4, 2.0), (9, 3.0), (16, 4.0)]


def test_forked_returns_the_childs_value_of_a_closure():
    data = np.arange(5.0)
    job = Forked(lambda: (os.getpid(), data * 2))  # a closure: not picklable, fine for a fork
    pid, value = job.result()
    assert pid != os.getpid()
    assert np.array_equal(value, data * 2)


def test_forked_raises_the_childs_exception():
    def fail():
        raise ValueError("bad value in the child")

    with pytest.raises(ValueError, match="bad value in the child"):
        Forked(fail).result()


def test_forked_child_that_dies_is_an_error():
    with pytest.raises(RuntimeError, match="died"):
        Forked(lambda: os._exit(3)).result()


def test_an_input_error_in_a_worker_reaches_the_caller_as_itself(tmp_path):
    """A located InputError raised in a spawned worker (a Monte Carlo case whose problem names a file
    that is not there) is re-raised in the parent with its file and message, not as a broken pool."""
    import pickle

    from casrecon.io.errors import InputError
    from casrecon.io.sounding import read_sounding

    err = InputError("a.toml", "expected a number", line=3, field="vehicle.mass_kg")
    again = pickle.loads(pickle.dumps(err))
    assert (again.path, again.line, again.field, again.message, str(again)) == \
        ("a.toml", 3, "vehicle.mass_kg", "expected a number", str(err))
    missing = [str(tmp_path / "a.csv"), str(tmp_path / "b.csv")]
    with pytest.raises(InputError, match=r"[ab]\.csv: cannot read file"):  # whichever worker fails first
        parallel_map(read_sounding, missing, workers=2)


def _thread_of(item):
    import threading

    time.sleep(0.01)
    return item, threading.get_ident()


def test_in_threads_keeps_order_and_uses_other_threads(monkeypatch):
    import threading

    from casrecon import parallel

    monkeypatch.setattr(parallel, "threads_for_one_task", lambda wanted: wanted)  # whatever the machine
    out = list(parallel.in_threads(_thread_of, range(6), threads=2))
    assert [item for item, _ in out] == list(range(6))
    assert {ident for _, ident in out} != {threading.get_ident()}


def test_in_a_pool_worker_in_threads_stays_in_the_calling_thread(monkeypatch):
    import threading

    from casrecon import parallel

    monkeypatch.setattr(parallel, "in_pool_worker", lambda: True)
    assert parallel.threads_for_one_task(8) == 1
    out = list(parallel.in_threads(_thread_of, range(4), threads=2))
    assert [item for item, _ in out] == list(range(4))
    assert {ident for _, ident in out} == {threading.get_ident()}


def test_pool_workers_know_they_are_workers():
    from casrecon import parallel

    flags = parallel_map(_worker_flag, [0, 1], workers=2)
    assert flags == [True, True] and not parallel.in_pool_worker()


def _worker_flag(_):
    from casrecon import parallel

    return parallel.in_pool_worker()


@pytest.mark.parametrize(("value", "expected"), [("1", 1), ("2", 2), ("", 2), ("zero", 2), ("0", 2)])
def test_casrecon_threads_caps_the_threads(monkeypatch, value, expected):
    from casrecon import parallel

    monkeypatch.setattr(parallel.os, "sched_getaffinity", lambda pid: {0, 1, 2, 3}, raising=False)
    monkeypatch.setenv("CASRECON_THREADS", value)
    assert parallel.threads_for_one_task(2) == expected


