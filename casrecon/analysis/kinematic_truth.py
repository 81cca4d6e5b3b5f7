"""A kinematic reconstruction against a known truth: the centre-of-mass position and velocity,
body attitude and IMU parameters the fit reports, their errors against a simulated flight, and
the share of node values whose truth lies inside the reported 3-sigma band (the truth test of
docs/design.md: Kinematic reconstruction).
"""

from __future__ import annotations

import dataclasses
import tempfile
import time
from functools import partial
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from casrecon.physics.vehicle import Vehicle

#: Groups of compared quantities and their columns in :func:`node_errors`.
GROUPS = {"position": slice(0, 3), "velocity": slice(3, 6), "attitude": slice(6, 9)}


def _rotations(q_scalar_first: np.ndarray) -> Rotation:
    q = np.asarray(q_scalar_first, float)
    return Rotation.from_quat(np.column_stack([q[:, 1:], q[:, 0]]))


def body_states(result, vehicle: Vehicle) -> tuple[np.ndarray, Rotation]:
    """Centre-of-mass position and velocity (K, 6; m, m/s, NED) and body-to-NED attitude at the
    nodes, from the IMU's states, the IMU mount and the measured rates (bias-corrected)."""
    r_ib = np.asarray(vehicle.imu_to_body, float)
    c_ni = _rotations(result.states[:, 6:10])
    c_nb = c_ni * Rotation.from_matrix(r_ib.T)
    lever = np.asarray(vehicle.lever(vehicle.imu_position_m), float)
    data = result.data
    gyro = np.column_stack([np.interp(result.node_time_s, data.imu_time_s, data.gyro_radps[:, i]) for i in range(3)])
    names = list(result.params.names)
    bias = np.array([result.values[names.index(f"gyro_bias_{a}")] if f"gyro_bias_{a}" in names else 0.0
                     for a in "xyz"])
    omega_body = (gyro - bias) @ r_ib.T
    pos = result.states[:, 0:3] - c_nb.apply(np.tile(lever, (len(c_nb), 1)))
    vel = result.states[:, 3:6] - c_nb.apply(np.cross(omega_body, lever))
    return np.column_stack([pos, vel]), c_nb


def node_errors(result, vehicle: Vehicle, trajectory, release_imu_s: float) -> tuple[np.ndarray, np.ndarray]:
    """(errors, sigmas), each (K, 9): position (m), velocity (m/s) and attitude (NED rotation
    vector from the truth to the estimate, rad) at the nodes, with the reported 1-sigma. The lever
    arm's effect on the bands is neglected (the IMU's position and velocity sigmas are used)."""
    t = result.node_time_s - release_imu_s
    truth = np.column_stack([np.interp(t, trajectory.time_s, trajectory.states[:, i]) for i in range(10)])
    est, c_nb = body_states(result, vehicle)
    q_true = truth[:, 6:10] / np.linalg.norm(truth[:, 6:10], axis=1, keepdims=True)
    att = (c_nb * _rotations(q_true).inv()).as_rotvec()
    err = np.column_stack([est - truth[:, :6], att])
    return err, result.state_sigma


def coverage(errors: np.ndarray, sigmas: np.ndarray, k: float = 3.0) -> dict[str, tuple[int, int]]:
    """Per group of :data:`GROUPS`: (values inside k sigma, values)."""
    out = {}
    for name, cols in GROUPS.items():
        e, s = errors[:, cols], sigmas[:, cols]
        ok = np.isfinite(e) & np.isfinite(s)
        out[name] = (int(np.sum(np.abs(e[ok]) <= k * s[ok])), int(ok.sum()))
    return out


