"""One parallel map for every pool in casrecon: in this process, on local processes, or on a Dask cluster.

:func:`parallel_map` returns ``[fn(item) for item in items]`` in the order of ``items``, whatever
order the work finishes in. ``workers == 1`` (or a single item) runs in this process;
``workers > 1`` runs on a :class:`~concurrent.futures.ProcessPoolExecutor` (spawn context by
default, so a worker never inherits CasADi or thread state); a ``scheduler`` address
(``"tcp://host:8786"``) sends the work to a Dask distributed cluster, whose workers must see the
same file system. ``fn`` and the items must be picklable for the last two.

Progress is a :mod:`tqdm` bar on a terminal and plain lines in a redirected log
(:class:`casrecon.progress.Progress`). An item
may count its own units as they finish (:func:`report_progress`, e.g. each case of a chunk of Monte
Carlo cases as it lands) so the bar moves before the whole item returns: in this process directly,
from local processes through a queue a thread of the parent reads (on a Dask cluster only whole
items count). ``on_done`` is called in the parent with each item and its
result as the item finishes (e.g. to log one line per finished case).
"""

from __future__ import annotations

import multiprocessing
import os
import queue
import signal
import threading
import time
from collections.abc import Callable, Iterable, Iterator, Sequence
from concurrent.futures import ProcessPoolExecutor, ThreadPoolExecutor, as_completed
from contextlib import contextmanager
from functools import partial
from typing import Any

from casrecon.progress import Progress


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


#: Where :func:`report_progress` sends its counts in this process: ``(chunk key, units) -> None``;
#: None outside :func:`parallel_map` (and on Dask workers).
_REPORTER: Callable[[int, int], None] | None = None
#: The worker's BLAS thread limit, kept referenced for the worker's life (set by :func:`ignore_interrupts`).
_BLAS_LIMIT: Any = None
#: The key of the chunk this process is working on (for :data:`_REPORTER`).
_CURRENT_CHUNK = -1
#: Whether this process is a worker of :func:`parallel_map` (set by :func:`ignore_interrupts`).
_IN_POOL_WORKER = False


def available_cores() -> int:
    """The cores this process may run on (its CPU affinity where the system has one)."""
    try:
        return len(os.sched_getaffinity(0))
    except AttributeError:  # not on Linux
        return os.cpu_count() or 1


def in_pool_worker() -> bool:
    """Whether this process is a worker of :func:`parallel_map` (on local processes)."""
    return _IN_POOL_WORKER


#: Environment variable that caps the threads of :func:`in_threads` (e.g. ``1`` on a machine shared
#: with other work); unset or not a positive integer: no cap beyond the cores.
THREADS_ENV = "CASRECON_THREADS"


def threads_for_one_task(wanted: int) -> int:
    """How many threads one computation of this process may use, at most ``wanted``: one in a
    worker of :func:`parallel_map` (its siblings hold the other cores), else ``wanted`` bounded by
    the cores this process may run on and by ``CASRECON_THREADS`` when that is set."""
    if in_pool_worker():
        return 1
    cap = os.environ.get(THREADS_ENV, "").strip()
    if cap.isdigit() and int(cap) > 0:
        wanted = min(wanted, int(cap))
    return max(1, min(wanted, available_cores()))


def in_threads(fn: Callable, items: Iterable, threads: int = 2) -> Iterator:
    """``fn(item)`` for each item, in order, computed on up to ``threads`` threads of this process
    (:func:`threads_for_one_task`; one: in the calling thread). For work that releases the GIL
    (SuperLU, CasADi's evaluations and constructions, large numpy operations). The pool is made for
    the call: one kept between calls would not survive a fork. ``fn`` must not return a SuperLU
    factor: scipy ties its memory to the thread that made it, and it leaks when it outlives the
    thread (:mod:`casrecon.estimation.engine.block_lu`); solving with one made elsewhere is safe."""
    items = list(items)
    threads = min(threads_for_one_task(threads), len(items))
    if threads < 2:
        yield from map(fn, items)
        return
    with ThreadPoolExecutor(threads) as pool:
        yield from pool.map(fn, items)


