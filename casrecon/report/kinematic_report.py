"""The kinematic (IMU-driven) reconstruction's own sections of its report
(:mod:`casrecon.report.report_style`: the statistics, the IMU parameters against their priors and the
correlations come before them): span and convergence, chi-square per residual group, the bands'
sizes and the parameters beyond 3 sigma of their prior, the data notes and the model-adequacy
verdict (per-channel reduced chi-square, lag-1 and Ljung-Box)."""

from __future__ import annotations

import numpy as np

from casrecon.analysis.parameter_estimates import parameter_estimate
from casrecon.report.adequacy_block import report_lines
from casrecon.report.report_style import PRIOR_Z_LIMIT, section


def kinematic_sections(result, adequacy=None) -> str:
    """The own sections of ``result`` (:class:`~casrecon.estimation.kinematic.fit.KinematicResult`):
    ``[[Solver]]`` (span, s, and nodes, clock, convergence, iterations, timings in s, reduced
    chi-square), ``[[Chi-square per residual group]]``, ``[[Bands]]`` (median 3-sigma of position,
    m, velocity, m/s, and attitude, deg; the parameters beyond :data:`PRIOR_Z_LIMIT` sigma of their
    prior, in their output unit, :func:`~casrecon.analysis.parameter_estimates.parameter_estimate`),
    ``[[Data notes]]``, and the model-adequacy block of ``adequacy``
    (:func:`casrecon.analysis.fit_adequacy.kinematic_adequacy`) when given."""
    t = result.node_time_s
    lines = section("Solver", [
        f"span {t[-1] - t[0]:.2f} s ({t.size} nodes), clock {result.data.time_ref_s + t[0]:.3f} to "
        f"{result.data.time_ref_s + t[-1]:.3f} s",
        f"converged: {result.solver.converged} ({result.solver.status}), {result.solver.iterations} iterations "
        f"(after {result.timings.get('earlier_iterations', 0)} from the inflated-noise starts, earlier "
        "linearisations and fix placements)",
        f"whole fit {result.timings.get('total_s', 0):.2f} s; its last placement: " + ", ".join(
            f"{what} {result.timings.get(key, 0):.2f} s" for what, key in (
                ("build", "build_s"), ("starts", "start_solve_s"), ("solve", "solve_s"),
                ("covariance", "covariance_s"))),
        f"reduced chi-square {result.reduced_chi2:.3f}"])
    groups = []
    for group, value in result.chi2.items():
        n = result.n_measurements.get(group, 0)
        groups.append(f"{group:18s} {value:12.2f}  n {n:6d}  ({value / max(n, 1):.3f} per measurement)")
    lines += section("Chi-square per residual group", groups)
    flagged = []
    for spec, value, sigma in zip(result.params.specs, result.values, result.sigma):
        e = parameter_estimate(spec, value, sigma, 1.0)  # in its output unit (deg/s, deg)
        z = e.value / e.prior_sigma if e.prior_sigma else float("nan")
        if np.isfinite(z) and abs(z) >= PRIOR_Z_LIMIT:
            flagged.append(f"{spec.name} ({z:+.1f})")
    sig = result.state_sigma
    bands = ["median 3-sigma bands: position N/E/D "
             + " / ".join(f"{3 * np.median(sig[:, i]):.2f}" for i in range(3)) + " m, velocity "
             + " / ".join(f"{3 * np.median(sig[:, i]):.3f}" for i in range(3, 6)) + " m/s, attitude "
             + " / ".join(f"{np.degrees(3 * np.median(sig[:, i])):.2f}" for i in range(6, 9)) + " deg"]
    if flagged:
        bands.append(f"parameters beyond {PRIOR_Z_LIMIT:g} sigma of their prior: {', '.join(flagged)}: the IMU "
                     "model (or its stated noise) does not describe these data; the bands assume it does")
    lines += section("Bands", bands)
    if result.notes:
        lines += section("Data notes", result.notes)
    if adequacy is not None:
        lines += report_lines(adequacy)
    return "\n".join(lines)
