"""The GPS kind: each fix compared with the antenna position and velocity on the collocation
polynomial at its own time, t_fix - clock_offset on the IMU clock (so the clock offset, which this
kind adds as a parameter, is estimable). Fixes are whitened by the receiver's reported accuracies
(north and east by hAcc, down by vAcc, each velocity component by sAcc).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.fitdata import FitData
from casrecon.estimation.kinds.base import DropContext
from casrecon.estimation.layout import BlockLocals
from casrecon.estimation.parameters import ParameterSpec
from casrecon.estimation.transcription import gps_function
from casrecon.io.problem import ProblemConfig

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

    def terms(self, context: DropContext) -> list[Term]:
        layout, model, data = context.layout, context.model, context.data
        loc = BlockLocals(layout)
        tau0, y, w = ca.SX.sym("tau0"), ca.SX.sym("y", 6), ca.SX.sym("w", 6)
        xk, xk1, theta, uk, uk1 = loc.split()
        clock = loc.theta_of(theta, CLOCK, layout.guess_clock_s)
        tau = tau0 - clock / layout.mesh.h
        r = gps_function(model, layout.mesh.h, layout.active)(xk, xk1, loc.model_params(theta), tau, y, w, uk, uk1)
        kind = BlockKind("gps", loc.symbol, [tau0, y, w], r, None)
        k, tau_fix = layout.interval_of(data.gps_time_s)
        block_data = [ca.DM(tau_fix).T, ca.DM(np.column_stack([data.gps_pos_ned, data.gps_vel_ned]).T),
                      ca.DM(1.0 / data.gps_sigma.T)]
        return [Term(context.group(self.name), (BlockSet(kind, layout.two_node_columns(k), block_data),))]

    def residuals(self, result) -> dict[str, np.ndarray]:
        """GPS antenna position/velocity residuals (NED, SI) at every fix used, with the fix sigmas."""
        data = result.data
        whitened = result.residuals[result.nlp.groups[result.group(self.name)]].reshape(-1, 6)
        return {"time_imu_s": data.gps_time_s - clock_offset(result), "residual": whitened * data.gps_sigma,
                "sigma": data.gps_sigma}


def clock_offset(result) -> float:
    """The IMU-to-GPS clock offset (s) of a fit: its estimate, or the guess it was held at. A fix
    stamped UTC u happened at IMU time u - utc_at_zero - offset."""
    if CLOCK in result.params.names:
        return result.parameter(CLOCK)[0]
    return float(result.part.guess_clock_s)
