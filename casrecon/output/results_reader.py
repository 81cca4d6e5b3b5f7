"""The one reader of results folders: what the writers of this package wrote, read back and checked.

``casrecon report``, :func:`casrecon.load_results` (every result's ``load``) and the figures of
:mod:`casrecon.report` read a results folder through this module only. Every file it reads is
checked against what the writers produce:

- text: not empty, UTF-8, no NUL byte (binary garbage is refused, not decoded);
- JSON: valid, and an object (``{...}``) at the top; ``parameters.json`` holds ``parameters``
  ``{name: {value, sigma, ...}}`` with finite numbers for ``value`` and ``sigma`` (sigma >= 0), and a
  ``correlation`` ``{names, matrix}`` whose square matrix of numbers names every parameter;
  ``summary.json``'s known keys have their types (``converged`` a boolean, ``release_imu_s`` a
  finite number, ...); ``imu_sigma.json`` holds finite numbers;
- CSV: a header row of distinct names; every row with as many cells as the header, none empty, the
  file ending with a line break (a row cut mid-line is refused); every cell outside the text columns
  (``utc``) a number; the time columns a table must have (``time_imu_s`` and ``flight_time_s`` of a
  per-drop ``trajectory.csv``, ``segment_time_s`` and ``time_unix_s`` of a point-mass one,
  ``segment_time_s`` of a kinematic one, whose clock need not be UTC) present and finite. Other
  cells may be NaN: the writers write NaN where a quantity does not exist (a missing GPS
  component, C_m outside its validity range).

Any damage is an :class:`~casrecon.io.errors.InputError` naming the file, the line (1-based, the
header being line 1) or key, and what was expected: exit status 2 from the command line.
"""

from __future__ import annotations

import io
import json
import math
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from casrecon.io.errors import InputError
from casrecon.io.units import TEXT_COLUMNS

if TYPE_CHECKING:
    import pandas as pd

#: Kinds of results folder: a per-drop 6-DOF fit, a joint fit (``drops/<name>/``), a point-mass
#: (GPS-only) fit, a kinematic (IMU-driven) reconstruction.
KINDS = ("drop", "joint", "point-mass", "kinematic")
#: Files without which a folder is not a results folder of each kind.
REQUIRED_FILES = {"drop": ("summary.json", "parameters.json", "trajectory.csv"),
                  "joint": ("summary.json", "parameters.json"),
                  "point-mass": ("summary.json", "parameters.json", "trajectory.csv"),
                  "kinematic": ("summary.json", "parameters.json", "trajectory.csv")}
#: What messages call a folder of each kind.
KIND_LABELS = {"drop": "per-drop", "joint": "joint", "point-mass": "point-mass", "kinematic": "kinematic"}
#: Time columns a ``trajectory.csv`` must have, finite at every row, by kind.
TRAJECTORY_TIME_COLUMNS = {"drop": ("time_imu_s", "flight_time_s"),
                           "point-mass": ("segment_time_s", "time_unix_s"),
                           "kinematic": ("segment_time_s",)}
#: summary.json keys the readers use, with the JSON types they must have when present.
SUMMARY_TYPES = {"problem": (str,), "name": (str,), "kind": (str,), "converged": (bool,),
                 "reduced_chi2": (int, float), "release_imu_s": (int, float), "impact_imu_s": (int, float),
                 "window_imu_s": (list,), "chi2": (dict, int, float), "chi2_per_drop": (dict,),
                 "fit": (dict,), "adequacy": (dict,), "single_drop_sigma": (dict,), "shared": (list,),
                 "notes": (list,)}
#: summary.json keys that must be finite numbers when present (the writers never write NaN there).
SUMMARY_FINITE = ("release_imu_s", "impact_imu_s")
PARAMETERS_SHAPE = "parameters {name: {value, sigma, ...}} and correlation {names, matrix}"


def read_text(path: str | Path, what: str) -> str:
    """The text of a results file; InputError naming it when it is empty, not UTF-8 or binary
    (``what``: what was expected, for the message)."""
    path = Path(path)
    data = path.read_bytes()
    if not data.strip():
        raise InputError(path, f"empty file; expected {what}")
    try:
        text = data.decode("utf-8")
    except UnicodeDecodeError as err:
        line = data[:err.start].count(b"\n") + 1
        raise InputError(path, f"not text: byte 0x{data[err.start]:02x} at offset {err.start} is not UTF-8 "
                               f"(binary or damaged); expected {what}", line=line) from None
    nul = text.find("\0")
    if nul >= 0:
        raise InputError(path, f"not text: a NUL byte at offset {nul} (binary or damaged); expected {what}",
                         line=text.count("\n", 0, nul) + 1)
    return text


