"""Estimator Monte Carlo: simulate, fit, and check the reported covariance is honest.

Each case draws a truth from the fit's own prior (the aero dispersions, wind bias and density
factor from their priors, sensor biases from their specification sigmas, the clock offset from its
prior), makes synthetic data with a fresh noise seed, fits, and computes the normalised estimation
error squared NEES = e^T C^-1 e (e = estimate - truth over the estimated parameters, C the reported
absolute covariance). For a consistent estimator NEES ~ chi2(n_params) in each case, so the sum
over N cases ~ chi2(N n_params): the test is that the sum lies in its two-sided 95 % interval.
Drawing the truth from the prior is what makes the Bayesian (MAP) estimator's covariance exactly
testable: with a fixed truth the prior's pull would show as a bias.

Cases run on local processes (spawn) or, given a Dask scheduler address, on that cluster; every
case is reproducible from (seed, case index). Each finished case is logged (INFO, logger
``casrecon.analysis.estimator_mc``): its index, how many are done, converged or not, chi-square and
seconds; the fits inside a case log their Ipopt iterations at DEBUG only.
"""

from __future__ import annotations

import dataclasses
import logging
import tempfile
import time
from dataclasses import dataclass
from functools import partial
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from casrecon.estimation.engine.convergence import iteration_logging
from casrecon.estimation.sixdof.drop import parameter_set
from casrecon.parallel import parallel_map
from casrecon.scenario import Scenario

LOG = logging.getLogger(__name__)


def draw_truth(scenario: Scenario, rng: np.random.Generator) -> Scenario:
    """The scenario with a truth drawn from the fit's own priors: every estimated aero dispersion,
    the wind bias (m/s, N and E), the density factor, the accelerometer and gyro biases (IMU axes,
    SI) and the clock offset (s); everything else in ``[truth]`` (e.g. gusts) is kept."""
    cfg = scenario.config
    params = parameter_set(cfg)
    truth = cfg.truth
    disp = dict(truth.dispersions)
    values = {s.name: rng.normal(0.0, s.prior_sigma or s.scale) for s in params.specs}
    for name in disp:
        if name in values:
            disp[name] = values[name]
    new = dataclasses.replace(
        truth, dispersions=disp, wind_bias_mps=(values["wind_bias_n"], values["wind_bias_e"]),
        density_factor=values["density_factor"],
        accel_bias_mps2=tuple(values[f"accel_bias_{a}"] for a in "xyz"),
        gyro_bias_radps=tuple(values[f"gyro_bias_{a}"] for a in "xyz"),
        clock_offset_s=values.get("clock_offset_s", 0.0))
    return Scenario.from_config(dataclasses.replace(cfg, truth=new))


def chi2_interval(dof: int, quantiles: tuple[float, float] = (0.025, 0.975)) -> tuple[float, float]:
    """Chi-square quantiles with ``dof`` degrees of freedom (default the two-sided 95 % interval;
    NaNs for 0 dof)."""
    if not dof:
        return float("nan"), float("nan")
    return float(chi2.ppf(quantiles[0], dof)), float(chi2.ppf(quantiles[1], dof))


def parameter_errors(result, truth: dict[str, float]) -> tuple[np.ndarray, float]:
    """(estimate - truth over the estimated parameters (SI), NEES e^T C^-1 e with C the reported
    absolute parameter covariance) of a :class:`~casrecon.estimation.sixdof.fit.FitResult`."""
    e = np.array([result.values[i] - truth[n] for i, n in enumerate(result.params.names)])
    cov = result.correlation * np.outer(result.sigma, result.sigma)
    return e, float(e @ np.linalg.solve(cov, e))


def run_case(problem: str, seed: int, index: int, method: str | None = None, information: str | None = None) -> dict:
    """Draw a truth, simulate, fit; returns the errors, sigmas and NEES of case ``index``, its
    chi-square and its wall time ``case_s`` (s). ``method`` ("map" or "marginal") and
    ``information`` ("observed" or "expected") override the problem's ``[estimation]``. The
    fit's iteration lines are logged at DEBUG."""
    from casrecon.estimation.sixdof.fit import FitError, fit_drop
    from casrecon.simulation.synthetic import truth_parameters_by_name, with_synthetic_data

    t0 = time.perf_counter()
    rng = np.random.default_rng([seed, index])
    scenario = draw_truth(Scenario.load(problem), rng)
    with tempfile.TemporaryDirectory() as tmp, iteration_logging(logging.DEBUG, f"case {index}"):
        sc = with_synthetic_data(scenario, Path(tmp), seed=int(rng.integers(2**31)))
        try:
            r = fit_drop(sc, method=method, information=information)
        except FitError as err:
            return {"index": index, "failed": str(err), "case_s": time.perf_counter() - t0}
        truth = truth_parameters_by_name(sc)
    e, nees = parameter_errors(r, truth)
    return {"index": index, "names": list(r.params.names), "error": e.tolist(), "sigma": r.sigma.tolist(),
            "nees": nees, "chi2": float(sum(r.chi2.values())), "reduced_chi2": r.reduced_chi2,
            "status": r.solver.status, "iterations": r.solver.iterations, "solver": r.solver.method,
            "solve_s": r.solver.solve_s, "case_s": time.perf_counter() - t0}


class CaseLog:
    """``on_done`` of the estimator Monte Carlo: one line per finished case, at ``level``."""

    def __init__(self, n_cases: int, level: int = logging.INFO) -> None:
        self.n_cases, self.level, self.done = n_cases, level, 0

    def __call__(self, index: int, case: dict) -> None:
        self.done += 1
        head = f"estimator montecarlo: case {index} ({self.done} of {self.n_cases} done):"
        if "failed" in case:
            LOG.log(self.level, "%s fit failed (%s), %.1f s", head, case["failed"], case["case_s"])
        else:
            LOG.log(self.level, "%s converged, chi-square %.6g (reduced %.4f), NEES %.2f, %d iterations, %.1f s",
                    head, case["chi2"], case["reduced_chi2"], case["nees"], case["iterations"], case["case_s"])


@dataclass(frozen=True)
class ConsistencyResult:
    """NEES of every case and the chi-square consistency test at 95 %."""

    cases: list[dict]
    n_params: int
    nees_sum: float
    interval: tuple[float, float]

    @property
    def consistent(self) -> bool:
        return self.interval[0] <= self.nees_sum <= self.interval[1]

    @property
    def failed(self) -> list[dict]:
        return [c for c in self.cases if "failed" in c]


def estimator_montecarlo(problem: Path, n_cases: int, seed: int = 0, workers: int = 2,
                         scheduler: str | None = None, progress: bool = False,
                         method: str | None = None, information: str | None = None) -> ConsistencyResult:
    """Run ``n_cases`` simulate-and-fit cases and test the NEES sum against chi2 at 95 %.

    Local spawn processes (``workers``) or, given a Dask scheduler address, that cluster; case i
    is reproducible from (seed, i) alone. Each finished case is logged, at INFO with ``progress``
    (else at DEBUG). ``method`` and ``information`` override the problem's ``[estimation]``.
    """
    cases = parallel_map(partial(run_case, str(Path(problem).resolve()), seed, method=method, information=information),
                         range(n_cases),
                         workers=workers,
                         scheduler=scheduler, on_done=CaseLog(n_cases, logging.INFO if progress else logging.DEBUG))
    ok = [c for c in cases if "nees" in c]
    n_params = len(ok[0]["names"]) if ok else 0
    dof = n_params * len(ok)
    total = float(sum(c["nees"] for c in ok))
    return ConsistencyResult(cases, n_params, total, chi2_interval(dof))
