"""Typed, located access to a parsed TOML table: every error names the file and the dotted field."""

from __future__ import annotations

import math
import re
import tomllib
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from casrecon.io.errors import InputError

_RECORDERS: list[set[tuple[Path, str, str]]] = []


@contextmanager
def record_keys() -> Iterator[set[tuple[Path, str, str]]]:
    """Collect the keys every :class:`Fields` getter reads inside the ``with`` block.

    Yields a set that fills with ``(file, table, key)``: the TOML file's path, the dotted table
    name ("" for the top level) and the key; sub-tables are recorded as tables, not as keys.
    Parsing behaves exactly as without the recorder (used by the test that keeps the key
    reference ``docs/problem-toml.md`` complete).
    """
    keys: set[tuple[Path, str, str]] = set()
    _RECORDERS.append(keys)
    try:
        yield keys
    finally:
        _RECORDERS.remove(keys)


@dataclass(frozen=True)
class TomlDocument:
    """A TOML file parsed once: its ``path`` (as given; relative paths inside it are read against its
    folder) and its ``data``. Commands read each input TOML once (:func:`read_toml`) and hand the
    document to every layer that needs it (the ``--out`` check, the problem's kind, its loader)."""

    path: Path
    data: dict

    def fields(self) -> Fields:
        """The document as located, validating :class:`Fields` (a fresh record of the keys read)."""
        return Fields(self.data, self.path, "")


def read_toml(path: str | Path) -> TomlDocument:
    """Parse a TOML file once, turning syntax errors into located InputErrors."""
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            data = tomllib.load(fh)
    except FileNotFoundError:
        raise InputError(path, "file not found") from None
    except tomllib.TOMLDecodeError as err:
        line = getattr(err, "lineno", None)  # Python >= 3.14; before, only in the message
        if line is None:
            found = re.search(r"at line (\d+)", str(err))
            line = int(found.group(1)) if found else None
        raise InputError(path, f"not valid TOML: {err}", line=line) from None
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(path, f"cannot read: {err}") from None
    return TomlDocument(path, data)


def load_toml(source: str | Path | TomlDocument) -> Fields:
    """:class:`Fields` of a TOML file: of an already parsed :class:`TomlDocument`, or of a path
    parsed now (:func:`read_toml`)."""
    document = source if isinstance(source, TomlDocument) else read_toml(source)
    return document.fields()


class Fields:
    """A TOML table with its file and dotted prefix; getters validate type and range.

    Every getter marks the key as used; :meth:`reject_unknown` then reports misspelt keys.
    """

    def __init__(self, data: dict, path: Path, prefix: str) -> None:
        self.data, self.path, self.prefix = data, Path(path), prefix
        self._used: set[str] = set()

    def name(self, key: str) -> str:
        return f"{self.prefix}{key}"

    def error(self, key: str, message: str) -> InputError:
        return InputError(self.path, message, field=self.name(key))

    def has(self, key: str) -> bool:
        return key in self.data

    def keys_read(self) -> frozenset[str]:
        """Keys of this table that a getter has asked for so far."""
        return frozenset(self._used)

    def raw(self, key: str, default: Any = None, required: bool = False) -> Any:
        return self._get(key, default, required, leaf=True)

    def _get(self, key: str, default: Any, required: bool, leaf: bool) -> Any:
        self._used.add(key)
        if leaf:
            for keys in _RECORDERS:
                keys.add((self.path, self.prefix.rstrip("."), key))
        if key not in self.data:
            if required:
                raise self.error(key, "is required but missing")
            return default
        return self.data[key]

    def table(self, key: str, required: bool = False) -> Fields | None:
        value = self._get(key, None, required, leaf=False)
        if value is None:
            return None
        if not isinstance(value, dict):
            raise self.error(key, f"expected a table, got {type(value).__name__}")
        return Fields(value, self.path, self.name(key) + ".")

    def string(self, key: str, default: str | None = None, required: bool = False,
               choices: tuple[str, ...] | None = None) -> str | None:
        value = self.raw(key, default, required)
        if value is None:
            return None
        if not isinstance(value, str):
            raise self.error(key, f"expected a string, got {value!r}")
        if choices and value not in choices:
            raise self.error(key, f"expected one of {', '.join(choices)}, got {value!r}")
        return value

    def boolean(self, key: str, default: bool) -> bool:
        value = self.raw(key, default)
        if not isinstance(value, bool):
            raise self.error(key, f"expected true or false, got {value!r}")
        return value

    def number(self, key: str, default: float | None = None, required: bool = False,
               minimum: float | None = None, positive: bool = False) -> float | None:
        value = self.raw(key, default, required)
        if value is None:
            return None
        return self._check_number(key, value, minimum, positive)

    def integer(self, key: str, default: int, minimum: int | None = None) -> int:
        value = self.raw(key, default)
        if not isinstance(value, int) or isinstance(value, bool):
            raise self.error(key, f"expected an integer, got {value!r}")
        if minimum is not None and value < minimum:
            raise self.error(key, f"expected an integer >= {minimum}, got {value}")
        return value

    def vector(self, key: str, n: int, default=None, required: bool = False) -> tuple[float, ...] | None:
        value = self.raw(key, default, required)
        if value is None:
            return None
        if not isinstance(value, (list, tuple)) or len(value) != n:
            raise self.error(key, f"expected a list of {n} numbers, got {value!r}")
        return tuple(self._check_number(key, v, None, False) for v in value)

    def matrix(self, key: str, default=None) -> tuple[tuple[float, ...], ...] | None:
        value = self.raw(key, default)
        if value is None:
            return None
        if not isinstance(value, (list, tuple)) or len(value) != 3:
            raise self.error(key, f"expected a 3x3 matrix as three rows of three numbers, got {value!r}")
        rows = []
        for row in value:
            if not isinstance(row, (list, tuple)) or len(row) != 3:
                raise self.error(key, f"expected a 3x3 matrix as three rows of three numbers, got {value!r}")
            rows.append(tuple(self._check_number(key, v, None, False) for v in row))
        return tuple(rows)

    def path_of(self, key: str, required: bool = False, must_exist: bool = True) -> Path | None:
        """A file path relative to this TOML file's folder."""
        value = self.string(key, required=required)
        if value is None:
            return None
        path = (self.path.parent / value).resolve()
        if must_exist and not path.is_file():
            raise self.error(key, f"file {value!r} not found (looked for {path})")
        return path

    def reject_unknown(self) -> None:
        """Raise on keys that no getter asked for (misspellings, stale settings)."""
        unknown = sorted(set(self.data) - self._used)
        if unknown:
            known = ", ".join(sorted(self._used)) or "none"
            raise self.error(unknown[0], f"unknown field (known here: {known})")

    def _check_number(self, key: str, value: Any, minimum: float | None, positive: bool) -> float:
        if isinstance(value, bool) or not isinstance(value, (int, float)):
            raise self.error(key, f"expected a number, got {value!r}")
        value = float(value)
        if not math.isfinite(value):
            raise self.error(key, f"expected a finite number, got {value!r}")
        if positive and value <= 0:
            raise self.error(key, f"expected a positive number, got {value}")
        if minimum is not None and value < minimum:
            raise self.error(key, f"expected a number >= {minimum}, got {value}")
        return value
