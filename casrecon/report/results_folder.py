"""The files of a per-drop results folder, as the figures read them (CSV and JSON only, no CasADi)."""

from __future__ import annotations

import functools
from collections.abc import Callable
from pathlib import Path

import numpy as np

from casrecon.io.units import (
    GPS_COMPONENT_UNITS,
    IMU_CHANNEL_UNITS,
    gps_residual_column,
    gps_sigma_column,
    imu_residual_column,
    imu_sigma_key,
)
from casrecon.output.results_reader import TRAJECTORY_TIME_COLUMNS, read_checked_document, read_table, require_files

#: Files without which a folder is not a per-drop results folder the figures can draw.
REQUIRED_FILES = ("summary.json", "trajectory.csv")

# Column names the figures read (one place to follow a rename of the writers' columns).
#: trajectory.csv (and the reconciled/nominal simulations where they share a name).
TIME_IMU, FLIGHT_TIME, H_AGL = "time_imu_s", "flight_time_s", "h_agl_m"
POS_NED = ("pos_n_m", "pos_e_m", "pos_d_m")
VEL_NED = ("vel_n_mps", "vel_e_mps", "vel_d_mps")
QBAR, ALPHA, ALPHA_T, ROLL_RATE, SPEED = "qbar_pa", "alpha_deg", "alpha_t_deg", "p_dps", "speed_mps"
#: pitching_moment.csv and cm_curves.csv.
CM_RECONSTRUCTED, CM_NOMINAL, CM_BEST_FIT = "cm_recon", "cm_nominal", "cm_fitted"
#: residuals_imu.csv / imu_sigma.json channels (specific force m/s^2, rate deg/s) and residuals_gps.csv
#: components (m, m/s); their column names come from :mod:`casrecon.io.units`.
IMU_CHANNELS = tuple(IMU_CHANNEL_UNITS)
GPS_COMPONENTS = tuple(GPS_COMPONENT_UNITS)


def three_sigma(column: str) -> str:
    """The 3-sigma column of a trajectory column."""
    return f"{column}_3sigma"


def residual(channel: str) -> str:
    """The residual column of an IMU channel (``wx_residual_dps``) or GPS component (``pos_n_residual_m``)."""
    return imu_residual_column(channel) if channel in IMU_CHANNEL_UNITS else gps_residual_column(channel)


def used(channel: str) -> str:
    """The 0/1 column saying whether an IMU sample entered the fit."""
    return f"{channel}_used"


def sigma(channel: str) -> str:
    """The 1-sigma key of an IMU channel in imu_sigma.json (``wx_sigma_dps``) or column of a GPS
    component in residuals_gps.csv (``pos_n_sigma_m``)."""
    return imu_sigma_key(channel) if channel in IMU_CHANNEL_UNITS else gps_sigma_column(channel)


class MissingInput(Exception):
    """An optional input of one figure is absent; the figure is skipped."""


