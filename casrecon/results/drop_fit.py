"""The per-drop result of the public API (``casrecon.fit``, ``casrecon.load_results``): parameters as
records, the trajectory, residuals and aero coefficients as pandas DataFrames, lmfit's statistics
and ``fit_report()``, the report, interpolation at flight times or UTC, and saving to (or loading
from) the results folder that ``casrecon fit --out`` writes.
"""

from __future__ import annotations

import datetime
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from casrecon.analysis.adequacy import Adequacy
from casrecon.io.errors import InputError
from casrecon.io.units import TEXT_COLUMNS, TIME_UNIX, UTC
from casrecon.output.fit_results import (
    parameters_document,
    product_tables,
    products_summary,
    summary_document,
    trajectory_table,
    write_fit_results,
)
from casrecon.output.kinematic_check_results import write_kinematic_check
from casrecon.output.out_folder import input_paths
from casrecon.output.results import json_values, save_results_folder
from casrecon.output.results_reader import (
    PARAMETERS_SHAPE,
    TRAJECTORY_TIME_COLUMNS,
    FolderFiles,
    Table,
    read_results_folder,
    read_text,
)
from casrecon.physics.aero import DISPERSION_NAMES
from casrecon.report.fit_report import FIXED_DISPERSION_NOTE
from casrecon.report.results_folder import DropTables
from casrecon.results.fit_statistics import FitStatistics
from casrecon.results.parameters import Parameter, Parameters, fixed_parameter, from_document

if TYPE_CHECKING:
    import pandas as pd

    from casrecon.analysis.fit_products import FitProducts
    from casrecon.analysis.kinematic_check import KinematicCheck
    from casrecon.estimation.sixdof.fit import FitResult
    from casrecon.report.figure_pool import FigurePool

#: Time columns of ``trajectory`` (s): IMU clock, flight time since release, UTC (Unix seconds).
TIME_COLUMNS = ("time_imu_s", "flight_time_s", TIME_UNIX)
#: Time columns a per-drop trajectory.csv must have.
REQUIRED_TIME_COLUMNS = TRAJECTORY_TIME_COLUMNS["drop"]


def read_frame(table: Table) -> pd.DataFrame:
    """A checked CSV table of a results folder (:func:`casrecon.output.results_reader.read_table`) as a
    DataFrame, every number parsed exactly as written, the ``utc`` column as tz-aware timestamps
    (:func:`with_timestamps`)."""
    return with_timestamps(table.frame())


def with_timestamps(frame: pd.DataFrame) -> pd.DataFrame:
    """``frame`` with its ``utc`` column (ISO 8601 text), if any, as pandas UTC timestamps."""
    import pandas as pd

    if UTC in frame.columns:
        frame[UTC] = pd.to_datetime(frame[UTC].astype(str), utc=True, format="ISO8601")
    return frame


def parameters_of(files: FolderFiles, reduced_chi2: float | None, held_dispersions: bool = False) -> Parameters:
    """The :class:`Parameters` of a checked folder's parameters.json (``reduced_chi2`` for entries without
    ``sigma_chi2_scaled``; ``held_dispersions``: with records of the aero dispersion factors a 6-DOF fit
    held at 0, :func:`fixed_dispersions`); InputError naming the file should the document still not
    make records."""
    path = files.folder / "parameters.json"
    try:
        doc = files.documents["parameters.json"]
        return from_document(doc, reduced_chi2, fixed_dispersions(doc["parameters"]) if held_dispersions else ())
    except (KeyError, TypeError, ValueError, IndexError) as err:
        raise InputError(path, f"expected {PARAMETERS_SHAPE} ({type(err).__name__}: {err})") from None


def report_text(folder: Path) -> str:
    """report.txt of a results folder without its final line break ("" without one); InputError
    naming it when it is not text."""
    report = folder / "report.txt"
    return read_text(report, "the text report").rstrip("\n") if report.is_file() and report.stat().st_size else ""


