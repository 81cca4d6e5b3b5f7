"""The time history of ``casrecon simulate``: ``trajectory.csv`` with UTC and the geodetic position
of the centre of mass, units in every column name (:mod:`casrecon.io.units`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from casrecon.io.gps_rules import ned_to_geodetic
from casrecon.io.problem import ProblemConfig
from casrecon.io.units import FLIGHT_TIME, GEODETIC, TIME_UNIX, UTC, utc_text
from casrecon.output.columns import write_table


def simulation_columns(traj, cfg: ProblemConfig) -> dict[str, np.ndarray]:
    """``flight_time_s`` (s since release; ``time_s`` before issue 52: the name every kind uses,
    :mod:`casrecon.io.units`; :func:`casrecon.io.truth_trajectory.read_truth_trajectory` reads
    both), ``time_unix_s`` and ``utc`` (the release's
    ``[release] time_utc`` plus the flight time: the truth's UTC, as the synthetic GPS is stamped),
    ``latitude_deg``, ``longitude_deg`` and ``h_msl_m`` of the centre of mass, then the columns of
    :meth:`~casrecon.simulation.simulate.Trajectory.table`."""
    names, table = traj.table()
    cols = dict(zip(names, table.T))
    flight_time = cols.pop("time_s")  # the Trajectory's own name
    t_unix = cfg.release.time_utc.timestamp() + flight_time
    pos = np.column_stack([cols["pos_n_m"], cols["pos_e_m"], cols["pos_d_m"]])
    head = {FLIGHT_TIME: flight_time, TIME_UNIX: t_unix, UTC: utc_text(t_unix),
            **dict(zip(GEODETIC, ned_to_geodetic(pos, cfg.site)))}
    return {**head, **cols}


def write_simulation_trajectory(path: str | Path, traj, cfg: ProblemConfig, every: int = 1) -> None:
    """Write :func:`simulation_columns` as CSV, every ``every``-th sample and the last (impact)."""
    cols = simulation_columns(traj, cfg)
    n = cols[FLIGHT_TIME].size
    rows = np.unique(np.r_[0:n:every, n - 1])
    write_table(path, {k: np.asarray(v)[rows] for k, v in cols.items()})


#: Columns of ``truth_atmosphere_error.csv`` and the :class:`ProfileError` attribute each holds.
ATMOSPHERE_ERROR_COLUMNS = {"altitude_msl_m": "altitude_msl_m", "wind_north_error_mps": "wind_north_mps",
                            "wind_east_error_mps": "wind_east_mps", "density_error": "density"}


def write_atmosphere_error(path: str | Path, error) -> None:
    """Write a drawn :class:`~casrecon.simulation.model_errors.ProfileError` (flown minus sounding:
    wind north and east, m/s, and the fractional density error, on its altitude grid, m MSL) as
    ``truth_atmosphere_error.csv``."""
    write_table(path, {col: getattr(error, attr) for col, attr in ATMOSPHERE_ERROR_COLUMNS.items()})
