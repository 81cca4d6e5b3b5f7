"""Forward 6-DOF simulation from release to ground impact.

The integrator is a fixed-step classical Runge-Kutta scheme (RK4, ``substeps`` steps per output
interval) with the quaternion renormalised after each step, built once as a CasADi function and
run in chunks with ``mapaccum`` so that Python is entered once per chunk, not once per step.
An optional disturbance input d(t) (:data:`casrecon.physics.dynamics.DISTURBANCE_NAMES`: gusts,
model-error force and moment) is sampled at the output times and interpolated linearly within each
output interval. Impact is an event: after the chunk in which altitude AGL changes sign, the step length that lands
exactly on the ground is found by the secant method on one RK4 step from the last state above
ground.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.physics.compiled import compiled
from casrecon.physics.dynamics import DISTURBANCE_NAMES, OUTPUT_NAMES, STATE_NAMES, FlightModel
from casrecon.physics.numpy_call import BufferedFunction


@dataclass(frozen=True)
class Trajectory:
    """A simulated flight sampled at uniform times plus the impact instant as last sample.

    Attributes
    ----------
    time_s : (N,) array
        Seconds since release.
    states : (N, 13) array
        States in :data:`casrecon.physics.dynamics.STATE_NAMES` order (SI).
    outputs : (N, len(OUTPUT_NAMES)) array
        Derived quantities in :data:`casrecon.physics.dynamics.OUTPUT_NAMES` order (SI, rad).
    params : (np,) array
        Model parameters used.
    impacted : bool
        Whether the ground was reached before ``t_max``.
    """

    time_s: np.ndarray
    states: np.ndarray
    outputs: np.ndarray
    params: np.ndarray
    impacted: bool

    def state(self, name: str) -> np.ndarray:
        """One state's history by name."""
        return self.states[:, STATE_NAMES.index(name)]

    def output(self, name: str) -> np.ndarray:
        """One output's history by name."""
        return self.outputs[:, OUTPUT_NAMES.index(name)]

    @property
    def flight_time_s(self) -> float:
        return float(self.time_s[-1])

    def table(self) -> tuple[list[str], np.ndarray]:
        """Time history as CSV columns (SI, angles in degrees) and a (N, k) array."""
        deg = np.degrees
        y = self.output
        cols = {"time_s": self.time_s, "pos_n_m": self.state("pos_n"), "pos_e_m": self.state("pos_e"),
                "pos_d_m": self.state("pos_d"), "h_agl_m": y("h_agl"), "vel_n_mps": self.state("vel_n"),
                "vel_e_mps": self.state("vel_e"), "vel_d_mps": self.state("vel_d"),
                "q0": self.state("q0"), "q1": self.state("q1"), "q2": self.state("q2"), "q3": self.state("q3"),
                "roll_deg": deg(y("roll")), "pitch_deg": deg(y("pitch")), "yaw_deg": deg(y("yaw")),
                "p_dps": deg(self.state("omega_x")), "q_dps": deg(self.state("omega_y")),
                "r_dps": deg(self.state("omega_z")), "alpha_deg": deg(y("alpha")), "beta_deg": deg(y("beta")),
                "alpha_t_deg": deg(y("alpha_t")), "qbar_pa": y("qbar"), "mach": y("mach"),
                "airspeed_mps": y("airspeed")}
        return list(cols), np.column_stack(list(cols.values()))

    def summary(self) -> dict:
        """Impact figures: flight time (s), impact speed (m/s), Euler angles (deg), peak rates (deg/s)."""
        vel = self.states[-1, 3:6]
        return {
            "impacted": self.impacted,
            "flight_time_s": self.flight_time_s,
            "impact_speed_mps": float(np.linalg.norm(vel)),
            "impact_velocity_ned_mps": vel.tolist(),
            "impact_euler_deg": np.degrees(self.outputs[-1, 1:4]).tolist(),
            "max_abs_rate_dps": np.degrees(np.abs(self.states[:, 10:13]).max(axis=0)).tolist(),
            "max_total_aoa_deg": float(np.degrees(self.output("alpha_t").max())),
        }


