"""The kinematic (IMU-driven) result of the public API: ``casrecon.fit`` on a ``kind = "kinematic"``
problem, or ``casrecon.load_results`` on its folder. It holds the files of the results folder that
``casrecon fit --out`` writes (:mod:`casrecon.output.kinematic_results`) as DataFrames and records,
and the estimator's own result when freshly fitted.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from casrecon.io.units import IMU_TIME, SEGMENT_TIME, TIME_UNIX
from casrecon.output.kinematic_results import write_kinematic_results
from casrecon.output.results_reader import read_results_folder
from casrecon.results.drop_fit import FolderViews, parameters_of, read_frame, report_text, sample_frame

if TYPE_CHECKING:
    import pandas as pd

    from casrecon.estimation.kinematic.fit import KinematicResult
    from casrecon.physics.dynamics import Site

#: Time columns of ``trajectory`` (s): UTC (Unix seconds; only when the clock is UTC), time since the
#: span's start, and the IMU's clock (only when it is not UTC).
TIME_COLUMNS = (TIME_UNIX, SEGMENT_TIME, IMU_TIME)
#: Attitude columns (deg), unwrapped before :meth:`KinematicFit.sample` interpolates them.
ANGLE_COLUMNS = ("roll_deg", "pitch_deg", "yaw_deg")
#: Names of the time axes before issue 52, taken by :meth:`KinematicFit.sample`'s ``time``.
OLD_TIME_NAMES = {"time_s": SEGMENT_TIME, "clock_s": IMU_TIME}
REQUIRED_FILES = ("summary.json", "parameters.json", "trajectory.csv")


@dataclass(frozen=True, eq=False, repr=False)
class KinematicFit(FolderViews):
    """An IMU-driven reconstruction: the IMU's position, velocity and attitude with 3-sigma, and the
    IMU error parameters.

    Attributes
    ----------
    name : str
    params : Parameters
        IMU biases (deg/s, m/s^2), scale factors (-) and misalignments (deg), and the clock offset
        (s) and barometer bias (Pa) and height scale (-) when estimated, with their correlations.
    trajectory : pandas.DataFrame
        ``time_unix_s`` and ``utc`` (when the clock is UTC, else the clock as ``time_imu_s``),
        ``segment_time_s`` (s since the span's start), ``latitude_deg``, ``longitude_deg``,
        ``h_msl_m`` (each with ``_3sigma``), NED position (m) and velocity
        (m/s) of the IMU, roll, pitch and yaw of the IMU axes (deg), each with ``_3sigma`` (the
        attitude's as NED rotation-vector components ``att_n_deg_3sigma``...).
    residuals : dict of str to pandas.DataFrame
        ``{"imu": ..., "gps": ...}``: whitened preintegration and fix residuals (-).
    summary : dict
        ``summary.json``: convergence, chi-square per group, timings, the adequacy verdict.
    report_text : str
    fit : KinematicResult or None
        The estimator's result (None when loaded).
    source : Path or None
        The folder a loaded result came from.

    Also (properties, :class:`~casrecon.results.drop_fit.FolderViews`): lmfit's ``success``,
    ``chisqr``, ``redchi``, ``nfev``, ``nvarys``, ``covar``, ``correl`` and ``fit_report()``; every
    parameter is estimated (``vary`` True).
    """

    fit: KinematicResult | None = None
    source: Path | None = None
    problem_path: Path | None = None
    site: Site | None = None

    @classmethod
    def from_fit(cls, result: KinematicResult, sections: str, site: Site, problem_path: Path | None,
                 name: str, adequacy: dict | None) -> KinematicFit:
        """Wrap a fresh result (through its results files, so a fresh and a loaded result hold the
        same tables); the report is the head of :meth:`report_head` and the fit's own ``sections``
        (:func:`casrecon.report.kinematic_report.kinematic_sections`)."""
        with tempfile.TemporaryDirectory(prefix="casrecon-kin-") as tmp:
            write_kinematic_results(Path(tmp), result, sections, site, problem_path, name, adequacy)
            loaded = cls.load(tmp)
        return cls(name=loaded.name, params=loaded.params, trajectory=loaded.trajectory,
                   residuals=loaded.residuals, summary=loaded.summary, report_text="",
                   fit=result, problem_path=problem_path, site=site).with_sections(sections)

    @classmethod
    def load(cls, folder: str | Path) -> KinematicFit:
        """Read a kinematic results folder, every file checked
        (:func:`casrecon.output.results_reader.read_results_folder`); InputError naming the folder and
        what is missing, or the damaged file, the line or key, and what was expected."""
        files = read_results_folder(folder, "kinematic")
        summary = files.summary
        residuals = {kind: read_frame(files.tables[f"residuals_{kind}.csv"]) for kind in ("imu", "gps")
                     if f"residuals_{kind}.csv" in files.tables}
        return cls(name=str(summary.get("problem") or files.folder.name),
                   params=parameters_of(files, summary.get("reduced_chi2")),
                   trajectory=read_frame(files.tables["trajectory.csv"]), residuals=residuals, summary=summary,
                   report_text=report_text(files.folder), source=files.folder.resolve())

    time_columns = TIME_COLUMNS
    report_kind = "kinematic, IMU-driven"

    def __repr__(self) -> str:
        state = "converged" if self.converged else "NOT converged"
        return (f"<KinematicFit {self.name!r}: {state}, reduced chi2 {self.reduced_chi2:.4f}, "
                f"{self.nvarys} parameters, {len(self.trajectory)} nodes>")

    def sample(self, columns: str | Sequence[str], times_s: Any, *, time: str | None = None) -> pd.DataFrame:
        """Columns (e.g. ``"vel_d_mps"``, ``"yaw_deg"``) and their 3-sigma interpolated linearly at
        ``times_s`` (s since the span's start, ``segment_time_s``; ``time="time_s"``, its name before
        issue 52, is taken for it; or UTC Unix seconds with ``time="time_unix_s"``), or
        at UTC instants (``datetime``, pandas ``Timestamp`` or a sequence of them; naive ones taken
        as UTC; returned in a ``utc`` column; a clock that is not UTC has none); the Euler angles are
        unwrapped first and returned in (-180, 180] deg. ValueError for an unknown column (listing
        the available ones) or a time outside the span."""
        frame = self.trajectory.copy()
        for col in ANGLE_COLUMNS:
            if col in frame:
                frame[col] = np.rad2deg(np.unwrap(np.deg2rad(frame[col].to_numpy(float))))
        out = sample_frame(self.name, frame, TIME_COLUMNS, columns, times_s, OLD_TIME_NAMES.get(time, time),
                           SEGMENT_TIME)
        for col in ANGLE_COLUMNS:
            if col in out:
                out[col] = 180.0 - np.mod(180.0 - out[col].to_numpy(float), 360.0)
        return out

    def write(self, out: Path) -> None:
        """Write this fit's results files into the folder ``out`` being made (by :meth:`save`, or by
        ``casrecon fit`` inside its atomic folder). ValueError for a loaded result."""
        if self.fit is None or self.site is None:
            raise ValueError(f"{self.name}: a loaded result has no fit to write; save() copies its folder")
        write_kinematic_results(out, self.fit, self.report_text, self.site, self.problem_path, self.name,
                                self.summary.get("adequacy"))

    def draw(self, out: Path, formats: Sequence[str] | None = None, notes: list[str] | None = None) -> None:
        """Draw the figures of the folder ``out`` into ``out/figures``, in each of ``formats`` (default
        PNG). ``notes`` is accepted for symmetry with the other results (nothing is skipped)."""
        from casrecon.report.figure_style import DEFAULT_FORMATS  # matplotlib only when figures are asked for
        from casrecon.report.kinematic_plots import plot_kinematic

        plot_kinematic(out, tuple(formats or DEFAULT_FORMATS))

    def holds_fit(self) -> bool:
        return self.fit is not None and self.site is not None

    def problem_paths(self) -> list[Path]:
        return [self.problem_path] if self.problem_path is not None else []
