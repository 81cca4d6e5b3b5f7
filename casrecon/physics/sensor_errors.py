"""Time-correlated GPS errors: each fix's error is part white, part first-order Gauss-Markov
(docs/design.md: Correlated GPS errors).

For each component c of a fix (position north, east, down; velocity north, east, down) with the
receiver's reported 1-sigma s_k (hAcc, hAcc, vAcc, sAcc, sAcc, sAcc), the error is

    err_k = s_k (sqrt(1 - f_c) w_k + sqrt(f_c) e_k),   e_k+1 = phi_k e_k + sqrt(1 - phi_k^2) n_k,

w and n white N(0, 1), e a stationary unit-variance Gauss-Markov process, phi_k = exp(-dt_k / tau_c)
over the time dt_k between consecutive fixes used (gaps where fixes were dropped included). f_c is
the fraction of the reported variance that is correlated; tau_c its correlation time. A component
with tau 0 is white (today's model). The fit estimates e at every fix (exactly whitened prior, like
the disturbance states); :func:`innovations` whitens a residual series under the same model for
the adequacy tests.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

#: The six components of a GPS fix, in residual order.
GPS_ERROR_COMPONENTS = ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")
#: Largest correlated fraction: the white part left keeps every residual row finite. 0.999 because
#: the real FlySight position errors measured by benchmarks/gps_error_statistics.py have a white part
#: below 0.1 % of hAcc^2 (a fit that forces 1 % on them overstates the fix-to-fix position noise
#: tenfold).
MAX_CORRELATED_FRACTION = 0.999


@dataclass(frozen=True)
class GpsErrorModel:
    """Correlation time and correlated variance fraction of the GPS position and velocity errors.

    The defaults are measured on the real FlySight 1 and 2 tracks of ``../shared/realdata``
    (``benchmarks/gps_error_statistics.py``): position errors are almost entirely correlated and
    still growing after 160 s (tau chosen at 100 s, longer than a drop), velocity errors about half
    (horizontal) to 95 % (vertical) correlated over 0.5 to 0.7 s.

    Parameters
    ----------
    position_time_s, velocity_time_s : float
        Correlation time of the correlated part (s); 0: that group's errors are white.
    position_fraction, velocity_fraction : float
        Fraction of the variance that is correlated, in [0, MAX_CORRELATED_FRACTION].
    position_scale, velocity_scale : float
        The error's 1-sigma (white and correlated parts together) over the receiver's reported
        accuracy (hAcc, vAcc; sAcc or ``velocity_sigma_mps``), > 0: below 1 for a receiver whose
        accuracies are pessimistic. 1: the reported accuracies are the error's size.
    """

    position_time_s: float = 100.0
    velocity_time_s: float = 0.6
    position_fraction: float = 0.99
    velocity_fraction: float = 0.7
    position_scale: float = 1.0
    velocity_scale: float = 1.0

    @classmethod
    def white(cls) -> GpsErrorModel:
        """Every GPS error white (the reported accuracies as independent 1-sigma per fix)."""
        return cls(0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if min(self.position_time_s, self.velocity_time_s) < 0:
            raise ValueError("GPS error correlation times must be >= 0")
        for f in (self.position_fraction, self.velocity_fraction):
            if not 0.0 <= f <= MAX_CORRELATED_FRACTION:
                raise ValueError(f"a correlated fraction must lie in [0, {MAX_CORRELATED_FRACTION}], not {f}")
        if not (self.position_scale > 0 and self.velocity_scale > 0 and np.isfinite(self.position_scale)
                and np.isfinite(self.velocity_scale)):
            raise ValueError(f"GPS accuracy scales must be finite and > 0, not {self.position_scale}, "
                             f"{self.velocity_scale}")

    @property
    def scale(self) -> np.ndarray:
        """The error's 1-sigma over the reported accuracy, for each of the six components."""
        return np.array([self.position_scale] * 3 + [self.velocity_scale] * 3)

    @property
    def time_s(self) -> np.ndarray:
        """Correlation time of each of the six components (s)."""
        return np.array([self.position_time_s] * 3 + [self.velocity_time_s] * 3)

    @property
    def fraction(self) -> np.ndarray:
        """Correlated variance fraction of each of the six components (0 where white)."""
        f = np.array([self.position_fraction] * 3 + [self.velocity_fraction] * 3)
        return np.where(self.time_s > 0, f, 0.0)

    @property
    def active(self) -> np.ndarray:
        """Indices of the components with a correlated part (tau > 0 and f > 0)."""
        return np.flatnonzero((self.time_s > 0) & (self.fraction > 0))

    @property
    def enabled(self) -> bool:
        return bool(self.active.size)

    def transition(self, dt_s: np.ndarray) -> np.ndarray:
        """phi = exp(-dt / tau) of the active components over the steps ``dt_s``, (len(dt), n_active)."""
        tau = self.time_s[self.active]
        return np.exp(-np.asarray(dt_s, float)[:, None] / tau[None, :])

    def whiten(self, normalised: np.ndarray, time_s: np.ndarray) -> np.ndarray:
        """:func:`innovations` of each of the six components of ``normalised`` (n, 6: residuals over
        the fixes' reported sigmas) at fix times ``time_s`` (n,); NaN entries (no fix) are skipped
        and stay NaN."""
        normalised = np.asarray(normalised, float)
        out = np.full_like(normalised, np.nan)
        for c in range(6):
            ok = np.isfinite(normalised[:, c])
            out[ok, c] = innovations(normalised[ok, c], np.asarray(time_s)[ok], self.time_s[c], self.fraction[c])
        return out

    def describe(self) -> str:
        """One line for reports."""
        scaled = "".join(f", {g} accuracies x {v:.3g}" for g, v in (("position", self.position_scale),
                                                                    ("velocity", self.velocity_scale)) if v != 1.0)
        if not self.enabled:
            return "GPS errors white" + scaled
        parts = []
        if self.position_time_s > 0 and self.position_fraction > 0:
            parts.append(f"position {100 * self.position_fraction:.0f} % of the variance over "
                         f"{self.position_time_s:g} s")
        if self.velocity_time_s > 0 and self.velocity_fraction > 0:
            parts.append(f"velocity {100 * self.velocity_fraction:.0f} % over {self.velocity_time_s:g} s")
        return "GPS errors Gauss-Markov: " + ", ".join(parts) + scaled


