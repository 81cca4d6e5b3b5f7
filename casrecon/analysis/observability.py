"""Is a parameter (pitch damping above all) observable? Fisher information, its eigen-directions
in parameter names, profile likelihoods, and the predicted sigma of drops not yet flown.

All sigmas come from the same KKT-matrix covariance as the fits (Gauss-Newton, absolute).
"""

from __future__ import annotations

import dataclasses
import logging
import tempfile
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.estimation.engine.convergence import iteration_logging
from casrecon.estimation.engine.covariance import compute_covariance
from casrecon.estimation.engine.solve import SolveResult, solve
from casrecon.estimation.sixdof.continuation import clock_bounds
from casrecon.estimation.sixdof.drop import build_nlp, parameter_set
from casrecon.estimation.sixdof.fit import FitResult, prepare_drop
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import simulate_truth, truth_parameters_by_name, with_synthetic_data

LOG = logging.getLogger(__name__)


@dataclass(frozen=True)
class FisherDirection:
    """One eigen-direction of the parameter Fisher information (parameters in units of their
    ``scale``): ``sigma`` is the 1-sigma along the unit direction ``weights`` {name: weight}."""

    eigenvalue: float
    sigma: float
    weights: dict[str, float]

    def describe(self, top: int = 4) -> str:
        items = sorted(self.weights.items(), key=lambda kv: -abs(kv[1]))[:top]
        return f"sigma {self.sigma:.3g}: " + " ".join(f"{w:+.2f}*{n}" for n, w in items)


def fisher_directions(result: FitResult) -> list[FisherDirection]:
    """Eigen-decomposition of the parameters' Fisher information (the inverse of their marginal
    covariance, states marginalised), weakest direction first. Parameters are normalised by their
    scale (for dispersions the database 3-sigma/3) so the directions do not depend on units; each
    direction's sign makes its largest loading positive."""
    scale = result.params.scales
    cov = (result.correlation * np.outer(result.sigma, result.sigma)) / np.outer(scale, scale)
    info = np.linalg.inv(cov)
    eig, vec = np.linalg.eigh(0.5 * (info + info.T))
    vec = vec * np.sign(vec[np.argmax(np.abs(vec), axis=0), np.arange(vec.shape[1])])  # largest loading > 0
    return [FisherDirection(float(e), float(1 / np.sqrt(e)), dict(zip(result.params.names, map(float, v))))
            for e, v in zip(eig, vec.T)]


@dataclass(frozen=True)
class Profile:
    """Profile likelihood of one parameter: grid values, delta chi-square (refit with the parameter
    held), the interval where delta chi-square <= 9, and the Fisher 3-sigma for comparison."""

    name: str
    values: np.ndarray
    delta_chi2: np.ndarray
    estimate: float
    fisher_three_sigma: float
    interval: tuple[float, float]

    @property
    def half_width(self) -> float:
        return 0.5 * (self.interval[1] - self.interval[0])

    @property
    def agreement(self) -> float:
        """Profile half-width over the Fisher 3-sigma (1 when the problem is locally quadratic)."""
        return self.half_width / self.fisher_three_sigma


def _crossing(x: np.ndarray, y: np.ndarray, level: float) -> float:
    """x where y crosses ``level`` between the first two points that bracket it (linear)."""
    for i in range(len(x) - 1):
        if (y[i] - level) * (y[i + 1] - level) <= 0 and y[i] != y[i + 1]:
            return float(x[i] + (level - y[i]) * (x[i + 1] - x[i]) / (y[i + 1] - y[i]))
    return float("nan")


def refit_with_held(result: FitResult, name: str, value: float, max_iter: int = 100) -> SolveResult:
    """Re-solve ``result``'s NLP with parameter ``name`` held at ``value`` (SI), warm-started from
    the fit, clock-offset bounds as in the fit; its Ipopt iteration lines are logged at DEBUG
    (labelled ``profile NAME = VALUE``)."""
    nlp, z_best, part = result.nlp, result.z, result.part
    i = result.params.index(name)
    col, scale = part.theta_cols[i], result.params.scales[i]
    lbx, ubx = clock_bounds([part], nlp.n_z)
    lbx[col] = ubx[col] = value / scale
    z0 = z_best.copy()
    z0[col] = value / scale
    with iteration_logging(logging.DEBUG, f"profile {name} = {value:.6g}"):
        return solve(nlp, z0, max_iter=max_iter, bounds=(lbx, ubx))


