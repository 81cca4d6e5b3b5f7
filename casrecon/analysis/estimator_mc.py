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
case is reproducible from (seed, case index).
"""

from __future__ import annotations

import dataclasses
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.stats import chi2

from casrecon.estimation.parameters import parameter_set
from casrecon.scenario import Scenario


def _draw_truth(scenario: Scenario, rng: np.random.Generator) -> Scenario:
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


def run_case(problem: str, seed: int, index: int) -> dict:
    """Draw a truth, simulate, fit; returns the errors, sigmas and NEES of case ``index``."""
    from casrecon.analysis.observability import _with_data
    from casrecon.analysis.synthetic import truth_parameters_by_name
    from casrecon.estimation.fit import FitError, fit_drop

    rng = np.random.default_rng([seed, index])
    scenario = _draw_truth(Scenario.load(problem), rng)
    with tempfile.TemporaryDirectory() as tmp:
        sc = _with_data(scenario, Path(tmp), seed=int(rng.integers(2**31)))
        try:
            r = fit_drop(sc)
        except FitError as err:
            return {"index": index, "failed": str(err)}
        truth = truth_parameters_by_name(sc)
    e = np.array([r.values[i] - truth[n] for i, n in enumerate(r.params.names)])
    cov = r.correlation * np.outer(r.sigma, r.sigma)
    nees = float(e @ np.linalg.solve(cov, e))
    return {"index": index, "names": list(r.params.names), "error": e.tolist(), "sigma": r.sigma.tolist(),
            "nees": nees, "reduced_chi2": r.reduced_chi2}


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
                         scheduler: str | None = None) -> ConsistencyResult:
    """Run ``n_cases`` simulate-and-fit cases and test the NEES sum against chi2 at 95 %."""
    args = [(str(problem), seed, i) for i in range(n_cases)]
    if scheduler:
        try:
            from distributed import Client
        except ImportError as err:
            raise RuntimeError("the Dask scheduler needs dask[distributed] (pip install casrecon[dask])") from err
        with Client(scheduler) as client:
            cases = client.gather(client.map(run_case, *zip(*args), pure=False))
    elif workers > 1:
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        with ProcessPoolExecutor(workers, mp_context=multiprocessing.get_context("spawn")) as pool:
            cases = list(pool.map(run_case, *zip(*args)))
    else:
        cases = [run_case(*a) for a in args]
    ok = [c for c in cases if "nees" in c]
    n_params = len(ok[0]["names"]) if ok else 0
    dof = n_params * len(ok)
    total = float(sum(c["nees"] for c in ok))
    return ConsistencyResult(cases, n_params, total, (float(chi2.ppf(0.025, dof)), float(chi2.ppf(0.975, dof))))
