"""What a fit leaves for plots and checks: per-sample sensor residuals, the pitching moment
reconstructed from the measured rates, and the reconciled forward simulation (EES paper VI).

All functions take a :class:`~casrecon.estimation.sixdof.fit.FitResult` and return plain arrays/dicts;
the results writer stores them as CSV so ``casrecon report`` can redraw every figure.
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.kinds.gps import GpsKind
from casrecon.estimation.kinds.imu import IMU_CHANNELS, ImuKind, model_and_bias_values
from casrecon.estimation.numerics.savgol import savgol_filter
from casrecon.estimation.sixdof.bands import node_parameter_values
from casrecon.physics.aero import DISPERSION_NAMES, aero_force_moment
from casrecon.physics.sensors import lever_acceleration
from casrecon.simulation.simulate import Simulator

__all__ = ["IMU_CHANNELS", "imu_residuals", "gps_residuals", "pitching_moment", "reconciled_simulation"]

def imu_residuals(result) -> dict[str, np.ndarray]:
    """Measured minus predicted IMU output at every sample of the fit (see
    :meth:`casrecon.estimation.kinds.imu.ImuKind.residuals`)."""
    return ImuKind().residuals(result)


def gps_residuals(result) -> dict[str, np.ndarray]:
    """GPS antenna position/velocity residuals at every fix used (see
    :meth:`casrecon.estimation.kinds.gps.GpsKind.residuals`)."""
    return GpsKind().residuals(result)


def _moment_coefficient_function(result) -> ca.Function:
    """``(v_air_body, omega, sound_speed, dispersions) -> (C_l, C_m, C_n)`` about the MRP, from the
    one aero model (:func:`aero_force_moment`, with rho chosen so that qbar = 1 and S = 1)."""
    veh, aero = result.scenario.config.vehicle, result.scenario.config.aero
    vb, w, a = ca.SX.sym("vb", 3), ca.SX.sym("w", 3), ca.SX.sym("a")
    disp = ca.SX.sym("d", len(DISPERSION_NAMES))
    rho = 2.0 / ca.sumsqr(vb)
    _, moment = aero_force_moment(aero, vb, w, rho, a, disp, 1.0, veh.ref_length_m, ca.DM.zeros(3))
    return ca.Function("moment_coefficients", [vb, w, a, disp], [moment / veh.ref_length_m])


def _air_at_nodes(result) -> tuple[np.ndarray, np.ndarray]:
    """Air-relative velocity in body axes (K, 3) and speed of sound (K,) at the fit's nodes (with
    the profile corrections at each node, if any)."""
    model = result.scenario.model
    x, pp = ca.SX.sym("x", model.n_states), ca.SX.sym("p", model.n_params)
    t = model.terms(x, pp)
    fn = ca.Function("air", [x, pp], [t["v_air_body"], t["air"].sound_speed]).map(result.states.shape[0])
    vb, a = fn(result.states.T, node_parameter_values(result.part, result.z))
    return np.asarray(vb).T, np.asarray(a).ravel()


def pitching_moment(result) -> dict[str, np.ndarray]:
    """Pitching-moment coefficient about the MRP (body y) reconstructed from the measured rates.

    dw/dt is the Savitzky-Golay derivative (0.1 s window, cubic) of the bias-corrected gyros; the
    moment about the centre of mass I dw/dt + w x I w is moved to the MRP with the measured
    specific force, the fitted model's damping moment is removed, and the rest is divided by
    qbar S d (NaN at a node whose filter window holds a saturated sample). The model curves are the
    static C_m,body at beta = 0 of the nominal and of the best-fit dispersed database. Every model value
    comes from the one aero model.
    """
    cfg, data = result.scenario.config, result.data
    veh = cfg.vehicle
    p, b = model_and_bias_values(result)
    r_ib = np.asarray(veh.imu_to_body)
    dt = float(np.median(np.diff(data.imu_time_s)))
    w = (data.gyro_imu - b[3:]) @ r_ib.T
    f = (data.accel_imu - b[:3]) @ r_ib.T
    saturated = ~(data.accel_valid.all(axis=1) & data.gyro_valid.all(axis=1))
    near_saturated = np.convolve(saturated.astype(float), np.ones(51), mode="same") > 0
    idx = np.clip(np.searchsorted(data.imu_time_s, result.node_time_s), 0, data.imu_time_s.size - 1)
    wdot = savgol_filter(w, 51, 3, deriv=1, delta=dt, rows=idx)
    w, f = w[idx], f[idx]
    inertia = np.asarray(veh.inertia_kgm2)
    f_cm = f - lever_acceleration(veh, w, wdot)
    m_cm = wdot @ inertia.T + np.cross(w, w @ inertia.T)
    m_mrp = m_cm - np.cross(veh.lever(veh.mrp_m), veh.mass_kg * f_cm)
    qbar = result.column("qbar_pa")[0]
    coef = _moment_coefficient_function(result)
    k = result.states.shape[0]
    vb, sound = _air_at_nodes(result)
    disp = np.tile(p[:len(DISPERSION_NAMES), None], k)
    with_rates = np.asarray(coef.map(k)(vb.T, w.T, sound[None, :], disp))
    without = np.asarray(coef.map(k)(vb.T, np.zeros((3, k)), sound[None, :], disp))
    cm = m_mrp[:, 1] / (qbar * veh.ref_area_m2 * veh.ref_length_m) - (with_rates[1] - without[1])
    cm[near_saturated[idx]] = np.nan
    grid = np.radians(np.linspace(-20, 20, 81))
    speed, a_med = float(np.median(np.linalg.norm(vb, axis=1))), float(np.median(sound))
    v_grid = speed * np.vstack([np.cos(grid), np.zeros_like(grid), np.sin(grid)])
    curves = {}
    n_disp = len(DISPERSION_NAMES)
    for label, d in (("cm_nominal", np.zeros_like(p[:n_disp])), ("cm_fitted", p[:n_disp])):
        curves[label] = np.asarray(coef.map(grid.size)(v_grid, np.zeros((3, grid.size)), a_med,
                                                       np.tile(d[:, None], grid.size)))[1]
    return {"time_imu_s": result.node_time_s, "alpha_deg": result.column("alpha_deg")[0], "qbar_pa": qbar,
            "cm_recon": cm, "alpha_grid_deg": np.degrees(grid), **curves}


def reconciled_simulation(result, nominal: bool = False) -> dict:
    """Forward simulation from the reconstructed first-node state with the fitted dispersions and
    atmosphere corrections (EES paper section VI), against the reconstruction. ``nominal=True``
    sets the dispersions to 0 (the pre-flight database) and keeps the fitted atmosphere."""
    scenario = result.scenario
    p, _ = model_and_bias_values(result)
    if nominal:
        p[:len(DISPERSION_NAMES)] = 0.0
    sim = Simulator(scenario.model, dt_s=0.002)
    traj = sim.run(result.states[0], p, t_max_s=300.0)
    t0 = result.flight_time_s[0]
    t_sim = t0 + traj.time_s
    recon_impact_flight = result.data.impact_imu_s - result.data.release_imu_s
    speed = np.linalg.norm(traj.states[:, 3:6], axis=1)
    end_speed = float(np.linalg.norm(result.states[-1, 3:6]))
    return {"flight_time_s": t_sim, "h_agl_m": traj.output("h_agl"), "speed_mps": speed,
            "alpha_t_deg": np.degrees(traj.output("alpha_t")), "p_dps": np.degrees(traj.state("omega_x")),
            "summary": {"simulated_flight_time_s": float(t_sim[-1]),
                        "reconstructed_flight_time_s": float(recon_impact_flight),
                        "flight_time_difference_s": float(t_sim[-1] - recon_impact_flight),
                        "simulated_impact_speed_mps": float(speed[-1]),
                        "reconstructed_end_speed_mps": end_speed,
                        "impact_speed_difference_mps": float(speed[-1] - end_speed)}}
