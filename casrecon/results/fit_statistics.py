"""What an lmfit user reads off a result, shared by every result object: ``success``, ``chisqr``,
``redchi``, ``nfev``, ``nvarys``, ``covar`` and ``correl`` (labelled DataFrames) and ``fit_report()``,
in the one report style of every problem kind (:mod:`casrecon.report.report_style`), so that
``fit_report()`` reads as the ``report.txt`` the command writes (with the default arguments, it is
that text).

:class:`FitStatistics` is a mixin: a result class that has ``name``, ``params``
(:class:`~casrecon.results.parameters.Parameters`), ``converged``, ``reduced_chi2``, ``chisqr``,
``nit``, ``adequacy`` and ``report_text``, and sets ``report_kind`` (and ``fixed_note``), gets the rest
from it.
"""

from __future__ import annotations

import dataclasses
from typing import TYPE_CHECKING, ClassVar

from casrecon.report.report_style import MAX_CORREL, MIN_CORREL, FitSummary, compose, report_head, sections_after

if TYPE_CHECKING:
    import pandas as pd

    from casrecon.results.parameters import Parameters


class FitStatistics:
    """lmfit's names for a result's statistics (a mixin; see the module docstring)."""

    name: str
    params: Parameters
    converged: bool
    reduced_chi2: float
    chisqr: float
    nit: int | None
    report_text: str

    #: What kind of fit, for ``[[Fit Statistics]]`` (``"6-DOF"``, ...).
    report_kind: ClassVar[str] = ""
    #: Why the parameters held fixed are fixed (the line after them in ``[[Variables]]``).
    fixed_note: ClassVar[str] = ""

    @property
    def success(self) -> bool:
        """Whether the solver converged (lmfit's name for :attr:`converged`)."""
        return self.converged

    @property
    def redchi(self) -> float:
        """Reduced chi-square, - (lmfit's name for :attr:`reduced_chi2`)."""
        return self.reduced_chi2

    @property
    def nfev(self) -> int | None:
        """The solver's iteration count (:attr:`nit`): casrecon records iterations, not function
        evaluations; None when the summary does not record it."""
        return self.nit

    @property
    def nvarys(self) -> int:
        """Number of estimated parameters (``vary`` True)."""
        return len(self.params.var_names)

    @property
    def covar(self) -> pd.DataFrame:
        """Covariance of the estimated parameters, a DataFrame labelled by name (each entry in the
        product of the two parameters' units; :attr:`~casrecon.results.parameters.Parameters.covar`)."""
        return self.params.covar

    @property
    def correl(self) -> pd.DataFrame:
        """Correlation of the estimated parameters, a DataFrame labelled by name (-;
        :attr:`~casrecon.results.parameters.Parameters.correl`)."""
        return self.params.correl

    def fit_report(self, min_correl: float = MIN_CORREL, max_correl: int = MAX_CORREL) -> str:
        """The report in the one style of every problem kind (:mod:`casrecon.report.report_style`): fit
        statistics, every parameter with its 1-sigma and 3-sigma named (the fixed ones marked), the
        largest correlations, then the kind's own sections and the model-adequacy verdict. With the
        default arguments it is :meth:`report` (``report.txt``).

        Parameters
        ----------
        min_correl : float
            Correlations of magnitude below this (-) are not listed.
        max_correl : int
            At most this many correlations are listed, largest first.
        """
        return compose(self.report_head(min_correl, max_correl), self.report_sections())

    def report_head(self, min_correl: float = MIN_CORREL, max_correl: int = MAX_CORREL) -> str:
        """``[[Fit Statistics]]``, ``[[Variables]]`` and ``[[Correlations]]`` of the report, from
        :attr:`params` and the statistics (:func:`casrecon.report.report_style.report_head`)."""
        fit = FitSummary(self.name, self.report_kind, self.success, self.nit, self.chisqr, self.redchi)
        params = self.params
        return report_head(fit, list(params.values()), params.var_names, params.correlation, min_correl,
                           max_correl, self.fixed_note)

    def report_sections(self) -> str:
        """The kind's own sections and the verdict: ``report.txt`` after its head; for a report written
        in another style (a folder from before issue 52), the model-adequacy verdict alone."""
        sections = sections_after(self.report_text, self.report_head())
        if sections is not None:
            return sections
        adequacy = self.adequacy
        return "" if adequacy is None else f"[[Model adequacy]]\n    VERDICT: {adequacy.line}"

    def with_sections(self, sections: str):
        """A copy whose ``report_text`` is the whole report: the head of :meth:`report_head` and the
        kind's own ``sections`` (its solver, data notes, ..., model-adequacy verdict)."""
        return dataclasses.replace(self, report_text=compose(self.report_head(), sections))
