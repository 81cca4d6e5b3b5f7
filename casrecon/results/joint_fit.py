"""The joint result of the public API (``casrecon.fit_joint``, ``casrecon.load_results`` on a joint
folder): global parameters (shared ones plain, each drop's own as ``<drop>.<name>``) with their
correlations, every drop as a :class:`~casrecon.results.drop_fit.DropFit`, and the results folder
that ``casrecon joint --out`` writes.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Any

from casrecon.analysis.fit_adequacy import JointAdequacy, joint_adequacy
from casrecon.output.joint_results import joint_parameters_document, joint_summary_document, write_joint_results
from casrecon.output.out_folder import input_paths
from casrecon.output.results import json_values, save_results_folder
from casrecon.output.results_reader import read_results_folder, read_text
from casrecon.report.fit_report import FIXED_DISPERSION_NOTE
from casrecon.results.drop_fit import DropFit, adequacy_of, fixed_dispersions, parameters_of, report_text
from casrecon.results.fit_statistics import FitStatistics
from casrecon.results.parameters import Parameters, from_document

if TYPE_CHECKING:
    import pandas as pd

    from casrecon.analysis.fit_products import FitProducts
    from casrecon.estimation.sixdof.joint import JointResult



@dataclass(frozen=True, eq=False, repr=False)
class JointFit(FitStatistics):
    """A joint fit of several drops, from :func:`casrecon.fit_joint` or loaded from a joint folder.

    Attributes
    ----------
    name : str
        Name of the joint fit.
    params : Parameters
        Global parameters in NLP order: shared dispersion factors by their name, each drop's own
        parameters as ``<drop>.<name>``; ``params[n].shared`` says which; correlations across all;
        then the aero dispersion factors no drop estimates (held at 0, ``vary`` False).
    drops : dict of str to DropFit
        Each drop's part of the joint fit (its trajectory, residuals and parameters as seen by it).
    summary : dict
        ``summary.json``: status, iterations, the joint chi-square, dof and reduced chi-square, each
        drop's own chi-square per group, dof and reduced chi-square, timings (s), single-drop sigmas
        when computed (output units, named in ``units``), the model-adequacy verdict
        (:attr:`adequacy`), reconciled-simulation differences per drop.
    tables_md : str
        ``tables.md``: shared factors (Table 5 style), per-drop summary, joint vs single sigmas.
    report_text : str
        ``report.txt``, the text report in the one style of every kind
        (:mod:`casrecon.report.report_style`); empty for a folder written before it existed.
    fit : casrecon.estimation.sixdof.joint.JointResult or None
        The estimator's result; None when loaded.
    products : dict of str to FitProducts or None
        Each drop's residuals and reconciled simulations; None when loaded.
    single : dict of str to dict of str to float
        Drop -> parameter -> 1-sigma of the drop's own fit (output units: gyro biases in deg/s).
    source : Path or None
        The folder a loaded result came from.

    Also (properties): ``trajectory`` and ``aero_coefficients`` (per drop), ``sample()`` (one drop or
    all), lmfit's ``success``, ``chisqr``, ``redchi``, ``nfev``, ``nvarys``, ``covar``, ``correl`` and
    ``fit_report()``.
    """

    name: str
    params: Parameters
    drops: dict[str, DropFit]
    summary: dict
    tables_md: str
    fit: JointResult | None = None
    products: dict[str, FitProducts] | None = field(default=None)
    single: dict[str, dict[str, float]] = field(default_factory=dict)
    source: Path | None = None
    report_text: str = ""

    fixed_note = FIXED_DISPERSION_NOTE

    @classmethod
    def from_fit(cls, result: JointResult, products: dict[str, FitProducts],
                 single: dict[str, dict[str, float]] | None = None) -> JointFit:
        """Wrap a :class:`~casrecon.estimation.sixdof.joint.JointResult` and each drop's products; the
        report is the head of :meth:`report_head` and the joint fit's own sections
        (:func:`casrecon.report.joint_report.joint_sections`), each drop's its own."""
        from casrecon.report.fit_report import sixdof_sections
        from casrecon.report.joint_report import joint_sections
        from casrecon.report.joint_tables import joint_tables

        single = single or {}
        drops = {d.scenario.config.name: DropFit.from_fit(d, products[d.scenario.config.name],
                                                          sixdof_sections(d, products[d.scenario.config.name].adequacy))
                 for d in result.drops}
        reconciled = {n: products[n].reconciled_summary for n in drops}
        adequacy = joint_adequacy({n: p.adequacy for n, p in products.items() if p.adequacy is not None})
        doc = json_values(joint_parameters_document(result))
        summary = json_values(joint_summary_document(result, single, reconciled, adequacy))
        joint = cls(name=result.config.name, params=from_document(doc, fixed=fixed_dispersions(doc["parameters"])),
                    drops=drops, summary=summary,
                    tables_md=joint_tables(result, single, reconciled, adequacy), fit=result, products=products,
                    single=single)
        return joint.with_sections(joint_sections(result, single, reconciled, adequacy))

    @classmethod
    def load(cls, folder: str | Path) -> JointFit:
        """Read a joint results folder (``casrecon joint --out`` or :meth:`save`), every file of it and
        of its drops checked (:func:`casrecon.output.results_reader.read_results_folder`).

        Raises
        ------
        InputError
            Not a folder, a missing top-level file, a drop sub-folder that is not a results folder,
            or a damaged file (the file, the line or key, and what was expected).
        """
        files = read_results_folder(folder, "joint")
        summary = files.summary
        drops = {}
        for sub in files.drops:
            drop = DropFit.from_files(sub)
            drops[drop.name] = drop
        tables = files.folder / "tables.md"
        return cls(name=str(summary.get("name") or files.folder.name),
                   params=parameters_of(files, summary.get("reduced_chi2"), held_dispersions=True),
                   drops=drops, summary=summary,
                   tables_md=read_text(tables, "the tables") if tables.is_file() and tables.stat().st_size else "",
                   single=dict(summary.get("single_drop_sigma") or {}), source=files.folder.resolve(),
                   report_text=report_text(files.folder))

    @property
    def converged(self) -> bool:
        """Whether the joint solve converged (always True for a fit that returned)."""
        return bool(self.summary.get("converged"))

    @property
    def report_kind(self) -> str:
        """What kind of fit, for ``[[Fit Statistics]]``."""
        return f"joint 6-DOF of {len(self.drops)} drops"

    @property
    def shared(self) -> tuple[str, ...]:
        """The dispersion factors common to all drops."""
        return tuple(self.summary.get("shared", ()))

    @property
    def reduced_chi2(self) -> float:
        """Joint chi-square over the joint dof, -."""
        return float(self.summary.get("reduced_chi2", float("nan")))

    @property
    def chisqr(self) -> float:
        """The joint chi-square (``summary.json`` ``chi2``), -."""
        return float(self.summary.get("chi2", float("nan")))

    @property
    def nit(self) -> int | None:
        """The joint solve's iteration count; None when not recorded."""
        n = self.summary.get("iterations")
        return None if n is None else int(n)

    @property
    def trajectory(self) -> dict[str, pd.DataFrame]:
        """Each drop's trajectory (:attr:`DropFit.trajectory <casrecon.results.drop_fit.DropFit>`) by drop name."""
        return {name: drop.trajectory for name, drop in self.drops.items()}

    @property
    def aero_coefficients(self) -> dict[str, pd.DataFrame | None]:
        """Each drop's ``aero_coefficients.csv`` as a DataFrame (None where not computed) by drop name."""
        return {name: drop.aero_coefficients for name, drop in self.drops.items()}

    def sample(self, columns: str | Sequence[str], times_s: Any, *, drop: str | None = None,
               time: str | None = None) -> pd.DataFrame:
        """Columns and their 3-sigma interpolated in one drop's trajectory (``drop``) or in every
        drop's, as :meth:`DropFit.sample <casrecon.results.drop_fit.DropFit.sample>` (flight time by
        default, the IMU clock, Unix seconds, or UTC instants).

        Returns
        -------
        pandas.DataFrame
            ``drop`` given: that drop's samples. Otherwise every drop's, one after the other, with a
            first column ``drop`` naming it.

        Raises
        ------
        ValueError
            An unknown drop (the message lists the drops), column or time axis, or a time outside a
            drop's fit window.
        """
        import pandas as pd

        if drop is not None:
            if drop not in self.drops:
                raise ValueError(f"{self.name}: no drop {drop!r}; the drops are {', '.join(self.drops)}")
            return self.drops[drop].sample(columns, times_s, time=time)
        frames = [d.sample(columns, times_s, time=time) for d in self.drops.values()]
        for name, frame in zip(self.drops, frames):
            frame.insert(0, "drop", name)
        return pd.concat(frames, ignore_index=True)

    @property
    def chi2(self) -> dict[str, dict[str, float]]:
        """Chi-square per drop and residual group (``{"ees-drop-1": {"imu": ..., "gps": ...}}``), -."""
        return {k: dict(v) for k, v in self.summary.get("chi2_per_drop", {}).items()}

    @property
    def adequacy(self) -> JointAdequacy | None:
        """The model-adequacy verdict (``summary.json`` ``adequacy``): ``.trusted``, ``.line`` and each
        drop's :class:`~casrecon.analysis.adequacy.Adequacy` (``.drop(name)``); None for an older folder."""
        return adequacy_of(self.summary, self.source, JointAdequacy.from_dict)

    def report(self) -> str:
        """The text report of ``casrecon joint`` (``report.txt``): in the one style of every kind, the
        text of :meth:`fit_report` with its default arguments. A folder written before report.txt
        existed: the joint chi-square and the model-adequacy verdict, then ``tables.md``."""
        if self.report_text:
            return self.report_text
        head = (f"[[Joint fit: {self.name}]] {len(self.drops)} drops, shared {', '.join(self.shared) or 'none'}; "
                f"chi-square {self.summary.get('chi2', float('nan')):.1f}, dof {self.summary.get('dof')}, "
                f"reduced chi-square {self.reduced_chi2:.4f}")
        if self.adequacy is not None:
            head += f"\n    VERDICT: {self.adequacy.line}"
        return head + "\n\n" + self.tables_md.rstrip("\n")

    def __repr__(self) -> str:
        where = f", from {self.source}" if self.source else ""
        return (f"<JointFit {self.name!r}: {len(self.drops)} drops, {len(self.shared)} shared factors, "
                f"reduced chi2 {self.reduced_chi2:.4f}, {self.nvarys} parameters{where}>")

    def write(self, out: Path) -> None:
        """Write this joint fit's results files into the folder ``out`` being made (by :meth:`save`, or
        by ``casrecon joint`` inside its atomic folder): the same writers, so the same bytes.
        ValueError for a loaded result (:meth:`save` copies its folder)."""
        if self.fit is None or self.products is None:
            raise ValueError(f"{self.name}: a loaded result has no fit to write; save() copies its folder")
        write_joint_results(out, self.fit, self.single, self.products, self.report_text,
                            {name: drop.report_text for name, drop in self.drops.items()})

    def draw(self, out: Path, formats: Sequence[str] | None = None, notes: list[str] | None = None) -> None:
        """Draw every drop's and the joint figures of the folder ``out`` (written by :meth:`write`), in
        each of ``formats`` (default PNG); reasons for skipped figures appended to ``notes``."""
        from casrecon.report.figure_style import DEFAULT_FORMATS  # matplotlib only when figures are asked for
        from casrecon.report.plots import draw_figures

        draw_figures(out, notes, tuple(formats or DEFAULT_FORMATS))

    def save(self, folder: str | Path, *, figures: bool = False, force: bool = False,
             formats: Sequence[str] | None = None) -> Path:
        """Write the folder ``casrecon joint --out folder`` writes, atomically; figures only if asked.
        A loaded result is saved as a copy of its files (without ``figures/`` unless ``figures``). A
        foreign existing folder or a file is replaced only with ``force``, a folder holding inputs never."""
        write = self.write if self.fit is not None and self.products is not None else None
        inputs = input_paths([d.scenario.config.path for d in self.fit.drops] if self.fit is not None else [])
        return save_results_folder(folder, self.name, write, self.source,
                                   (lambda out: self.draw(out, formats)) if figures else None,
                                   kind="joint", force=force, inputs=inputs)
