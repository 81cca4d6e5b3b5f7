"""The IMU kind: the collocation interval block, which carries the dynamics defects and the
residuals of every IMU sample in the interval (see :mod:`casrecon.estimation.sixdof.transcription`), and
the accelerometer and gyro biases (IMU axes) it adds.

The IMU sets the mesh and the fit window, so it is present in every 6-DOF fit; its interval
blocks hold the collocation defects (the determining constraints of the NLP).
"""

from __future__ import annotations

import casadi as ca
import numpy as np

from casrecon.estimation.engine.blocks import BlockKind, BlockSet, Term
from casrecon.estimation.kinds.base import DropContext
from casrecon.estimation.sixdof.fitdata import FitData
from casrecon.estimation.sixdof.initial_guess import initial_guess
from casrecon.estimation.sixdof.layout import BlockLocals
from casrecon.estimation.sixdof.parameters import ParameterSpec
from casrecon.estimation.sixdof.subgrid import SubgridModel
from casrecon.estimation.sixdof.transcription import (
    D_OFFSETS,
    R_OFFSETS,
    channel_bases,
    compress_imu,
    interval_function,
)
from casrecon.io.problem import ProblemConfig
from casrecon.physics.dynamics import PARAMETER_NAMES
from casrecon.physics.numpy_call import numpy_call

#: Names of the IMU bias parameters (accelerometer m/s^2, gyro rad/s; IMU axes).
SENSOR_NAMES = tuple(f"{k}_bias_{a}" for k in ("accel", "gyro") for a in "xyz")
#: The six IMU channels (specific force x, y, z; rate x, y, z), IMU axes.
IMU_CHANNELS = ("ax", "ay", "az", "wx", "wy", "wz")


def imu_sigma(config: ProblemConfig) -> np.ndarray:
    """1-sigma white noise of the six channels (m/s^2, rad/s)."""
    return np.r_[np.full(3, config.imu.accel_noise_mps2), np.full(3, config.imu.gyro_noise_radps)]


def measured_imu(data: FitData, n_samples: int) -> tuple[np.ndarray, np.ndarray]:
    """Measured IMU output (n, 6; IMU axes, SI) and its validity mask for the first ``n_samples``
    samples of the window."""
    y = np.column_stack([data.accel_imu, data.gyro_imu])[:n_samples]
    valid = np.column_stack([data.accel_valid, data.gyro_valid])[:n_samples]
    return y, valid