def attempt_figure(label: str, draw: Callable[[], list[Path]]) -> tuple[list[Path], list[str], list[str]]:
    """Draw and save one figure: ``(paths, notes, failures)``. An absent optional input
    (:class:`MissingInput`) skips it with a note; anything else that stops it (a damaged file, a
    file that cannot be written) is a failure, located (the file, and why)."""
    try:
        return draw(), [], []
    except MissingInput as exc:
        return [], [f"skipped {label}: {exc}"], []
    except OSError as exc:
        where = f"{exc.filename}: " if exc.filename else ""
        return [], [], [f"{label} not written: {where}{exc.strerror or exc}"]
    except (KeyError, ValueError) as exc:
        what = f"missing column {exc}" if isinstance(exc, KeyError) else str(exc)
        return [], [], [f"{label} not drawn: {what}"]


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Numeric columns of a results CSV file, as float arrays keyed by header name (text columns such
    as ``utc`` are left out; the numbers hold the same time as ``time_unix_s``), checked by
    :func:`casrecon.output.results_reader.read_table` (InputError, located, when damaged);
    MissingInput if absent."""
    if not path.is_file():
        raise MissingInput(f"{path.name} not found in {path.parent}")
    return read_table(path).columns()


def read_json(path: Path) -> dict:
    """A results JSON file as a dict, checked by :func:`casrecon.output.results_reader.read_checked_document`
    (InputError, located, when damaged); MissingInput if absent."""
    if not path.is_file():
        raise MissingInput(f"{path.name} not found in {path.parent}")
    return read_checked_document(path)


class DropFolder:
    """The files of one drop's results folder, read lazily and cached.

    ``traj`` (trajectory.csv's columns) is read when first used (a figure without it does not pay the
    ~15 ms). ``release_imu_s`` (s, IMU clock) comes from summary.json, or from the trajectory's first
    node (time_imu_s - flight_time_s) when the summary lacks it.
    """

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        require_files(self.folder, REQUIRED_FILES)
        self._cache: dict[str, object] = {}
        self.summary = read_json(self.folder / "summary.json")
        self.name = str(self.summary.get("problem") or self.folder.name)

    @functools.cached_property
    def traj(self) -> dict[str, np.ndarray]:
        """Columns of trajectory.csv (its time columns present and finite)."""
        if "trajectory.csv" not in self._cache:
            times = TRAJECTORY_TIME_COLUMNS["drop"]
            self._cache["trajectory.csv"] = read_table(self.folder / "trajectory.csv", times, times).columns()
        return self._cache["trajectory.csv"]

    @functools.cached_property
    def release_imu_s(self) -> float:
        """Release time on the IMU clock, s."""
        release = self.summary.get("release_imu_s")
        if release is None:
            release = self.traj[TIME_IMU][0] - self.traj[FLIGHT_TIME][0]
        return float(release)

    def csv(self, name: str) -> dict[str, np.ndarray]:
        """Columns of ``name`` (MissingInput if absent)."""
        if name not in self._cache:
            self._cache[name] = read_csv(self.folder / name)
        return self._cache[name]

    def json(self, name: str) -> dict:
        """Contents of ``name`` (MissingInput if absent)."""
        if name not in self._cache:
            self._cache[name] = read_json(self.folder / name)
        return self._cache[name]

    def flight_time(self, time_imu_s: np.ndarray) -> np.ndarray:
        """Flight time (s since release) of IMU-clock times (s)."""
        return np.asarray(time_imu_s) - self.release_imu_s


def drop_folders(results_dir: Path) -> list[Path]:
    """The per-drop sub-folders ``drops/<name>/`` of a joint results folder (empty if none)."""
    drops = Path(results_dir) / "drops"
    return sorted(p for p in drops.iterdir() if p.is_dir()) if drops.is_dir() else []


class DropTables:
    """The same interface as :class:`DropFolder` over tables held in memory (no folder on disk).

    Parameters
    ----------
    name : str
        Drop name, for titles.
    summary : dict
        ``summary.json`` content (``release_imu_s``, ``reconciled``, ...).
    tables : dict of str to dict of str to ndarray
        File name (``"trajectory.csv"``, ``"residuals_imu.csv"``, ...) -> named columns; must hold
        ``trajectory.csv``.
    documents : dict of str to dict
        File name (``"imu_sigma.json"``, ``"parameters.json"``, ...) -> content.
    """

    def __init__(self, name: str, summary: dict, tables: dict[str, dict[str, np.ndarray]],
                 documents: dict[str, dict]):
        self.name = name
        self.summary = summary
        self._tables = tables
        self._documents = documents
        self.traj = self.csv("trajectory.csv")
        release = summary.get("release_imu_s")
        if release is None:
            release = self.traj[TIME_IMU][0] - self.traj[FLIGHT_TIME][0]
        self.release_imu_s = float(release)

    def csv(self, name: str) -> dict[str, np.ndarray]:
        """Columns of table ``name`` (MissingInput if absent)."""
        if name not in self._tables:
            raise MissingInput(f"{self.name} has no {name}")
        return {k: np.asarray(v, dtype=float) for k, v in self._tables[name].items()}

    def json(self, name: str) -> dict:
        """Document ``name`` (MissingInput if absent)."""
        if name not in self._documents:
            raise MissingInput(f"{self.name} has no {name}")
        return self._documents[name]

    def flight_time(self, time_imu_s: np.ndarray) -> np.ndarray:
        """Flight time (s since release) of IMU-clock times (s)."""
        return np.asarray(time_imu_s) - self.release_imu_s
