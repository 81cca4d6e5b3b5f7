"""Many flights at once: the RK4 step of :class:`~casrecon.simulation.simulate.Simulator` mapped
across a batch of cases, for Monte Carlo statistics.

One CasADi function advances one case by one RK4 step (quaternion renormalised, as in the
simulator) and also returns the total angle of attack of the new state; ``map(batch)`` applies
it column-wise to a (13, batch) state matrix, so Python is entered once per step for the whole
batch. The step length is a per-case input: a case that has landed gets a zero step and stays
where it is while the others fly on.

Impact is found exactly as :class:`Simulator` does it: from the last state above ground, the
RK4 step length that lands on the ground is found by the secant method (vectorised over the
cases). The flight time is therefore ``k dt + h_impact`` with k the number of whole steps.

With a C compiler available the step is generated as C, compiled once per machine (cached in
the temporary folder under a hash of the source) and loaded with ``casadi.external``; that is
about 6 times faster than CasADi's virtual machine. ``backend="casadi"`` forces the virtual
machine. Each case's arithmetic does not depend on which other cases share its batch, so a
case's result is the same whatever the batching, for a given backend.
"""

from __future__ import annotations

import hashlib
import os
import shutil
import subprocess
import tempfile
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import casadi as ca
import numpy as np

from casrecon.physics.dynamics import DISTURBANCE_NAMES, OUTPUT_NAMES, FlightModel
from casrecon.simulation.simulate import rk4_step

#: Default Monte Carlo step, s. Checked against the 500 Hz :class:`Simulator` (tests/integration/
#: test_montecarlo.py): flight time and impact speed agree within 1e-3 s and 1e-3 m/s.
DEFAULT_DT_S = 0.02


@dataclass(frozen=True)
class BatchResult:
    """Impact figures of a batch of cases (arrays of length n).

    Attributes
    ----------
    impacted : (n,) bool
        The ground was reached before ``t_max_s``.
    flight_time_s : (n,) array
        Release to impact, s (``t_max_s`` when not impacted).
    impact_state : (13, n) array
        State at impact (at ``t_max_s`` when not impacted).
    impact_speed_mps : (n,) array
        Ground speed at impact, m/s.
    impact_euler_deg : (3, n) array
        Roll, pitch, yaw at impact, deg.
    max_alpha_t_deg : (n,) array
        Largest total angle of attack over the RK4 step points, release and impact included, deg.
    """

    impacted: np.ndarray
    flight_time_s: np.ndarray
    impact_state: np.ndarray
    impact_speed_mps: np.ndarray
    impact_euler_deg: np.ndarray
    max_alpha_t_deg: np.ndarray


def euler_deg_from_quats(q: np.ndarray) -> np.ndarray:
    """ZYX Euler angles (deg, (3, n)) of quaternions (4, n), as :func:`euler_from_quat`."""
    q0, q1, q2, q3 = q
    n2 = q0 * q0 + q1 * q1 + q2 * q2 + q3 * q3
    phi = np.arctan2(2 * (q0 * q1 + q2 * q3), q0 * q0 - q1 * q1 - q2 * q2 + q3 * q3)
    theta = np.arcsin(np.clip(2 * (q0 * q2 - q3 * q1) / n2, -1.0, 1.0))
    psi = np.arctan2(2 * (q0 * q3 + q1 * q2), q0 * q0 + q1 * q1 - q2 * q2 - q3 * q3)
    return np.degrees(np.vstack([phi, theta, psi]))


def quats_from_euler_deg(euler_deg: np.ndarray) -> np.ndarray:
    """Unit quaternions (4, n) of ZYX Euler angles (3, n) in degrees, as :func:`quat_from_euler`."""
    phi, theta, psi = np.radians(np.asarray(euler_deg, float)) / 2
    cr, sr, cp, sp, cy, sy = np.cos(phi), np.sin(phi), np.cos(theta), np.sin(theta), np.cos(psi), np.sin(psi)
    return np.vstack([cy * cp * cr + sy * sp * sr, cy * cp * sr - sy * sp * cr,
                      cy * sp * cr + sy * cp * sr, sy * cp * cr - cy * sp * sr])


#: Quantities of a case's history (:meth:`BatchSimulator.run_with_history`): altitude above ground
#: (m), inertial speed (m/s), total angle of attack (deg) and pitch angle (deg; roll and yaw are
#: left out: a capsule falls near pitch -90 deg, where they are not defined).
HISTORY_CHANNELS = ("h_agl_m", "speed_mps", "alpha_t_deg", "pitch_deg")
#: Bytes per case per history sample (float32).
HISTORY_SAMPLE_BYTES = 4 * len(HISTORY_CHANNELS)