def fixed_dispersions(estimated: Sequence[str]) -> tuple[Parameter, ...]:
    """Records of the aero dispersion factors a 6-DOF fit held at 0 (those of ``DISPERSION_NAMES``
    not among the ``estimated`` names; a joint fit's ``<drop>.<name>`` counts as estimating ``name``):
    dimensionless, group ``aero``, ``vary`` False, as the report lists them."""
    held = set(estimated) | {n.rsplit(".", 1)[-1] for n in estimated}
    return tuple(fixed_parameter(n, 0.0, "-", "aero") for n in DISPERSION_NAMES if n not in held)


@dataclass(frozen=True, eq=False, repr=False)
class FolderViews(FitStatistics):
    """What every result held as its results folder's files has and answers alike: the fields
    ``name``, ``params``, ``trajectory``, ``residuals``, ``summary`` and ``report_text`` (each
    subclass documents what its own hold), and ``converged``, ``reduced_chi2``, ``chi2``,
    ``chisqr``, ``nit``, ``adequacy``, ``columns``, ``report()`` and lmfit's names
    (:class:`~casrecon.results.fit_statistics.FitStatistics`: ``success``, ``redchi``, ``nfev``,
    ``covar``, ``correl``, ``fit_report()``). Subclasses add the field ``source`` (the folder a
    loaded result came from) and set the class attribute ``time_columns``."""

    name: str
    params: Parameters
    trajectory: pd.DataFrame
    residuals: dict[str, pd.DataFrame]
    summary: dict
    report_text: str

    time_columns: ClassVar[tuple[str, ...]] = ()

    @property
    def converged(self) -> bool:
        """Whether the solver converged (always True for a fit that returned)."""
        return bool(self.summary.get("converged"))

    @property
    def reduced_chi2(self) -> float:
        """Chi-square over degrees of freedom, - (NaN when the summary lacks it)."""
        return float(self.summary.get("reduced_chi2", float("nan")))

    @property
    def chi2(self) -> dict[str, float]:
        """Chi-square per residual group (``imu``, ``gps``, ``prior_aero``, ...), -."""
        return dict(self.summary.get("chi2", {}))

    @property
    def chisqr(self) -> float:
        """Total chi-square (the sum of :attr:`chi2` over its groups, priors included), -."""
        return float(sum(self.chi2.values())) if self.chi2 else float("nan")

    @property
    def nit(self) -> int | None:
        """The solver's iteration count (``summary.json`` ``iterations``); None when not recorded."""
        n = self.summary.get("iterations")
        return None if n is None else int(n)

    @property
    def adequacy(self) -> Adequacy | None:
        """The model-adequacy verdict (``summary.json`` ``adequacy``): ``.trusted``, ``.line``, per-channel
        tests, parameters beyond 3 sigma of their prior, prior NEES, ground check; None for a folder
        written before it existed."""
        return adequacy_of(self.summary, self.source, Adequacy.from_dict)

    @property
    def columns(self) -> tuple[str, ...]:
        """Time-history columns that ``sample`` accepts (the trajectory's, without time and 3-sigma)."""
        return history_columns(self.trajectory, self.time_columns)

    def report(self) -> str:
        """The text report of ``casrecon fit`` (``report.txt``): in the one style of every kind, the
        text of :meth:`fit_report` with its default arguments."""
        return self.report_text

    def problem_paths(self) -> list[Path]:
        """The problem files a fresh fit read (protected from being overwritten by :meth:`save`); none
        for a loaded result. Subclasses that hold a fit say which."""
        return []

    def holds_fit(self) -> bool:
        """Whether this result holds the fit itself (fresh) rather than only its folder's files (loaded)."""
        return False

    def save(self, folder: str | Path, *, figures: bool = False, force: bool = False,
             formats: Sequence[str] | None = None) -> Path:
        """Write the results folder ``casrecon fit --out folder`` writes, atomically (an earlier folder
        is replaced only once the new one is complete); figures only if ``figures``, in ``formats``.

        A loaded result is saved as a copy of the files it was loaded from (without ``figures/``
        unless ``figures``). An existing folder that casrecon did not write (no
        ``.casrecon-results.json``), or a file, is replaced only with ``force``; a folder holding the
        problem's inputs never (:class:`~casrecon.output.out_folder.OutFolderError`). Returns the folder.
        """
        return save_results_folder(folder, self.name, self.write if self.holds_fit() else None, self.source,
                                   (lambda out: self.draw(out, formats)) if figures else None,
                                   kind="fit", force=force, inputs=input_paths(self.problem_paths()))

    def write(self, out: Path) -> None:
        """Write the results files into the folder ``out`` being made (subclasses)."""
        raise NotImplementedError

    def draw(self, out: Path, formats: Sequence[str] | None = None, notes: list[str] | None = None) -> None:
        """Draw the figures of the folder ``out`` (subclasses)."""
        raise NotImplementedError