class ImuKind:
    """Dynamics defects and IMU samples per collocation interval; accelerometer and gyro biases."""

    name = "imu"

    def parameters(self, config: ProblemConfig) -> tuple[ParameterSpec, ...]:
        on = config.estimation.imu_bias_prior
        specs = []
        for name in SENSOR_NAMES:
            accel = name.startswith("accel")
            sigma = config.imu.accel_bias_sigma_mps2 if accel else config.imu.gyro_bias_sigma_radps
            specs.append(ParameterSpec(name, "imu", sigma, sigma if on else None, "m/s^2" if accel else "rad/s"))
        return tuple(specs)

    def load(self, config: ProblemConfig, data: FitData) -> FitData:
        return data

    def terms(self, context: DropContext) -> list[Term]:
        layout, model = context.layout, context.model
        mesh = layout.mesh
        n_int, k = mesh.n_intervals, mesh.samples_per_interval
        y, valid = measured_imu(context.data, n_int * k)
        subgrid = subgrid_model(context)
        blocks = compress_imu(mesh, y, valid, imu_sigma(context.config), subgrid and subgrid.imu_covariance)
        loc = BlockLocals(layout, collocation=True)
        d, rr = ca.SX.sym("d", int(D_OFFSETS[-1])), ca.SX.sym("R", int(R_OFFSETS[-1]))
        bu = ca.SX.sym("bu", 13 * layout.n_u) if subgrid else ca.SX(0, 1)
        xk, xk1, theta, uk, uk1 = loc.split()
        um, ui = (loc.midpoint_u(), loc.subgrid_integral()) if layout.n_u else (uk, uk)
        defect, r_imu, _ = interval_function(model, mesh.h, layout.active)(
            xk, xk1, loc.point_params(theta, xk), loc.point_params(theta, xk1), loc.select(theta, SENSOR_NAMES), d,
            rr, uk, uk1, um, ui, bu)
        kicks = [bu] if subgrid else []
        kind = BlockKind("interval", loc.symbol, [d, rr, *kicks, *loc.data], r_imu, defect)
        k_all = np.arange(n_int)
        kick_data = [ca.DM(subgrid.state_sensitivity)] if subgrid else []
        blockset = BlockSet(kind, layout.two_node_columns(k_all, collocation=True),
                            [ca.DM(blocks.d), ca.DM(blocks.R), *kick_data, *layout.profile_block_data(k_all)])
        return [Term(context.group(self.name), (blockset,), float(blocks.const_chi2.sum()), int(blocks.n_used.sum()))]

    def residuals(self, result) -> dict[str, np.ndarray]:
        """Measured minus predicted IMU output at every sample of the fit (IMU axes, SI), with sigma
        and the validity mask (False where saturated and masked)."""
        layout, data = result.part, result.data
        mesh, model = layout.mesh, result.scenario.model
        n, k = mesh.n_intervals, mesh.samples_per_interval
        _, b = model_and_bias_values(result)
        f = interval_function(model, mesh.h, layout.active).map(n, "thread", 2)
        x = result.states.T
        u = layout.disturbances(result.z)[:, list(layout.active)].T
        u_mid = layout.midpoint_disturbances(result.z)[:, list(layout.active)].T
        pk, pk1 = interval_parameters(result)
        coefs = numpy_call(f, x[:, :-1], x[:, 1:], pk, pk1, np.tile(b[:, None], n),
                           np.zeros((int(D_OFFSETS[-1]), n)), np.zeros((int(R_OFFSETS[-1]), n)),
                           u[:, :-1], u[:, 1:], u_mid, np.zeros_like(u_mid), np.zeros((13 * layout.n_u, n)))[2]
        pred = np.zeros((n * k, 6))
        for c, basis in enumerate(channel_bases(k)):
            pred[:, c] = (basis @ coefs[D_OFFSETS[c]:D_OFFSETS[c + 1]]).T.ravel()
        y, valid = measured_imu(data, n * k)
        return {"time_imu_s": data.imu_time_s[:n * k], "residual": y - pred, "valid": valid,
                "sigma": imu_sigma(result.scenario.config)}


def subgrid_model(context: DropContext) -> SubgridModel | None:
    """With disturbance states, what they do between the nodes (:mod:`casrecon.estimation.sixdof.subgrid`),
    its sensitivities taken on the initial guess; None without them."""
    layout, model, cfg = context.layout, context.model, context.config
    if not layout.n_u:
        return None
    states = initial_guess(context.data, layout.mesh, cfg.vehicle, model.atmosphere, cfg.site.ground_alt_msl_m)
    return SubgridModel.on(model, layout.active, layout.u_scale, np.asarray(layout.disturbance.time_s)[
        list(layout.active)], layout.mesh.h, layout.mesh.samples_per_interval, states, np.zeros(model.n_params))


def interval_parameters(result) -> tuple[np.ndarray, np.ndarray]:
    """The model parameters (n_params, n_intervals) at the first and the second node of every
    interval of a fit: its estimates plus, with a profile, each interval's profile corrections."""
    layout = result.part
    loc = BlockLocals(layout)
    xk, xk1, theta, _, _ = loc.split()
    fn = ca.Function("interval_parameters", [loc.symbol, *loc.data],
                     [loc.point_params(theta, xk), loc.point_params(theta, xk1)])
    k = np.arange(layout.mesh.n_intervals)
    cols = layout.two_node_columns(k)
    pk, pk1 = fn.map(k.size)(result.z[cols].T, *layout.profile_block_data(k))
    return np.asarray(pk), np.asarray(pk1)


def model_and_bias_values(result) -> tuple[np.ndarray, np.ndarray]:
    """FlightModel parameter vector and the 6 IMU biases (SI) of a fit's estimates (0 for what it
    did not estimate)."""
    names = result.params.names

    def pick(wanted: tuple[str, ...]) -> np.ndarray:
        return np.array([float(result.values[names.index(n)]) if n in names else 0.0 for n in wanted])

    return pick(PARAMETER_NAMES), pick(SENSOR_NAMES)
