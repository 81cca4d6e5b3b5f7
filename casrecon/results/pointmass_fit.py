"""The point-mass (GPS-only) result of the public API: ``casrecon.fit`` on a ``kind = "point-mass"``
problem, or ``casrecon.load_results`` on its folder. It holds the files of the results folder that
``casrecon fit --out`` writes (:mod:`casrecon.output.pointmass_results`) as DataFrames and records.
"""

from __future__ import annotations

import tempfile
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from casrecon.analysis.adequacy import Adequacy
from casrecon.analysis.fit_adequacy import pointmass_adequacy
from casrecon.io.units import SEGMENT_TIME, TIME_UNIX
from casrecon.output.pointmass_results import write_pointmass_results
from casrecon.output.results_reader import read_results_folder
from casrecon.results.drop_fit import FolderViews, parameters_of, read_frame, report_text, sample_frame

if TYPE_CHECKING:
    import pandas as pd

    from casrecon.estimation.pointmass.fit import PointMassResult

#: Time columns of ``trajectory`` (s): UTC (Unix seconds, us resolution) and time since the segment start.
TIME_COLUMNS = (TIME_UNIX, SEGMENT_TIME)
#: Names of the time axes before issue 52, taken by :meth:`PointMassFit.sample`'s ``time``.
OLD_TIME_NAMES = {"time_s": SEGMENT_TIME}
REQUIRED_FILES = ("summary.json", "parameters.json", "trajectory.csv")