@dataclass(frozen=True, eq=False, repr=False)
class DropFit(FolderViews):
    """One drop's reconstruction, from :func:`casrecon.fit` or loaded from a results folder.

    Attributes
    ----------
    name : str
        Problem name.
    params : Parameters
        Estimated parameters in fit order (``params["Cmq_mult"].stderr``, ``params.to_frame()``),
        each in its ``unit`` as parameters.json holds it (gyro biases in deg/s; ``fit`` keeps SI),
        then the aero dispersion factors the fit held at 0 (``vary`` False, as the report lists them).
    trajectory : pandas.DataFrame
        ``time_imu_s``, ``flight_time_s`` and ``time_unix_s`` (s), ``utc`` (pandas UTC timestamps;
        the GPS receiver's UTC through the fitted clock offset), the centre of mass's
        ``latitude_deg``, ``longitude_deg`` and ``h_msl_m``, then every reconstructed column (unit in
        its name: ``_m``, ``_mps``, ``_deg``, ``_dps``, ``_pa``) followed by its ``<name>_3sigma``. A
        loaded result holds trajectory.csv as written (9 significant digits, Unix times to 1 us); a
        fresh fit holds full precision, which agrees with the file to a relative 5e-9.
    residuals : dict of str to pandas.DataFrame
        Per measurement kind (``"imu"``, ``"gps"``, ...) the ``residuals_<kind>.csv`` table: time
        (s, IMU clock; UTC for the GPS), measured minus model residuals and sigmas (unit in each
        column name, gyros in deg/s) or use flags. A loaded result holds the files as written (9
        significant digits).
    summary : dict
        ``summary.json``: convergence, chi-square per group, dof, timings (s), the model-adequacy
        verdict (:attr:`adequacy`), reconciled simulation.
    report_text : str
        The text report (``report.txt``; :mod:`casrecon.report.report_style`).
    tables : dict of str to pandas.DataFrame
        Every table of the results folder by file name (``trajectory.csv``, ``gps_fixes.csv``, ...);
        a fresh fit holds ``reconciled.csv`` and ``nominal.csv`` at every sample, the files every 5th.
    documents : dict of str to dict
        Every JSON document by file name (``parameters.json``, ``imu_sigma.json``, ...).
    fit : casrecon.estimation.sixdof.fit.FitResult or None
        The estimator's own result (CasADi objects, covariance); None when loaded from a folder.
    products : casrecon.analysis.fit_products.FitProducts or None
        Residuals and reconciled simulations as computed; None when loaded.
    source : Path or None
        The folder a loaded result came from.
    kinematic_check : casrecon.analysis.kinematic_check.KinematicCheck or None
        The comparison with the drop's IMU-driven reconstruction (``kinematic_check=True``), whose
        verdict ends the report; None when not asked for, or loaded (the folder's
        ``kinematic_check.json`` and ``.csv`` are in :attr:`documents` and :attr:`tables`).
    implied_aero : dict of str to numpy.ndarray or None
        The coefficients that reconstruction implies (``implied_aero.csv``), with the check.

    Also (properties): ``aero_coefficients`` (DataFrame), lmfit's ``success``, ``chisqr``,
    ``redchi``, ``nfev``, ``nvarys``, ``covar``, ``correl`` and ``fit_report()``.
    """

    tables: dict[str, pd.DataFrame] = field(default_factory=dict)
    documents: dict[str, dict] = field(default_factory=dict)
    fit: FitResult | None = None
    products: FitProducts | None = None
    source: Path | None = None
    kinematic_check: KinematicCheck | None = None
    implied_aero: dict[str, np.ndarray] | None = None

    # ---- construction -------------------------------------------------------------------------
    @classmethod
    def from_fit(cls, fit: FitResult, products: FitProducts, sections: str,
                 kinematic_check: tuple[dict[str, np.ndarray], KinematicCheck] | None = None) -> DropFit:
        """Wrap a converged :class:`~casrecon.estimation.sixdof.fit.FitResult` and its products (and the
        ``(implied coefficients, check)`` of a kinematic check, when made); the report is the head of
        :meth:`report_head` and the fit's own ``sections``
        (:func:`casrecon.report.fit_report.sixdof_sections`, and the check's verdict)."""
        import pandas as pd

        params_doc = json_values(parameters_document(fit))  # exactly what parameters.json holds
        summary = json_values({**summary_document(fit), **products_summary(products)})
        trajectory = with_timestamps(pd.DataFrame(trajectory_table(fit)))
        tables = {"trajectory.csv": trajectory}
        tables.update({k: pd.DataFrame({c: np.asarray(v, dtype=float) for c, v in t.items()})
                       for k, t in product_tables(products).items()})
        params = from_document(params_doc, fixed=fixed_dispersions(params_doc["parameters"]))
        return cls(name=fit.scenario.config.name, params=params, trajectory=trajectory,
                   residuals=_residuals_of(tables), summary=summary, report_text="", tables=tables,
                   documents={"parameters.json": params_doc, "summary.json": summary,
                              "imu_sigma.json": dict(products.imu_sigma)},
                   fit=fit, products=products, kinematic_check=None if kinematic_check is None else kinematic_check[1],
                   implied_aero=None if kinematic_check is None else kinematic_check[0]).with_sections(sections)

    @classmethod
    def load(cls, folder: str | Path) -> DropFit:
        """Read a per-drop results folder (``casrecon fit --out`` or :meth:`save`), every file checked
        (:func:`casrecon.output.results_reader.read_results_folder`).

        Raises
        ------
        InputError
            The folder does not exist, lacks one of its
            :data:`~casrecon.output.results_reader.REQUIRED_FILES`, or holds a damaged file
            (the file, the line or key, and what was expected).
        """
        return cls.from_files(read_results_folder(folder, "drop"))

    @classmethod
    def from_files(cls, files: FolderFiles) -> DropFit:
        """The result held by a checked per-drop folder (:class:`~casrecon.output.results_reader.FolderFiles`)."""
        folder = files.folder
        tables = {name: read_frame(table) for name, table in files.tables.items()}
        summary = files.summary
        return cls(name=str(summary.get("problem") or folder.name),
                   params=parameters_of(files, summary.get("reduced_chi2"), held_dispersions=True),
                   trajectory=tables["trajectory.csv"],
                   residuals=_residuals_of(tables), summary=summary,
                   report_text=report_text(folder), tables=tables, documents=dict(files.documents),
                   source=folder.resolve())

    time_columns = TIME_COLUMNS
    report_kind = "6-DOF"
    fixed_note = FIXED_DISPERSION_NOTE

    def __repr__(self) -> str:
        state = "converged" if self.converged else "NOT converged"
        where = f", from {self.source}" if self.source else ""
        return (f"<DropFit {self.name!r}: {state}, reduced chi2 {self.reduced_chi2:.4f}, "
                f"{self.nvarys} parameters, {len(self.trajectory)} nodes{where}>")

    @property
    def aero_coefficients(self) -> pd.DataFrame | None:
        """``aero_coefficients.csv``: C_A, C_Y, C_N, C_l, C_m, C_n (-) along the flight, reconstructed
        from the IMU, of the best-fit and of the nominal database, with 3-sigma, against
        ``time_imu_s`` and ``flight_time_s`` (s), ``alpha_t_deg`` and ``qbar_pa``; None when the fit
        computed none."""
        return self.tables.get("aero_coefficients.csv")

    def sample(self, columns: str | Sequence[str], times_s: Any, *, time: str | None = None) -> pd.DataFrame:
        """Time-history columns and their 3-sigma, interpolated linearly between nodes.

        Parameters
        ----------
        columns : str or sequence of str
            Names from :attr:`columns` (e.g. ``"alpha_t_deg"``, ``["qbar_pa", "mach"]``).
        times_s : float, array_like, or datetime-like
            Times, s, on the ``time`` axis, within the fit window; or UTC instants (``datetime``,
            ``numpy.datetime64``, pandas ``Timestamp``, or a sequence, array, Index or Series of
            them; naive ones are taken as UTC), sampled on the ``time_unix_s`` axis.
        time : {"flight_time_s", "time_imu_s", "time_unix_s"}, optional
            Flight time since release (the default for numbers), the IMU clock, or UTC in Unix seconds.

        Returns
        -------
        pandas.DataFrame
            One row per time: the ``time`` column (for UTC instants the ``utc`` column, pandas UTC
            timestamps), then each column and its ``<name>_3sigma``.

        Raises
        ------
        ValueError
            An unknown column or time axis (the message lists the available ones), or a time
            outside the fit window.
        """
        return sample_frame(self.name, self.trajectory, TIME_COLUMNS, columns, times_s, time, "flight_time_s")

    def figure_source(self) -> DropTables:
        """The tables as the figure functions of :mod:`casrecon.report` read them (no folder needed)."""
        tables = {k: {c: v.to_numpy() for c, v in df.items() if c not in TEXT_COLUMNS}
                  for k, df in self.tables.items()}
        return DropTables(self.name, self.summary, tables, self.documents)

    def write(self, out: Path) -> None:
        """Write this fit's results files into the folder ``out`` being made (by :meth:`save`, or by
        ``casrecon fit`` inside its atomic folder): the same writers, so the same bytes. ValueError
        for a loaded result (it holds the files, not the fit: :meth:`save` copies them)."""
        from casrecon.report.tables import drop_tables

        if self.fit is None or self.products is None:
            raise ValueError(f"{self.name}: a loaded result has no fit to write; save() copies its folder")
        write_fit_results(out, self.fit, self.products, self.report_text, drop_tables(self.fit, self.products))
        if self.kinematic_check is not None:
            write_kinematic_check(out, self.implied_aero, self.kinematic_check)

    def draw(self, out: Path, formats: Sequence[str] | None = None, notes: list[str] | None = None,
             pool: FigurePool | None = None) -> None:
        """Draw the figures of the results folder ``out`` (written by :meth:`write`) into ``out/figures``,
        in each of ``formats`` (default PNG); reasons for skipped figures appended to ``notes``.
        ``pool``: figure workers started before the fit (``casrecon fit``); without it the figures
        are drawn in this process."""
        from casrecon.report.figure_style import DEFAULT_FORMATS  # matplotlib only when figures are asked for
        from casrecon.report.plots import draw_drop_figures

        formats = tuple(formats or DEFAULT_FORMATS)

        if pool is not None:
            pool.draw(out, notes, formats)
        else:
            draw_drop_figures(out, notes, workers=1, formats=formats)
        if (out / "kinematic_check.json").is_file():
            from casrecon.report.kinematic_check_plots import plot_kinematic_check

            plot_kinematic_check(out, formats)

    def holds_fit(self) -> bool:
        return self.fit is not None and self.products is not None

    def problem_paths(self) -> list[Path]:
        return [self.fit.scenario.config.path] if self.fit is not None else []


