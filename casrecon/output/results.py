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
from collections.abc import Iterator, Sequence
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


def write_json(path: str | Path, data) -> None:
    """Write ``data`` as indented JSON (numpy scalars and arrays converted)."""
    Path(path).write_text(json.dumps(data, indent=2, default=_to_builtin) + "\n")


def _to_builtin(obj):
    if isinstance(obj, np.ndarray):
        return obj.tolist()
    if isinstance(obj, np.generic):
        return obj.item()
    return str(obj)


def write_columns(path: str | Path, columns: Sequence[str], data: np.ndarray, fmt: str = "%.9g") -> None:
    """Write a numeric table as CSV with a header row."""
    np.savetxt(path, np.asarray(data), delimiter=",", header=",".join(columns), comments="", fmt=fmt)
