"""How a ``casrecon`` command ends: one line and a documented exit status, never a traceback.

Exit status (also in :mod:`casrecon.cli` and the README):

===  ==========================================================================================
0    success
1    unexpected error (a bug): one line naming the exception; ``casrecon --debug ...`` or
     ``CASRECON_DEBUG=1`` shows the traceback
2    bad input or arguments (a located line), an ``--out`` that may not or cannot be written, a
     system error (a file that cannot be read or written, disk full, not enough memory, an
     unreachable or malformed Dask scheduler address)
3    a fit failed (no convergence, singular KKT matrix)
4    estimator Monte Carlo: not consistent, or some of its fits failed
130  interrupted by SIGINT (Ctrl-C); 143 by SIGTERM: the earlier results folder is kept
===  ==========================================================================================

:func:`run_command` installs SIGINT and SIGTERM handlers that raise (:class:`Interrupted` for
SIGTERM), so every ``with atomic_folder(...)`` block unwinds and removes its temporary folder;
a signal that arrives while a solver runs in C++ (which may then report a failure) is still
reported as the interrupt it was. A library may swallow the exception (one did, inside an import):
:data:`GRACE_S` after the signal, or at a second signal, :func:`force_exit` removes the temporary
folders, stops the workers and exits.
"""

from __future__ import annotations

import argparse
import logging
import os
import signal
import socket
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path

from casrecon.io.errors import InputError

EXIT_OK, EXIT_ERROR, EXIT_INPUT, EXIT_FIT, EXIT_INCONSISTENT = 0, 1, 2, 3, 4
#: Exit status after a signal: 128 + its number (130 for SIGINT, 143 for SIGTERM).
EXIT_SIGNAL = 128


#: Signals received during the command :func:`run_command` runs (read by :func:`fit_failed`).
RECEIVED: list[int] = []


class Interrupted(KeyboardInterrupt):
    """Raised by the SIGTERM handler: a ``KeyboardInterrupt`` (no ``except Exception`` swallows it, and
    CasADi stops a solve for it without printing a traceback), told apart by its ``signum``."""

    def __init__(self, signum: int) -> None:
        self.signum = signum
        super().__init__(f"signal {signum}")


def debug_enabled(flag: bool = False) -> bool:
    """``--debug`` given, or ``CASRECON_DEBUG`` set to anything but empty or ``0``."""
    return flag or os.environ.get("CASRECON_DEBUG", "") not in ("", "0")


def run_command(func: Callable[[object], int], args, *, debug: bool = False) -> int:
    """Run one command ``func(args)`` and turn whatever ends it into an exit status and at most one
    line on stderr (see the module table). ``args.out``, when present, names the results folder
    the interrupt message speaks about. With ``debug``, unexpected errors keep their traceback.

    On SIGINT or SIGTERM the command unwinds by an exception (``with atomic_folder`` blocks remove
    their temporary folders). Should it not have ended :data:`GRACE_S` after the signal (a library
    swallowed the exception), or at a second signal, :func:`force_exit` ends the process.
    """
    from casrecon.output import results  # loaded now: force_exit may run in another thread
    from casrecon.progress import end_progress_line

    out = getattr(args, "out", None)
    before = _identity(out)
    received = RECEIVED
    received.clear()
    watch = SignalWatch(received, lambda signum: force_exit(signum, results.abandon_active_folders,
                                                            interrupted_line(out, before)))
    previous = {}
    if threading.current_thread() is threading.main_thread():
        for sig in (signal.SIGINT, signal.SIGTERM):
            previous[sig] = signal.signal(sig, watch.on_signal)
    try:
        try:
            code = func(args)
        except Interrupted as err:
            received.append(err.signum)
            code = EXIT_SIGNAL + err.signum
        except KeyboardInterrupt as err:
            if previous and not received:  # no signal came: a solver took a failure for an interrupt
                code, line = describe(RuntimeError(str(err) or "KeyboardInterrupt without a signal"))
                end_progress_line()
                print(line, file=sys.stderr)
            else:
                received.append(signal.SIGINT)
                code = EXIT_SIGNAL + signal.SIGINT
        except Exception as err:
            if received:  # a solver stopped by the signal may raise something else first
                code = EXIT_SIGNAL + received[0]
            elif debug:
                raise
            else:
                code, line = describe(err)
                end_progress_line()
                print(line, file=sys.stderr)
    finally:
        for sig, handler in previous.items():
            signal.signal(sig, handler)
        watch.done.set()
    if received:
        end_progress_line()
        print(interrupted_line(out, before), file=sys.stderr, flush=True)
        return EXIT_SIGNAL + received[0]
    return code


