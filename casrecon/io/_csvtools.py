"""Small shared helpers of the input readers: text loading and located number parsing.

Every helper raises :class:`casrecon.io.errors.InputError` (never a bare ``ValueError``,
``IndexError`` or ``UnicodeDecodeError``) so that a reader can let it propagate unchanged.
"""

from __future__ import annotations

import re
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from casrecon.io.errors import InputError

#: Bytes that never occur in a text data file; their presence means binary garbage.
_BINARY = re.compile(rb"[\x00-\x08\x0b\x0c\x0e-\x1a\x1c-\x1f\x7f]")


def read_lines(path: str | Path, require_final_newline: bool = False) -> list[str]:
    """Read a text data file as a list of lines without their line terminators.

    Parameters
    ----------
    path : str or Path
        File to read. LF and CRLF line endings are both accepted.
    require_final_newline : bool
        If true, a last line without a line terminator is taken as a file cut mid-write
        (a device that was switched off while writing) and is an error.

    Returns
    -------
    list of str
        The lines, 1-based line ``k`` being element ``k - 1``.

    Raises
    ------
    InputError
        If the file cannot be opened, is empty, holds binary bytes (NUL or other control
        characters) or is not valid UTF-8; the line of the first bad byte is given.
    """
    try:
        raw = Path(path).read_bytes()
    except OSError as exc:
        raise InputError(path, f"cannot read file: {exc.strerror or exc}") from None
    if not raw.strip():
        raise InputError(path, "file is empty")
    found = _BINARY.search(raw)
    if found is not None:
        bad = found.start()
        raise InputError(path, f"binary data (byte 0x{raw[bad]:02x}); expected a text file",
                         line=raw.count(b"\n", 0, bad) + 1)
    try:
        text = raw.decode("utf-8-sig")
    except UnicodeDecodeError as exc:
        raise InputError(path, "not UTF-8 text (undecodable byte); expected a text file",
                         line=raw.count(b"\n", 0, exc.start) + 1) from None
    lines = text.replace("\r\n", "\n").replace("\r", "\n").split("\n")
    if lines[-1] == "":
        lines.pop()
    elif require_final_newline:
        raise InputError(path, "last line has no line terminator: file cut mid-write "
                         "(partial last row)", line=len(lines))
    return lines


def split_rows(path: str | Path, lines: Sequence[str], line_numbers: Sequence[int],
               ncols: int, sep: str = ",") -> list[list[str]]:
    """Split delimited rows and check each has exactly ``ncols`` fields.

    Parameters
    ----------
    path : str or Path
        File name, for error messages.
    lines : sequence of str
        The data lines.
    line_numbers : sequence of int
        1-based line number of each of ``lines`` in the file.
    ncols : int
        Number of fields the header declares.
    sep : str
        Field separator.

    Raises
    ------
    InputError
        On a row with a different number of fields (a truncated or cut-off row); the
        message gives the line number.
    """
    rows = [ln.split(sep) for ln in lines]
    for k, row in enumerate(rows):
        if len(row) != ncols:
            what = "truncated row" if len(row) < ncols else "row with extra fields"
            raise InputError(path, f"{what}: {len(row)} fields, expected {ncols} "
                             "(as in the header)", line=int(line_numbers[k]))
    return rows


def parse_floats(path: str | Path, cells: Sequence[str], line_numbers: Sequence[int] | np.ndarray,
                 field: str, allow_empty: bool = False) -> np.ndarray:
    """Convert a column of text cells to finite float64, fast, with a located error.

    Parameters
    ----------
    path : str or Path
        File name, for error messages.
    cells : sequence of str
        Text of the cells, one per row.
    line_numbers : sequence of int
        1-based line number of each cell.
    field : str
        Column name, for error messages.
    allow_empty : bool
        If true, blank cells become NaN (a missing value the caller handles); otherwise a
        blank cell is an error.

    Returns
    -------
    numpy.ndarray
        float64 values. NaN only where a blank cell was allowed.

    Raises
    ------
    InputError
        On an unparseable number, a blank cell (unless allowed), or a NaN or infinite
        value written in the file; the line and column are given.
    """
    convert = _float_or_nan if allow_empty else float
    try:
        values = np.fromiter(map(convert, cells), dtype=np.float64, count=len(cells))
    except ValueError:
        for k, text in enumerate(cells):
            try:
                convert(text)
            except ValueError:
                shown = text.strip()
                msg = "empty value" if not shown else f"not a number: '{shown[:40]}'"
                raise InputError(path, msg, line=int(line_numbers[k]), field=field) from None
        raise InputError(path, "unparseable number", field=field) from None
    bad = ~np.isfinite(values)
    if allow_empty:
        bad &= np.array([bool(c.strip()) for c in cells], dtype=bool)
    if bad.any():
        k = int(np.argmax(bad))
        raise InputError(path, f"non-finite value '{cells[k].strip()}'; expected a finite "
                         "number", line=int(line_numbers[k]), field=field)
    return values


def _float_or_nan(text: str) -> float:
    """``float(text)``, NaN for a blank cell."""
    return float(text) if text.strip() else np.nan


def find_columns(path: str | Path, header: Sequence[str], wanted: Sequence[str], line: int,
                 ) -> dict[str, int]:
    """Locate named columns in a header row.

    Parameters
    ----------
    path : str or Path
        File name, for error messages.
    header : sequence of str
        Column names (already stripped).
    wanted : sequence of str
        Required names.
    line : int
        1-based line number of the header.

    Returns
    -------
    dict
        Name to 0-based column index.

    Raises
    ------
    InputError
        Naming the first required column that is missing.
    """
    index: dict[str, int] = {}
    for k, name in enumerate(header):
        index.setdefault(name, k)
    for name in wanted:
        if name not in index:
            raise InputError(path, f"required column '{name}' is missing (columns found: "
                             f"{', '.join(header)[:200]})", line=line, field=name)
    return {name: index[name] for name in wanted}


def check_increasing(path: str | Path, t: np.ndarray, line_numbers: Sequence[int] | np.ndarray,
                     field: str, fmt: Callable[[float], str] = repr) -> None:
    """Require strictly increasing times; report the first offending line.

    Raises
    ------
    InputError
        If a value goes backwards or repeats the previous one.
    """
    if t.size < 2:
        return
    step = np.diff(t)
    bad = step <= 0
    if bad.any():
        k = int(np.argmax(bad)) + 1
        how = "repeats the previous value" if step[k - 1] == 0 else "goes backwards"
        raise InputError(path, f"time {how} ({fmt(t[k - 1])} then {fmt(t[k])}); times must be "
                         "strictly increasing", line=int(line_numbers[k]), field=field)
