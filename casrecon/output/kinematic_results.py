"""The results folder of a kinematic (IMU-driven) reconstruction.

Files: ``trajectory.csv`` (``time_unix_s`` and ``utc`` when the clock is UTC, else the clock as
``time_imu_s``; ``segment_time_s`` since the span's start; the IMU's latitude, longitude and h_MSL,
NED position and velocity, roll, pitch and yaw of the IMU axes, each with its 3-sigma; the
attitude's 3-sigma as the NED rotation-vector components ``att_n/e/d_deg_3sigma``),
``parameters.json`` (IMU errors, clock offset, barometer bias and scale: value, 1- and 3-sigma,
chi-square-scaled sigma, prior, unit; gyro biases in deg/s and misalignments in deg as in every
problem kind), ``summary.json`` (convergence, chi-square per residual group and per measurement,
timings, notes), ``residuals_imu.csv`` (the whitened preintegration residual of every interval, at
its start's ``time_unix_s`` (or ``time_imu_s``) and ``segment_time_s``: rotation, velocity,
position), ``residuals_gps.csv`` (fix residuals over their sigma, at the fix's ``time_unix_s`` (or
``time_imu_s``) and ``segment_time_s``, as the other kinds' residual files), ``report.txt``,
``config/problem.toml``. Units in every name (:mod:`casrecon.io.units`).
"""

from __future__ import annotations

import shutil
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from casrecon.analysis.parameter_estimates import parameter_estimate
from casrecon.estimation.kinematic.terms import INTERVAL_RESIDUALS
from casrecon.io.units import IMU_TIME, SEGMENT_TIME, TIME_UNIX, UTC, utc_text
from casrecon.output.columns import geodetic_columns, write_table
from casrecon.output.results import write_json

#: Clock values above this are UTC seconds since 1970 (a flight computer's clock counts from boot).
UTC_CLOCK_MIN_S = 1e8
STATE_COLUMNS = ("pos_n_m", "pos_e_m", "pos_d_m", "vel_n_mps", "vel_e_mps", "vel_d_mps")


def euler_deg(quaternions: np.ndarray) -> np.ndarray:
    """Roll, pitch, yaw (ZYX, deg) of scalar-first quaternions (K, 4)."""
    q = np.asarray(quaternions, float)
    return Rotation.from_quat(np.column_stack([q[:, 1:], q[:, 0]])).as_euler("ZYX", degrees=True)[:, ::-1]


def time_columns(result, times_s: np.ndarray | None = None, utc: bool = True) -> dict[str, np.ndarray]:
    """Times (:mod:`casrecon.io.units`' time bases) of the nodes, or of ``times_s`` (s on the fit's
    time axis, :attr:`~casrecon.estimation.kinematic.fit.KinematicResult.node_time_s`'s):
    ``time_unix_s`` (and ``utc`` if ``utc``) when the problem's clock is UTC, else that clock as
    ``time_imu_s`` (a flight computer's); then ``segment_time_s``, s since the span's first node (an
    IMU-driven span has no release, so no ``flight_time_s``)."""
    t = result.node_time_s if times_s is None else np.asarray(times_s, dtype=float)
    clock = t + result.data.time_ref_s
    segment = t - result.node_time_s[0]
    if result.data.time_ref_s > UTC_CLOCK_MIN_S:
        return {TIME_UNIX: clock, **({UTC: utc_text(clock)} if utc else {}), SEGMENT_TIME: segment}
    return {IMU_TIME: clock, SEGMENT_TIME: segment}


def fix_times(result) -> np.ndarray:
    """Times (s, the fit's time axis) of the fixes the fit used, in the order of its GPS residuals:
    those inside the span, each where the last placement put it (its stamp shifted by the clock
    offset the fixes were placed with)."""
    t, nodes = result.data.fix_time_s, result.node_time_s
    return t[(t >= nodes[0] - 1e-9) & (t <= nodes[-1] + 1e-9)]


