"""One parallel map for every pool in casrecon: in this process, on local processes, or on a Dask cluster.

:func:`parallel_map` returns ``[fn(item) for item in items]`` in the order of ``items``, whatever
order the work finishes in. ``workers == 1`` (or a single item) runs in this process;
``workers > 1`` runs on a :class:`~concurrent.futures.ProcessPoolExecutor` (spawn context by
default, so a worker never inherits CasADi or thread state); a ``scheduler`` address
(``"tcp://host:8786"``) sends the work to a Dask distributed cluster, whose workers must see the
same file system. ``fn`` and the items must be picklable for the last two.

Progress is a one-line bar on stderr (:class:`Progress`): a dozen lines of our own rather than a
new dependency, and the same line the Monte Carlo has always printed.
"""

from __future__ import annotations

import multiprocessing
import signal
import sys
import time
from collections.abc import Callable, Iterable, Sequence
from concurrent.futures import ProcessPoolExecutor, as_completed
from functools import partial
from typing import Any


class Progress:
    """A one-line stderr progress bar, rewritten as work finishes.

    Parameters
    ----------
    total : int
        Units of work in all (e.g. cases).
    enabled : bool
        False counts silently (nothing is written).
    label : str
        Text before the bar.
    unit : str
        Name of the units after the count.
    """

    #: A bar is on screen without its newline (a message printed now would run into it).
    line_open = False

    def __init__(self, total: int, enabled: bool = True, label: str = "", unit: str = "cases") -> None:
        self.total, self.done, self.enabled, self.label, self.unit = total, 0, enabled, label, unit
        self.t0 = time.perf_counter()

    def update(self, n: int) -> None:
        """Count ``n`` more units done and redraw the bar (elapsed time and ETA in s)."""
        self.done += n
        if not self.enabled:
            return
        el = time.perf_counter() - self.t0
        frac = self.done / max(self.total, 1)
        eta = el * (1 - frac) / frac if frac > 0 else float("nan")
        bar = "#" * int(30 * frac)
        sys.stderr.write(f"\r{self.label} [{bar:<30s}] {self.done}/{self.total} {self.unit}  {el:6.1f} s  "
                         f"ETA {eta:5.1f} s")
        Progress.line_open = self.done < self.total
        if not Progress.line_open:
            sys.stderr.write("\n")
        sys.stderr.flush()


def end_progress_line() -> None:
    """End a progress bar's line cut short (by an error or a signal), so the next message starts a line."""
    if Progress.line_open:
        Progress.line_open = False
        sys.stderr.write("\n")
        sys.stderr.flush()


def import_distributed() -> tuple[type, Callable]:
    """``(distributed.Client, distributed.as_completed)``, imported on demand.

    Raises
    ------
    ImportError
        With the install command, when dask.distributed is not installed.
    """
    try:
        from distributed import Client, as_completed
    except ImportError as err:
        raise ImportError("a Dask scheduler was given but dask.distributed is not installed: "
                          "pip install 'casrecon[dask]' (or 'dask[distributed]')") from err
    return Client, as_completed


def apply_to_chunk(fn: Callable, chunk: Sequence) -> list:
    """``[fn(item) for item in chunk]``: the unit of work of :func:`parallel_map` (top level, so picklable)."""
    return [fn(item) for item in chunk]


def ignore_interrupts() -> None:
    """Worker initializer: Ctrl-C reaches the whole process group, but only the parent acts on it
    (it stops the workers; no worker prints a KeyboardInterrupt traceback)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel the pending work of ``pool`` and terminate its workers (after an error or a signal in
    the parent), so that leaving the ``with`` block does not wait for the running work."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # shutdown forgets them
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        try:
            proc.terminate()
        except (OSError, ValueError, AttributeError):
            pass


def parallel_map(fn: Callable[[Any], Any], items: Iterable, *, workers: int = 1, scheduler: str | None = None,
                 progress: str | None = None, weight: Callable[[Any], int] | None = None, chunksize: int = 1,
                 start_method: str = "spawn") -> list:
    """``[fn(item) for item in items]`` in this process, on local processes or on a Dask cluster.

    Parameters
    ----------
    fn : callable
        Applied to each item; importable (picklable) when ``workers > 1`` or ``scheduler`` is given.
    items : iterable
        The inputs; the results come back in their order.
    workers : int
        Local processes; 1 or fewer (or a single chunk of work) runs in this process. Ignored with
        ``scheduler``.
    scheduler : str or None
        Dask distributed scheduler address; takes precedence over ``workers``. An unreachable
        scheduler raises the ``OSError`` of ``distributed.Client``.
    progress : str or None
        Label of a stderr :class:`Progress` bar; None draws no bar.
    weight : callable or None
        Units of progress of one item (default 1 each), e.g. the number of cases in a chunk of cases.
    chunksize : int
        Items sent together to a worker as one unit of work (fewer round trips for cheap items).
    start_method : {"spawn", "fork", "forkserver"}
        Multiprocessing context of the local pool.

    Returns
    -------
    list
        ``fn(item)`` for each item, in input order.

    Raises
    ------
    ImportError
        A scheduler is given but dask.distributed is not installed.
    ValueError
        ``chunksize`` below 1.
    """
    items = list(items)
    if chunksize < 1:
        raise ValueError(f"chunksize must be >= 1, got {chunksize}")
    weigh = weight if weight is not None else (lambda item: 1)
    chunks = [items[s:s + chunksize] for s in range(0, len(items), chunksize)]
    bar = Progress(sum(weigh(item) for item in items), progress is not None, progress or "")
    results: dict[int, list] = {}

    def done(k: int, values: list) -> None:
        results[k] = values
        bar.update(sum(weigh(item) for item in chunks[k]))

    if scheduler is not None:
        Client, dask_as_completed = import_distributed()
        with Client(scheduler) as client:
            futures = client.map(partial(apply_to_chunk, fn), chunks, pure=False)
            where = {f.key: k for k, f in enumerate(futures)}
            for fut in dask_as_completed(futures):
                done(where[fut.key], fut.result())
    elif workers <= 1 or len(chunks) <= 1:
        for k, chunk in enumerate(chunks):
            done(k, apply_to_chunk(fn, chunk))
    else:
        ctx = multiprocessing.get_context(start_method)
        with ProcessPoolExecutor(max_workers=min(workers, len(chunks)), mp_context=ctx,
                                 initializer=ignore_interrupts) as pool:
            try:
                futs = {pool.submit(apply_to_chunk, fn, chunk): k for k, chunk in enumerate(chunks)}
                for fut in as_completed(futs):
                    done(futs[fut], fut.result())
            except BaseException:
                stop_pool(pool)
                raise
    return [value for k in range(len(chunks)) for value in results[k]]
