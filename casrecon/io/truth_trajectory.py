"""Read the truth trajectory ``casrecon simulate`` writes (``trajectory.csv``, also ``data/`` of a
synthetic problem): every column of the file, the flight time since release as ``flight_time_s``
(s), the name of :mod:`casrecon.io.units`. Folders written before issue 52 name it ``time_s``; they
load too, the column renamed."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING

from casrecon.io._csvtools import read_lines
from casrecon.io.errors import InputError
from casrecon.io.units import FLIGHT_TIME, UTC

if TYPE_CHECKING:
    import pandas as pd

#: The flight-time column's name in simulation folders written before issue 52.
OLD_FLIGHT_TIME = "time_s"


def read_truth_trajectory(path: str | Path) -> pd.DataFrame:
    """The truth trajectory at ``path`` as a DataFrame: ``flight_time_s`` (s since release; read from
    ``time_s`` in an older file), every other column as written, ``utc`` as pandas UTC timestamps.

    Raises
    ------
    InputError
        Not readable text, no flight-time column (line 1: ``flight_time_s`` or ``time_s``
        expected), or a cell that is not a number (the line and the column).
    """
    import pandas as pd

    lines = read_lines(path)
    header = [c.strip() for c in lines[0].split(",")] if lines else []
    time_name = next((c for c in (FLIGHT_TIME, OLD_FLIGHT_TIME) if c in header), None)
    if time_name is None:
        raise InputError(path, f"no flight-time column: expected {FLIGHT_TIME!r} (or {OLD_FLIGHT_TIME!r} in a "
                               f"folder written before issue 52) in the header, got {', '.join(header) or 'none'}",
                         line=1)
    frame = pd.read_csv(path, dtype={UTC: str} if UTC in header else None)
    for column in frame.columns:
        if column == UTC:
            continue
        values = pd.to_numeric(frame[column], errors="coerce")
        bad = values.isna() & frame[column].notna()
        if bad.any():
            raise InputError(path, f"expected a number, got {frame[column][bad].iloc[0]!r}",
                             line=int(bad.to_numpy().argmax()) + 2, field=column)
        frame[column] = values
    if UTC in frame:
        frame[UTC] = pd.to_datetime(frame[UTC], utc=True, format="ISO8601")
    return frame.rename(columns={OLD_FLIGHT_TIME: FLIGHT_TIME})