@dataclass(frozen=True, eq=False, repr=False)
class PointMassFit(FolderViews):
    """A GPS-only fit: antenna track and drag area with 3-sigma, and the constant-drag comparison.

    Attributes
    ----------
    name : str
    params : Parameters
        Estimated parameters (wind bias, drag-area spline weights, ...); no correlations are
        recorded for point-mass fits (``correl`` empty).
    trajectory : pandas.DataFrame
        ``time_unix_s`` (UTC, s), ``utc`` (pandas UTC timestamps), ``segment_time_s`` (s since the
        segment start), the antenna's ``latitude_deg``, ``longitude_deg``, ``h_msl_m``, NED position (m) and
        velocity (m/s), drag area ``cda_m2`` (and lift areas, m^2; with ``[model_error]`` also the
        area processes' parts ``cda_process_m2``, ``lift_n_process_m2``, ``lift_e_process_m2``),
        each with ``_3sigma``: trajectory.csv as written (9 significant digits, UTC to 1 us), also
        for a fresh fit.
    residuals : dict of str to pandas.DataFrame
        ``{"gps": ...}``: normalised residuals of the fitted and the constant-drag model
        (``<component>_fit_z``, ``<component>_constant_z``; -), and with a GPS error model or area
        processes the innovations the adequacy tests read (``<component>_fit_innovation_z``, NaN
        where there is none).
    summary : dict
        ``summary.json``: the fit's and the constant model's convergence, chi-square, residual statistics,
        the fitted model's model-adequacy verdict (:attr:`adequacy`).
    report_text : str
    fit, constant : PointMassResult or None
        The estimator's results (None when loaded).
    fit_verdict : Adequacy or None
        The verdict of a fresh fit as computed (what :attr:`adequacy` reads back from ``summary``);
        None when loaded.
    source : Path or None
        The folder a loaded result came from.

    Also (properties, :class:`~casrecon.results.drop_fit.FolderViews`): lmfit's ``success``,
    ``chisqr``, ``redchi``, ``nfev``, ``nvarys``, ``covar``, ``correl`` and ``fit_report()``; every
    parameter is estimated (``vary`` True).
    """

    fit: PointMassResult | None = None
    constant: PointMassResult | None = None
    source: Path | None = None
    fit_verdict: Adequacy | None = None

    @classmethod
    def from_fit(cls, main: PointMassResult, constant: PointMassResult, sections: str,
                 adequacy: Adequacy | None = None) -> PointMassFit:
        """Wrap the fitted and the constant-drag results (through their results files, so a fresh
        and a loaded result hold the same tables) and the fitted model's verdict (computed here from
        ``main`` when not given); the report is the head of :meth:`report_head` and the fit's own
        ``sections`` (:func:`casrecon.report.pointmass_report.pointmass_sections`)."""
        adequacy = pointmass_adequacy(main) if adequacy is None else adequacy
        with tempfile.TemporaryDirectory(prefix="casrecon-pm-") as tmp:
            write_pointmass_results(Path(tmp), main, constant, sections, adequacy)
            loaded = cls.load(tmp)
        return cls(name=loaded.name, params=loaded.params, trajectory=loaded.trajectory,
                   residuals=loaded.residuals, summary=loaded.summary, report_text="",
                   fit=main, constant=constant, fit_verdict=adequacy).with_sections(sections)

    @classmethod
    def load(cls, folder: str | Path) -> PointMassFit:
        """Read a point-mass results folder, every file checked
        (:func:`casrecon.output.results_reader.read_results_folder`); InputError naming the folder and
        what is missing, or the damaged file, the line or key, and what was expected."""
        files = read_results_folder(folder, "point-mass")
        summary = files.summary
        residuals = {kind: read_frame(files.tables[f"residuals_{kind}.csv"]) for kind in ("gps",)
                     if f"residuals_{kind}.csv" in files.tables}
        return cls(name=str(summary.get("problem") or files.folder.name),
                   params=parameters_of(files, (summary.get("fit") or {}).get("reduced_chi2")),
                   trajectory=read_frame(files.tables["trajectory.csv"]), residuals=residuals, summary=summary,
                   report_text=report_text(files.folder), source=files.folder.resolve())

    time_columns = TIME_COLUMNS
    report_kind = "point-mass, GPS-only"

    @property
    def reduced_chi2(self) -> float:
        """Reduced chi-square of the fitted model, -."""
        return float((self.summary.get("fit") or {}).get("reduced_chi2", np.nan))

    @property
    def chi2(self) -> dict[str, float]:
        """Chi-square per residual group of the fitted model, -."""
        return dict((self.summary.get("fit") or {}).get("chi2", {}))

    @property
    def nit(self) -> int | None:
        """The fitted model's iteration count; None when not recorded."""
        n = (self.summary.get("fit") or {}).get("iterations")
        return None if n is None else int(n)

    def __repr__(self) -> str:
        state = "converged" if self.converged else "NOT converged"
        return (f"<PointMassFit {self.name!r}: {state}, reduced chi2 {self.reduced_chi2:.4f}, "
                f"{self.nvarys} parameters, {len(self.trajectory)} fixes>")

    def sample(self, columns: str | Sequence[str], times_s: Any, *, time: str | None = None) -> pd.DataFrame:
        """Columns (e.g. ``"cda_m2"``) and their 3-sigma interpolated linearly at ``times_s`` (s since the
        segment start, ``segment_time_s``; ``time="time_s"``, its name before issue 52, is taken for it;
        or UTC Unix seconds with ``time="time_unix_s"``), or at UTC instants
        (``datetime``, pandas ``Timestamp`` or a sequence of them; naive ones taken as UTC; returned
        in a ``utc`` column); ValueError for an unknown column (listing the available ones) or a
        time outside the segment."""
        return sample_frame(self.name, self.trajectory, TIME_COLUMNS, columns, times_s,
                            OLD_TIME_NAMES.get(time, time), SEGMENT_TIME)

    def write(self, out: Path) -> None:
        """Write this fit's results files into the folder ``out`` being made (by :meth:`save`, or by
        ``casrecon fit`` inside its atomic folder). ValueError for a loaded result."""
        if self.fit is None or self.constant is None:
            raise ValueError(f"{self.name}: a loaded result has no fit to write; save() copies its folder")
        write_pointmass_results(out, self.fit, self.constant, self.report_text, self.fit_verdict)

    def draw(self, out: Path, formats: Sequence[str] | None = None, notes: list[str] | None = None) -> None:
        """Draw the track-fit figure of the folder ``out`` into ``out/figures``, in each of ``formats``
        (default PNG). ``notes`` is accepted for symmetry with the other results (nothing is skipped)."""
        from casrecon.report.figure_style import DEFAULT_FORMATS  # matplotlib only when figures are asked for
        from casrecon.report.pointmass_plots import plot_track_fit

        plot_track_fit(out, tuple(formats or DEFAULT_FORMATS))

    def holds_fit(self) -> bool:
        return self.fit is not None and self.constant is not None

    def problem_paths(self) -> list[Path]:
        return [self.fit.config.path] if self.fit is not None else []
