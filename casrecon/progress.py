"""Progress of a count of work units on stderr, readable on a terminal and in a redirected log.

On a terminal :class:`Progress` draws a :mod:`tqdm` bar (tqdm rather than a bar of our own: it
handles terminal widths, rates and unit formats); where stderr is not a terminal (a log file, a
pipe) it writes plain lines without ``\\r``, at most one every :data:`PLAIN_INTERVAL_S` seconds and
one at the end. :func:`casrecon.parallel.parallel_map` moves it as work finishes.

:func:`heartbeat` keeps a long step from being a silent stretch of a log: while it runs, a line
saying it is still running whenever :data:`HEARTBEAT_S` seconds pass without another line.
"""

from __future__ import annotations

import logging
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

#: Seconds between the plain progress lines written where stderr is not a terminal (a log file).
PLAIN_INTERVAL_S = 4.0


def is_terminal(stream: Any) -> bool:
    """Whether ``stream`` is an interactive terminal (where a bar may rewrite its line with ``\\r``)."""
    try:
        return bool(stream.isatty())
    except (AttributeError, ValueError, OSError):  # no isatty, or a closed stream
        return False


class Progress:
    """Progress of a count of work units on stderr: a :mod:`tqdm` bar on a terminal; elsewhere (a
    redirected log) plain lines without ``\\r``, at most one every :data:`PLAIN_INTERVAL_S` seconds
    and one at the end.

    Nothing is written before the first unit finishes, and no ETA before a second one has: the rate
    is that since the first finished unit, so a pool's start-up (spawning workers, compiling) does
    not make the first estimate absurd (a 200-case Monte Carlo's first bar said "ETA 3471 s").

    Parameters
    ----------
    total : int
        Units of work in all (e.g. cases).
    enabled : bool
        False counts silently (nothing is written).
    label : str
        Text before the bar or at the start of each line.
    unit : str
        Name of the units after the count.
    stream : file-like or None
        Where to write; None: whatever ``sys.stderr`` is at each write.
    """

    #: The progress bar on screen without its newline (:func:`end_progress_line` closes it).
    active: Progress | None = None

    def __init__(self, total: int, enabled: bool = True, label: str = "", unit: str = "cases",
                 stream: Any = None) -> None:
        self.total, self.done, self.enabled, self.label, self.unit = total, 0, enabled, label, unit
        self.stream = stream
        self.t0 = time.perf_counter()
        self.first: tuple[float, int] | None = None  # (time, units done) when the first unit finished
        self.last_line = -float("inf")
        self.bar: Any = None

    def out(self) -> Any:
        """The stream written to now."""
        return self.stream if self.stream is not None else sys.stderr

    def eta_s(self, now: float) -> float | None:
        """Seconds left at the rate since the first finished unit; None before a second one finished."""
        if self.first is None or self.done <= self.first[1] or now <= self.first[0]:
            return None
        rate = (self.done - self.first[1]) / (now - self.first[0])
        return (self.total - self.done) / rate

    def line(self, now: float) -> str:
        """The plain progress line at ``now`` (``perf_counter`` s)."""
        eta = self.eta_s(now)
        left = "" if eta is None or self.done >= self.total else f", about {eta:.0f} s left"
        return f"{self.label}: {self.done}/{self.total} {self.unit}, {now - self.t0:.0f} s{left}"

    def update(self, n: int) -> None:
        """Count ``n`` more units done and show it (a bar's redraw, or a plain line when due)."""
        self.done += n
        if not self.enabled or n <= 0:
            return
        now = time.perf_counter()
        if self.first is None:
            self.first = (now, self.done)
        out = self.out()
        if not is_terminal(out):
            if self.done >= self.total or now - self.last_line >= PLAIN_INTERVAL_S:
                self.last_line = now
                out.write(self.line(now) + "\n")
                out.flush()
                note_line()
            return
        if self.bar is None:  # made at the first finished unit: its rate (and ETA) counts from here
            from tqdm import tqdm

            self.bar = tqdm(total=self.total, initial=self.done, desc=self.label, unit=f" {self.unit}",
                            file=out, leave=True, dynamic_ncols=True, mininterval=0.2,
                            bar_format="{desc} {percentage:3.0f}%|{bar}| {n_fmt}/{total_fmt}{unit} "
                                       "[{elapsed}<{remaining}, {rate_fmt}]")
            self.bar.refresh()
            Progress.active = self
        else:
            self.bar.update(n)
        if self.done >= self.total:
            self.close()

    def close(self) -> None:
        """End the bar's line (a no-op without a bar)."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None
        if Progress.active is self:
            Progress.active = None


def end_progress_line() -> None:
    """End a progress bar's line cut short (by an error or a signal), so the next message starts a line."""
    bar = Progress.active
    if bar is not None:
        bar.close()


#: Seconds without a log line after which a running stage says it is still running (:func:`heartbeat`).
HEARTBEAT_S = 4.0
#: ``time.monotonic()`` of the last line written (:func:`note_line`).
_LAST_LINE = [time.monotonic()]


def note_line() -> None:
    """Record that a progress or log line has just been written (``casrecon``'s command-line log
    handler calls it for each record, :class:`Progress` for each plain line)."""
    _LAST_LINE[0] = time.monotonic()


@contextmanager
def heartbeat(log: logging.Logger, level: int, text: str, every_s: float | None = None) -> Iterator[None]:
    """While the block runs, log ``"<text>: still running (N s)"`` at ``level`` on ``log`` whenever
    ``every_s`` seconds (default :data:`HEARTBEAT_S`) have passed without a line (:func:`note_line`),
    so that a long step is never a silent stretch of the log. Nothing when ``log`` does not log
    ``level``. The beats come from a daemon thread, stopped when the block ends."""
    every = HEARTBEAT_S if every_s is None else every_s
    if not log.isEnabledFor(level):
        yield
        return
    note_line()
    stop, t0 = threading.Event(), time.monotonic()

    def beat() -> None:
        while not stop.wait(min(0.25, every / 4)):
            now = time.monotonic()
            if now - _LAST_LINE[0] >= every:
                _LAST_LINE[0] = now
                log.log(level, "%s: still running (%.0f s)", text, now - t0)

    thread = threading.Thread(target=beat, name="casrecon-heartbeat", daemon=True)
    thread.start()
    try:
        yield
    finally:
        stop.set()
        thread.join()


@contextmanager
def stage(log: logging.Logger, text: str, level: int = logging.INFO) -> Iterator[None]:
    """Log ``text`` (the stage a command enters, e.g. ``"writing results -> out"``) at ``level`` on
    ``log``, and a :func:`heartbeat` while the block runs."""
    log.log(level, "%s", text)
    with heartbeat(log, level, text):
        yield
