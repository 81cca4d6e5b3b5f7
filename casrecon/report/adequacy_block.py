"""The ``[[Model adequacy]]`` block of a text report: the verdict of
:mod:`casrecon.analysis.adequacy` as indented lines, the verdict last."""

from __future__ import annotations

from casrecon.analysis.adequacy import NAMED_Z, Adequacy, p_text
from casrecon.analysis.process_scale import ProcessScale


def process_line(t: ProcessScale) -> str:
    """One prior process's size test as an indented line."""
    flag = "  <-" if t.too_large else "  <- small" if t.too_small else ""
    return (f"    {t.name:18s} n {t.n:4d}  NEES {t.nees:7.1f} on {t.dof} in [{t.interval[0]:.1f}, {t.interval[1]:.1f}]"
            f"  sigma: data {t.estimated_sigma:.3g} {t.unit}, assumed {t.assumed_sigma:.3g} {t.unit}{flag}")


def report_lines(adequacy: Adequacy) -> list[str]:
    """The ``[[Model adequacy]]`` block of a text report (indented lines, the verdict last)."""
    a = adequacy
    lines = [f"[[Model adequacy]] {a.n_tests} tests, Bonferroni at {100 * a.alpha:g} % family-wise "
             f"({a.alpha / max(a.n_tests, 1):.2g} each); residuals / sigma per channel:"]
    for c in a.channels:
        if not c.n:
            lines.append(f"    {c.name:14s} no samples")
            continue
        flag = "" if c.scale_ok and c.white else "  <- small" if c.white and c.below else "  <-"
        lines.append(f"    {c.name:14s} n {c.n:6d}  reduced chi2 {c.reduced_chi2:7.3f} in [{c.chi2_interval[0]:.3f}, "
                     f"{c.chi2_interval[1]:.3f}]  lag-1 {c.lag1:+.2f}  Ljung-Box({c.lags}) {p_text(c.ljung_box_p)}"
                     f"{flag}")
    if a.processes:
        lines.append("    prior processes (whitened prior residuals; sigma the data say, one MacKay step):")
        lines += [process_line(t) for t in a.processes]
    if a.nees is not None:
        n = a.nees
        lines.append(f"    priors: NEES {n.nees:.1f} on {n.dof} informed directions in [{n.interval[0]:.1f}, "
                     f"{n.interval[1]:.1f}]; sum of squared z {n.prior_chi2:.1f} over {n.n_priors} priors")
    beyond = ", ".join(f"{d.name} z {d.z:+.1f}" for d in a.deviations) or "none"
    lines.append(f"    beyond {NAMED_Z:g} sigma of their prior: {beyond} (verdict limit |z| {a.z_limit:.2f})")
    if a.ground is not None:
        lines.append(f"    ground: {a.ground.explanation}")
    lines += [f"    note: {n}" for n in a.notes]
    lines.append(f"    VERDICT: {a.line}")
    return lines