def report_progress(n: int = 1) -> None:
    """Count ``n`` units of the item being worked on as done before it returns (its ``weight`` is
    what counts in all: what it reported is subtracted when it finishes). Called by the ``fn`` of
    :func:`parallel_map`; a no-op anywhere else and on a Dask cluster."""
    if _REPORTER is not None and n > 0:
        _REPORTER(_CURRENT_CHUNK, int(n))


def apply_to_chunk(fn: Callable, chunk: Sequence, key: int = -1) -> list:
    """``[fn(item) for item in chunk]``: the unit of work of :func:`parallel_map` (top level, so
    picklable); ``key`` names the chunk in what :func:`report_progress` sends."""
    global _CURRENT_CHUNK
    _CURRENT_CHUNK = key
    return [fn(item) for item in chunk]


#: The signals that stop a run (held while workers are being started, see :func:`interrupts_deferred`).
INTERRUPTS = (signal.SIGINT, signal.SIGTERM)


@contextmanager
def interrupts_deferred() -> Iterator[None]:
    """Hold SIGINT and SIGTERM (delivered, not lost, when the block ends) in this thread, in the
    threads it starts and in the processes it spawns, while the block runs. Workers are spawned
    inside it: a signal handled in the middle of a spawn (the parent's handler raises) would cut
    the child's start-up data short and the child would print an ``EOFError`` traceback. The
    workers unblock the signals in their initializer (:func:`ignore_interrupts`). A no-op where
    ``signal.pthread_sigmask`` does not exist."""
    if not hasattr(signal, "pthread_sigmask"):
        yield
        return
    previous = signal.pthread_sigmask(signal.SIG_BLOCK, INTERRUPTS)
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, previous)


@contextmanager
def single_threaded_blas() -> Iterator[None]:
    """Limit the BLAS libraries loaded in this process when the block starts to one thread while it
    runs. casrecon's dense products are thin (20,000 x 32): threads gain nothing on them, and when
    another process competes for the cores (figure workers, Monte Carlo workers, a second fit)
    OpenBLAS's spinning threads make such a product 300 times slower (0.65 s against 2 ms measured
    on the 2-core machine). threadpoolctl reaches only loaded libraries: numpy's OpenBLAS, and
    scipy's once ``scipy.linalg`` has been imported. ``casrecon``'s command line and the pool
    workers set their limit before scipy's loads, so scipy's keeps two threads there (functions
    that need it at one, e.g. the error models' evidence, set the limit themselves). Limiting it
    everywhere (scipy.linalg imported first) was tried on 2026-11-29: one fit and a four-case
    Monte Carlo moved by less than the machine's drift between runs; not changed."""
    from threadpoolctl import threadpool_limits

    with threadpool_limits(limits=1, user_api="blas"):
        yield


def ignore_interrupts(counts: Any = None) -> None:
    """Worker initializer: Ctrl-C reaches the whole process group, but only the parent acts on it
    (it stops the workers; no worker prints a KeyboardInterrupt traceback); the signals held while
    the worker was spawned (:func:`interrupts_deferred`) are let through again (a SIGTERM from
    :func:`stop_pool` then ends it). ``counts``: the multiprocessing queue :func:`report_progress`
    puts ``(chunk key, units)`` on."""
    global _REPORTER, _BLAS_LIMIT, _IN_POOL_WORKER
    from threadpoolctl import threadpool_limits

    _IN_POOL_WORKER = True
    _BLAS_LIMIT = threadpool_limits(limits=1, user_api="blas")  # for the worker's life (see single_threaded_blas)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "pthread_sigmask"):
        signal.pthread_sigmask(signal.SIG_UNBLOCK, INTERRUPTS)
    if counts is not None:
        counts.cancel_join_thread()  # a count not yet sent when the worker exits is not waited for
        _REPORTER = lambda key, n: counts.put((key, n))  # noqa: E731
    threading.Thread(target=exit_with_parent, args=(os.getppid(),), daemon=True).start()


