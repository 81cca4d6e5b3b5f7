"""The barometer kind: each static-pressure sample compared with the sounding's pressure at the
vehicle's altitude on the collocation polynomial at the sample's own time, plus a constant sensor
bias (``baro_bias_pa``, with a zero-mean prior) and, when ``[sensors.baro] position_error_sigma``
is set, a static-port position error k qbar (``baro_qbar_coef``, with a zero-mean prior), whitened
by the sensor's white-noise sigma:

    r = (p_measured - p_sounding(h_msl(t)) - bias - k qbar(t)) / noise.

Samples stamped on the receiver's clock (UTC: FlySight 2 SENSOR.CSV, or a plain CSV with
``time_unix_s``) are placed at ``t - clock_offset`` on the IMU clock like GPS fixes; samples on
the IMU clock (``time_s``) at ``t``. The altitude is the centre of mass's (a sensor a few cm away
is off by well under 1 Pa). Without the position-error term an error proportional to qbar is
absorbed by the clock offset and the bias while the residuals stay white (measured: k = 0.01 put
the clock offset 10.6 sigma off), so switch it on for a sensor inside a fast vehicle. Not modelled:
the sensor's lag.
"""

from __future__ import annotations

import logging
from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.kinds.base import DropContext
from casrecon.estimation.kinds.gps import clock_offset, state_at_sample
from casrecon.estimation.sixdof.fitdata import FitData, FitDataError
from casrecon.estimation.sixdof.layout import BlockLocals
from casrecon.estimation.sixdof.parameters import ParameterSpec
from casrecon.io.baro import read_baro
from casrecon.io.problem import ProblemConfig

logger = logging.getLogger(__name__)

#: Name of the barometer bias parameter (Pa).
BIAS = "baro_bias_pa"
#: Name of the static-port position-error coefficient (dimensionless: pressure error / qbar).
PORT = "baro_qbar_coef"


@dataclass(frozen=True)
class BaroData:
    """Barometer samples in the fit window.

    Attributes
    ----------
    time_s : (N,) array
        On the IMU clock when ``receiver_clock`` is False; UTC minus the IMU clock's UTC at zero
        (the clock offset still to subtract) when True.
    pressure_pa : (N,) array
    noise_pa : float
        1-sigma white noise of a sample.
    receiver_clock : bool
    """

    time_s: np.ndarray
    pressure_pa: np.ndarray
    noise_pa: float
    receiver_clock: bool


class BaroKind:
    """Static pressure samples; the barometer bias."""

    name = "baro"

    def parameters(self, config: ProblemConfig) -> tuple[ParameterSpec, ...]:
        baro = config.baro
        if baro is None or baro.file is None:
            return ()
        sigma = baro.bias_sigma_pa
        specs = (ParameterSpec(BIAS, "baro", sigma, sigma if baro.bias_prior else None, "Pa"),)
        if baro.position_error_sigma > 0:
            specs += (ParameterSpec(PORT, "baro", baro.position_error_sigma, baro.position_error_sigma, "-"),)
        return specs

    def load(self, config: ProblemConfig, data: FitData) -> BaroData | None:
        baro = config.baro
        if baro is None or baro.file is None:
            return None
        log = read_baro(baro.file)
        for note in log.notes:  # the reader's notes (a SENSOR.CSV's dropped $TIME rows), said once
            logger.info("%s", note)
        receiver = log.clock == "utc"
        t = log.time_s - config.imu.clock_utc_at_zero.timestamp() if receiver else log.time_s
        # the clock offset moves receiver-clock samples by a fraction of a second at most: keep a
        # margin of one second inside the window so none falls off the mesh
        margin = 1.0 if receiver else 0.0
        keep = (t >= data.window[0] + margin) & (t <= data.window[1] - margin)
        if keep.sum() < 2:
            raise FitDataError(f"{baro.file}: only {int(keep.sum())} barometer samples in the fit window "
                             f"{data.window[0]:.2f} to {data.window[1]:.2f} s (IMU clock)")
        return BaroData(t[keep], log.pressure_pa[keep], baro.noise_pa, receiver)

    def terms(self, context: DropContext) -> list[Term]:
        layout = context.layout
        samples: BaroData = context.measurements[self.name]
        loc = BlockLocals(layout)
        tau0, y = ca.SX.sym("tau0"), ca.SX.sym("p")
        theta, _, terms = state_at_sample(context, loc, tau0, samples.receiver_clock)
        air = terms["air"]
        qbar = 0.5 * air.density * ca.sumsqr(terms["v_air_body"])
        r = (y - air.pressure - loc.theta_of(theta, BIAS) - loc.theta_of(theta, PORT) * qbar) / samples.noise_pa
        kind = BlockKind("baro", loc.symbol, [tau0, y, *loc.data], r, None)
        shift = 0.0 if samples.receiver_clock else layout.guess_clock_s
        k, tau_sample = layout.interval_of(samples.time_s + shift)
        block_data = [ca.DM(tau_sample).T, ca.DM(samples.pressure_pa).T, *layout.profile_block_data(k)]
        return [Term(context.group(self.name), (BlockSet(kind, layout.two_node_columns(k), block_data),))]

    def residuals(self, result) -> dict[str, np.ndarray] | None:
        """Named columns at every sample used: ``time_imu_s`` (s, IMU clock), measured minus
        predicted ``pressure_residual_pa`` and its ``pressure_sigma_pa`` (Pa); None without a
        barometer."""
        samples: BaroData | None = result.measurements.get(self.name)
        if samples is None:
            return None
        whitened = result.residuals[result.nlp.groups[result.group(self.name)]]
        clock = 0.0
        if samples.receiver_clock:
            clock = clock_offset(result)
        return {"time_imu_s": samples.time_s - clock, "pressure_residual_pa": whitened * samples.noise_pa,
                "pressure_sigma_pa": np.full(samples.time_s.size, samples.noise_pa)}