def innovations(normalised: np.ndarray, time_s: np.ndarray, time_constant_s: float, fraction: float) -> np.ndarray:
    """Whitened innovations of one residual component under the model of the module docstring.

    Parameters
    ----------
    normalised : (n,) array
        Residuals divided by the reported sigma of each fix.
    time_s : (n,) array
        Fix times (s), increasing.
    time_constant_s, fraction : float
        tau and f of the component (tau 0 or f 0: the input is returned, already white).

    Returns
    -------
    (n,) array
        nu_k / sqrt(S_k) from a scalar Kalman filter of e: independent N(0, 1) when the model holds.
    """
    y = np.asarray(normalised, float)
    if time_constant_s <= 0 or fraction <= 0 or y.size == 0:
        return y.copy()
    phi = np.exp(-np.diff(np.asarray(time_s, float)) / time_constant_s)
    a, white = np.sqrt(fraction), 1.0 - fraction
    out = np.empty_like(y)
    m, p = 0.0, 1.0
    for k in range(y.size):
        if k:
            m, p = phi[k - 1] * m, phi[k - 1] ** 2 * p + 1.0 - phi[k - 1] ** 2
        s = a * a * p + white
        nu = y[k] - a * m
        out[k] = nu / np.sqrt(s)
        gain = a * p / s
        m, p = m + gain * nu, p - gain * a * p
    return out