class SignalWatch:
    """The SIGINT/SIGTERM handler of one command and its watchdog thread.

    The first signal raises ``KeyboardInterrupt`` (SIGINT) or :class:`Interrupted` (SIGTERM) where
    the main thread is, unless that is a spot where the exception would be printed and dropped (a
    weakref callback, ``__del__``, the import machinery's locks, CasADi's SWIG shims): then the
    watchdog sends the signal again 0.2 s later. A second signal after the raise, or :data:`GRACE_S` without the command
    ending (a library swallowed the exception), calls ``force(signum)`` (:func:`force_exit`).
    """

    UNSAFE = ("__del__", "cb", "remove", "_remove", "_remove_dead_weakref")
    UNSAFE_FILES = ("<frozen importlib",)
    #: CasADi's SWIG type checks call these back from C++ while choosing an overload, and drop an
    #: exception raised in them.
    CASADI_FILE = os.path.join("casadi", "casadi.py")
    CASADI_CHECKS = ("shape", "size1", "size2", "size", "numel", "nnz", "toarray", "__array__", "__float__",
                     "__int__", "__len__", "__iter__", "elements", "full", "sparse", "is_scalar", "is_dense")

    def __init__(self, received: list[int], force: Callable[[int], None]) -> None:
        self.received, self.force = received, force
        self.raised = self.pending = False
        self.done = threading.Event()

    def unsafe(self, frame) -> bool:
        """Whether an exception raised in ``frame`` would be dropped (see the class notes)."""
        if frame is None:
            return False
        code = frame.f_code
        return (code.co_name in self.UNSAFE or code.co_filename.startswith(self.UNSAFE_FILES)
                or (code.co_filename.endswith(self.CASADI_FILE) and code.co_name in self.CASADI_CHECKS))

    def on_signal(self, signum, frame) -> None:
        if self.raised:
            self.force(self.received[0])  # a second signal: do not wait
        if not self.received:
            self.received.append(signum)
            threading.Thread(target=self.watchdog, args=(signum,), daemon=True).start()
        if self.unsafe(frame):
            self.pending = True
            return
        self.pending, self.raised = False, True
        raise KeyboardInterrupt if signum == signal.SIGINT else Interrupted(signum)

    def watchdog(self, signum: int) -> None:
        deadline = time.monotonic() + GRACE_S
        while not self.done.wait(0.2):
            if time.monotonic() >= deadline:
                self.force(signum)
            elif self.pending:
                os.kill(os.getpid(), signum)


def exit_process(code: int) -> None:
    """End the ``casrecon`` process with ``code``, the streams and log handlers flushed first.

    When no worker process or other thread is left, the process ends at once, without the
    interpreter's teardown (freeing every CasADi function and array one by one: 0.15 to 0.25 s
    of a fit command; the operating system reclaims the memory). After a signal (130, 143) it ends
    at once in any case: a library that swallowed the ``KeyboardInterrupt`` may have left Python set
    to kill itself with SIGINT at exit, which would replace the status. Otherwise ``sys.exit``,
    which joins what is left."""
    for stream in (sys.stdout, sys.stderr):
        try:
            stream.flush()
        except (OSError, ValueError):  # a closed pipe (``casrecon ... | head``) or stream
            pass
    if code >= EXIT_SIGNAL:
        os._exit(code)
    mp = sys.modules.get("multiprocessing")  # never imported: no workers
    if (mp is None or not mp.active_children()) and threading.active_count() == 1:
        logging.shutdown()
        os._exit(code)
    sys.exit(code)


#: Seconds the command has to unwind after SIGINT or SIGTERM before :func:`force_exit` ends it.
GRACE_S = 10.0


def force_exit(signum: int, abandon: Callable[[], object], line: str | None) -> None:
    """End the process now with status 128 + ``signum``: remove the temporary folders of the results
    being written (``abandon``, which waits for a swap in progress), terminate worker processes, print
    ``line`` (if not None)."""
    import multiprocessing

    from casrecon.progress import end_progress_line

    try:
        abandon()
        for child in multiprocessing.active_children():
            child.terminate()
        if line is not None:
            end_progress_line()
            print(line, file=sys.stderr, flush=True)
    finally:
        os._exit(EXIT_SIGNAL + signum)


def out_folder_arguments(args, *problems) -> dict:
    """Check ``args.out`` before any work (never a folder holding the ``problems``' inputs; a foreign
    folder or a file only with ``args.force``; writable): the keyword arguments of ``atomic_folder``.
    Raises :class:`~casrecon.output.out_folder.OutFolderError` (exit 2)."""
    from casrecon.output.out_folder import check_out_folder, input_paths

    inputs = input_paths(problems, sensor_files=not getattr(args, "data", False))  # simulate --data writes them
    check_out_folder(args.out, inputs=inputs, force=args.force)
    return {"kind": args.command, "force": args.force, "inputs": inputs}