def truth_aero(scenario, trajectory, truth: dict[str, float], flight_time_s: np.ndarray) -> dict[str, np.ndarray]:
    """The coefficients (:data:`~casrecon.analysis.aero_columns.COEFFICIENTS`, database totals about the
    MRP), alpha_T (deg) and qbar (Pa) that acted on the simulated flight at ``flight_time_s`` (s
    after release), with the true dispersions and atmosphere corrections ``truth`` (by name)."""
    from casrecon.analysis import aero_columns as cols
    from casrecon.analysis.aero_coefficients import coefficient_functions
    from casrecon.physics.dynamics import OUTPUT_NAMES, PARAMETER_NAMES

    x = np.column_stack([np.interp(flight_time_s, trajectory.time_s, trajectory.states[:, i]) for i in range(13)]).T
    p = np.array([truth.get(n, 0.0) for n in PARAMETER_NAMES])
    p = np.repeat(p[:, None], x.shape[1], axis=1)
    database, _ = coefficient_functions(scenario.model)
    c = np.asarray(database.map(x.shape[1])(x, p, np.zeros((9, x.shape[1])))).T
    y = np.asarray(scenario.model.outputs.map(x.shape[1])(x, p)).T
    out = {cols.ALPHA_T: np.degrees(y[:, OUTPUT_NAMES.index("alpha_t")]), cols.QBAR: y[:, OUTPUT_NAMES.index("qbar")]}
    out.update({name: c[:, i] for i, name in enumerate(cols.COEFFICIENTS)})
    return out


def aero_coverage(implied: dict[str, np.ndarray], truth: dict[str, np.ndarray], k: float = 3.0) -> dict:
    """Per coefficient, alpha_T and qbar: (nodes whose truth lies inside the implied value's k/3 of
    its 3-sigma band, nodes with a value), from :func:`~casrecon.analysis.implied_aero.implied_aero`'s
    table and :func:`truth_aero`."""
    from casrecon.analysis import aero_columns as cols
    from casrecon.analysis.implied_aero import ALPHA_T_3SIGMA, IMPLIED, QBAR_3SIGMA

    pairs = {c: (cols.column(c, IMPLIED), cols.sigma_column(c, IMPLIED)) for c in cols.COEFFICIENTS}
    pairs.update({cols.ALPHA_T: (cols.ALPHA_T, ALPHA_T_3SIGMA), cols.QBAR: (cols.QBAR, QBAR_3SIGMA)})
    out = {}
    for name, (value, three) in pairs.items():
        e, band = implied[value] - truth[name], implied[three] * k / 3.0
        ok = np.isfinite(e) & np.isfinite(band)
        out[name] = (int(np.sum(np.abs(e[ok]) <= band[ok])), int(ok.sum()))
    return out


def decimated(data, step: int):
    """The IMU record of ``data`` (KinematicData) keeping every ``step``-th sample (a lower IMU rate
    with the same per-sample noise)."""
    if step <= 1:
        return data
    sl = slice(None, None, step)
    return dataclasses.replace(data, imu_time_s=data.imu_time_s[sl], gyro_radps=data.gyro_radps[sl],
                               accel_mps2=data.accel_mps2[sl], gyro_valid=data.gyro_valid[sl],
                               accel_valid=data.accel_valid[sl])


