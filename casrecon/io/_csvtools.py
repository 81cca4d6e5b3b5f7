"""Small shared helpers of the input readers: text loading and located number parsing.

Every helper raises :class:`casrecon.io.errors.InputError` (never a bare ``ValueError``,
``IndexError`` or ``UnicodeDecodeError``) so that a reader can let it propagate unchanged.
"""

from __future__ import annotations

import os
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
                 kind: str = "the expected kind of file") -> dict[str, int]:
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
    kind : str
        What the file should be, with its article (``"an IMU CSV"``), for the message when none of ``wanted`` is there.

    Returns
    -------
    dict
        Name to 0-based column index.

    Raises
    ------
    InputError
        Naming the first required column that is missing; when none of them is there (another
        kind of file), saying what header was expected instead of quoting the file's line.
    """
    index: dict[str, int] = {}
    for k, name in enumerate(header):
        index.setdefault(name, k)
    if not any(name in index for name in wanted):
        raise InputError(path, f"not {kind}: expected a header line naming the columns "
                         f"{', '.join(wanted)} (none of them found)", line=line)
    for name in wanted:
        if name not in index:
            raise InputError(path, f"required column '{name}' is missing (columns found: "
                             f"{', '.join(header)[:200]})", line=line, field=name)
    return {name: index[name] for name in wanted}


def check_increasing(path: str | Path, t: np.ndarray, line_numbers: Sequence[int] | np.ndarray,
                     field: str, fmt: Callable[[float], str] = "{:.9g}".format) -> None:
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


# ------------------------------------------------------------------ large files, in blocks
#: Default size of the blocks a large file is read in (bytes; blocks end on a line break).
CHUNK_BYTES = 1 << 19
_WHITESPACE = b" \t\n\r\x0b\x0c"


def _content_end(fh, size: int) -> int:
    """Offset just past the last non-whitespace byte of an open binary file (0 if none)."""
    end = size
    step = 1 << 16
    while end > 0:
        start = max(0, end - step)
        fh.seek(start)
        tail = fh.read(end - start).rstrip(_WHITESPACE)
        if tail:
            return start + len(tail)
        end = start
    return 0


def iter_line_blocks(path: str | Path, chunk_bytes: int = CHUNK_BYTES):
    """Yield a file as ``(first_line_number, block)`` pairs of whole lines, memory bounded.

    Each block is ``bytes`` of complete lines, every line ending in ``b"\\n"`` (CRLF and lone
    CR line ends are turned into LF, as :func:`read_lines` does); a UTF-8 byte-order mark is
    dropped; trailing whitespace and blank lines at the end of the file are not yielded
    (as :func:`read_lines` callers drop them). Line numbers are 1-based. Blocks are about
    ``chunk_bytes`` long (longer when a single line is longer). The bytes are *not* checked
    here: :func:`decode_block` does that for a block that needs the slow path.

    Raises
    ------
    InputError
        If the file cannot be opened or holds only whitespace ("file is empty").
    """
    try:
        fh = open(path, "rb")  # noqa: SIM115 - closed in the finally below
    except OSError as exc:
        raise InputError(path, f"cannot read file: {exc.strerror or exc}") from None
    try:
        end = _content_end(fh, os.fstat(fh.fileno()).st_size)
        if end == 0:
            raise InputError(path, "file is empty")
        fh.seek(0)
        pos, line, carry, first = 0, 1, b"", True
        while pos < end:
            data = fh.read(min(chunk_bytes, end - pos))
            if not data:
                break
            pos += len(data)
            buf = carry + data
            if first:
                first = False
                if buf.startswith(b"\xef\xbb\xbf"):
                    buf = buf[3:]
            if pos < end:
                cut = buf.rfind(b"\n") + 1
                if cut == 0:
                    carry = buf
                    continue
                block, carry = buf[:cut], buf[cut:]
            else:
                block, carry = buf + b"\n", b""
            if b"\r" in block:
                block = block.replace(b"\r\n", b"\n").replace(b"\r", b"\n")
            yield line, block
            line += block.count(b"\n")
        if carry:
            block = carry.replace(b"\r\n", b"\n").replace(b"\r", b"\n") + b"\n"
            yield line, block
    except OSError as exc:
        raise InputError(path, f"cannot read file: {exc.strerror or exc}") from None
    finally:
        fh.close()


def decode_block(path: str | Path, block: bytes, first_line: int) -> list[str]:
    """Check and decode a block from :func:`iter_line_blocks` into its lines.

    Raises
    ------
    InputError
        On binary bytes or bytes that are not UTF-8, located by line, as :func:`read_lines`.
    """
    found = _BINARY.search(block)
    if found is not None:
        bad = found.start()
        raise InputError(path, f"binary data (byte 0x{block[bad]:02x}); expected a text file",
                         line=first_line + block.count(b"\n", 0, bad))
    try:
        text = block.decode("utf-8")
    except UnicodeDecodeError as exc:
        raise InputError(path, "not UTF-8 text (undecodable byte); expected a text file",
                         line=first_line + block.count(b"\n", 0, exc.start)) from None
    return text.split("\n")[:-1]


_FAST_BYTES = b"0123456789.,-+eE\n"
_POW10_I = 10 ** np.arange(19, dtype=np.int64)
_POW10_F = 10.0 ** np.arange(23)
#: Most significant digits a number may have on the fast path (exact below 2**53).
FAST_MAX_DIGITS = 15


def parse_numeric_block(block: bytes, ncols: int) -> np.ndarray | None:
    """Parse a block of comma-separated decimal numbers, fast and exactly, or give up.

    The fast path of the large-file readers: numpy operations over the bytes (no Python
    loop per value), releasing the GIL so blocks parse in parallel threads. Only the plain
    form ``[+-]digits[.digits][(e|E)[+-]digits]`` with at most 15 significant digits and
    a decimal exponent within +-22 is accepted; each value is then the correctly rounded
    double (an exact integer mantissa times or divided by an exact power of ten), the same
    as ``float(text)``.

    Parameters
    ----------
    block : bytes
        Whole lines, each ending in ``b"\\n"``.
    ncols : int
        Fields every line must have.

    Returns
    -------
    numpy.ndarray or None
        (rows, ncols) float64, or None when anything is outside the plain form (another
        byte, a blank field or line, a row with another field count, too many digits...):
        the caller then takes the slow path, which finds and locates any real error.
    """
    if not block.endswith(b"\n") or block.translate(None, _FAST_BYTES):
        return None
    a = np.frombuffer(block, np.uint8)
    is_sep = (a == 44) | (a == 10)
    ends = np.flatnonzero(is_sep)
    nf = ends.size
    if nf % ncols:
        return None
    kinds = a[ends].reshape(-1, ncols)
    if not ((kinds[:, -1] == 10).all() and (kinds[:, :-1] == 44).all()):
        return None
    starts = np.empty(nf, np.int64)
    starts[0] = 0
    starts[1:] = ends[:-1] + 1
    lengths = ends - starts
    if not lengths.all():
        return None
    v = a - np.uint8(48)
    digit = v < 10
    fid = np.cumsum(is_sep, dtype=np.int32)  # field index of every non-separator byte
    dot_pos = np.flatnonzero(a == 46)
    dot_f = fid[dot_pos]
    if dot_f.size > 1 and not (np.diff(dot_f) > 0).all():
        return None
    exp10 = np.zeros(nf, np.int64)
    mant = digit
    e_pos = np.flatnonzero((a == 101) | (a == 69))
    if e_pos.size:
        e_f = fid[e_pos]
        if (e_f.size > 1 and not (np.diff(e_f) > 0).all()) or (e_pos == starts[e_f]).any():
            return None
        prev = a[e_pos - 1]
        if not (((prev - np.uint8(48)) < 10) | (prev == 46)).all():
            return None
        first = e_pos + 1
        neg = a[first] == 45
        first = first + (neg | (a[first] == 43))
        elen = ends[e_f] - first
        if not ((elen >= 1) & (elen <= 3)).all():
            return None
        val = np.zeros(e_pos.size, np.int64)
        for j in range(3):
            use = j < elen
            d = v[np.where(use, first + j, first)].astype(np.int64)
            if not (d[use] < 10).all():
                return None
            val = np.where(use, val * 10 + d, val)
        exp10[e_f] = np.where(neg, -val, val)
        if dot_pos.size:
            e_at = np.full(nf, np.iinfo(np.int64).max)
            e_at[e_f] = e_pos
            if (dot_pos > e_at[dot_f]).any():
                return None
        marks = np.zeros(a.size + 1, np.int8)
        marks[e_pos] = 1
        marks[ends[e_f]] = -1
        mant = digit & (np.cumsum(marks[:-1], dtype=np.int8) == 0)
    s_pos = np.flatnonzero((a == 45) | (a == 43))
    if s_pos.size:
        prev = a[np.maximum(s_pos - 1, 0)]
        if not ((s_pos == starts[fid[s_pos]]) | (prev == 101) | (prev == 69)).all():
            return None
    c = np.cumsum(mant, dtype=np.int32)
    cend = c[ends]
    ndig = np.diff(cend, prepend=np.int32(0))
    if not ((ndig >= 1) & (ndig <= FAST_MAX_DIGITS)).all():
        return None
    r = np.repeat(cend, lengths + 1) - c
    contrib = np.where(mant, v, 0).astype(np.int64) * _POW10_I[np.minimum(r, 18)]
    m = np.add.reduceat(contrib, starts)
    frac = np.zeros(nf, np.int64)
    frac[dot_f] = cend[dot_f] - c[dot_pos]
    e10 = exp10 - frac
    if (np.abs(e10) > 22).any():
        return None
    x = m.astype(np.float64)
    up = e10 >= 0
    x = np.where(up, x * _POW10_F[np.where(up, e10, 0)], x / _POW10_F[np.where(up, 0, -e10)])
    x = np.where(a[starts] == 45, -x, x)
    return x.reshape(-1, ncols)