def parameters_document(result) -> dict:
    """``parameters.json``: each IMU error, clock and barometer parameter in its output unit
    (:func:`~casrecon.analysis.parameter_estimates.parameter_estimate`: gyro biases in deg/s,
    misalignments in deg, as in every problem kind), with 1- and 3-sigma, the chi-square-scaled
    sigma and the prior; the correlations when the covariance was computed."""
    scale = float(np.sqrt(result.reduced_chi2))
    params = {s.name: parameter_estimate(s, v, sg, scale).record()
              for s, v, sg in zip(result.params.specs, result.values, result.sigma)}
    doc = {"parameters": params}
    if result.parameter_covariance is not None:
        sd = np.sqrt(np.diag(result.parameter_covariance))
        doc["correlation"] = {"names": list(params),
                              "matrix": (result.parameter_covariance / np.outer(sd, sd)).tolist()}
    return doc


def write_kinematic_results(out: Path, result, report_text: str, site, problem_path: Path | None,
                            name: str = "", adequacy: dict | None = None) -> None:
    """Write the folder into ``out`` (an atomic temporary folder).

    Parameters
    ----------
    out : Path
    result : casrecon.estimation.kinematic.fit.KinematicResult
    report_text : str
    site : casrecon.physics.dynamics.Site
        For latitude, longitude and h_MSL.
    problem_path : Path or None
        ``problem.toml`` copied into ``config/``.
    name : str
        Problem name for ``summary.json``.
    adequacy : dict or None
        The model-adequacy verdict (``Adequacy.to_dict()``) for ``summary.json``.
    """
    out = Path(out)
    cols = dict(time_columns(result))
    cols.update(geodetic_columns(result.states[:, :3], 3 * result.state_sigma[:, :3], site))
    for i, column in enumerate(STATE_COLUMNS):
        cols[column], cols[f"{column}_3sigma"] = result.states[:, i], 3 * result.state_sigma[:, i]
    for column, values in zip(("roll_deg", "pitch_deg", "yaw_deg"), euler_deg(result.states[:, 6:10]).T):
        cols[column] = values
    for i, axis in enumerate("ned"):
        cols[f"att_{axis}_deg_3sigma"] = np.degrees(3 * result.state_sigma[:, 6 + i])
    write_table(out / "trajectory.csv", cols)
    r = result.nlp.residual_vector(result.z)
    interval = r[result.nlp.groups["imu"]].reshape(-1, 9)
    write_table(out / "residuals_imu.csv", {**time_columns(result, result.node_time_s[:-1], utc=False),
                                            **{f"{n}_z": interval[:, i] for i, n in enumerate(INTERVAL_RESIDUALS)}})
    gps = r[result.nlp.groups["gps"]].reshape(-1, 6)
    names = ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")
    fixes = fix_times(result)
    if fixes.size != gps.shape[0]:
        raise ValueError(f"{fixes.size} fixes in the span but {gps.shape[0]} GPS residual rows")
    write_table(out / "residuals_gps.csv", {**time_columns(result, fixes, utc=False),
                                            **{f"{n}_z": gps[:, i] for i, n in enumerate(names)}})
    write_json(out / "parameters.json", parameters_document(result))
    write_json(out / "summary.json", {
        "problem": name, "kind": "kinematic", "converged": result.solver.converged, "status": result.solver.status,
        "iterations": result.solver.iterations, "chi2": result.chi2, "n_measurements": result.n_measurements,
        "reduced_chi2": result.reduced_chi2, "reduced_chi2_by_group": result.group_reduced_chi2(),
        "span_clock_s": [float(result.data.time_ref_s + result.node_time_s[0]),
                         float(result.data.time_ref_s + result.node_time_s[-1])],
        "nodes": int(result.node_time_s.size), "timings": result.timings, "notes": list(result.notes),
        **({} if adequacy is None else {"adequacy": adequacy})})
    (out / "report.txt").write_text(report_text + "\n")
    if problem_path is not None:
        (out / "config").mkdir()
        shutil.copy2(problem_path, out / "config" / "problem.toml")
