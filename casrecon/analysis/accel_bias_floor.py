"""The accelerometer bias along the specific force checked against the GPS velocities (issue 49).

A 6-DOF fit holds its trajectory to the flight model: where the air flown differs from the model's
at scales it cannot follow (gusts in time, roughness below the profile grid), the model's drag is
wrong from moment to moment and the fit trades it against the accelerometer's bias along the
drag, the direction of the specific force. Measured on the error-family study's `turbulence` seed
262 (docs/studies/error-families.md): `accel_bias_x` 0.07 m/s^2 off with a model sigma of 0.0006
(122 sigma), and still 7.4 sigma off the time-block sandwich's widened sigma, which sees what the
residuals do to the estimate, not what the model absorbed.

That bias is also measured without any flight model: the GPS velocities differ between two fixes
by the integral of the acceleration, which is the fit's attitude times the IMU's specific force
less its bias, plus gravity and the Coriolis term (kinematics, no aerodynamics). Only the down
component is used: the specific force is near vertical, so an error of the fit's attitude turns it
sideways and moves its down component only to second order (the lateral biases found from all
three components were 7 sigmas off the truth on `turbulence` 262, where the fit's attitude was
off). A least-squares fit of the initial down velocity and a bias beta
along the mean specific force's direction u (IMU axes; a falling capsule's axis) beyond the fit's
own, and a clock offset of the fixes beyond the fit's (the fit may hold its own at a limit), to
the fixes' centre-of-mass down velocities, gives u . b = u . b_fit + beta: weighted least squares
at the receiver's stated accuracies, its variance scaled by the residuals' own reduced chi-square
(where above 1) and lag-1 autocorrelation rho ((1 + rho) / (1 - rho), rho at least 0). Not by the
fit's GPS error model: its sizes and correlation are estimated from residuals that take up what
the flight model cannot follow (under gusts in time, whitening white GPS velocity errors under the
correlation the fit had estimated gave this regression reduced chi-squares of 5 to 10).

Where the fit's u . b differs from the kinematic one by more than :data:`DETECTION_SIGMA` of their
combined sigma (if both are Gaussian, about 0.3 % of drops whose model is right), the
published covariance is widened along that direction to the difference squared plus the kinematic
variance, every other parameter and the trajectory growing with it by its regression on u . b
(:func:`~casrecon.estimation.engine.block_sandwich.grown_along`); a note says so. Otherwise nothing
changes: the kinematic sigma (about 0.002 m/s^2 on the study's drops) is three to five times the
fit's, and flooring every fit with it would widen the drag's sigmas on fits that are right. The
same comparison is one test of the model-adequacy verdict
(:class:`~casrecon.analysis.adequacy.IndependentCheck`). Chosen on the study's selection seeds
(docs/studies/error-families.md, "The accelerometer bias checked by kinematics").

Not counted in the kinematic sigma: the accelerometers' white noise integrated (0.05 m/s^2 at 500
Hz gives 0.014 m/s after 40 s, against GPS velocity accuracies of 0.1 to 0.3 m/s per fix).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.integrate import cumulative_trapezoid
from scipy.interpolate import interp1d

from casrecon.analysis.adequacy import IndependentCheck
from casrecon.estimation.engine.block_sandwich import grown_along
from casrecon.estimation.engine.covariance import Covariance
from casrecon.estimation.kinds.imu import model_and_bias_values
from casrecon.estimation.sixdof.bands import trajectory_with_bands
from casrecon.estimation.sixdof.diagnostics import gps_residuals
from casrecon.physics.dynamics import STATE_NAMES
from casrecon.physics.numpy_call import numpy_rows
from casrecon.physics.rotations import dcm_body_to_ned_array
from casrecon.physics.sensors import gps_antenna_ned, lever_acceleration

#: The accelerometer bias parameters (IMU axes, m/s^2).
BIAS_NAMES = ("accel_bias_x", "accel_bias_y", "accel_bias_z")
#: The fit's and the kinematic bias along the specific force differ significantly beyond this many
#: sigmas of their difference (the two taken as independent).
DETECTION_SIGMA = 3.0
#: How the note of a widened fit begins.
NOTE_START = "accelerometer bias along the specific force"
#: Index of the down component among NED.
DOWN = 2
#: Half-width of the window over which the down acceleration at a fix is averaged (s).
CLOCK_WINDOW_S = 0.1
#: Largest lag-1 autocorrelation of the regression's residuals taken (the variance factor
#: (1 + rho) / (1 - rho) is then 39).
MAX_LAG1 = 0.95
#: Fixes closer than this to either end of the fit's nodes are not used (s).
END_MARGIN_S = 0.5


@dataclass(frozen=True)
class KinematicBias:
    """The accelerometer bias along the mean specific force, by the fit and by kinematics.

    Attributes
    ----------
    direction_imu : (3,) array
        Unit vector u in IMU axes: the mean measured specific force's direction over the fit.
    kinematic_mps2, kinematic_sigma_mps2 : float
        u . b from the GPS velocities and the IMU (m/s^2), and its 1-sigma.
    fit_mps2, fit_sigma_mps2 : float
        u . b of the fit and its 1-sigma (m/s^2), as the fit's published covariance says.
    n_fixes : int
        GPS fixes used.
    reduced_chi2 : float
        Of the kinematic regression (the sigma above is scaled by its root where it exceeds 1).
    lag1 : float
        Lag-1 autocorrelation of the regression's residuals, at least 0 (the variance above is
        scaled by (1 + lag1) / (1 - lag1)).
    """

    direction_imu: np.ndarray
    kinematic_mps2: float
    kinematic_sigma_mps2: float
    fit_mps2: float
    fit_sigma_mps2: float
    n_fixes: int
    reduced_chi2: float
    lag1: float

    @property
    def difference_mps2(self) -> float:
        """Fit less kinematic, m/s^2."""
        return self.fit_mps2 - self.kinematic_mps2

    @property
    def z(self) -> float:
        """The difference over its combined sigma."""
        return self.difference_mps2 / math.hypot(self.kinematic_sigma_mps2, self.fit_sigma_mps2)

    def check(self) -> IndependentCheck:
        """As one test of the model-adequacy verdict."""
        return IndependentCheck("accelerometer bias along the specific force", self.z, (
            f"fit {self.fit_mps2:+.4f} +- {self.fit_sigma_mps2:.4f} m/s^2, from the GPS velocities and the IMU alone "
            f"{self.kinematic_mps2:+.4f} +- {self.kinematic_sigma_mps2:.4f} m/s^2"))

    @property
    def floor_variance(self) -> float:
        """The variance (m^2/s^4) the published u . b is widened to when :attr:`z` is significant."""
        return self.difference_mps2 ** 2 + self.kinematic_sigma_mps2 ** 2


def field_acceleration(model, states: np.ndarray) -> np.ndarray:
    """The flight model's field acceleration (NED, m/s^2: gravity and Coriolis,
    :meth:`~casrecon.physics.dynamics.FlightModel.acceleration_ned`) at each of the (n, 13)
    ``states``, (n, 3)."""
    x = ca.SX.sym("x", model.n_states)
    return numpy_rows(ca.Function("field", [x], [model.acceleration_ned(x)]), states)


def antenna_velocity(vehicle, states: np.ndarray) -> np.ndarray:
    """The GPS antenna's velocity less the centre of mass's (NED, m/s,
    :func:`~casrecon.physics.sensors.gps_antenna_ned`) at each of the (n, 13) ``states``, (n, 3)."""
    x = ca.SX.sym("x", len(STATE_NAMES))
    _, v_antenna = gps_antenna_ned(vehicle, x[0:3], x[3:6], x[6:10], x[10:13])
    return numpy_rows(ca.Function("antenna", [x], [v_antenna - x[3:6]]), states)


def _at(time_s: np.ndarray, sample_time_s: np.ndarray, values: np.ndarray) -> np.ndarray:
    """``values`` (n, ...) linearly interpolated to ``time_s``, every trailing index apart (the end
    values held beyond the samples)."""
    return interp1d(sample_time_s, values, axis=0, assume_sorted=True, bounds_error=False,
                    fill_value=(values[0], values[-1]))(time_s)


def kinematic_bias(result) -> KinematicBias | None:
    """The accelerometer bias along the mean specific force from the GPS velocities and the IMU,
    with the fit's attitude, body rates and clock offset (see the module); None when it cannot be
    formed: the fit does not estimate all three accelerometer biases, its covariance is not a
    :class:`~casrecon.estimation.engine.covariance.Covariance`, an accelerometer saturates within
    the fit, or fewer than four fixes have velocities."""
    names = result.params.names
    if not all(n in names for n in BIAS_NAMES) or not isinstance(result.covariance, Covariance):
        return None
    data, cfg = result.data, result.scenario.config
    veh = cfg.vehicle
    t_nodes = result.node_time_s
    inside = (data.imu_time_s >= t_nodes[0]) & (data.imu_time_s <= t_nodes[-1])
    if not np.all(data.accel_valid[inside]):
        return None
    t = data.imu_time_s[inside]
    _, bias = model_and_bias_values(result)
    imu_to_body = np.asarray(veh.imu_to_body, float)
    states = result.states
    omega_dot = np.gradient(states[:, 10:13], t_nodes, axis=0)
    at_samples = _at(t, t_nodes, states)
    c_nb = dcm_body_to_ned_array(at_samples[:, 6:10])
    # the flight model's own terms: the field (gravity, Coriolis) at the nodes, interpolated (it is
    # smooth); the lever-arm specific force, quadratic in the rates, at the samples themselves
    field = _at(t, t_nodes, field_acceleration(result.scenario.model, states))
    lever = lever_acceleration(veh, at_samples[:, 10:13], _at(t, t_nodes, omega_dot))
    accel_imu = data.accel_imu[inside]
    u = np.mean(accel_imu, axis=0)
    u = u / np.linalg.norm(u)
    # specific force at the centre of mass, body axes, less the fit's bias; its down component in NED
    f_cm = (accel_imu - bias[:3]) @ imu_to_body.T - lever
    accel_down = np.einsum("kj,kj->k", c_nb[:, 2, :], f_cm) + field[:, DOWN]
    gps = gps_residuals(result)
    fix_t = gps["time_imu_s"]
    # the receiver's stated accuracies, not the fit's scaled ones: the sizes a fit estimates take up
    # what its flight model cannot follow, which this check must not (the regression's own reduced
    # chi-square scales them up instead)
    vel, sigma = data.gps_vel_ned, data.gps_sigma[:, 3:6]
    used = ((fix_t > t[0] + END_MARGIN_S) & (fix_t < t[-1] - END_MARGIN_S)
            & np.all(np.isfinite(vel), 1) & np.all(np.isfinite(sigma), 1))
    if np.count_nonzero(used) < 4:  # three unknowns, and one fix to spare
        return None
    order = np.argsort(fix_t[used], kind="stable")
    fix_t, vel, sigma = fix_t[used][order], vel[used][order, DOWN], sigma[used][order, DOWN]
    vel_cm = vel - antenna_velocity(veh, _at(fix_t, t_nodes, states))[:, DOWN]  # antenna to centre of mass
    cumulative = cumulative_trapezoid(accel_down, t, initial=0.0)
    integral = np.interp(fix_t, t, cumulative)
    # the down acceleration at each fix, for a clock offset beyond the fit's (a mean over +-CLOCK_WINDOW_S)
    accel_at_fix = (np.interp(fix_t + CLOCK_WINDOW_S, t, cumulative)
                    - np.interp(fix_t - CLOCK_WINDOW_S, t, cumulative)) / (2.0 * CLOCK_WINDOW_S)
    # a bias beta u more than the fit's lowers the down acceleration by (C_nb R_ib u)_down beta
    gain = np.interp(fix_t, t, cumulative_trapezoid(c_nb[:, 2, :] @ (imu_to_body @ u), t, initial=0.0))
    # v_k = v0 + integral_k - gain_k beta + a_k delta (delta: the fixes' times later than the fit
    # says), weighted by the stated accuracies; the variance scaled by the residuals' own size and
    # lag-1 correlation (not by the fit's GPS error model: see the module)
    a = np.column_stack([np.ones_like(gain), -gain, accel_at_fix]) / sigma[:, None]
    y = (vel_cm - integral) / sigma
    solution, *_ = np.linalg.lstsq(a, y, rcond=None)
    residual = y - a @ solution
    reduced = float(np.sum(residual ** 2) / max(y.size - 3, 1))
    lag1 = float(np.clip(np.sum(residual[1:] * residual[:-1]) / np.sum(residual ** 2), 0.0, MAX_LAG1))
    variance = float(np.linalg.inv(a.T @ a)[1, 1]) * max(reduced, 1.0) * (1.0 + lag1) / (1.0 - lag1)
    idx = [names.index(n) for n in BIAS_NAMES]
    fit_cov = result.correlation[np.ix_(idx, idx)] * np.outer(result.sigma[idx], result.sigma[idx])
    fit_u = float(u @ bias[:3])
    return KinematicBias(direction_imu=u, kinematic_mps2=fit_u + float(solution[1]),
                         kinematic_sigma_mps2=math.sqrt(variance), fit_mps2=fit_u,
                         fit_sigma_mps2=float(np.sqrt(u @ fit_cov @ u)), n_fixes=int(fix_t.size), reduced_chi2=reduced,
                         lag1=lag1)


def bias_floored(result, detection_sigma: float = DETECTION_SIGMA):
    """``result`` (a per-drop 6-DOF FitResult, as published) with its covariance widened along the
    accelerometer bias u . b when the fit's and the kinematic value differ by more than
    ``detection_sigma`` (see the module): that direction's variance becomes
    :attr:`KinematicBias.floor_variance`, the other parameters and the trajectory bands grow by
    their regression on it (the bands by the increase of their variance), and a note says so.
    Returns (result, KinematicBias or None)."""
    check = kinematic_bias(result)
    if check is None or not abs(check.z) > detection_sigma:
        return result, check
    cov, part = result.covariance, result.part
    idx = [result.params.index(n) for n in BIAS_NAMES]
    theta_rows = cov.rows(part.theta_cols[idx]) * np.asarray(part.params.scales)[idx, None]
    direction = check.direction_imu @ theta_rows                   # u . b in reduced coordinates, m/s^2
    factor = check.floor_variance / float(direction @ cov.cov_w @ direction)
    widened = dataclasses.replace(cov, cov_w=grown_along(cov.cov_w, direction[None, :], factor))
    cov_theta = widened.covariance_of(part.theta_cols, part.params.scales)
    sigma = np.sqrt(np.diag(cov_theta))
    _, before = trajectory_with_bands(result.scenario.model, part, result.z, cov)
    _, after = trajectory_with_bands(result.scenario.model, part, result.z, widened)
    table_sigma = np.sqrt(np.asarray(result.table_sigma, float) ** 2 + np.maximum(after ** 2 - before ** 2, 0.0))
    note = (f"{NOTE_START} (IMU axes {np.round(check.direction_imu, 3).tolist()}): "
            f"the fit's {check.fit_mps2:+.4f} +- {check.fit_sigma_mps2:.4f} m/s^2 differs from what the GPS velocities "
            f"and the IMU alone say ({check.kinematic_mps2:+.4f} +- {check.kinematic_sigma_mps2:.4f} m/s^2, "
            f"{check.n_fixes} fixes) by {check.z:+.1f} sigma: forces the model does not have (gusts, air rougher than "
            f"the profile) traded against the bias; its sigma widened to "
            f"{math.sqrt(check.floor_variance):.4f} m/s^2, the other parameters and the bands with it by their "
            "correlation with it")
    return dataclasses.replace(result, covariance=widened, sigma=sigma, correlation=cov_theta / np.outer(sigma, sigma),
                               table_sigma=table_sigma, notes=result.notes + (note,)), check