def exit_with_parent(parent_pid: int, poll_s: float = 2.0) -> None:
    """End this worker once its parent ``parent_pid`` is gone (checked every ``poll_s`` s). A
    parent killed by SIGTERM or SIGKILL cannot stop its pool; without this its workers ran on as
    orphans, each finishing its case of a study nobody would read (measured: a Monte Carlo killed
    with ``pkill`` left 6 workers fitting for 30 minutes)."""
    while os.getppid() == parent_pid:
        time.sleep(poll_s)
    os._exit(1)


class ProgressCounter:
    """The parent's count of finished units: whole chunks (:meth:`finished`) and the units their
    items reported before (:meth:`partial`, from any thread); a chunk's late reports are ignored,
    so the bar ends at exactly the total."""

    def __init__(self, bar: Progress, weights: Sequence[int]) -> None:
        self.bar, self.weights = bar, list(weights)
        self.reported = [0] * len(self.weights)
        self.closed: set[int] = set()
        self.lock = threading.Lock()

    def partial(self, key: int, n: int) -> None:
        with self.lock:
            if 0 <= key < len(self.weights) and key not in self.closed:
                n = min(n, self.weights[key] - self.reported[key])
                self.reported[key] += n
                self.bar.update(n)

    def finished(self, key: int) -> None:
        with self.lock:
            self.closed.add(key)
            self.bar.update(self.weights[key] - self.reported[key])


def drain(counts: Any, counter: ProgressCounter, stop: threading.Event) -> None:
    """Thread of the parent: pass the workers' ``(chunk key, units)`` to ``counter`` until ``stop``."""
    while not stop.is_set():
        try:
            key, n = counts.get(timeout=0.05)
        except queue.Empty:
            continue
        except (OSError, EOFError, ValueError):  # the queue was closed under us (the pool was stopped)
            return
        counter.partial(key, n)


def stop_pool(pool: ProcessPoolExecutor) -> None:
    """Cancel the pending work of ``pool`` and terminate its workers (after an error or a signal in
    the parent), so that leaving the ``with`` block does not wait for the running work; a worker
    still alive 2 s after SIGTERM is killed."""
    processes = list((getattr(pool, "_processes", None) or {}).values())  # shutdown forgets them
    pool.shutdown(wait=False, cancel_futures=True)
    for proc in processes:
        try:
            proc.terminate()
        except (OSError, ValueError, AttributeError):
            pass
    for proc in processes:  # a worker terminated before its initializer ran may hold the parent's
        try:                # SIGTERM handler (which only records the signal): it is killed
            proc.join(timeout=2.0)
            if proc.is_alive():
                proc.kill()
                proc.join(timeout=2.0)
        except (OSError, ValueError, AttributeError, AssertionError):
            pass


