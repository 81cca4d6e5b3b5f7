"""The GPS kind: each fix compared with the antenna position and velocity on the collocation
polynomial at its own time, t_fix - clock_offset on the IMU clock (so the clock offset, which this
kind adds as a parameter, is estimable). Fixes are whitened by the receiver's reported accuracies
(north and east by hAcc, down by vAcc, each velocity component by sAcc) times the error model's
accuracy scales (:func:`fix_sigma`). A component the GPS file
does not give (NaN value, infinite sigma: :func:`casrecon.io.gps_rules.fixes_ned`) has zero weight and
no correlated error; its residual is NaN.

With a GPS error model (``[sensors.gps]`` correlation times and fractions,
:class:`~casrecon.physics.sensor_errors.GpsErrorModel`) the correlated part of each active
component's error is a latent unit-variance value e_k at every fix (extra unknowns of the drop,
eliminated in the covariance), the fix residual is (y - h(x) - s sqrt(f) e_k) / (s sqrt(1 - f)),
and e carries the exactly whitened Gauss-Markov prior (group ``gps_error``).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.kinds.base import DropContext
from casrecon.estimation.kinds.disturbance import gauss_markov_terms
from casrecon.estimation.sixdof.fitdata import FitData
from casrecon.estimation.sixdof.layout import BlockLocals
from casrecon.estimation.sixdof.parameters import ParameterSpec
from casrecon.estimation.sixdof.transcription import (
    collocated_state,
    disturbance_selection,
    gps_function,
    selection_matrix,
)
from casrecon.io.problem import ProblemConfig
from casrecon.physics.sensor_errors import GpsErrorModel

#: Name of the IMU-to-GPS clock-offset parameter (s): a fix stamped t happened at IMU time t - offset.
CLOCK = "clock_offset_s"
#: The six residual components of a fix.
GPS_COMPONENTS = ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")


class GpsKind:
    """GPS antenna position and velocity fixes; the IMU-to-GPS clock offset."""

    name = "gps"

    def parameters(self, config: ProblemConfig) -> tuple[ParameterSpec, ...]:
        est = config.estimation
        if not est.estimate_clock:
            return ()
        return (ParameterSpec(CLOCK, "clock", est.clock_sigma_s, est.clock_sigma_s if est.clock_prior else None, "s"),)

    def load(self, config: ProblemConfig, data: FitData) -> FitData:
        return data

    def latent_size(self, config: ProblemConfig, data: FitData) -> tuple[int, bool]:
        """(number of latent GPS error values, eliminable): one per fix and correlated component."""
        return data.gps_time_s.size * config.gps.error_model.active.size, True

    def terms(self, context: DropContext) -> list[Term]:
        layout, model, data = context.layout, context.model, context.data
        errors = context.config.gps.error_model
        active = errors.active
        loc = BlockLocals(layout)
        tau0, y, w = ca.SX.sym("tau0"), ca.SX.sym("y", 6), ca.SX.sym("w", 6)
        e, amp = ca.SX.sym("e", active.size), ca.SX.sym("amp", active.size)
        xk, xk1, theta, uk, uk1 = loc.split()
        clock = loc.theta_of(theta, CLOCK, layout.guess_clock_s)
        tau = tau0 - clock / layout.mesh.h
        y_white = y - selection_matrix(6, active) @ (amp * e) if active.size else y
        r = gps_function(model, layout.mesh.h, layout.active)(
            xk, xk1, loc.point_params(theta, xk), loc.point_params(theta, xk1), tau, y_white, w, uk, uk1)
        k, tau_fix = layout.interval_of(data.gps_time_s)
        fraction, sigma = errors.fraction, fix_sigma(data, errors)
        y_fix = np.nan_to_num(np.column_stack([data.gps_pos_ned, data.gps_vel_ned]))  # missing: weight 1/inf = 0
        block_data = [ca.DM(tau_fix).T, ca.DM(y_fix.T),
                      ca.DM(1.0 / (sigma * np.sqrt(1.0 - fraction)).T), *layout.profile_block_data(k)]
        cols = layout.two_node_columns(k)
        n_meas = int(np.isfinite(data.gps_sigma).sum())  # components the file gives
        if not active.size:
            kind = BlockKind("gps", loc.symbol, [tau0, y, w, *loc.data], r, None)
            return [Term(context.group(self.name), (BlockSet(kind, cols, block_data),), n_measurements=n_meas)]
        e_cols = layout.extra(self.name).cols.reshape(-1, active.size)
        kind = BlockKind("gps", ca.vertcat(loc.symbol, e), [tau0, y, w, *loc.data, amp], r, None)
        amp_fix = np.where(np.isfinite(sigma), sigma, 0.0) * np.sqrt(fraction)
        block_data.append(ca.DM(amp_fix[:, active].T))
        phi = errors.transition(np.diff(data.gps_time_s))
        return [Term(context.group(self.name), (BlockSet(kind, np.column_stack([cols, e_cols]), block_data),),
                     n_measurements=n_meas),
                *gauss_markov_terms(e_cols, phi, context.group("gps_error_start"), context.group("gps_error"))]

    def residuals(self, result) -> dict[str, np.ndarray]:
        """GPS antenna position/velocity residuals y - h(x) (NED, SI) at every fix used, with the fix
        sigmas; with a GPS error model also the estimated correlated error (``correlated``, SI) and
        the residuals whitened under the model (``normalised``: Kalman innovations over sigma, see
        GpsErrorModel.whiten)."""
        data = result.data
        errors = result.scenario.config.gps.error_model
        sigma = fix_sigma(data, errors)
        white_sigma = sigma * np.sqrt(1.0 - errors.fraction)
        whitened = result.residuals[result.nlp.groups[result.group(self.name)]].reshape(-1, 6)
        correlated = np.zeros_like(whitened)
        missing = ~np.isfinite(sigma)
        extra = result.part.extra(self.name)
        if extra is not None:
            e = result.z[extra.cols].reshape(-1, errors.active.size)
            act = errors.active
            correlated[:, act] = e * np.where(missing, 0.0, sigma)[:, act] * np.sqrt(errors.fraction[act])
        correlated[missing] = np.nan
        residual = np.where(missing, np.nan, whitened * np.where(missing, 0.0, white_sigma) + correlated)
        time = data.gps_time_s - clock_offset(result)
        normalised = errors.whiten(residual / sigma, time)
        return {"time_imu_s": time, "residual": residual, "sigma": sigma, "correlated": correlated,
                "normalised": normalised}


def fix_sigma(data: FitData, errors: GpsErrorModel) -> np.ndarray:
    """(M, 6) 1-sigma of each fix's error the fit assumes: the reported accuracies times the error
    model's accuracy scales (inf where the file gives no such component)."""
    return data.gps_sigma * errors.scale[None, :]