def history_columns(frame: pd.DataFrame, time_columns: Sequence[str]) -> tuple[str, ...]:
    """The time-history columns of a trajectory frame: neither time, text (``utc``) nor ``_3sigma`` columns."""
    return tuple(c for c in frame.columns
                 if c not in time_columns and c not in TEXT_COLUMNS and not c.endswith("_3sigma"))


def utc_instants(times: Any) -> pd.DatetimeIndex | None:
    """``times`` as a pandas UTC DatetimeIndex when they are datetime-like (a ``datetime``,
    ``numpy.datetime64``, pandas ``Timestamp``, or a non-empty sequence, array, Index or Series of
    them; naive ones taken as UTC), else None (numbers)."""
    import pandas as pd

    instant = (datetime.datetime, np.datetime64)
    if isinstance(times, instant):
        values = [times]
    elif isinstance(times, (pd.Series, pd.Index, np.ndarray)):
        if not (pd.api.types.is_datetime64_any_dtype(times.dtype) or
                (times.dtype == object and len(times) and all(isinstance(x, instant) for x in times))):
            return None
        values = times
    elif isinstance(times, (list, tuple)) and times and all(isinstance(x, instant) for x in times):
        values = list(times)
    else:
        return None
    return pd.DatetimeIndex(pd.to_datetime(values, utc=True))


