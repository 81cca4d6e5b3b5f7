"""Calibration of the weak-constraint (gust-state) fit: one seeded case of a multi-seed study.

A case flies ``problem`` (default ees-drop-3) through a fresh Gauss-Markov gust realisation that the
balloon did not see, with a parameter truth drawn from the fit's priors (as in the estimator Monte
Carlo), makes synthetic IMU and GPS data with the case's noise seed, and fits with gust states at
every node under the same Gauss-Markov prior. It returns, per gust axis, the error of the window
mean divided by its reported sigma (full node covariance) and the NEES of the gust error at nodes
``subsample_s`` apart, and the parameters' NEES and normalised errors. Across seeds the first should
be N(0, 1) and the NEES chi-square distributed if the reported uncertainties are right.

Measured (benchmarks/gust_calibration.py): they are not. The fit is a joint MAP over states, gusts
and parameters; a gain that multiplies the gusts (the normal-force and pitching-moment slope
multipliers ``CNY_mult``, ``Cmn_mult``) is then biased upward, because the joint objective lacks
the marginal likelihood's log-determinant of the gust block (see the README).
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from pathlib import Path

import numpy as np

from casrecon.analysis.estimator_mc import draw_truth, parameter_errors
from casrecon.estimation.engine.checks import FitError
from casrecon.estimation.engine.laplace import LatentSplit, log_det_curvature
from casrecon.estimation.sixdof.fit import FitResult, fit_drop, with_marginal_estimate
from casrecon.physics.disturbance import DisturbanceModel
from casrecon.scenario import Scenario
from casrecon.simulation.synthetic import truth_disturbance, truth_parameters_by_name, with_synthetic_data

#: Gauss-Markov gusts of the study: sigma 0.5, 0.5, 0.25 m/s (N, E, D), correlation time 3 s.
GUSTS = DisturbanceModel((0.5, 0.5, 0.25) + (0.0,) * 6, (3.0,) * 9)
#: Result columns of the three gust axes.
AXES = ("gust_n_mps", "gust_e_mps", "gust_d_mps")


@dataclasses.dataclass(frozen=True)
class GustCase:
    """One case of the study.

    Attributes
    ----------
    problem : Path
        Problem folder.
    seed : int
        Seeds the gust realisation, the parameter truth and the sensor noise.
    start_s : float
        Fit window start after release, s (the window runs to impact).
    gusts : DisturbanceModel
        Gust process of the truth and the fit's prior.
    truth_gusts : bool
        False: the truth flies in still air (gusts still estimated), a control case.
    subsample_s : float
        Spacing of the nodes at which the gust NEES is taken, s.
    interval_s : float or None
        The fit's collocation interval, s (None: the problem's ``[estimation] interval_s``, 25 ms by
        default). The truth's gusts vary between the fit's nodes; the fit models that part to first
        order (:mod:`casrecon.estimation.sixdof.subgrid`), and a finer mesh shrinks it.
    fit_noise_scale : tuple of 2 float
        The fit's accelerometer and gyro noise sigmas as multiples of the truth's (1, 1: the data's
        own): a diagnostic of which channel over-trusts what it sees of the gusts.
    """

    problem: Path
    seed: int
    start_s: float = 15.0
    gusts: DisturbanceModel = GUSTS
    truth_gusts: bool = True
    subsample_s: float = 1.0
    interval_s: float | None = None
    fit_noise_scale: tuple[float, float] = (1.0, 1.0)


def case_scenario(case: GustCase, folder: Path) -> Scenario:
    """The case's scenario: gust truth (unless a control case), gust estimation, a parameter truth
    drawn from the priors, synthetic data of ``case.seed`` written to ``folder``."""
    cfg = Scenario.load(case.problem).config
    cfg = dataclasses.replace(
        cfg, truth=dataclasses.replace(cfg.truth, disturbance=case.gusts if case.truth_gusts else None,
                                       seed=case.seed),
        estimation=dataclasses.replace(cfg.estimation, start_after_release_s=case.start_s,
                                       disturbance=case.gusts,
                                       interval_s=case.interval_s or cfg.estimation.interval_s))
    drawn = draw_truth(Scenario.from_config(cfg), np.random.default_rng([case.seed, 2]))
    return with_synthetic_data(drawn, folder, seed=case.seed)


def _axis_errors(r: FitResult, truth: np.ndarray, j: int, subsample_s: float) -> dict:
    """Window-mean z and subsampled NEES of gust axis ``j`` (DISTURBANCE_NAMES index) of ``r``."""
    part, cov = r.part, r.covariance
    jj = list(part.active).index(j)
    idx, scale = part.u_cols[:, jj], part.u_scale[jj]
    err = r.column(AXES[j])[0] - truth[:, j]
    sigma_mean = scale * np.sqrt(cov.variance_of_combination(idx, np.full(idx.size, 1.0 / idx.size)))
    sub = _subsampled_nodes(r, subsample_s)
    c_sub = cov.covariance_of(idx[sub], np.full(sub.size, scale))
    return {"z_mean": float(err.mean() / sigma_mean), "sigma_mean": float(sigma_mean),
            "nees": float(err[sub] @ np.linalg.solve(c_sub, err[sub])), "dof": int(sub.size),
            "rms_error": float(np.sqrt(np.mean(err**2))), "rms_truth": float(np.sqrt(np.mean(truth[:, j] ** 2)))}


def _subsampled_nodes(r: FitResult, subsample_s: float) -> np.ndarray:
    """Indices of the fit's nodes about ``subsample_s`` apart, from the first."""
    t = r.flight_time_s
    return np.unique(np.searchsorted(t, np.arange(t[0], t[-1], subsample_s)))