def history_sample(x: np.ndarray, alpha_t: np.ndarray, flying: np.ndarray) -> np.ndarray:
    """:data:`HISTORY_CHANNELS` (float32, (n, 4)) of states ``x`` (13, n) and total angles of attack
    ``alpha_t`` (rad, (n,)); NaN for the cases not ``flying``."""
    out = np.vstack([-x[2], np.linalg.norm(x[3:6], axis=0), np.degrees(alpha_t),
                     euler_deg_from_quats(x[6:10])[1]]).T.astype(np.float32)
    out[~flying] = np.nan
    return out


def pad_histories(parts: list[np.ndarray | None]) -> np.ndarray:
    """Histories (n_i, k_i, c) of several batches as one (sum n_i, max k_i, c) array, NaN-padded."""
    parts = [p for p in parts if p is not None]
    k = max(p.shape[1] for p in parts)
    out = np.full((sum(p.shape[0] for p in parts), k, parts[0].shape[2]), np.nan, dtype=np.float32)
    row = 0
    for p in parts:
        out[row:row + p.shape[0], :p.shape[1]] = p
        row += p.shape[0]
    return out


def _compiler() -> str | None:
    return os.environ.get("CC") or shutil.which("gcc") or shutil.which("cc") or shutil.which("clang")


def _compiled(fn: ca.Function) -> ca.Function:
    """``fn`` generated as C, compiled (cached by source hash) and loaded; raises on failure."""
    cc = _compiler()
    if cc is None:
        raise RuntimeError("no C compiler found")
    with tempfile.TemporaryDirectory() as tmp:
        cwd = os.getcwd()
        try:
            os.chdir(tmp)
            gen = ca.CodeGenerator("casrecon_mc.c", {"with_header": False})
            gen.add(fn)
            gen.generate()
        finally:
            os.chdir(cwd)
        source = (Path(tmp) / "casrecon_mc.c").read_text()
        key = hashlib.sha256((source + ca.__version__ + cc).encode()).hexdigest()[:20]
        cache = Path(tempfile.gettempdir()) / f"casrecon-{os.getuid() if hasattr(os, 'getuid') else 0}"
        cache.mkdir(exist_ok=True)
        lib = cache / f"mc_{key}.so"
        if not lib.exists():
            part = cache / f".mc_{key}.{os.getpid()}.so"
            subprocess.run([cc, "-O2", "-fPIC", "-shared", str(Path(tmp) / "casrecon_mc.c"), "-o", str(part), "-lm"],
                           check=True, capture_output=True)
            os.replace(part, lib)
    return ca.external(fn.name(), str(lib))


