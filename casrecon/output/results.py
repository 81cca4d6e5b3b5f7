"""Results folders written atomically, and the table/JSON writers they use.

:func:`atomic_folder` first checks that the target may be written (:mod:`casrecon.output.out_folder`:
never a folder holding the inputs, a foreign folder or a file only with ``force``, a writable
location), then hands out a fresh temporary folder next to the target; only when the block finishes
without an exception is the marker file written and the folder swapped in place of the target, so a
failed or interrupted run never leaves a half-written folder and never destroys an earlier result.
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import secrets
import shutil
import tempfile
import threading
from collections.abc import Callable, Iterable, Iterator, Sequence
from pathlib import Path

import numpy as np

from casrecon.output.out_folder import (
    MARKER,
    OutFolderError,
    ResultsWriteError,
    check_out_folder,
    clean_stale,
    is_results_folder,
    remove_tree,
    signals_held,
    temp_name,
    write_marker,
)

#: errno values of ``os.replace(tmp, target)`` when another writer put a folder at ``target`` meanwhile.
_RACE_ERRNOS = (errno.ENOTEMPTY, errno.EEXIST, errno.ENOTDIR, errno.EISDIR)
#: Temporary folders being written in this process, and the lock held while one is swapped in.
_ACTIVE: set[Path] = set()
_SWAP_LOCK = threading.Lock()


def abandon_active_folders(timeout_s: float = 5.0) -> list[Path]:
    """Remove the temporary folders this process is writing (for an exit that cannot wait for the
    ``with`` blocks to unwind); a swap in progress is let finish first (up to ``timeout_s``)."""
    locked = _SWAP_LOCK.acquire(timeout=timeout_s)
    try:
        gone = sorted(_ACTIVE)
        for tmp in gone:
            remove_tree(tmp)
        _ACTIVE.clear()
        return gone
    finally:
        if locked:
            _SWAP_LOCK.release()


@contextlib.contextmanager
def atomic_folder(target: str | Path, *, kind: str = "results", force: bool = False,
                  inputs: Iterable[Path] = ()) -> Iterator[Path]:
    """Yield a temporary folder that replaces ``target`` when the ``with`` block succeeds.

    Parameters
    ----------
    target : str or Path
        The results folder.
    kind : str
        What writes it (``"fit"``, ``"simulate"``, ...), recorded in the marker file.
    force : bool
        Replace an existing file or a folder casrecon did not write. Never a folder holding ``inputs``.
    inputs : iterable of Path
        The run's inputs (:func:`casrecon.output.out_folder.input_paths`), never replaced.

    Raises
    ------
    OutFolderError
        ``target`` may not or cannot be written (before the block runs).
    ResultsWriteError
        An ``OSError`` while writing (disk full, ...), as an ``OSError`` naming ``target``.

    Notes
    -----
    Temporary folders of runs that were killed (SIGKILL) are removed first. On any exception,
    ``KeyboardInterrupt`` and other ``BaseException`` included, the temporary folder (and any parent
    folder created for it) is removed and the earlier ``target`` is untouched. The swap is two renames
    with SIGINT and SIGTERM held back between them; writers finishing together each end with a
    complete folder in place (the last one's) and nothing left behind.
    """
    given = target
    target = Path(target).expanduser().resolve()
    clean_stale(target)
    target = check_out_folder(given, inputs=inputs, force=force)
    missing = []
    parent = target.parent
    while not parent.exists():
        missing.append(parent)
        parent = parent.parent
    tmp = None
    try:
        target.parent.mkdir(parents=True, exist_ok=True)
        with signals_held():  # no Ctrl-C between creating the folder and knowing its name
            tmp = Path(tempfile.mkdtemp(prefix=temp_name(target, "tmp"), dir=target.parent))
            _ACTIVE.add(tmp)
        yield tmp
        write_marker(tmp, kind)
        backups = _swap(tmp, target, None if force else str(given))
    except BaseException as err:
        if tmp is not None:
            remove_tree(tmp)
            _ACTIVE.discard(tmp)
        for folder in missing:
            try:
                folder.rmdir()
            except OSError:
                break
        if isinstance(err, OSError) and not isinstance(err, ResultsWriteError):
            raise ResultsWriteError(err.errno, err.strerror or str(err), str(target)) from err
        raise
    for backup in backups:
        remove_tree(backup)


def _swap(tmp: Path, target: Path, owned_check: str | None) -> list[Path]:
    """Rename ``tmp`` to ``target``, the earlier ``target`` (and any folder a concurrent writer put
    there) to backups, which are returned for removal; SIGINT/SIGTERM are held back meanwhile.
    On failure the newest backup is put back and the others removed. With ``owned_check`` (the name
    to report), a folder someone else created at ``target`` meanwhile is not replaced."""
    with signals_held(), _SWAP_LOCK:
        return _swap_held(tmp, target, owned_check)


def _swap_held(tmp: Path, target: Path, owned_check: str | None) -> list[Path]:
    backups: list[Path] = []
    try:
        if owned_check is not None and target.is_dir() and not is_results_folder(target):
            raise OutFolderError(owned_check, f"was created by someone else while casrecon wrote (no {MARKER}); "
                                 "nothing replaced")
        for _ in range(100):
            if target.exists() or target.is_symlink():
                backup = target.parent / f"{temp_name(target, 'old')}{secrets.token_hex(4)}"
                try:
                    os.replace(target, backup)
                    backups.append(backup)
                except FileNotFoundError:
                    pass  # a concurrent writer moved it away first
            try:
                os.replace(tmp, target)
                _ACTIVE.discard(tmp)
                return backups
            except OSError as err:
                if err.errno not in _RACE_ERRNOS:
                    raise
                # a concurrent writer swapped its folder in between our renames: move it aside too
        raise OSError(errno.EBUSY, "the folder kept being replaced by concurrent writers", str(target))
    except BaseException:
        if backups and not (target.exists() or target.is_symlink()):
            try:
                os.replace(backups.pop(), target)
            except OSError:
                pass
        for backup in backups:
            remove_tree(backup)
        raise


def save_results_folder(folder: str | Path, name: str, write: Callable[[Path], None] | None,
                        source: Path | None, draw: Callable[[Path], None] | None = None, *,
                        kind: str = "results", force: bool = False, inputs: Iterable[Path] = ()) -> Path:
    """Write a result's folder atomically: with ``write(out)`` when the result holds a fit, else as a
    copy of the folder it was loaded from (``source``, without ``figures/``); then ``draw(out)``
    when given. ValueError naming the result ``name`` when it has neither. ``kind``, ``force`` and
    ``inputs`` as for :func:`atomic_folder` (an existing folder casrecon did not write is replaced
    only with ``force``; never one holding ``inputs``). Returns the folder."""
    folder = Path(folder)
    with atomic_folder(folder, kind=kind, force=force, inputs=inputs) as out:
        if write is not None:
            write(out)
        elif source is not None:
            shutil.copytree(source, out, dirs_exist_ok=True, ignore=shutil.ignore_patterns("figures"))
        else:
            raise ValueError(f"{name}: nothing to save (neither a fit nor a source folder)")
        if draw is not None:
            draw(out)
    return folder


def write_json(path: str | Path, data) -> None:
    """Write ``data`` as indented JSON (numpy scalars and arrays converted)."""
    Path(path).write_text(json.dumps(data, indent=2, default=to_builtin) + "\n")


def to_builtin(obj):
    """JSON form of what ``json`` cannot write itself: numpy arrays as lists, numpy scalars as
    Python numbers, anything else as its ``str``."""
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


def json_values(obj):
    """``obj`` as its JSON file reads back (``json.loads(json.dumps(obj, default=to_builtin))``), made
    without the text: dicts with string keys (``True`` -> ``"true"``, ``None`` -> ``"null"``, numbers
    by their repr), tuples and arrays as lists, numpy scalars as Python numbers, anything else as
    :func:`to_builtin` makes it. What a fresh result object holds is then what its saved folder holds."""
    if isinstance(obj, dict):
        return {_json_key(k): json_values(v) for k, v in obj.items()}
    if isinstance(obj, (list, tuple)):
        return [json_values(v) for v in obj]
    if obj is None or isinstance(obj, bool):
        return obj
    if isinstance(obj, str):
        return str(obj)
    if isinstance(obj, int):
        return int(obj)
    if isinstance(obj, float):
        return float(obj)
    return json_values(to_builtin(obj))


def _json_key(key) -> str:
    """A dict key as ``json.dumps`` writes it (a TypeError for keys it refuses, as it does)."""
    if isinstance(key, str):
        return str(key)
    if key is None or isinstance(key, (bool, int, float)):
        return json.dumps(key)
    raise TypeError(f"keys must be str, int, float, bool or None, not {type(key).__name__}")


def write_columns(path: str | Path, columns: Sequence[str], data: np.ndarray, fmt: str = "%.9g") -> None:
    """Write a numeric table as CSV with a header row."""
    np.savetxt(path, np.asarray(data), delimiter=",", header=",".join(columns), comments="", fmt=fmt)
