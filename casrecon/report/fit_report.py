"""The 6-DOF fit's own sections of its report (:mod:`casrecon.report.report_style`: the statistics,
variables and correlations come before them): the solver and its window, chi-square per group and
timings, the data notes and the model-adequacy verdict."""

from __future__ import annotations

from casrecon.analysis.adequacy import Adequacy
from casrecon.analysis.fit_products import result_adequacy
from casrecon.estimation.engine.information import information_text
from casrecon.report.adequacy_block import report_lines
from casrecon.report.report_style import section

#: Why a 6-DOF fit holds an aero dispersion factor fixed (at 0, the nominal database).
FIXED_DISPERSION_NOTE = ("not estimated, its database size U is 0 or [estimation] estimate leaves it out; "
                         "no error bar")


def estimator_text(sol) -> str:
    """One line on the estimator a solve result came from (joint MAP, or marginal likelihood with
    how far it moved the parameters)."""
    run = sol.marginal
    if run is None:
        return "joint maximum a posteriori over states, disturbances and parameters"
    return (f"Laplace marginal likelihood of the parameters (latent unknowns integrated out): {run.outer_iterations} "
            f"Newton steps from the joint MAP, which it moved by {run.shift_sigma:.2f} sigma; 1/2 log det of the "
            f"latent Hessian {run.half_log_det:.2f}; parameter sigmas from the profile's Gauss-Newton Hessian")


def sixdof_sections(result, adequacy: Adequacy | None = None) -> str:
    """The 6-DOF fit's own sections of its report: ``[[Solver]]`` (status, iterations, Hessian and
    covariance, estimator, window and nodes, chi-square, dof and reduced chi-square, chi-square per
    group, timings in s) of a :class:`~casrecon.estimation.sixdof.fit.FitResult`, ``[[Data notes]]``,
    and its model-adequacy verdict last (``adequacy``, computed from the fit's residuals when not
    given). The head comes from the result object
    (:meth:`~casrecon.results.fit_statistics.FitStatistics.report_head`)."""
    sol, d = result.solver, result.data
    chi2 = sum(result.chi2.values())
    t = result.timings
    information = information_text(result.covariance.information)
    lines = section("Solver", [
        f"{sol.status} in {sol.iterations} iterations ({sol.method}); Hessian {sol.hessian}, linear solver "
        f"{sol.linear_solver}; covariance from the KKT matrix with the {information}",
        f"estimator: {estimator_text(sol)}",
        f"window {d.window[0]:.3f} to {d.window[1]:.3f} s IMU clock ({d.window[0] - d.release_imu_s:.2f} s after "
        f"release to {d.impact_imu_s - d.window[1]:.2f} s before impact); {result.node_time_s.size} nodes every "
        f"{1000 * result.part.mesh.h:.3g} ms",
        f"chi-square {chi2:.1f}, dof {result.dof}, reduced chi-square {result.reduced_chi2:.4f}",
        "per group: " + ", ".join(f"{g} {v:.1f}/{result.n_measurements[g]}" for g, v in result.chi2.items()),
        f"timings: build {t['build_s']:.2f} s, solve {t['solve_s']:.2f} s, covariance {t['covariance_s']:.2f} s, "
        f"total {t['total_s']:.2f} s"])
    if result.notes:
        lines += section("Data notes", result.notes)
    lines += report_lines(adequacy if adequacy is not None else result_adequacy(result))
    return "\n".join(lines)