def read_document(path: str | Path) -> dict:
    """A results JSON file as a dict; InputError naming the file when it is not text, not JSON (cut
    short or damaged: the line of the fault) or not a JSON object."""
    path = Path(path)
    text = read_text(path, "a JSON object {...}")
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as err:
        # the writers end every document with its closing bracket: without one the file was cut short
        cut = "" if text.rstrip().endswith(("}", "]")) else " (the file is cut short)"
        raise InputError(path, f"not valid JSON: {err.msg}{cut}; expected a JSON object {{...}}",
                         line=err.lineno) from None
    if not isinstance(doc, dict):
        raise InputError(path, f"expected a JSON object {{...}}, found {_json_type(doc)}", line=1)
    return doc


def _json_type(value) -> str:
    if isinstance(value, list):
        return f"a JSON array of {len(value)} items"
    if value is None:
        return "null"
    if isinstance(value, bool):
        return f"the boolean {json.dumps(value)}"
    if isinstance(value, (int, float)):
        return f"the number {value!r}"
    if isinstance(value, str):
        return f"the string {value!r}"
    return f"a {type(value).__name__}"


def is_number(value) -> bool:
    """A JSON number (int or float, not a boolean)."""
    return isinstance(value, (int, float)) and not isinstance(value, bool)


@dataclass(frozen=True)
class Table:
    """A checked CSV file of a results folder: its header and its text (every row complete).

    Attributes
    ----------
    path : Path
        The file.
    header : tuple of str
        Column names.
    text : str
        The whole file (header row first), every row with a cell per column and a final line break.
    """

    path: Path
    header: tuple[str, ...]
    text: str

    def columns(self) -> dict[str, np.ndarray]:
        """Numeric columns as float arrays keyed by name (text columns such as ``utc`` left out)."""
        keep = [k for k, name in enumerate(self.header) if name not in TEXT_COLUMNS]
        try:
            data = np.loadtxt(io.StringIO(self.text), delimiter=",", skiprows=1, ndmin=2, usecols=keep)
        except ValueError:
            self._locate_bad_number(keep)
            raise
        if data.shape[0] == 0:
            data = np.zeros((0, len(keep)))
        return {self.header[k]: data[:, j] for j, k in enumerate(keep)}

    def frame(self) -> pd.DataFrame:
        """The table as a pandas DataFrame, every number parsed exactly as written (the nearest float;
        pandas 3 does so by default, pandas 2 needs ``float_precision="round_trip"``); the ``utc``
        column left as text."""
        import pandas as pd

        options = {"float_precision": "round_trip"} if int(pd.__version__.split(".")[0]) < 3 else {}
        frame = pd.read_csv(io.StringIO(self.text), **options)
        numeric = [k for k, name in enumerate(self.header) if name not in TEXT_COLUMNS]
        if any(not pd.api.types.is_numeric_dtype(frame.iloc[:, k]) for k in numeric):
            self._locate_bad_number(numeric)
        return frame

    def _locate_bad_number(self, numeric: list[int]) -> None:
        """Raise InputError at the first cell of a numeric column that is not a number."""
        for i, line in enumerate(self.text.split("\n")[1:], start=2):
            cells = line.split(",")
            for k in numeric:
                try:
                    float(cells[k])
                except (ValueError, IndexError):
                    raise InputError(self.path, f"expected a number, found {cells[k]!r}" if k < len(cells)
                                     else "a cell is missing", line=i, field=self.header[k]) from None


def read_table(path: str | Path, required: tuple[str, ...] = (), finite: tuple[str, ...] = ()) -> Table:
    """A results CSV file, checked for shape and completeness (module notes); ``required`` columns must
    be there and ``finite`` ones finite at every row. InputError naming the file, the line and the
    column when it is not."""
    path = Path(path)
    text = read_text(path, "a CSV table with a header row")
    lines = text.split("\n")
    if lines[-1]:
        raise InputError(path, f"the last row is cut mid-line (no line break at the end of the file; "
                               f"{lines[-1].count(',') + 1} of {lines[0].count(',') + 1} cells)", line=len(lines))
    lines.pop()
    header = tuple(n.strip() for n in lines[0].split(","))
    if any(not n for n in header) or len(set(header)) != len(header):
        raise InputError(path, f"expected a header row of distinct column names, found {lines[0][:200]!r}", line=1)
    missing = [c for c in required if c not in header]
    if missing:
        raise InputError(path, f"no column {', '.join(missing)} (the header has {', '.join(header[:12])}"
                               f"{', ...' if len(header) > 12 else ''})", line=1)
    n = len(header) - 1
    for i, line in enumerate(lines[1:], start=2):
        if line.count(",") != n:
            raise InputError(path, f"{line.count(',') + 1} cells, expected {n + 1} (one per header column)",
                             line=i)
        if line.startswith(",") or line.endswith(",") or ",," in line:
            k = line.split(",").index("")
            raise InputError(path, "an empty cell; expected a value in every column", line=i, field=header[k])
    table = Table(path, header, "\n".join(lines) + "\n")
    if finite:
        for k in (header.index(c) for c in finite):
            values = np.array([line.split(",")[k] for line in lines[1:]])
            try:
                numbers = values.astype(float)
            except ValueError:
                table._locate_bad_number([k])
                raise
            bad = np.flatnonzero(~np.isfinite(numbers))
            if bad.size:
                raise InputError(path, f"expected a finite number, found {values[bad[0]]!r}", line=int(bad[0]) + 2,
                                 field=header[k])
    return table