def sample_frame(name: str, frame: pd.DataFrame, time_columns: Sequence[str], columns: str | Sequence[str],
                 times_s: Any, time: str | None, default: str) -> pd.DataFrame:
    """``columns`` of ``frame`` and their ``_3sigma`` interpolated linearly at ``times_s`` on the
    ``time`` axis (one of ``time_columns``; None: ``default``), or at UTC
    instants (:func:`utc_instants`) on the ``time_unix_s`` axis, returned in a ``utc`` column;
    ValueError naming what is available, or the window."""
    import pandas as pd

    available = history_columns(frame, time_columns)
    names = [columns] if isinstance(columns, str) else list(columns)
    unknown = [n for n in names if n not in available]
    if unknown:
        raise ValueError(f"{name}: no time-history column {', '.join(map(repr, unknown))}; "
                         f"available: {', '.join(available)}")
    instants = utc_instants(times_s)
    if instants is not None:
        if time not in (None, TIME_UNIX):
            raise ValueError(f"{name}: UTC instants are sampled on {TIME_UNIX}, not {time}; give numbers for {time}")
        if TIME_UNIX not in frame.columns:
            raise ValueError(f"{name}: this fit has no UTC time axis ({TIME_UNIX}): its clock is not UTC")
        time = TIME_UNIX
        t = np.asarray((instants - pd.Timestamp(0, tz="UTC")) / pd.Timedelta(seconds=1), dtype=float)
    else:
        time = default if time is None else time
        if time not in time_columns:
            raise ValueError(f"time must be one of {', '.join(time_columns)} (or give UTC instants: datetime, "
                             f"pandas Timestamp), got {time!r}")
        t = np.atleast_1d(np.asarray(times_s, dtype=float))
    grid = frame[time].to_numpy()
    outside = t[(t < grid[0]) | (t > grid[-1]) | ~np.isfinite(t)]
    if outside.size:
        raise ValueError(f"{name}: {time} {outside[0]:.6f} s is outside the fit window "
                         f"[{grid[0]:.4f}, {grid[-1]:.4f}] s")
    out: dict[str, Any] = {UTC: instants} if instants is not None else {time: t}
    for n in names:
        out[n] = np.interp(t, grid, frame[n].to_numpy())
        if f"{n}_3sigma" in frame:
            out[f"{n}_3sigma"] = np.interp(t, grid, frame[f"{n}_3sigma"].to_numpy())
    return pd.DataFrame(out)


def adequacy_of(summary: dict, source: Path | None, read):
    """``summary["adequacy"]`` read by ``read`` (a ``from_dict``); None when absent; InputError naming
    ``source/summary.json`` when malformed."""
    doc = summary.get("adequacy")
    if not doc:
        return None
    try:
        return read(doc)
    except (KeyError, TypeError, ValueError, AttributeError) as err:
        where = Path(source or ".") / "summary.json"
        raise InputError(where, f"field 'adequacy': malformed ({type(err).__name__}: {err})") from None


def _residuals_of(tables: dict[str, pd.DataFrame]) -> dict[str, pd.DataFrame]:
    return {k.removeprefix("residuals_").removesuffix(".csv"): v for k, v in tables.items()
            if k.startswith("residuals_") and k.endswith(".csv")}