class BatchSimulator:
    """Fixed-step RK4 integration of ``batch`` cases at once to ground impact.

    Parameters
    ----------
    model : FlightModel
    dt_s : float
        RK4 step, s (default :data:`DEFAULT_DT_S`).
    batch : int
        Cases per CasADi call; fewer cases are padded.
    backend : {"auto", "compiled", "casadi"}
        Compiled C (``auto`` falls back to the CasADi virtual machine when compiling fails).
    """

    def __init__(self, model: FlightModel, dt_s: float = DEFAULT_DT_S, batch: int = 250, backend: str = "auto"):
        if backend not in ("auto", "compiled", "casadi"):
            raise ValueError(f"backend must be 'auto', 'compiled' or 'casadi', not {backend!r}")
        if not dt_s > 0:
            raise ValueError(f"dt_s must be positive, got {dt_s}")
        self.model, self.dt_s, self.batch = model, float(dt_s), int(batch)
        x = ca.SX.sym("x", model.n_states)
        p = ca.SX.sym("p", model.n_params)
        h = ca.SX.sym("h")
        no_disturbance = ca.DM.zeros(len(DISTURBANCE_NAMES))
        xn = rk4_step(model.rhs_d, x, p, h, no_disturbance, no_disturbance)
        xn = ca.vertcat(xn[:6], xn[6:10] / ca.norm_2(xn[6:10]), xn[10:])
        alpha_t = model.outputs(xn, p)[OUTPUT_NAMES.index("alpha_t")]
        step = ca.Function("casrecon_mc_step", [x, p, h], [xn, alpha_t])
        self.backend = "casadi"
        if backend != "casadi":
            try:
                step = _compiled(step)
                self.backend = "compiled"
            except (RuntimeError, OSError, subprocess.CalledProcessError):
                if backend == "compiled":
                    raise
        self._step = step.map(self.batch)
        self._alpha_t0 = ca.Function("alpha_t0", [x, p], [model.outputs(x, p)[OUTPUT_NAMES.index("alpha_t")]]
                                     ).map(self.batch)

    def run(self, x0: np.ndarray, params: np.ndarray, t_max_s: float = 300.0) -> BatchResult:
        """Integrate cases ``x0`` (13, n) with parameters ``params`` (np, n) from release (t = 0)."""
        return self.run_with_history(x0, params, t_max_s)[0]

    def run_with_history(self, x0: np.ndarray, params: np.ndarray, t_max_s: float = 300.0, every: int = 0,
                         on_landed: Callable[[int], None] | None = None) -> tuple[BatchResult, np.ndarray | None]:
        """:meth:`run`, and, if ``every`` > 0, each case's :data:`HISTORY_CHANNELS` at release and
        every ``every`` steps (``every * dt_s`` s apart) while it flies: a float32 (n, k, 4) array,
        NaN once the case has landed (k samples up to the last landing, or ``t_max_s``).
        ``on_landed(k)`` is called after each RK4 step in which k > 0 cases reached the ground."""
        x0 = np.asarray(x0, float)
        params = np.asarray(params, float)
        n = x0.shape[1]
        if params.shape != (self.model.n_params, n) or x0.shape[0] != self.model.n_states:
            raise ValueError(f"x0 must be (13, n) and params ({self.model.n_params}, n), got {x0.shape}, "
                             f"{params.shape}")
        parts = [self._run_block(x0[:, s:s + self.batch], params[:, s:s + self.batch], t_max_s, every, on_landed)
                 for s in range(0, n, self.batch)]
        result = BatchResult(*[np.concatenate([getattr(r, f) for r, _ in parts], axis=-1)
                               for f in BatchResult.__dataclass_fields__])
        return result, (pad_histories([h for _, h in parts]) if every > 0 else None)

    def _call(self, x, p, h):
        xn, at = self._step(x, p, h)
        return xn.full(), at.full().ravel()

    def _run_block(self, x0, p, t_max_s, every: int = 0, on_landed=None) -> tuple[BatchResult, np.ndarray | None]:
        m, b, dt = x0.shape[1], self.batch, self.dt_s
        pad = b - m
        x = np.hstack([x0, np.repeat(x0[:, -1:], pad, axis=1)]).copy()
        x[6:10] /= np.linalg.norm(x[6:10], axis=0)
        p = np.hstack([p, np.repeat(p[:, -1:], pad, axis=1)])
        flying = np.ones(b, bool)
        flying[m:] = False                               # padding does not fly
        x_above, k_above = x.copy(), np.zeros(b, int)
        amax = np.asarray(self._alpha_t0(x, p)).ravel()
        samples = [history_sample(x[:, :m], amax[:m], flying[:m])] if every > 0 else []
        n_steps = int(np.floor(t_max_s / dt + 1e-9))
        for k in range(n_steps):
            if not flying.any():
                break
            h = np.where(flying, dt, 0.0)[None, :]
            xn, at = self._call(x, p, h)
            landed = flying & (xn[2] > 0.0)
            x_above[:, landed], k_above[landed] = x[:, landed], k
            if on_landed is not None and landed.any():
                on_landed(int(landed.sum()))
            still = flying & ~landed
            amax[still] = np.maximum(amax[still], at[still])
            flying = still
            x = xn
            if every > 0 and (k + 1) % every == 0 and flying[:m].any():
                samples.append(history_sample(x[:, :m], at[:m], flying[:m]))
        impacted = np.zeros(b, bool)
        impacted[:m] = ~flying[:m]
        # Cases still flying at t_max: report their state at the last step.
        x_above[:, flying], k_above[flying] = x[:, flying], n_steps
        h_imp = np.zeros(b)
        if impacted.any():
            h_imp, x_imp, at_imp = self._secant(x_above, p, impacted)
            amax[impacted] = np.maximum(amax[impacted], at_imp[impacted])
            x_above[:, impacted] = x_imp[:, impacted]
        t = k_above * dt + h_imp
        xi = x_above[:, :m]
        history = np.stack(samples, axis=1) if samples else None
        return BatchResult(impacted[:m], t[:m], xi, np.linalg.norm(xi[3:6], axis=0),
                           euler_deg_from_quats(xi[6:10]), np.degrees(amax[:m])), history

    def _secant(self, x_above, p, mask):
        """Step length from ``x_above`` to the ground (secant method, as :class:`Simulator`)."""
        b = self.batch
        h0, h1 = np.zeros(b), np.full(b, self.dt_s)
        f0 = x_above[2].copy()
        xs, at = self._call(x_above, p, np.where(mask, h1, 0.0)[None, :])
        f1 = xs[2].copy()
        active = mask.copy()
        for _ in range(20):
            active &= ~((np.abs(f1) < 1e-9) | (f1 == f0))
            if not active.any():
                break
            with np.errstate(divide="ignore", invalid="ignore"):
                h_new = h1 - f1 * (h1 - h0) / (f1 - f0)
            h0 = np.where(active, h1, h0)
            f0 = np.where(active, f1, f0)
            h1 = np.where(active, h_new, h1)
            xs_new, _ = self._call(x_above, p, np.where(active, h1, 0.0)[None, :])
            f1 = np.where(active, xs_new[2], f1)
        xs, at = self._call(x_above, p, np.where(mask, h1, 0.0)[None, :])
        return np.where(mask, h1, 0.0), xs, at
