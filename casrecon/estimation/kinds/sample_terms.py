"""A sample kind (:mod:`.samples`) in the 6-DOF fit: :class:`SampleTerms` wraps one as a
:class:`~casrecon.estimation.kinds.base.MeasurementKind`.

Its samples, stamped on the receiver's clock (UTC), are placed on the IMU clock like the
barometer's receiver-clock samples (:mod:`.baro`): at ``t - utc_at_zero - clock_offset``, the
clock offset estimated with the GPS fixes (or held at its guess), so a sample lies on the interval
that holds it at the guessed offset and is moved within it by the estimate. Samples closer than
:data:`MARGIN_S` to the fit window's ends are left out (the offset moves them by a fraction of a
second at most). At each sample the state is the cubic Hermite of the collocation polynomial
through the interval's two nodes, and the air (pressure, density, air velocity) the flight
model's at that state; each component's residual is ``(y - predict) / sigma``.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.kinds.base import DropContext
from casrecon.estimation.kinds.gps import clock_offset, state_at_sample
from casrecon.estimation.kinds.samples import BodyState, SampleKind
from casrecon.estimation.sixdof.fitdata import FitData, FitDataError
from casrecon.estimation.sixdof.layout import BlockLocals
from casrecon.estimation.sixdof.parameters import ParameterSpec
from casrecon.io.problem import ProblemConfig

#: Samples closer than this to the fit window's ends are not used, s.
MARGIN_S = 1.0


@dataclass(frozen=True)
class PlacedSamples:
    """A sample kind's samples in a drop's fit window.

    Attributes
    ----------
    time_s : (N,) array
        UTC minus the IMU clock's UTC at zero, s (the clock offset still to subtract for the IMU clock).
    values, sigma : (N, m) arrays
        Measured values and their 1-sigma, SI.
    kind : SampleTerms
        The adapter that placed them (for the residual tables).
    """

    time_s: np.ndarray
    values: np.ndarray
    sigma: np.ndarray
    kind: SampleTerms


class SampleTerms:
    """The 6-DOF measurement kind of one :class:`~casrecon.estimation.kinds.samples.SampleKind`.

    Parameters
    ----------
    kind : SampleKind
        Its position and lever arms refer to the centre of mass and body axes.
    """

    def __init__(self, kind: SampleKind) -> None:
        self.kind = kind
        self.name = kind.name

    def parameters(self, config: ProblemConfig) -> tuple[ParameterSpec, ...]:
        return tuple(self.kind.parameters())

    def load(self, config: ProblemConfig, data: FitData) -> PlacedSamples:
        samples = self.kind.samples
        t = samples.time_unix_s - config.imu.clock_utc_at_zero.timestamp()
        keep = (t >= data.window[0] + MARGIN_S) & (t <= data.window[1] - MARGIN_S)
        if keep.sum() < 1:
            raise FitDataError(f"sample kind {self.name!r}: no sample in the fit window {data.window[0]:.2f} to "
                               f"{data.window[1]:.2f} s (IMU clock) less {MARGIN_S:g} s at each end")
        return PlacedSamples(t[keep], samples.values[keep], samples.sigma[keep], self)

    def terms(self, context: DropContext) -> list[Term]:
        layout = context.layout
        placed: PlacedSamples = context.measurements[self.name]
        width = placed.values.shape[1]
        loc = BlockLocals(layout)
        tau0, y, inv = ca.SX.sym("tau0"), ca.SX.sym("y", width), ca.SX.sym("inv", width)
        theta, x, terms = state_at_sample(context, loc, tau0, receiver_clock=True)
        air = terms["air"]
        state = BodyState(x[0:3], x[3:6], x[6:10], loc.layout_altitude(x), air.pressure, air.density,
                          terms["v_air_body"])
        own = {spec.name: loc.theta_of(theta, spec.name) for spec in self.kind.parameters()}
        r = (y - ca.vec(self.kind.predict(state, own))) * inv
        block = BlockKind(f"samples_{self.name}", loc.symbol, [tau0, y, inv, *loc.data], r, None)
        k, tau_sample = layout.interval_of(placed.time_s)
        block_data = [ca.DM(tau_sample).T, ca.DM(placed.values.T), ca.DM(1.0 / placed.sigma.T),
                      *layout.profile_block_data(k)]
        return [Term(context.group(self.name), (BlockSet(block, layout.two_node_columns(k), block_data),))]

    def residuals(self, result) -> dict[str, np.ndarray] | None:
        """Named columns at every sample used: ``time_imu_s`` (s, IMU clock at the fit's clock
        offset), then per component ``<column>_residual`` (measured minus predicted) and
        ``<column>_sigma`` (SI); None when the fit has none of these samples."""
        placed: PlacedSamples | None = result.measurements.get(self.name)
        if placed is None:
            return None
        whitened = result.residuals[result.nlp.groups[result.group(self.name)]].reshape(-1, placed.values.shape[1])
        out = {"time_imu_s": placed.time_s - clock_offset(result)}
        for i, column in enumerate(self.kind.columns):
            out[f"{column}_residual"] = whitened[:, i] * placed.sigma[:, i]
            out[f"{column}_sigma"] = placed.sigma[:, i]
        return out


def placed_kinds(measurements: dict) -> tuple[SampleTerms, ...]:
    """The sample-kind adapters whose samples are among a fit's ``measurements`` (by kind name)."""
    return tuple(m.kind for m in measurements.values() if isinstance(m, PlacedSamples))
