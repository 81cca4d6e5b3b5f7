"""First-order Gauss-Markov disturbances: gusts and model-error force and moment (issue 5;
docs/design.md: Weak-constraint disturbances).

Each active entry of the disturbance input d (:data:`casrecon.physics.dynamics.DISTURBANCE_NAMES`)
is a stationary first-order Gauss-Markov process of standard deviation sigma and correlation time
tau: dd/dt = -d / tau + w, w white. Its exact discretisation over a step h is

    d(t + h) = phi d(t) + sigma sqrt(1 - phi^2) e,   phi = exp(-h / tau),   e ~ N(0, 1),

which the simulator samples (:meth:`DisturbanceModel.sample`) and the fit uses as the prior of the
values of d at the nodes and interval midpoints, in time order (weak-constraint option): the
residuals (d_k+1 - phi d_k) / (sigma sqrt(1 - phi^2)) per half interval and d_0 / sigma at the first
node are exactly whitened.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

N_DISTURBANCES = 9


@dataclass(frozen=True)
class DisturbanceModel:
    """Sigma and correlation time of each disturbance entry; sigma 0 means absent.

    Parameters
    ----------
    sigma : tuple of 9 float
        1-sigma of gust N, E, D (m/s), model-error force x, y, z (N, body axes) and moment x, y, z
        (N m, body axes, about the centre of mass).
    time_s : tuple of 9 float
        Correlation time of each entry, s.
    """

    sigma: tuple[float, ...]
    time_s: tuple[float, ...]

    def __post_init__(self) -> None:
        if len(self.sigma) != N_DISTURBANCES or len(self.time_s) != N_DISTURBANCES:
            raise ValueError("a disturbance model needs 9 sigmas and 9 correlation times")
        if min(self.sigma) < 0 or min(self.time_s) <= 0:
            raise ValueError("disturbance sigmas must be >= 0 and correlation times > 0")

    @property
    def active(self) -> np.ndarray:
        """Indices of the entries with a non-zero sigma."""
        return np.flatnonzero(np.asarray(self.sigma) > 0)

    def transition(self, h: float) -> np.ndarray:
        """phi = exp(-h / tau) of the active entries over a step of ``h`` seconds."""
        return np.exp(-h / np.asarray(self.time_s)[self.active])

    def step_sigma(self, h: float) -> np.ndarray:
        """1-sigma of the innovation over a step of ``h`` seconds, active entries."""
        return np.asarray(self.sigma)[self.active] * np.sqrt(1.0 - self.transition(h) ** 2)

    def sample(self, t: np.ndarray, rng: np.random.Generator) -> np.ndarray:
        """A realisation at increasing times ``t`` (s), (len(t), 9), starting stationary."""
        t = np.asarray(t, float)
        out = np.zeros((t.size, N_DISTURBANCES))
        act = self.active
        if act.size == 0 or t.size == 0:
            return out
        sigma, tau = np.asarray(self.sigma)[act], np.asarray(self.time_s)[act]
        e = rng.normal(size=(t.size, act.size))
        phi = np.exp(-np.diff(t)[:, None] / tau[None, :])
        d = sigma * e[0]
        out[0, act] = d
        scale = sigma * np.sqrt(1.0 - phi**2)
        for k in range(1, t.size):
            d = phi[k - 1] * d + scale[k - 1] * e[k]
            out[k, act] = d
        return out