def check_parameters(doc: dict, path: str | Path) -> None:
    """InputError naming ``path`` and the key unless ``doc`` is a parameters.json document: every
    parameter an object with a finite ``value`` and a finite ``sigma`` >= 0 (numbers, not text);
    ``sigma_chi2_scaled``, ``three_sigma`` and ``prior_sigma`` numbers or null; a correlation, when
    present, naming every parameter with a square matrix of numbers."""
    entries = doc.get("parameters")
    if not isinstance(entries, dict):
        raise InputError(path, f"expected an object {{name: {{value, sigma, ...}}}}, found {_json_type(entries)}",
                         field="parameters")
    for name, entry in entries.items():
        where = f"parameters.{name}"
        if not isinstance(entry, dict):
            raise InputError(path, f"expected an object {{value, sigma, ...}}, found {_json_type(entry)}", field=where)
        for key in ("value", "sigma"):
            if key not in entry:
                raise InputError(path, f"no '{key}'; expected {PARAMETERS_SHAPE}", field=where)
            v = entry[key]
            if not is_number(v) or not math.isfinite(v) or (key == "sigma" and v < 0):
                expected = "a finite number >= 0" if key == "sigma" else "a finite number"
                raise InputError(path, f"expected {expected}, found {_json_type(v)}", field=f"{where}.{key}")
        for key in ("sigma_chi2_scaled", "three_sigma", "prior_sigma"):
            if entry.get(key) is not None and not is_number(entry[key]):
                raise InputError(path, f"expected a number or null, found {_json_type(entry[key])}",
                                 field=f"{where}.{key}")
        for key, types, what in (("unit", (str,), "a string"), ("group", (str,), "a string"),
                                 ("shared", (bool, type(None)), "true, false or null")):
            if key in entry and not isinstance(entry[key], types):
                raise InputError(path, f"expected {what}, found {_json_type(entry[key])}", field=f"{where}.{key}")
    corr = doc.get("correlation")
    if not corr:
        return
    if not isinstance(corr, dict):
        raise InputError(path, f"expected an object {{names, matrix}}, found {_json_type(corr)}", field="correlation")
    names, matrix = corr.get("names"), corr.get("matrix")
    if not isinstance(names, list) or not all(isinstance(n, str) for n in names):
        raise InputError(path, f"expected a list of parameter names, found {_json_type(names)}",
                         field="correlation.names")
    absent = [n for n in entries if n not in names]
    if absent:
        raise InputError(path, f"does not name the parameter(s) {', '.join(absent[:5])}", field="correlation.names")
    n = len(names)
    if (not isinstance(matrix, list) or len(matrix) != n
            or not all(isinstance(row, list) and len(row) == n for row in matrix)):
        raise InputError(path, f"expected a {n} x {n} matrix (a list of {n} rows of {n} numbers)",
                         field="correlation.matrix")
    for i, row in enumerate(matrix):
        for j, v in enumerate(row):
            if not is_number(v):
                raise InputError(path, f"expected a number, found {_json_type(v)}",
                                 field=f"correlation.matrix[{i}][{j}]")


def check_summary(doc: dict, path: str | Path) -> None:
    """InputError naming ``path`` and the key unless every known key of the summary.json ``doc``
    (:data:`SUMMARY_TYPES`) has its type, and :data:`SUMMARY_FINITE` keys are finite."""
    for key, types in SUMMARY_TYPES.items():
        if doc.get(key) is None:
            continue
        v = doc[key]
        if not isinstance(v, types) or (isinstance(v, bool) and bool not in types):
            expected = " or ".join({str: "a string", bool: "true or false", int: "a number", float: "a number",
                                    list: "a list", dict: "an object"}[t] for t in dict.fromkeys(types))
            raise InputError(path, f"expected {expected}, found {_json_type(v)}", field=key)
        if key in SUMMARY_FINITE and not math.isfinite(v):
            raise InputError(path, f"expected a finite number, found {v!r}", field=key)
    window = doc.get("window_imu_s")
    if window is not None and (len(window) != 2 or not all(is_number(w) and math.isfinite(w) for w in window)):
        raise InputError(path, f"expected [start, end], two finite numbers (s), found {window!r}", field="window_imu_s")