def state_at_sample(context: DropContext, loc: BlockLocals, tau0: ca.SX, receiver_clock: bool):
    """What a two-node block sees at a sample's time: ``(theta, x, terms)``, the drop's parameters
    (SI), its state (SI) on the collocation polynomial at fraction ``tau0`` of the interval (less the
    clock offset over the interval length for a sample stamped on the receiver's clock, like a fix),
    and the flight model's terms there (``air``, ``v_air_body``...), with the disturbances
    interpolated to that time."""
    layout, model = context.layout, context.model
    xk, xk1, theta, uk, uk1 = loc.split()
    pk, pk1 = loc.point_params(theta, xk), loc.point_params(theta, xk1)
    clock = loc.theta_of(theta, CLOCK, layout.guess_clock_s) if receiver_clock else 0.0
    tau = tau0 - clock / layout.mesh.h
    sel = disturbance_selection(layout.active)
    x = collocated_state(model, tau, layout.mesh.h, xk, xk1, pk, pk1, sel, uk, uk1)
    p = loc.point_params(theta, x)
    return theta, x, model.terms(x, p, sel @ (uk + tau * (uk1 - uk)) if layout.n_u else None)


def clock_offset(result) -> float:
    """The IMU-to-GPS clock offset (s) of a fit: its estimate, or the guess it was held at. A fix
    stamped UTC u happened at IMU time u - utc_at_zero - offset."""
    if CLOCK in result.params.names:
        return result.parameter(CLOCK)[0]
    return float(result.part.guess_clock_s)
