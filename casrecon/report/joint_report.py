"""A joint fit's own sections of its report (:mod:`casrecon.report.report_style`: the statistics, the
global parameters and their correlations come before them): the solver, the per-drop summary, the
joint against the single-drop sigmas, and the model-adequacy verdict (each drop's, then the joint
one). ``tables.md`` holds the same numbers as Markdown tables (:mod:`casrecon.report.joint_tables`)."""

from __future__ import annotations

from casrecon.report.joint_tables import per_drop_rows, sigma_rows
from casrecon.report.report_style import section


def joint_sections(result, single: dict[str, dict[str, float]], reconciled: dict[str, dict], adequacy=None) -> str:
    """The joint fit's own sections: ``[[Solver]]`` (status, iterations, drops and shared factors,
    chi-square, dof and reduced chi-square of the joint NLP), ``[[Drops]]`` (per drop: window, s
    after release; chi-square over measurements; wind bias N, E, m/s; density factor; end speed, m/s;
    reconciled-simulation flight-time and impact-speed differences, s and m/s), ``[[Joint vs
    single-drop sigma]]`` (1-sigma of each shared factor, -) and ``[[Model adequacy]]`` (each drop's
    verdict, the joint verdict last) when ``adequacy`` (a
    :class:`~casrecon.analysis.fit_adequacy.JointAdequacy`) is given.

    Parameters
    ----------
    result : casrecon.estimation.sixdof.joint.JointResult
    single : dict of str to dict of str to float
        Drop -> parameter -> 1-sigma of the drop's own fit (may be empty: not run).
    reconciled : dict of str to dict
        Drop -> reconciled-simulation summary (s, m/s).
    adequacy : JointAdequacy or None
    """
    lines = section("Solver", [
        f"{result.status} in {result.iterations} iterations; {len(result.drops)} drops, shared "
        f"{', '.join(result.shared) or 'none'}",
        f"chi-square {result.chi2:.1f}, dof {result.dof}, reduced chi-square {result.reduced_chi2:.4f} (the joint "
        "NLP, shared factors counted once)"])
    rows = per_drop_rows(result, reconciled)
    width = max(len(r.name) for r in rows)
    lines += section("Drops", [
        f"{'drop':<{width}}  window after release, s  chi2 / n  wind bias N, E (m/s)  density factor  "
        "end speed (m/s)  reconciled dt (s), dV (m/s)",
        *[f"{r.name:<{width}}  {r.window_s[0]:.2f} to {r.window_s[1]:.2f}  {r.chi2:.0f} / {r.n}  "
          f"{r.wind_bias_mps[0]:+.3f}, {r.wind_bias_mps[1]:+.3f}  {r.density_factor:+.5f}  {r.end_speed_mps:.2f}  "
          f"{r.reconciled_dt_s:+.3f}, {r.reconciled_dv_mps:+.3f}" for r in rows]])
    if single:
        lines += section("Joint vs single-drop sigma", [
            "1-sigma of each shared factor: joint, each drop's own fit (" + ", ".join(single) + "), "
            "joint / best single",
            *[f"{n}: {js:.4g}; " + ", ".join(f"{s:.4g}" for s in singles) + f"; {ratio:.3f}"
              for n, js, singles, ratio in sigma_rows(result, single)]])
    else:
        lines += section("Joint vs single-drop sigma", ["single-drop fits were not run (--no-single)"])
    if adequacy is not None:
        lines += ["[[Model adequacy]] each drop's verdict (its drops/<name>/report.txt has its tests), then the "
                  "joint one", *[f"    {n}: {a.line}" for n, a in adequacy.drops], f"    VERDICT: {adequacy.line}"]
    return "\n".join(lines)