def truth_case(problem: str, seed: int, index: int, steps: tuple[int, ...] = (1,)) -> dict:
    """Case ``index``: a truth drawn from the fit's priors (IMU biases, clock offset, aero and
    atmosphere of the 6-DOF problem), synthetic data, and a kinematic fit of the IMU record
    decimated by each of ``steps``: per step the coverage counts of :func:`coverage` and of the
    implied aerodynamics (:func:`aero_coverage`), whether the adequacy verdict trusts the bands,
    the NEES of the estimated parameters that have a truth, and the seconds taken."""
    from casrecon.analysis.estimator_mc import draw_truth
    from casrecon.analysis.fit_adequacy import kinematic_adequacy
    from casrecon.analysis.implied_aero import AirPrior, implied_aero
    from casrecon.estimation.engine.checks import FitError
    from casrecon.estimation.kinematic.fit import fit_kinematic
    from casrecon.estimation.kinematic.inputs import data_from_problem, options_from_problem
    from casrecon.scenario import Scenario
    from casrecon.simulation.synthetic import synthetic_scenario, truth_parameters_by_name

    rng = np.random.default_rng([seed, index])
    scenario = draw_truth(Scenario.load(problem), rng)
    out = {"index": index}
    with tempfile.TemporaryDirectory() as tmp:
        sc, syn = synthetic_scenario(scenario, Path(tmp), seed=int(rng.integers(2**31)))
        cfg = sc.config
        full = data_from_problem(cfg)
        truth = truth_parameters_by_name(sc)
        release = float(syn.truth["release_imu_time_s"])
        for step in steps:
            t0 = time.perf_counter()
            data = decimated(full, step)
            try:
                res = fit_kinematic(data, options_from_problem(cfg))
            except FitError as err:
                out[step] = {"failed": str(err)}
                continue
            err_nodes, sig = node_errors(res, cfg.vehicle, syn.trajectory, release)
            prior = AirPrior(cfg.atmosphere.wind_3sigma_mps / 3.0, cfg.atmosphere.density_3sigma / 3.0)
            implied = implied_aero(res, cfg.vehicle, sc.atmosphere, prior)
            aero = aero_coverage(implied, truth_aero(sc, syn.trajectory, truth, res.node_time_s - release))
            names = [n for n in res.params.names if n in truth]
            idx = [res.params.index(n) for n in names]
            e = np.array([res.values[i] - truth[n] for i, n in zip(idx, names)])
            cols = np.array(sorted(res.nlp.parameter_names))[idx]
            c = res.covariance.covariance_of(cols, res.params.scales[idx])
            out[step] = {"rate_hz": float(1.0 / np.median(np.diff(data.imu_time_s))),
                         "coverage": coverage(err_nodes, sig), "aero_coverage": aero,
                         "trusted": kinematic_adequacy(res).trusted, "names": names,
                         "z": (e / np.sqrt(np.diag(c))).tolist(),
                         "nees": float(e @ np.linalg.solve(c, e)), "seconds": time.perf_counter() - t0,
                         "reduced_chi2": res.reduced_chi2}
    return out


def kinematic_truth_study(problem: str, n_cases: int, steps: tuple[int, ...], seed: int = 0,
                          workers: int = 2) -> dict:
    """Run ``n_cases`` cases of :func:`truth_case` and pool them per IMU decimation step: coverage
    per group, NEES sum against its 95 % interval, mean z per parameter, failures, seconds."""
    from casrecon.analysis.estimator_mc import chi2_interval
    from casrecon.parallel import parallel_map

    cases = parallel_map(partial(truth_case, str(Path(problem).resolve()), seed, steps=steps), range(n_cases),
                         workers=workers, progress="kinematic truth study")
    out = {}
    for step in steps:
        fits = [c[step] for c in cases if "coverage" in c[step]]
        pooled = {g: (sum(f["coverage"][g][0] for f in fits), sum(f["coverage"][g][1] for f in fits)) for g in GROUPS}
        dof = sum(len(f["names"]) for f in fits)
        aero = {c: (sum(f["aero_coverage"][c][0] for f in fits), sum(f["aero_coverage"][c][1] for f in fits))
                for c in (fits[0]["aero_coverage"] if fits else {})}
        out[step] = {"rate_hz": fits[0]["rate_hz"] if fits else float("nan"), "fits": len(fits),
                     "failed": [c[step]["failed"] for c in cases if "failed" in c[step]],
                     "coverage": {g: a / b if b else float("nan") for g, (a, b) in pooled.items()},
                     "aero_coverage": {c: a / b if b else float("nan") for c, (a, b) in aero.items()},
                     "nees": float(sum(f["nees"] for f in fits)), "nees_interval": chi2_interval(dof),
                     "trusted": sum(bool(f["trusted"]) for f in fits),
                     "names": fits[0]["names"] if fits else [],
                     "mean_z": np.mean([f["z"] for f in fits], axis=0).tolist() if fits else [],
                     "seconds": [f["seconds"] for f in fits]}
    return out