def check_numbers(doc: dict, path: str | Path) -> None:
    """InputError naming ``path`` and the key unless every value of ``doc`` is a finite number
    (``imu_sigma.json``: 1-sigma per IMU channel)."""
    for key, v in doc.items():
        if not is_number(v) or not math.isfinite(v):
            raise InputError(path, f"expected a finite number, found {_json_type(v)}", field=key)


#: Checks of the JSON files of a results folder beyond "a JSON object", by file name.
DOCUMENT_CHECKS = {"parameters.json": check_parameters, "summary.json": check_summary,
                   "imu_sigma.json": check_numbers}


def read_checked_document(path: str | Path) -> dict:
    """:func:`read_document` and, for a file of :data:`DOCUMENT_CHECKS`, its check."""
    doc = read_document(path)
    check = DOCUMENT_CHECKS.get(Path(path).name)
    if check is not None:
        check(doc, path)
    return doc


def folder_kind(folder: str | Path) -> str:
    """The kind of results folder (:data:`KINDS`): ``"joint"`` with a ``drops/`` folder, else the
    summary's ``kind`` (``"drop"`` when it has none). InputError when the folder does not exist or
    its summary.json is damaged."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(folder, "results folder not found: it does not exist or is not a folder")
    if (folder / "drops").is_dir():
        return "joint"
    summary = folder / "summary.json"
    kind = read_checked_document(summary).get("kind") if summary.is_file() else None
    return kind if kind in ("point-mass", "kinematic") else "drop"


@dataclass(frozen=True)
class FolderFiles:
    """The checked files of one results folder (not its sub-folders).

    Attributes
    ----------
    folder : Path
        The folder.
    kind : str
        One of :data:`KINDS`.
    documents : dict of str to dict
        Every ``*.json`` by file name.
    tables : dict of str to Table
        Every ``*.csv`` by file name.
    drops : tuple of FolderFiles
        A joint folder's ``drops/<name>/`` folders, by name; empty otherwise.
    """

    folder: Path
    kind: str
    documents: dict[str, dict]
    tables: dict[str, Table]
    drops: tuple[FolderFiles, ...] = ()

    @property
    def summary(self) -> dict:
        """summary.json."""
        return self.documents["summary.json"]


def require_files(folder: str | Path, names: Sequence[str], kind: str = "") -> None:
    """InputError naming ``folder`` unless it is a folder holding every file of ``names`` (a name
    ending in ``/``: a sub-folder); ``kind`` names the kind of folder in the message."""
    folder = Path(folder)
    if not folder.is_dir():
        raise InputError(folder, "results folder not found: it does not exist or is not a folder")
    missing = [n for n in names if not ((folder / n).is_dir() if n.endswith("/") else (folder / n).is_file())]
    if missing:
        raise InputError(folder, f"not a casrecon {kind + ' ' if kind else ''}results folder: "
                                 f"{', '.join(missing)} missing")


def read_results_folder(folder: str | Path, kind: str | None = None, required: Sequence[str] | None = None,
                        drop_required: Sequence[str] | None = None) -> FolderFiles:
    """Read and check every JSON and CSV file of a results folder (and of a joint folder's drops).

    Parameters
    ----------
    folder : path
        The results folder.
    kind : str, optional
        The kind expected (:data:`KINDS`); default :func:`folder_kind`.
    required : sequence of str, optional
        Files the folder must hold (``drops/`` for a joint folder's sub-folder); default
        :data:`REQUIRED_FILES` of its kind (and ``drops/`` for a joint folder).
    drop_required : sequence of str, optional
        The same for each of a joint folder's ``drops/<name>/`` (default: those of a per-drop folder).

    Raises
    ------
    InputError
        Not a folder, a required file missing (:data:`REQUIRED_FILES`), or any file damaged
        (module notes): the file, the line or key, and what was expected.
    """
    folder = Path(folder)
    kind = kind or folder_kind(folder)
    label = ""  # what the message calls the folder: "per-drop", ... when the kind's own files are required
    if required is None:
        required, label = REQUIRED_FILES[kind] + (("drops/",) if kind == "joint" else ()), KIND_LABELS[kind]
    require_files(folder, required, label)
    documents = {p.name: read_checked_document(p) for p in sorted(folder.glob("*.json"))}
    times = TRAJECTORY_TIME_COLUMNS.get(kind, ())
    tables = {p.name: read_table(p, *((times, times) if p.name == "trajectory.csv" else ()))
              for p in sorted(folder.glob("*.csv"))}
    drops: tuple[FolderFiles, ...] = ()
    if kind == "joint":
        drops = tuple(read_results_folder(sub, "drop", drop_required)
                      for sub in sorted((folder / "drops").iterdir()) if sub.is_dir())
    return FolderFiles(folder, kind, documents, tables, drops)
