"""The one style of every text report: ``report.txt`` of each problem kind (6-DOF, point-mass,
kinematic, joint) and ``fit_report()`` of the API read alike, in lmfit's manner::

    [[Fit Statistics]]   the fit and its kind, success, iterations, # variables, chi-square, reduced chi-square
    [[Variables]]        per parameter: value +/- 1-sigma (1-sigma), +/- 3-sigma (3-sigma) [unit], the
                         chi-square-scaled 3-sigma, the prior 1-sigma and z = value / prior 1-sigma
                         (priors are zero-mean), flags; the parameters held fixed marked
    [[Correlations]]     the largest, |r| >= min_correl
    [[...]]              the problem kind's own sections (solver, data notes, ...)
    [[Model adequacy]]   the verdict, last

The head (the first three sections) is made by :func:`report_head` from the parameter records alone
(name, value, stderr, stderr_scaled, unit, prior_sigma, vary), so a results folder's
``parameters.json`` and ``summary.json`` give it back exactly; the kind's own sections follow it
(:func:`compose`, :func:`sections_after`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Protocol

import numpy as np

#: Correlations at or above this magnitude (-) are listed by default.
MIN_CORREL = 0.5
#: At most this many correlations are listed by default.
MAX_CORREL = 10
#: Correlations above this magnitude (-) are flagged.
CORRELATION_FLAG = 0.9
#: A 1-sigma above this fraction of the prior 1-sigma is flagged as set mostly by the prior.
PRIOR_DOMINATED = 0.9
#: An estimate this many prior sigmas (or more) from its zero prior mean is flagged.
PRIOR_Z_LIMIT = 3.0
#: Width of the statistics' labels.
LABEL_WIDTH = 18


class VariableRecord(Protocol):
    """What a report reads of one parameter (:class:`casrecon.results.parameters.Parameter` has it)."""

    name: str
    value: float
    stderr: float
    stderr_scaled: float
    unit: str
    prior_sigma: float | None
    vary: bool


@dataclass(frozen=True)
class FitSummary:
    """The ``[[Fit Statistics]]`` of a fit.

    Attributes
    ----------
    name : str
        The problem's (or joint fit's) name.
    kind : str
        What kind of fit (``"6-DOF"``, ``"kinematic, IMU-driven"``, ...).
    success : bool
        Whether the solver converged.
    iterations : int or None
        The solver's iteration count; None when not recorded.
    chisqr : float
        Total chi-square (every residual group and prior), -.
    redchi : float
        Reduced chi-square, -.
    """

    name: str
    kind: str
    success: bool
    iterations: int | None
    chisqr: float
    redchi: float


def statistics_lines(fit: FitSummary, n_vary: int, n_fixed: int) -> list[str]:
    """The ``[[Fit Statistics]]`` section."""
    rows = (("fit", f"{fit.name} ({fit.kind})" if fit.kind else fit.name), ("success", str(fit.success)),
            ("iterations", "not recorded" if fit.iterations is None else str(fit.iterations)),
            ("# variables", f"{n_vary}" + (f" (and {n_fixed} fixed)" if n_fixed else "")),
            ("chi-square", f"{fit.chisqr:.8g}"), ("reduced chi-square", f"{fit.redchi:.6g}"))
    return ["[[Fit Statistics]]", *[f"    {label:<{LABEL_WIDTH}} = {text}" for label, text in rows]]


def variable_line(p: VariableRecord, width: int) -> str:
    """One parameter's line of ``[[Variables]]``: value, 1- and 3-sigma named, unit; the chi-square-
    scaled 3-sigma when known; prior 1-sigma and z with a prior; flags."""
    unit = p.unit or "-"
    label = f"{p.name}:"
    if not p.vary:
        return f"    {label:<{width}} {p.value: .6g} (fixed) [{unit}]"
    line = (f"    {label:<{width}} {p.value: .6g} +/- {p.stderr:.4g} (1-sigma), +/- {3 * p.stderr:.4g} (3-sigma) "
            f"[{unit}]")
    if p.stderr_scaled is not None and math.isfinite(p.stderr_scaled):
        line += f"; chi2-scaled 3-sigma {3 * p.stderr_scaled:.3g}"
    flags = []
    if p.prior_sigma:
        z = p.value / p.prior_sigma
        line += f"; prior 1-sigma {p.prior_sigma:.3g}, z {z:+.1f}"
        if abs(z) >= PRIOR_Z_LIMIT:
            flags.append(f"beyond {PRIOR_Z_LIMIT:g} sigma of its prior")
        if p.stderr > PRIOR_DOMINATED * p.prior_sigma:
            flags.append("set mostly by its prior (the data add little)")
    return line + (f"  <- {'; '.join(flags)}" if flags else "")


def variable_lines(records: Sequence[VariableRecord], fixed_note: str = "") -> list[str]:
    """The ``[[Variables]]`` section: every parameter, estimated ones first as given, then those held
    fixed, followed by ``fixed_note`` (why they are fixed) when there are any."""
    width = max([1, *(len(p.name) for p in records)]) + 1
    lines = ["[[Variables]] value +/- 1-sigma (absolute), +/- 3-sigma [unit]; chi2-scaled 3-sigma; prior "
             "1-sigma, z = value / prior 1-sigma"]
    lines += [variable_line(p, width) for p in records]
    if fixed_note and any(not p.vary for p in records):
        lines.append(f"    (fixed: {fixed_note})")
    return lines


def correlation_lines(names: Sequence[str], correlation: np.ndarray, min_correl: float = MIN_CORREL,
                      max_correl: int = MAX_CORREL) -> list[str]:
    """The ``[[Correlations]]`` section: ``C(a, b) = +0.912`` for the largest (|r| >= ``min_correl``,
    at most ``max_correl``, largest first; those above :data:`CORRELATION_FLAG` flagged) of the
    ``correlation`` matrix (-, rows and columns in the order of ``names``)."""
    c, n = np.asarray(correlation, dtype=float), len(names)
    head = f"[[Correlations]] (unreported correlations are < {min_correl:.3f})"
    if n > 1 and np.all(np.isnan(c[~np.eye(n, dtype=bool)])):
        return [head, "    not recorded for this kind of fit"]
    pairs = sorted(((abs(c[i, j]), names[i], names[j], c[i, j]) for i in range(n) for j in range(i + 1, n)
                    if np.isfinite(c[i, j]) and abs(c[i, j]) >= min_correl), reverse=True)
    lines = [f"    C({a}, {b}) = {r:+.3f}" + (f"  <- |r| > {CORRELATION_FLAG:g}" if m > CORRELATION_FLAG else "")
             for m, a, b, r in pairs[:max_correl]]
    return [head, *(lines or ["    none"])]


def report_head(fit: FitSummary, records: Sequence[VariableRecord], names: Sequence[str], correlation: np.ndarray,
                min_correl: float = MIN_CORREL, max_correl: int = MAX_CORREL, fixed_note: str = "") -> str:
    """``[[Fit Statistics]]``, ``[[Variables]]`` and ``[[Correlations]]`` of a report.

    Parameters
    ----------
    fit : FitSummary
    records : sequence of VariableRecord
        Every parameter, in the order listed (estimated ones in fit order, then the fixed ones).
    names : sequence of str
        The estimated parameters' names, in the order of ``correlation``'s rows.
    correlation : ndarray
        Correlation matrix of the estimated parameters (-; NaN off the diagonal when not recorded).
    min_correl, max_correl : float, int
        Correlations of magnitude below ``min_correl`` (-) are not listed; at most ``max_correl`` are.
    fixed_note : str
        Why the fixed parameters are fixed (one line after them).
    """
    n_vary = sum(bool(p.vary) for p in records)
    return "\n".join([*statistics_lines(fit, n_vary, len(records) - n_vary), *variable_lines(records, fixed_note),
                      *correlation_lines(names, correlation, min_correl, max_correl)])


def section(title: str, lines: Sequence[str]) -> list[str]:
    """A kind's own section: ``[[title]]`` and its lines indented by four spaces."""
    return [f"[[{title}]]", *[f"    {line}" for line in lines]]


def compose(head: str, sections: str) -> str:
    """A whole report: the head (:func:`report_head`), then the kind's own sections and verdict."""
    sections = sections.strip("\n")
    return f"{head}\n{sections}" if sections else head


def sections_after(report: str, head: str) -> str | None:
    """The kind's own sections of ``report`` (the text after ``head``), or None when ``report`` does
    not begin with ``head`` (a report written in another style, or from other numbers)."""
    if report == head:
        return ""
    if report.startswith(head + "\n"):
        return report[len(head) + 1:]
    return None
