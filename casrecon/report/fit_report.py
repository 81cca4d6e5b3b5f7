"""Console fit report in the spirit of lmfit's: values with sigma, flagged correlations, and why
an error bar is missing."""

from __future__ import annotations

from casrecon.analysis.adequacy import Adequacy
from casrecon.analysis.fit_products import result_adequacy
from casrecon.analysis.parameter_estimates import parameter_estimates
from casrecon.estimation.engine.information import information_text
from casrecon.physics.aero import DISPERSION_NAMES
from casrecon.report.adequacy_block import report_lines

#: Correlations above this magnitude are flagged.
CORRELATION_FLAG = 0.9
#: A posterior sigma above this fraction of the prior sigma is reported as prior-dominated.
PRIOR_DOMINATED = 0.9


def _parameter_lines(result) -> list[str]:
    lines = []
    for e in parameter_estimates(result):  # gyro biases in deg/s, as in parameters.json
        note = ""
        if e.prior_sigma and e.sigma > PRIOR_DOMINATED * e.prior_sigma:
            note = "  <- set mostly by its prior (the data add little)"
        lines.append(f"    {e.name:16s} = {e.value: .6g} +/- {e.three_sigma:.3g} (3-sigma; chi2-scaled "
                     f"{3 * e.sigma_chi2_scaled:.3g}) [{e.unit}]{note}")
    fixed = [n for n in DISPERSION_NAMES if n not in result.params.names]
    for name in fixed:
        lines.append(f"    {name:16s} = 0 (fixed: not estimated, its database size U is 0 or "
                     f"[estimation] estimate leaves it out; no error bar)")
    return lines


def _correlation_lines(result) -> list[str]:
    names, c = result.params.names, result.correlation
    pairs = [(abs(c[i, j]), names[i], names[j], c[i, j]) for i in range(len(names)) for j in range(i)]
    pairs.sort(reverse=True)
    lines = [f"    C({a}, {b}) = {r:+.3f}{'  <- |r| > 0.9' if m > CORRELATION_FLAG else ''}"
             for m, a, b, r in pairs[:10] if m > 0.5]
    return lines or ["    none above 0.5"]


def estimator_text(sol) -> str:
    """One line on the estimator a solve result came from (joint MAP, or marginal likelihood with
    how far it moved the parameters)."""
    run = sol.marginal
    if run is None:
        return "joint maximum a posteriori over states, disturbances and parameters"
    return (f"Laplace marginal likelihood of the parameters (latent unknowns integrated out): {run.outer_iterations} "
            f"Newton steps from the joint MAP, which it moved by {run.shift_sigma:.2f} sigma; 1/2 log det of the "
            f"latent Hessian {run.half_log_det:.2f}; parameter sigmas from the profile's Gauss-Newton Hessian")


def fit_report(result, adequacy: Adequacy | None = None) -> str:
    """Multi-line text report of a :class:`~casrecon.estimation.sixdof.fit.FitResult`, ending with its
    model-adequacy verdict (``adequacy``, computed from the fit's residuals when not given)."""
    cfg, sol, d = result.scenario.config, result.solver, result.data
    chi2 = sum(result.chi2.values())
    t = result.timings
    lines = [f"[[Fit: {cfg.name}]]",
             f"    {sol.status} in {sol.iterations} iterations ({sol.method}); Hessian {sol.hessian}, linear solver "
             f"{sol.linear_solver}; covariance from the KKT matrix with the "
             f"{information_text(result.covariance.information)}",
             f"    estimator: {estimator_text(sol)}",
             f"    window {d.window[0]:.3f} to {d.window[1]:.3f} s IMU clock "
             f"({d.window[0] - d.release_imu_s:.2f} s after release to "
             f"{d.impact_imu_s - d.window[1]:.2f} s before impact); {result.node_time_s.size} nodes every "
             f"{1000 * result.part.mesh.h:.3g} ms",
             f"    chi-square {chi2:.1f}, dof {result.dof}, reduced chi-square {result.reduced_chi2:.4f}",
             "    per group: " + ", ".join(f"{g} {v:.1f}/{result.n_measurements[g]}" for g, v in result.chi2.items()),
             f"    timings: build {t['build_s']:.2f} s, solve {t['solve_s']:.2f} s, covariance "
             f"{t['covariance_s']:.2f} s, total {t['total_s']:.2f} s",
             "[[Parameters]]", *_parameter_lines(result),
             "[[Correlations]] (largest, |r| > 0.5)", *_correlation_lines(result)]
    if result.notes:
        lines += ["[[Data notes]]", *[f"    {n}" for n in result.notes]]
    lines += report_lines(adequacy if adequacy is not None else result_adequacy(result))
    return "\n".join(lines)
