"""The text report of a kinematic reconstruction: span, convergence, chi-square per residual group,
the IMU parameters against their priors (those beyond 3 sigma named; gyro biases in deg/s and
misalignments in deg, :func:`~casrecon.analysis.parameter_estimates.parameter_estimate`), the bands' sizes and the
model-adequacy verdict (per-channel reduced chi-square, lag-1 and Ljung-Box)."""

from __future__ import annotations

import numpy as np

from casrecon.analysis.parameter_estimates import parameter_estimate
from casrecon.report.adequacy_block import report_lines

#: A parameter whose estimate lies this many prior sigmas from its prior mean is named.
PRIOR_Z_LIMIT = 3.0


def kinematic_report(result, name: str = "", adequacy=None) -> str:
    """The report text of ``result`` (:class:`~casrecon.estimation.kinematic.fit.KinematicResult`),
    with the model-adequacy block of ``adequacy`` (:func:`casrecon.analysis.fit_adequacy.kinematic_adequacy`)
    when given."""
    t = result.node_time_s
    lines = [f"KINEMATIC RECONSTRUCTION {name}".rstrip(),
             f"span {t[-1] - t[0]:.2f} s ({t.size} nodes), clock {result.data.time_ref_s + t[0]:.3f} to "
             f"{result.data.time_ref_s + t[-1]:.3f} s",
             f"converged: {result.solver.converged} ({result.solver.status}), {result.solver.iterations} iterations "
             f"(after {result.timings.get('earlier_iterations', 0)} from the inflated-noise starts, earlier "
             "linearisations and fix placements)",
             f"whole fit {result.timings.get('total_s', 0):.2f} s; its last placement: " + ", ".join(
                 f"{what} {result.timings.get(key, 0):.2f} s" for what, key in (
                     ("build", "build_s"), ("starts", "start_solve_s"), ("solve", "solve_s"),
                     ("covariance", "covariance_s"))),
             f"reduced chi-square {result.reduced_chi2:.3f}", "", "chi-square per residual group (per measurement):"]
    for group, value in result.chi2.items():
        n = result.n_measurements.get(group, 0)
        lines.append(f"  {group:18s} {value:12.2f}  n {n:6d}  ({value / max(n, 1):.3f})")
    lines += ["", f"{'parameter':18s} {'value':>12s} {'3-sigma':>11s} {'prior 1-sigma':>14s} {'z':>6s}  unit"]
    flagged = []
    for spec, value, sigma in zip(result.params.specs, result.values, result.sigma):
        e = parameter_estimate(spec, value, sigma, 1.0)  # in its output unit (deg/s, deg)
        z = e.value / e.prior_sigma if e.prior_sigma else float("nan")
        if np.isfinite(z) and abs(z) >= PRIOR_Z_LIMIT:
            flagged.append(f"{spec.name} ({z:+.1f})")
        lines.append(f"{spec.name:18s} {e.value:12.5g} {e.three_sigma:11.3g} {e.prior_sigma or float('nan'):14.3g} "
                     f"{z:6.1f}  {e.unit}")
    sig = result.state_sigma
    lines += ["", "median 3-sigma bands: position N/E/D "
              + " / ".join(f"{3 * np.median(sig[:, i]):.2f}" for i in range(3)) + " m, velocity "
              + " / ".join(f"{3 * np.median(sig[:, i]):.3f}" for i in range(3, 6)) + " m/s, attitude "
              + " / ".join(f"{np.degrees(3 * np.median(sig[:, i])):.2f}" for i in range(6, 9)) + " deg"]
    if flagged:
        lines.append(f"parameters beyond {PRIOR_Z_LIMIT:g} sigma of their prior: {', '.join(flagged)}: the IMU "
                     "model (or its stated noise) does not describe these data; the bands assume it does")
    if adequacy is not None:
        lines += ["", *report_lines(adequacy)]
    lines += ["", *result.notes]
    return "\n".join(lines)
