"""The ground kind: the impact as a measurement of altitude, when the problem says how well the
ground's altitude there is known (``[estimation] impact_ground_sigma_m``).

At the impact instant (detected from the IMU, or ``[estimation] impact_imu_s``; on the IMU clock,
so no clock offset enters) the centre of mass was at ``impact_ground_alt_msl_m`` (default the
site's ground). The fit window ends ``end_before_impact_s`` earlier; the last node is carried to
the impact at its own vertical velocity:

    r = (h_msl(x_N) - v_down(x_N) dt - h_ground) / sigma,

sigma the ground's 1-sigma and what one IMU sample of timing moves the centre of mass at the last
GPS fix's vertical speed, in quadrature. Why: the fit otherwise takes its absolute altitude from the
GPS heights, whose errors may be correlated over the whole drop, and from where the sounding's wind
structure lets the trajectory sit, which is metres off with a band of centimetres where the air
differs from the sounding at scales the profile grid cannot place (docs/design/error-models.md,
"The sounding's altitude shift"). Not modelled: the ground's slope between the origin and the
impact point (give the impact point's altitude), the vehicle's attitude at contact (put the centre
of mass's height above the contact point in the altitude or the sigma).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.kinds.base import DropContext
from casrecon.estimation.sixdof.fitdata import FitData, FitDataError
from casrecon.estimation.sixdof.layout import BlockLocals
from casrecon.estimation.sixdof.parameters import ParameterSpec
from casrecon.io.problem import ProblemConfig

#: Longest time (s) from the fit window's end to the impact over which the last node is carried.
MAX_CARRY_S = 2.0


@dataclass(frozen=True)
class GroundData:
    """The impact as a measurement.

    Attributes
    ----------
    impact_imu_s : float
        Impact instant, IMU clock, s.
    height_agl_m : float
        Altitude of the centre of mass at impact above the site's ground altitude (the NED origin's), m.
    sigma_m : float
        1-sigma of the measurement: the ground's and one IMU sample's timing, m.
    """

    impact_imu_s: float
    height_agl_m: float
    sigma_m: float


class GroundKind:
    """The impact's altitude; no parameters."""

    name = "ground"

    def parameters(self, config: ProblemConfig) -> tuple[ParameterSpec, ...]:
        return ()

    def load(self, config: ProblemConfig, data: FitData) -> GroundData | None:
        est = config.estimation
        if est.impact_ground_sigma_m is None:
            return None
        carry = data.impact_imu_s - data.window[1]
        if not 0.0 <= carry <= MAX_CARRY_S:
            raise FitDataError(f"[estimation] impact_ground_sigma_m: the fit window ends {carry:.2f} s before the "
                               f"impact; the impact is a measurement only within 0 to {MAX_CARRY_S:g} s of it "
                               "(end_before_impact_s)")
        site_ground = config.site.ground_alt_msl_m
        ground = site_ground if est.impact_ground_alt_msl_m is None else est.impact_ground_alt_msl_m
        sample_s = float(np.median(np.diff(data.imu_time_s)))
        descent = float(abs(data.gps_vel_ned[-1, 2])) if data.gps_vel_ned.size else 0.0
        sigma = float(np.hypot(est.impact_ground_sigma_m, descent * sample_s))
        return GroundData(float(data.impact_imu_s), float(ground - site_ground), sigma)

    def terms(self, context: DropContext) -> list[Term]:
        layout = context.layout
        ground: GroundData = context.measurements[self.name]
        loc = BlockLocals(layout)
        _, x_last, _, _, _ = loc.split()
        carry = ca.SX.sym("carry_s")
        height = -x_last[2] - x_last[5] * carry
        r = (height - ground.height_agl_m) / ground.sigma_m
        kind = BlockKind("ground", loc.symbol, [carry, *loc.data], r, None)
        k = np.array([layout.mesh.n_intervals - 1])
        dt = ground.impact_imu_s - float(layout.mesh.t_nodes[-1])
        block_data = [ca.DM([[dt]]), *layout.profile_block_data(k)]
        return [Term(context.group(self.name), (BlockSet(kind, layout.two_node_columns(k), block_data),))]

    def residuals(self, result) -> dict[str, np.ndarray] | None:
        """``time_imu_s`` (the impact, IMU clock), measured minus fitted ``height_residual_m`` and
        its ``height_sigma_m`` (m); None without the measurement."""
        ground: GroundData | None = result.measurements.get(self.name)
        if ground is None:
            return None
        whitened = result.residuals[result.nlp.groups[result.group(self.name)]]
        return {"time_imu_s": np.array([ground.impact_imu_s]), "height_residual_m": -whitened * ground.sigma_m,
                "height_sigma_m": np.array([ground.sigma_m])}