class Simulator:
    """Fixed-step RK4 simulator of a :class:`FlightModel`.

    Parameters
    ----------
    model : FlightModel
    dt_s : float
        Output interval, s (0.002 gives 500 Hz).
    substeps : int
        RK4 steps per output interval.
    chunk : int
        Output intervals integrated per CasADi call.
    """

    def __init__(self, model: FlightModel, dt_s: float = 0.002, substeps: int = 1, chunk: int = 1000):
        self.model, self.dt_s, self.substeps, self.chunk = model, float(dt_s), int(substeps), int(chunk)
        x = ca.SX.sym("x", model.n_states)
        p = ca.SX.sym("p", model.n_params)
        h = ca.SX.sym("h")
        d0, d1 = ca.SX.sym("d0", len(DISTURBANCE_NAMES)), ca.SX.sym("d1", len(DISTURBANCE_NAMES))
        xn, n = x, self.substeps
        for i in range(n):
            xn = rk4_step(model.rhs_d, xn, p, h / n, d0 + (d1 - d0) * i / n, d0 + (d1 - d0) * (i + 1) / n)
        xn = ca.vertcat(xn[:6], xn[6:10] / ca.norm_2(xn[6:10]), xn[10:])
        self.step = ca.Function("rk4_step", [x, p, h, d0, d1], [xn])
        # compiled (and cached on disk) when a C compiler exists: a 40 s drop at 2 ms steps takes
        # 0.30 s instead of 0.56 s, the first time plus about 1 s to compile
        self._run = BufferedFunction(compiled(self.step.mapaccum("rk4_chunk", self.chunk, [0], [0])))
        self._outputs = BufferedFunction(compiled(model.outputs_d.map(self.chunk + 1)))

    def run(self, x0, params, t_max_s: float = 300.0, first_step_s: float | None = None,
            disturbance=None) -> Trajectory:
        """Integrate from ``x0`` (release, t = 0) until ground impact or ``t_max_s``.

        Samples are at 0, t1, t1 + dt, t1 + 2 dt, ... and at impact, where t1 = ``first_step_s``
        (default ``dt_s``); a shorter first step puts the samples on another clock's grid.
        ``disturbance``, if given, maps an array of times since release (s) to the (n, 9)
        disturbance input at those times (SI; :data:`DISTURBANCE_NAMES`).
        """
        x0 = np.asarray(x0, float).copy()
        x0[6:10] /= np.linalg.norm(x0[6:10])
        p = np.asarray(params, float)
        p_rep = np.repeat(p[:, None], self.chunk, axis=1)
        h_rep = np.full(self.chunk, self.dt_s)
        t1 = self.dt_s if first_step_s is None else float(first_step_s)
        if not 0 < t1 <= self.dt_s:
            raise ValueError(f"first_step_s must lie in (0, dt_s], got {t1}")
        dist = _Disturbance(disturbance)
        x1 = np.asarray(self.step(x0, p, t1, *dist.ends(np.array([0.0, t1])))).ravel()
        blocks, x, t_end, impacted = [x0[:, None], x1[:, None]], x1, t1, False
        while t_end < t_max_s:
            xs = self._run(x, p_rep, h_rep, *dist.ends(t_end + self.dt_s * np.arange(self.chunk + 1)))[0]
            below = np.nonzero(xs[2] > 0.0)[0]
            if below.size:
                k = below[0]
                blocks.append(xs[:, :k])
                x_last = xs[:, k - 1] if k > 0 else x
                t_last = t_end + k * self.dt_s
                blocks.append(self._impact_state(x_last, p, dist.at(np.array([t_last]))[:, 0])[:, None])
                t_end = t_last
                impacted = True
                break
            blocks.append(xs)
            x, t_end = xs[:, -1], t_end + self.chunk * self.dt_s
        states = np.hstack(blocks).T
        n = states.shape[0]
        time = np.concatenate([[0.0], t1 + np.arange(n - 1) * self.dt_s])
        if impacted:
            time[-1] = t_end + self._last_h
        return Trajectory(time, states, self._eval_outputs(states, p, dist.at(time).T), p, impacted)

    def _impact_state(self, x_above: np.ndarray, p: np.ndarray, d: np.ndarray) -> np.ndarray:
        """State on the ground, found by the secant method on the step length from ``x_above``
        (the disturbance held at its value at the last sample above ground)."""
        def depth(h: float) -> float:
            return float(self.step(x_above, p, h, d, d)[2])
        h0, h1 = 0.0, self.dt_s
        f0, f1 = x_above[2], depth(h1)
        for _ in range(20):
            if abs(f1) < 1e-9 or f1 == f0:
                break
            h0, h1, f0 = h1, h1 - f1 * (h1 - h0) / (f1 - f0), f1
            f1 = depth(h1)
        self._last_h = h1
        return np.asarray(self.step(x_above, p, h1, d, d)).ravel()

    def _eval_outputs(self, states: np.ndarray, p: np.ndarray, d: np.ndarray) -> np.ndarray:
        out, n, m = [], states.shape[0], self.chunk + 1
        for start in range(0, n, m):
            block, dblock = states[start:start + m], d[start:start + m]
            pad = np.vstack([block, np.repeat(block[-1:], m - block.shape[0], axis=0)])
            dpad = np.vstack([dblock, np.repeat(dblock[-1:], m - dblock.shape[0], axis=0)])
            y = self._outputs(pad.T, np.repeat(p[:, None], m, axis=1), dpad.T)[0].T
            out.append(y[:block.shape[0]])
        return np.vstack(out)


class _Disturbance:
    """The disturbance input at given times: a user function, or zero."""

    def __init__(self, fn) -> None:
        self.fn = fn

    def at(self, t: np.ndarray) -> np.ndarray:
        """(9, n) disturbance at times ``t`` (s since release)."""
        if self.fn is None:
            return np.zeros((len(DISTURBANCE_NAMES), t.size))
        d = np.asarray(self.fn(t), float)
        if d.shape != (t.size, len(DISTURBANCE_NAMES)):
            raise ValueError(f"the disturbance function must return shape ({t.size}, 9), got {d.shape}")
        return d.T

    def ends(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Disturbance at the start and at the end of each step between consecutive times."""
        d = self.at(t)
        return d[:, :-1], d[:, 1:]


def rk4_step(f: ca.Function, x, p, h, d0, d1):
    """One classical Runge-Kutta (RK4) step of dx/dt = f(x, p, d).

    Parameters
    ----------
    f : casadi.Function
        Right-hand side ``(x, p, d) -> dx/dt`` (SI units of the state per s).
    x, p : casadi expression or array
        State at the start of the step and parameters (held constant over the step).
    h : float or casadi expression
        Step length, s.
    d0, d1 : casadi expression or array
        Disturbance input at the start and at the end of the step; linear in between.

    Returns
    -------
    casadi expression or array
        The state after the step (same type as ``x``); the quaternion is not renormalised.
    """
    dm = 0.5 * (d0 + d1)
    k1 = f(x, p, d0)
    k2 = f(x + h / 2 * k1, p, dm)
    k3 = f(x + h / 2 * k2, p, dm)
    k4 = f(x + h * k3, p, d1)
    return x + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
