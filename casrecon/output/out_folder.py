"""Which folders casrecon may replace with results, and the temporary folders of a replacement.

A results folder carries a marker file, :data:`MARKER` (``.casrecon-results.json``: what wrote it,
the casrecon version, the UTC time). :func:`check_out_folder` decides whether ``--out`` may be
written, before any work starts:

- never (not even with ``force``): the folder that holds the problem's inputs, an input itself, a
  folder containing one (a parent of the problem folder, a folder holding a shared vehicle file),
  the working directory or one of its parents, the home folder, the file system root (the sensor
  files named in ``[sensors]`` are not inputs of ``simulate --data``, which writes them);
- without ``force`` only: an existing folder that is not a casrecon results folder, or an existing
  file;
- always: a folder that does not exist yet, an empty folder, a folder with the marker, or a folder
  written by a casrecon older than the marker (see :func:`is_results_folder`).

The location must also be writable: the first existing folder above ``--out`` is probed by creating
and removing a temporary folder in it (this works for root too, where permission bits do not).

Temporary and backup folders of a replacement are named ``.NAME.tmp-PID-XXXX`` and
``.NAME.old-PID-XXXX`` beside the target; :func:`clean_stale` removes those of a process that is
no longer alive (a run killed with SIGKILL), and puts a backup back in place when the kill came
between the two renames of the swap and the target is missing.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import signal
import tempfile
import threading
from collections.abc import Iterable, Iterator
from datetime import UTC, datetime
from pathlib import Path

from casrecon.io.errors import InputError
from casrecon.io.toml_fields import TomlDocument, read_toml

#: Marker file of a casrecon results folder.
MARKER = ".casrecon-results.json"
#: JSON files that mark a results folder written before the marker existed (with no ``problem.toml``
#: beside them), and keys casrecon wrote into each (any one group complete): ``summary.json`` (fit,
#: point-mass, joint: ``converged``; simulate: ``problem`` and ``flight_time_s``), ``statistics.json``
#: (Monte Carlo), ``nees.json`` (estimator Monte Carlo), ``design.json`` / ``fisher.json`` (sensitivity).
LEGACY_SIGNATURES = {"summary.json": (("converged",), ("problem", "flight_time_s")),
                     "statistics.json": (("n_cases", "n_impacted"),), "nees.json": (("nees_sum",),),
                     "design.json": (("parameter", "n_drops"),), "fisher.json": (("eigenvalue", "weights"),)}


class OutFolderError(InputError):
    """``--out`` (or the folder given to ``save``) cannot or must not be written; one located line."""


class ResultsWriteError(OSError):
    """Writing a results folder failed (disk full, I/O error): ``filename`` is the results folder,
    ``errno``/``strerror`` those of the failure; the temporary folder is gone, nothing was replaced."""


def results_version() -> str:
    """The installed casrecon version, ``"unknown"`` when it is not installed."""
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("casrecon")
    except PackageNotFoundError:
        return "unknown"


def write_marker(folder: Path, kind: str) -> None:
    """Write :data:`MARKER` into ``folder``: ``kind`` (the command or result that wrote it), version, UTC time."""
    stamp = datetime.now(UTC).strftime("%Y-%m-%dT%H:%M:%SZ")
    data = {"written_by": "casrecon", "kind": kind, "casrecon_version": results_version(), "written_utc": stamp}
    (folder / MARKER).write_text(json.dumps(data, indent=2) + "\n")


def is_results_folder(folder: Path) -> bool:
    """True for an empty folder, a folder holding :data:`MARKER`, or one that looks like a results
    folder of an older casrecon: no ``problem.toml``, and one of :data:`LEGACY_SIGNATURES` holding the
    keys casrecon wrote into it (so a user's own ``summary.json`` does not count)."""
    try:
        names = {p.name for p in folder.iterdir()}
    except FileNotFoundError:
        return True  # gone (another casrecon writer moved it aside): nothing of anyone's to replace
    except OSError:
        return False
    if not names or MARKER in names:
        return True
    return "problem.toml" not in names and any(_signed(folder / n, LEGACY_SIGNATURES[n])
                                               for n in LEGACY_SIGNATURES if n in names)


def _signed(path: Path, key_groups: tuple[tuple[str, ...], ...]) -> bool:
    try:
        if path.stat().st_size > 50_000_000:
            return False
        doc = json.loads(path.read_text())
    except (OSError, ValueError):
        return False
    if isinstance(doc, list):  # fisher.json: one record per direction
        doc = doc[0] if doc and isinstance(doc[0], dict) else {}
    return isinstance(doc, dict) and any(all(k in doc for k in keys) for keys in key_groups)


def input_paths(problems: Iterable[str | Path | TomlDocument], *, sensor_files: bool = True) -> list[Path]:
    """The inputs a run reads, to be protected: each problem file and its folder, and every file or
    folder a string of its TOML names (relative to the file), one level deep (a joint file's drops).
    A problem given as its parsed :class:`~casrecon.io.toml_fields.TomlDocument` is not read again;
    neither is a named ``.toml`` that is one of the given documents. ``sensor_files=False`` leaves
    out what the ``[sensors]`` table names (``simulate --data`` writes those files rather than
    reading them, e.g. into the problem's ``data/`` folder)."""
    parsed = {p.path.expanduser().resolve(): p.data for p in problems if isinstance(p, TomlDocument)}
    out: list[Path] = []
    todo = [(p.path if isinstance(p, TomlDocument) else Path(p), 0) for p in problems]
    while todo:
        path, depth = todo.pop()
        path = path.expanduser().resolve()
        toml = path / "problem.toml" if path.is_dir() else path
        out += [path, toml.parent]
        if depth > 1 or not toml.is_file():
            continue
        out.append(toml)
        data = parsed.get(toml)
        if data is None:
            try:
                data = read_toml(toml).data
            except InputError:
                continue  # the loader says what is wrong with it, located
        if not sensor_files and isinstance(data, dict):
            data = {k: v for k, v in data.items() if k != "sensors"}
        for text in _strings(data):
            if "\n" in text or len(text) > 4096:
                continue
            named = (toml.parent / text).expanduser()
            try:
                if not named.exists():
                    continue
                if named.is_dir() or named.suffix == ".toml":
                    todo.append((named, depth + 1))
                else:
                    out.append(named.resolve())
            except OSError:
                continue
    return out


def _strings(data) -> Iterable[str]:
    if isinstance(data, str):
        yield data
    elif isinstance(data, dict):
        for v in data.values():
            yield from _strings(v)
    elif isinstance(data, list):
        for v in data:
            yield from _strings(v)


def _within(inner: Path, outer: Path) -> bool:
    return inner == outer or outer in inner.parents


def check_out_folder(target: str | Path, *, inputs: Iterable[Path] = (), force: bool = False) -> Path:
    """Check that results may be written to ``target`` (see the module notes); returns it resolved.

    Raises
    ------
    OutFolderError
        Naming ``target`` and why: it holds inputs, is the working directory or a parent of it, is
        an existing file or a folder casrecon did not write (without ``force``), lies under a file,
        or its location is not writable.
    """
    given = str(target)
    target = Path(target).expanduser().resolve()
    try:
        cwd = Path.cwd().resolve()
    except OSError:  # the working directory was removed
        cwd = Path(target.anchor) / ".casrecon-no-working-directory"
    for inp in inputs:
        inp = Path(inp).resolve()
        if inp == target:
            raise OutFolderError(given, "is an input of this run (a problem folder or file); results never "
                                 f"replace their inputs: choose a new folder, e.g. {Path(given) / 'results'}")
        if _within(inp, target):
            raise OutFolderError(given, f"holds the input {inp}; results never replace their inputs: choose a "
                                 "new folder")
    if _within(cwd, target) or target in (Path.home().resolve(), Path(target.anchor)):
        raise OutFolderError(given, "is the working directory, one of its parents, the home folder or the root; "
                             "results never replace it (choose a new folder)")
    if target.is_symlink() or target.exists():
        if not target.is_dir():
            if not force:
                raise OutFolderError(given, "exists and is a file, not a results folder; choose another --out "
                                     "or pass --force to replace it")
        elif not force and not is_results_folder(target):
            raise OutFolderError(given, f"exists and was not written by casrecon (no {MARKER}); choose another "
                                 "--out or pass --force to replace it")
    anchor = target.parent
    while not anchor.exists() and not anchor.is_symlink():
        anchor = anchor.parent
    if not anchor.is_dir():
        raise OutFolderError(given, f"cannot be created: {anchor} is a file, not a folder")
    try:
        with signals_held():  # a Ctrl-C between the two calls would leave the probe behind
            os.rmdir(tempfile.mkdtemp(prefix=".casrecon-probe-", dir=anchor))
    except OSError as err:
        raise OutFolderError(given, f"cannot be written: {anchor}: {err.strerror or err}") from None
    return target


@contextlib.contextmanager
def signals_held() -> Iterator[None]:
    """Hold SIGINT and SIGTERM back (in the main thread, where Python runs their handlers) for a few
    file-system calls that must not be split; they are delivered when the block ends."""
    if threading.current_thread() is not threading.main_thread() or not hasattr(signal, "pthread_sigmask"):
        yield
        return
    old = signal.pthread_sigmask(signal.SIG_BLOCK, {signal.SIGINT, signal.SIGTERM})
    try:
        yield
    finally:
        signal.pthread_sigmask(signal.SIG_SETMASK, old)


def temp_name(target: Path, kind: str) -> str:
    """Prefix of a temporary (``kind="tmp"``) or backup (``"old"``) folder of ``target``, with this process id."""
    return f".{target.name}.{kind}-{os.getpid()}-"


def _alive(pid: int) -> bool:
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except PermissionError:
        return True  # someone else's live process
    return True


def remove_tree(path: Path) -> None:
    """Remove a folder, a file or a link, quietly."""
    if path.is_dir() and not path.is_symlink():
        shutil.rmtree(path, ignore_errors=True)
    else:
        try:
            path.unlink()
        except OSError:
            pass


def clean_stale(target: Path) -> list[Path]:
    """Remove the temporary and backup folders of ``target`` left by processes that are no longer alive;
    when ``target`` is missing, the newest such backup is renamed back to it first. Returns what was removed."""
    pattern = re.compile(rf"^\.{re.escape(target.name)}\.(tmp|old)-(\d+)-.+$")
    try:
        found = [(m.group(1), int(m.group(2)), p) for p in target.parent.iterdir()
                 if (m := pattern.match(p.name))]
    except OSError:
        return []
    dead = [(k, p) for k, pid, p in found if not _alive(pid)]
    backups = sorted((p for k, p in dead if k == "old"), key=lambda p: p.stat().st_mtime)
    if backups and not target.exists() and not target.is_symlink():
        try:
            os.replace(backups[-1], target)
            dead = [(k, p) for k, p in dead if p != backups[-1]]
        except OSError:
            pass
    for _, path in dead:
        remove_tree(path)
    return [p for _, p in dead]
