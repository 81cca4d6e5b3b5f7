"""The files of a per-drop results folder, as the figures read them (CSV and JSON only, no CasADi)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from casrecon.io.units import TEXT_COLUMNS

#: Files without which a folder is not a per-drop results folder.
REQUIRED_FILES = ("summary.json", "trajectory.csv")


class MissingInput(Exception):
    """An optional input of one figure is absent; the figure is skipped."""


def read_csv(path: Path) -> dict[str, np.ndarray]:
    """Numeric columns of a CSV file with a one-line header, as float arrays keyed by header name
    (text columns such as ``utc`` are left out; the numbers hold the same time as ``time_unix_s``)."""
    if not path.is_file():
        raise MissingInput(f"{path.name} not found in {path.parent}")
    with path.open() as f:
        header = [n.strip() for n in f.readline().strip().split(",")]
        first = f.readline().strip()
    if first and len(first.split(",")) != len(header):
        raise ValueError(f"{path}: {len(first.split(','))} columns but {len(header)} header names")
    keep = [k for k, name in enumerate(header) if name not in TEXT_COLUMNS]
    data = np.loadtxt(path, delimiter=",", skiprows=1, ndmin=2, usecols=keep)
    if data.shape[0] == 0:
        data = np.zeros((0, len(keep)))
    return {header[k]: data[:, j] for j, k in enumerate(keep)}


def read_json(path: Path) -> dict:
    """A JSON file as a dict; MissingInput if absent."""
    if not path.is_file():
        raise MissingInput(f"{path.name} not found in {path.parent}")
    return json.loads(path.read_text())


class DropFolder:
    """The files of one drop's results folder, read lazily and cached.

    ``release_imu_s`` (s, IMU clock) comes from summary.json, or from the trajectory's first node
    (time_imu_s - flight_time_s) when the summary lacks it.
    """

    def __init__(self, folder: Path):
        self.folder = Path(folder)
        for name in REQUIRED_FILES:
            if not (self.folder / name).is_file():
                raise FileNotFoundError(
                    f"{self.folder} is not a casrecon results folder: {name} is missing")
        self._cache: dict[str, object] = {}
        self.summary = read_json(self.folder / "summary.json")
        self.traj = self.csv("trajectory.csv")
        self.name = str(self.summary.get("problem") or self.folder.name)
        release = self.summary.get("release_imu_s")
        if release is None:
            release = self.traj["time_imu_s"][0] - self.traj["flight_time_s"][0]
        self.release_imu_s = float(release)

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
            release = self.traj["time_imu_s"][0] - self.traj["flight_time_s"][0]
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