def parallel_map(fn: Callable[[Any], Any], items: Iterable, *, workers: int = 1, scheduler: str | None = None,
                 progress: str | None = None, weight: Callable[[Any], int] | None = None, chunksize: int = 1,
                 start_method: str = "spawn", on_done: Callable[[Any, Any], None] | None = None) -> list:
    """``[fn(item) for item in items]`` in this process, on local processes or on a Dask cluster.

    Parameters
    ----------
    fn : callable
        Applied to each item; importable (picklable) when ``workers > 1`` or ``scheduler`` is given.
        It may call :func:`report_progress` to move the bar before it returns.
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
    on_done : callable or None
        ``on_done(item, result)``, called in this process for each item as its chunk finishes.

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
    global _REPORTER
    items = list(items)
    if chunksize < 1:
        raise ValueError(f"chunksize must be >= 1, got {chunksize}")
    weigh = weight if weight is not None else (lambda item: 1)
    chunks = [items[s:s + chunksize] for s in range(0, len(items), chunksize)]
    weights = [sum(weigh(item) for item in chunk) for chunk in chunks]
    counter = ProgressCounter(Progress(sum(weights), progress is not None, progress or ""), weights)
    results: dict[int, list] = {}

    def done(k: int, values: list) -> None:
        results[k] = values
        counter.finished(k)
        if on_done is not None:
            for item, value in zip(chunks[k], values):
                on_done(item, value)

    if scheduler is not None:
        Client, dask_as_completed = import_distributed()
        with Client(scheduler) as client:
            futures = client.map(partial(apply_to_chunk, fn), chunks, pure=False)
            where = {f.key: k for k, f in enumerate(futures)}
            for fut in dask_as_completed(futures):
                done(where[fut.key], fut.result())
    elif workers <= 1 or len(chunks) <= 1:
        previous, _REPORTER = _REPORTER, counter.partial
        try:
            for k, chunk in enumerate(chunks):
                done(k, apply_to_chunk(fn, chunk, k))
        finally:
            _REPORTER = previous
    else:
        ctx = multiprocessing.get_context(start_method)
        counts = ctx.Queue() if progress is not None else None
        stop = threading.Event()
        reader = threading.Thread(target=drain, args=(counts, counter, stop), daemon=True) if counts else None
        with ProcessPoolExecutor(max_workers=min(workers, len(chunks)), mp_context=ctx,
                                 initializer=ignore_interrupts, initargs=(counts,)) as pool:
            try:
                with interrupts_deferred():  # the reader and the workers start with the signals held
                    if reader is not None:
                        reader.start()
                    futs = {pool.submit(apply_to_chunk, fn, chunk, k): k for k, chunk in enumerate(chunks)}
                for fut in as_completed(futs):
                    done(futs[fut], fut.result())
            except BaseException:
                stop_pool(pool)
                raise
            finally:
                stop.set()
                if reader is not None and reader.ident is not None:  # started
                    reader.join()
        if counts is not None:
            counts.close()
    return [value for k in range(len(chunks)) for value in results[k]]


def stop_child_processes() -> None:
    """Terminate (SIGTERM) every child process of this one, e.g. the workers of a study whose
    results are no longer wanted: their pool then finds them gone and its :func:`parallel_map`
    raises in the thread that waits for it."""
    for child in multiprocessing.active_children():
        child.terminate()


def spare_core() -> bool:
    """Whether a forked helper can run beside this process on a core of its own: more than one
    core available to this process, fork available, and this process not a daemon (which may not
    have children)."""
    return (available_cores() > 1 and "fork" in multiprocessing.get_all_start_methods()
            and not multiprocessing.current_process().daemon)


class Forked:
    """``fn()`` computed in a forked child process while this one goes on; :meth:`result` waits for
    it and returns its value (sent back pickled) or raises its exception. ``fn`` need not be
    picklable (the child is a copy of this process), its value must be. Where fork is not available
    ``fn()`` runs at once in this process."""

    def __init__(self, fn: Callable[[], Any]) -> None:
        self.fn, self.proc = fn, None
        if "fork" not in multiprocessing.get_all_start_methods():
            self.value = self._call()
            return
        ctx = multiprocessing.get_context("fork")
        self.conn, child = ctx.Pipe(duplex=False)
        self.proc = ctx.Process(target=self._child, args=(child,), daemon=True)
        self.proc.start()
        child.close()

    def _call(self) -> tuple[bool, Any]:
        try:
            return True, self.fn()
        except Exception as exc:  # noqa: BLE001 - handed to the parent, which raises it
            return False, exc

    def _child(self, conn: Any) -> None:
        signal.signal(signal.SIGINT, signal.SIG_IGN)  # the parent acts on Ctrl-C
        conn.send(self._call())
        conn.close()

    def result(self) -> Any:
        """The child's value of ``fn()``; its exception is raised here."""
        if self.proc is not None:
            try:
                self.value = self.conn.recv()
            except EOFError:
                self.proc.join()
                self.value = (False, RuntimeError(f"forked worker died (exit code {self.proc.exitcode})"))
            finally:
                self.proc.join()
                self.conn.close()
                self.proc = None
        ok, value = self.value
        if not ok:
            raise value
        return value