def profile_likelihood(result: FitResult, name: str, n_points: int = 9, span_sigma: float = 4.0) -> Profile:
    """Refit with ``name`` held at each of ``n_points`` values across +-``span_sigma`` Fisher
    sigmas (warm-started from the fit); delta chi-square = 2 (objective - best objective). Logs one
    line per grid point (INFO); the refits' Ipopt iterations at DEBUG."""
    value, sigma = result.parameter(name)
    grid = value + sigma * np.linspace(-span_sigma, span_sigma, n_points)
    best = result.solver.objective
    delta = []
    for i, v in enumerate(grid, 1):
        sol = refit_with_held(result, name, v)
        delta.append(2 * (sol.objective - best) if sol.converged else np.nan)
        LOG.info("profile %s: point %d of %d, %s = %.6g: delta chi-square %s", name, i, len(grid), name, v,
                 f"{delta[-1]:.4g}" if sol.converged else f"not converged ({sol.status})")
    delta = np.maximum(np.array(delta), 0.0)
    mid = len(grid) // 2
    lo = _crossing(grid[:mid + 1][::-1], delta[:mid + 1][::-1], 9.0)
    hi = _crossing(grid[mid:], delta[mid:], 9.0)
    return Profile(name, grid, delta, value, 3 * sigma, (lo, hi))


def predicted_covariance(scenario: Scenario) -> tuple[tuple[str, ...], np.ndarray]:
    """Parameter covariance a fit of this (simulated) drop would report: the KKT covariance with the
    Gauss-Newton Hessian evaluated at the truth, without solving (design of experiments)."""
    with tempfile.TemporaryDirectory() as tmp:
        sc = with_synthetic_data(scenario, Path(tmp))
        data, mesh = prepare_drop(sc)
        params = parameter_set(sc.config)
        fit_nlp = build_nlp(sc.model, data, mesh, params, sc.config)
        traj, t_zero = simulate_truth(sc, 0)     # the truth of the data of with_synthetic_data's seed 0
        t = t_zero + traj.time_s
        idx = np.clip(np.searchsorted(t, mesh.t_nodes - 1e-6), 0, t.size - 1)
        truth = truth_parameters_by_name(sc)
        values = np.array([truth.get(n, 0.0) for n in params.names])
        z = fit_nlp.pack(traj.states[idx], values)
        cov = compute_covariance(fit_nlp.nlp, z, 1.0, 1)
        part = fit_nlp.parts[0]
        return params.names, cov.covariance_of(part.theta_cols, params.scales)


def multi_drop_sigma(names: tuple[str, ...], cov: np.ndarray, shared: tuple[str, ...], n_drops: int,
                     prior_sigma: dict[str, float]) -> dict[str, float]:
    """Sigma of the shared parameters from ``n_drops`` drops like this one in a joint fit: each
    drop's information on the shared parameters (its own parameters marginalised: a Schur
    complement) is summed, the shared priors counted once."""
    info = np.linalg.inv(cov)
    s = np.array([names.index(n) for n in shared], dtype=int)
    o = np.array([i for i in range(len(names)) if i not in s], dtype=int)
    marg = info[np.ix_(s, s)]
    if o.size:
        marg = marg - info[np.ix_(s, o)] @ np.linalg.solve(info[np.ix_(o, o)], info[np.ix_(o, s)])
    prior = np.diag([1 / prior_sigma[n] ** 2 if prior_sigma.get(n) else 0.0 for n in shared])
    joint = n_drops * (marg - prior) + prior
    return dict(zip(shared, np.sqrt(np.diag(np.linalg.inv(joint)))))


def with_release(scenario: Scenario, pitch_rate_dps: float | None = None, h_agl_m: float | None = None) -> Scenario:
    """The scenario released with another initial pitch rate (body y, deg/s) or altitude AGL (m)."""
    rel = scenario.config.release
    rates = rel.rates_dps if pitch_rate_dps is None else (rel.rates_dps[0], pitch_rate_dps, rel.rates_dps[2])
    rel = dataclasses.replace(rel, rates_dps=rates, h_agl_m=rel.h_agl_m if h_agl_m is None else h_agl_m)
    return Scenario.from_config(dataclasses.replace(scenario.config, release=rel))


def design_study(scenario: Scenario, parameter: str = "Cmq_mult", pitch_rates_dps=(0.0, 30.0, 60.0, 90.0),
                 altitudes_m=(800.0, 1600.0, 2400.0), n_drops=(1, 2, 4, 8)) -> dict:
    """Predicted 1-sigma of ``parameter`` against the initial pitch rate, the release altitude and
    the number of drops (each like the problem's, in one joint fit)."""
    out = {"parameter": parameter, "pitch_rate": [], "altitude": [], "n_drops": []}
    for q in pitch_rates_dps:
        names, cov = predicted_covariance(with_release(scenario, pitch_rate_dps=q))
        out["pitch_rate"].append((q, float(np.sqrt(cov[names.index(parameter), names.index(parameter)]))))
    for h in altitudes_m:
        names, cov = predicted_covariance(with_release(scenario, h_agl_m=h))
        out["altitude"].append((h, float(np.sqrt(cov[names.index(parameter), names.index(parameter)]))))
    names, cov = predicted_covariance(scenario)
    specs = parameter_set(scenario.config).specs
    shared = tuple(s.name for s in specs if s.group == "aero")
    priors = {s.name: s.prior_sigma for s in specs}
    for n in n_drops:
        out["n_drops"].append((n, float(multi_drop_sigma(names, cov, shared, n, priors)[parameter])))
    return out