def fit_failed(what: str, err: Exception) -> int:
    """Say ``casrecon: WHAT failed: ERR`` and return 3; but when a signal stopped the solver (it then
    reports a failure), raise the interrupt instead, so that only the interrupt line is printed."""
    if RECEIVED:
        if RECEIVED[0] == signal.SIGINT:
            raise KeyboardInterrupt
        raise Interrupted(RECEIVED[0])
    print(f"casrecon: {what} failed: {err}", file=sys.stderr)
    return EXIT_FIT


def describe(err: BaseException) -> tuple[int, str]:
    """Exit status and the one line for an exception that ended a command."""
    from casrecon.estimation.sixdof.fit import FitError
    from casrecon.output.out_folder import ResultsWriteError

    if isinstance(err, InputError):
        return EXIT_INPUT, f"casrecon: {err}"
    if isinstance(err, FitError):
        return EXIT_FIT, f"casrecon: fit failed: {err}"
    if isinstance(err, ResultsWriteError):
        return EXIT_INPUT, (f"casrecon: cannot write {err.filename}: {err.strerror}; "
                            f"nothing replaced (no temporary folder left)")
    if isinstance(err, OSError):
        where = f"{err.filename}: " if err.filename else ""
        return EXIT_INPUT, f"casrecon: {where}{err.strerror or err}"
    if isinstance(err, MemoryError):
        return EXIT_INPUT, "casrecon: not enough memory for this run (nothing written)"
    text = " ".join(str(err).split())
    text = text if len(text) <= 400 else text[:400] + " ..."
    return EXIT_ERROR, (f"casrecon: unexpected error {type(err).__name__}: {text} "
                        "(casrecon --debug, or CASRECON_DEBUG=1, shows the traceback)")


def _identity(out) -> tuple[int, int] | None:
    if out is None:
        return None
    try:
        st = os.stat(Path(out).expanduser())
    except (OSError, ValueError):
        return None
    return st.st_dev, st.st_ino


def interrupted_line(out, before: tuple[int, int] | None) -> str:
    """The one line after a signal, saying what became of ``out`` (unchanged, new or not written)."""
    if out is None:
        return "casrecon: interrupted"
    now = _identity(out)
    if now is None:
        return f"casrecon: interrupted; nothing written to {out}"
    if now == before:
        return f"casrecon: interrupted; earlier results in {out} kept"
    return f"casrecon: interrupted after the results were written to {out} (complete)"


def scheduler_problem(address: str, timeout_s: float = 5.0) -> str | None:
    """Why ``address`` cannot serve as a Dask scheduler (not installed, malformed, unreachable over
    TCP within ``timeout_s``), or None when it looks usable. Checked before any work starts."""
    from casrecon.parallel import import_distributed

    try:
        import_distributed()
        from distributed.comm import parse_address
        from distributed.comm.addressing import parse_host_port
    except ImportError as err:
        return str(err)
    try:
        scheme, location = parse_address(address)
        host, port = parse_host_port(location) if scheme in ("tcp", "tls") else (None, None)
    except (ValueError, TypeError) as err:
        return f"not a scheduler address ({err}); expected e.g. tcp://HOST:8786"
    if host is None:
        return None
    try:
        with socket.create_connection((host, int(port)), timeout=timeout_s):
            return None
    except (OSError, ValueError, OverflowError) as err:
        return f"cannot reach the Dask scheduler ({getattr(err, 'strerror', None) or err})"


def available_memory_bytes() -> int | None:
    """Memory this process may still use, bytes: ``MemAvailable`` of /proc/meminfo, capped by the
    cgroup limit (v2 ``memory.max``, v1 ``memory.limit_in_bytes``) less its usage; None if unknown."""
    values = []
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                values.append(int(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    v1 = "/sys/fs/cgroup/memory/memory."
    for limit, usage in (("/sys/fs/cgroup/memory.max", "/sys/fs/cgroup/memory.current"),
                         (v1 + "limit_in_bytes", v1 + "usage_in_bytes")):
        try:
            cap = Path(limit).read_text().strip()
            if cap != "max" and int(cap) < 1 << 60:
                values.append(int(cap) - int(Path(usage).read_text().strip()))
        except (OSError, ValueError):
            continue
    return min(values) if values else None


def formats_argument(text: str) -> tuple[str, ...]:
    """``--format png,pdf`` -> ("png", "pdf"); an unsupported format is a usage error (exit 2)."""
    from casrecon.report.figure_style import parse_formats

    try:
        return parse_formats(text)
    except ValueError as err:
        raise argparse.ArgumentTypeError(str(err)) from None


def add_format_argument(p: argparse.ArgumentParser, default: tuple[str, ...] | None = ("png",)) -> None:
    """Add ``--format`` (figure file formats) to the command parser ``p``."""
    p.add_argument("--format", dest="formats", type=formats_argument, default=default, metavar="png,pdf",
                   help="figure file formats, comma-separated, of png, pdf and svg"
                        + (" (default png)" if default else " (default: the suffix of --plot)"))
