"""What an lmfit user reads off a result, shared by every result object: ``success``, ``chisqr``,
``redchi``, ``nfev``, ``nvarys``, ``covar`` and ``correl`` (labelled DataFrames) and ``fit_report()``,
one report style for every problem kind with the 1- and 3-sigma named.

:class:`FitStatistics` is a mixin: a result class that has ``name``, ``params``
(:class:`~casrecon.results.parameters.Parameters`), ``converged``, ``reduced_chi2``, ``chisqr``,
``nit`` and ``adequacy`` gets the rest from it.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np

if TYPE_CHECKING:
    import pandas as pd

    from casrecon.results.parameters import Parameters

#: Correlations at or above this magnitude are listed by :meth:`FitStatistics.fit_report` by default.
MIN_CORREL = 0.5
#: At most this many correlations are listed by :meth:`FitStatistics.fit_report` by default.
MAX_CORREL = 10


class FitStatistics:
    """lmfit's names for a result's statistics (a mixin; see the module docstring)."""

    name: str
    params: Parameters
    converged: bool
    reduced_chi2: float
    chisqr: float
    nit: int | None

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
        """An lmfit-style report: fit statistics, every parameter with its 1-sigma and 3-sigma (the
        fixed ones marked), the largest correlations, and the model-adequacy verdict.

        Parameters
        ----------
        min_correl : float
            Correlations of magnitude below this (-) are not listed.
        max_correl : int
            At most this many correlations are listed, largest first.
        """
        return report_text(self, min_correl, max_correl)


def report_text(result: FitStatistics, min_correl: float = MIN_CORREL, max_correl: int = MAX_CORREL) -> str:
    """The text of :meth:`FitStatistics.fit_report` for ``result``."""
    params = result.params
    fixed = len(params) - result.nvarys
    lines = ["[[Fit Statistics]]",
             f"    fit                = {result.name} ({type(result).__name__})",
             f"    success            = {result.success}",
             f"    iterations         = {'not recorded' if result.nit is None else result.nit}",
             f"    # variables        = {result.nvarys}" + (f" (and {fixed} fixed)" if fixed else ""),
             f"    chi-square         = {result.chisqr:.8g}",
             f"    reduced chi-square = {result.redchi:.6g}",
             "[[Variables]] value +/- 1-sigma (absolute), +/- 3-sigma, [unit]"]
    width = max([1, *map(len, params)]) + 1
    for p in (params[n] for n in params):
        label = f"{p.name}:"
        if p.vary:
            lines.append(f"    {label:<{width}} {p.value: .6g} +/- {p.stderr:.4g} (1-sigma), +/- {p.three_sigma:.4g} "
                         f"(3-sigma) [{p.unit or '-'}]")
        else:
            lines.append(f"    {label:<{width}} {p.value: .6g} (fixed) [{p.unit or '-'}]")
    lines.append(f"[[Correlations]] (unreported correlations are < {min_correl:.3f})")
    lines += correlation_lines(params, min_correl, max_correl)
    adequacy = getattr(result, "adequacy", None)
    if adequacy is not None:
        lines += ["[[Model adequacy]]", f"    {adequacy.line}"]
    return "\n".join(lines)


def correlation_lines(params: Parameters, min_correl: float, max_correl: int) -> list[str]:
    """``C(a, b) = +0.912`` lines of the largest correlations (|r| >= ``min_correl``), at most ``max_correl``."""
    names, c = params.var_names, params.correlation
    if len(names) > 1 and np.all(np.isnan(c[~np.eye(len(names), dtype=bool)])):
        return ["    not recorded for this kind of fit"]
    n = len(names)
    pairs = sorted(((abs(c[i, j]), names[i], names[j], c[i, j]) for i in range(n) for j in range(i + 1, n)
                    if np.isfinite(c[i, j]) and abs(c[i, j]) >= min_correl), reverse=True)
    return [f"    C({a}, {b}) = {r:+.3f}" for _, a, b, r in pairs[:max_correl]] or ["    none"]
