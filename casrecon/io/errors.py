"""The one error type every reader and the configuration parser raise on bad input."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np


class InputError(ValueError):
    """Bad input, located: which file, which line or field, and what was expected.

    Parameters
    ----------
    path : str or Path
        The file that is wrong.
    message : str
        What was found and what was expected, in one sentence.
    line : int, optional
        1-based line number in the file, when the fault is on a line.
    field : str, optional
        Dotted field name (``vehicle.mass_kg``) or column name, when known.

    Notes
    -----
    ``str(err)`` is a single line ``FILE:LINE: field 'F': MESSAGE`` suitable for a
    command-line tool to print as is.
    """

    def __init__(self, path: str | Path, message: str, *, line: int | None = None,
                 field: str | None = None) -> None:
        self.path = str(path)
        self.line = line
        self.field = field
        self.message = message
        super().__init__(self._format())

    def __reduce__(self):
        """Pickle by the constructor's arguments, so that an InputError raised in a worker process
        (a Monte Carlo case) reaches the parent as itself, not as a broken process pool."""
        return _rebuild, (self.path, self.message, self.line, self.field)

    def _format(self) -> str:
        where = self.path if self.line is None else f"{self.path}:{self.line}"
        what = f"field '{self.field}': " if self.field else ""
        return f"{where}: {what}{self.message}"


def _rebuild(path: str, message: str, line: int | None, field: str | None) -> InputError:
    return InputError(path, message, line=line, field=field)


def plain_repr(value: Any) -> str:
    """``repr`` of a value for a message, with numpy scalars and arrays shown as plain Python numbers
    and lists (``(1.5, 2)``, not ``(np.float64(1.5), np.int64(2))``)."""

    def plain(v: Any) -> Any:
        if isinstance(v, np.generic | np.ndarray):
            return v.tolist()
        if isinstance(v, list | tuple):
            return type(v)(plain(x) for x in v)
        return v

    return repr(plain(value))