def _fit_case(case: GustCase) -> tuple[Scenario, FitResult]:
    """The case's scenario and its fit (the synthetic data live in a temporary folder)."""
    with tempfile.TemporaryDirectory() as tmp:
        sc = case_scenario(case, Path(tmp))
        return sc, fit_drop(with_fit_noise(sc, case.fit_noise_scale))


def with_fit_noise(sc: Scenario, scale: tuple[float, float]) -> Scenario:
    """``sc`` with its accelerometer and gyro noise sigmas times ``scale`` (the fit's, not the data's)."""
    if tuple(scale) == (1.0, 1.0):
        return sc
    imu = dataclasses.replace(sc.config.imu, accel_noise_mps2=sc.config.imu.accel_noise_mps2 * scale[0],
                              gyro_noise_radps=sc.config.imu.gyro_noise_radps * scale[1])
    return dataclasses.replace(sc, config=dataclasses.replace(sc.config, imu=imu))


def _case_figures(case: GustCase, sc: Scenario, r: FitResult, seconds: float) -> dict:
    """Status, reduced chi-square, per-axis gust figures and parameter errors of one fit."""
    truth_fn = truth_disturbance(sc, case.seed)
    truth = truth_fn(r.flight_time_s) if truth_fn else np.zeros((r.flight_time_s.size, 9))
    out = {"seed": case.seed, "converged": bool(r.converged), "status": r.solver.status,
           "reduced_chi2": float(r.reduced_chi2), "fit_s": seconds}
    out.update({AXES[j]: _axis_errors(r, truth, j, case.subsample_s) for j in range(3)})
    e, nees = parameter_errors(r, truth_parameters_by_name(sc))
    out["params"] = {"nees": nees, "dof": len(e),
                     "z": dict(zip(r.params.names, (e / r.sigma).tolist()))}
    return out


