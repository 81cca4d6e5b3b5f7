"""Results folders written atomically, and the table/JSON writers they use.

:func:`atomic_folder` hands out a fresh temporary folder next to the target; only when the block
finishes without an exception is it swapped in place of the target, so a failed run never leaves a
half-written folder and never destroys an earlier result.
"""

from __future__ import annotations

import contextlib
import json
import os
import shutil
import tempfile
from collections.abc import Callable, Iterator, Sequence
from pathlib import Path

import numpy as np


@contextlib.contextmanager
def atomic_folder(target: str | Path) -> Iterator[Path]:
    """Yield a temporary folder that replaces ``target`` when the ``with`` block succeeds."""
    target = Path(target).resolve()
    target.parent.mkdir(parents=True, exist_ok=True)
    tmp = Path(tempfile.mkdtemp(prefix=f".{target.name}.tmp-", dir=target.parent))
    try:
        yield tmp
    except BaseException:
        shutil.rmtree(tmp, ignore_errors=True)
        raise
    backup = None
    if target.exists():
        backup = target.parent / f".{target.name}.old-{os.getpid()}"
        os.replace(target, backup)
    os.replace(tmp, target)
    if backup is not None:
        shutil.rmtree(backup, ignore_errors=True)


def save_results_folder(folder: str | Path, name: str, write: Callable[[Path], None] | None,
                        source: Path | None, draw: Callable[[Path], None] | None = None) -> Path:
    """Write a result's folder atomically: with ``write(out)`` when the result holds a fit, else as a
    copy of the folder it was loaded from (``source``, without ``figures/``); then ``draw(out)``
    when given. ValueError naming the result ``name`` when it has neither. Returns the folder."""
    folder = Path(folder)
    with atomic_folder(folder) as out:
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


def write_columns(path: str | Path, columns: Sequence[str], data: np.ndarray, fmt: str = "%.9g") -> None:
    """Write a numeric table as CSV with a header row."""
    np.savetxt(path, np.asarray(data), delimiter=",", header=",".join(columns), comments="", fmt=fmt)