def run_gust_case(case: GustCase, marginal: bool = False) -> dict:
    """Fit one case; its status, reduced chi-square, per-axis gust figures and parameter errors.
    ``marginal``: also move that joint-MAP fit to the marginal-likelihood estimate
    (:func:`~casrecon.estimation.sixdof.fit.with_marginal_estimate`) and return the same figures of both,
    ``{"map": ..., "marginal": ...}`` (the marginal's ``fit_s`` is its extra time)."""
    t0 = time.perf_counter()
    sc, r = _fit_case(case)
    out = _case_figures(case, sc, r, time.perf_counter() - t0)
    if not marginal:
        return out
    t1 = time.perf_counter()
    try:
        m = _case_figures(case, sc, with_marginal_estimate(r), 0.0)
    except FitError as err:
        m = {"seed": case.seed, "converged": False, "status": str(err)}
    m["fit_s"] = time.perf_counter() - t1
    return {"map": out, "marginal": m}


def marginal_profile_case(case: GustCase, name: str = "Cmn_mult", n_points: int = 9) -> dict:
    """Fit one case and profile ``name`` jointly and under the Laplace marginal
    (:func:`casrecon.analysis.marginal.marginal_profile`) over a grid spanning the truth and the
    estimate plus 1.5 sigma either side; the truth, estimate, sigma and both minima (SI)."""
    from casrecon.analysis.marginal import marginal_profile

    sc, r = _fit_case(case)
    truth = truth_parameters_by_name(sc)[name]
    value, sigma = r.parameter(name)
    grid = np.linspace(min(truth, value) - 1.5 * sigma, max(truth, value) + 1.5 * sigma, n_points)
    prof = marginal_profile(r, name, grid)
    return {"seed": case.seed, "name": name, "truth": truth, "estimate": value, "sigma": sigma,
            "joint_minimum": prof.joint_minimum, "marginal_minimum": prof.marginal_minimum,
            "all_converged": bool(prof.converged.all())}


def curvature_case(case: GustCase) -> dict:
    """What the marginal estimator's missing log-determinant curvature does on one case: fit, move
    to the marginal estimate, and compare the parameter covariance P^-1 with (P + L)^-1
    (:func:`~casrecon.estimation.engine.laplace.log_det_curvature`): the eigenvalues of
    P^-1/2 L P^-1/2, each parameter's sigma ratio, and each gust axis's NEES at the subsampled
    nodes with the gust covariance's parameter part T P^-1 T^T replaced by T (P + L)^-1 T^T."""
    sc, r = _fit_case(case)
    m = with_marginal_estimate(r)
    cur = log_det_curvature(m.nlp, m.solver.z)
    p, ld = cur.profile_hessian, cur.log_det_hessian
    chol = np.linalg.cholesky(p)
    relative = np.linalg.solve(chol, np.linalg.solve(chol, ld).T)
    delta = np.linalg.inv(p + ld) - np.linalg.inv(p)
    ratio = np.sqrt(np.diag(np.linalg.inv(p + ld)) / np.diag(np.linalg.inv(p)))
    split = LatentSplit.of(m.nlp)
    truth = truth_disturbance(sc, case.seed)(m.flight_time_s)
    sub = _subsampled_nodes(m, case.subsample_s)
    nees = {}
    for j, axis in enumerate(AXES):
        jj = list(m.part.active).index(j)
        idx, scale = m.part.u_cols[sub, jj], m.part.u_scale[jj]
        err = m.column(axis)[0][sub] - truth[sub, j]
        c_sub = m.covariance.covariance_of(idx, np.full(idx.size, scale))
        t_sub = cur.tangent[np.searchsorted(split.latent, idx)] * scale
        nees[axis] = {"without": float(err @ np.linalg.solve(c_sub, err)),
                      "with": float(err @ np.linalg.solve(c_sub + t_sub @ delta @ t_sub.T, err)), "dof": int(sub.size)}
    return {"seed": case.seed, "eigenvalues": np.linalg.eigvalsh(0.5 * (relative + relative.T)).tolist(),
            "sigma_ratio": dict(zip([m.nlp.parameter_names[int(c)] for c in split.theta], ratio.tolist())),
            "gust_nees": nees}
