"""The atmosphere-profile error of a 6-DOF fit: how the air the vehicle flew through differs from
the sounding, as unknowns on an altitude grid (docs/design.md: Atmosphere-profile error).

The wind north and east and the relative density differ from the sounding (plus the constant wind
bias and density factor, which stay the profile's mean) by corrections that are stationary
first-order Gauss-Markov processes in altitude, sigma and correlation length L from
``[atmosphere]``. A correction is a uniform cubic B-spline in altitude, c(h) = sum_j g_j B((h - h_j) / step)
with knots at the grid levels h_j = base + j step; its coefficients g_j are the unknowns (scaled by
sigma), with the exactly whitened prior g_0 and (g_j+1 - phi g_j) / sqrt(1 - phi^2),
phi = exp(-step / L). The spline is evaluated at each point's actual altitude, so the model is one
twice-differentiable function of the unknowns whatever the initial guess. Each collocation interval
(and each measurement block on it) sees the coefficients around the cell that holds its guessed
altitude, enough for the correction to be exact for an actual altitude within a tolerance of
that cell (at least 10 m, four times the GPS's vertical 1-sigma; the fit checks that every node
stayed there, ``DropLayout.profile_window_violation``). The corrections enter the model as
per-point additions to the wind-bias and density-factor entries of its parameter vector.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.estimation.sixdof.transcription import selection_matrix
from casrecon.physics.dynamics import PARAMETER_NAMES

#: The corrected quantities, and the FlightModel parameter each is added to.
PROFILE_COMPONENTS = ("wind_n", "wind_e", "density")
PROFILE_PARAMETERS = ("wind_bias_n", "wind_bias_e", "density_factor")
#: Report unit of each corrected quantity and the factor from its SI sigma to that unit.
PROFILE_UNITS = {"wind_n": ("m/s", 1.0), "wind_e": ("m/s", 1.0), "density": ("%", 100.0)}
#: Levels added beyond the guessed altitude range at each end, besides those of the window's reach.
MARGIN_LEVELS = 2
#: Least distance (m) by which a fitted altitude may differ from its guess with the correction
#: still exact (see ProfileGrid.covering's tolerance_m).
LEAST_TOLERANCE_M = 10.0


def cubic_bspline(x):
    """The uniform cubic B-spline basis function centred at 0 (support -2 to 2, twice
    continuously differentiable), of a CasADi or numpy argument in units of the knot step."""
    d = ca.fabs(x)
    return (ca.fmax(0, 2 - d) ** 3 - 4 * ca.fmax(0, 1 - d) ** 3) / 6


@dataclass(frozen=True)
class ProfileGrid:
    """Altitude grid of a drop's profile corrections.

    Attributes
    ----------
    base_msl_m : float
        Altitude of level 0, m MSL.
    step_m : float
        Level spacing, m.
    n_levels : int
    components : tuple of int
        Indices (in PROFILE_COMPONENTS) of the corrected quantities (those with a non-zero sigma).
    sigma : (n_components,) array
        1-sigma of each (m/s, m/s, fraction) as configured: the unknowns' scale (a correction's
        coefficients are sigma times the scaled unknowns), and the prior's unless ``prior_sigma``.
    length_m : float
        Correlation length in altitude, m.
    window_levels : int
        Spline coefficients a block sees: the cubic B-spline's 4 of its guessed cell and
        (window_levels - 4) / 2 more on each side, so that the correction is exact for an actual
        altitude within that many steps of the cell.
    prior_sigma : (n_components,) array or None
        The prior's 1-sigma of each, when it differs from ``sigma`` (a refit with the sizes the
        data say, :mod:`casrecon.estimation.error_models.profile_sigma`): a prior-only change keeps the model's
        expressions, and so their compiled code.
    """

    base_msl_m: float
    step_m: float
    n_levels: int
    components: tuple[int, ...]
    sigma: np.ndarray
    length_m: float
    window_levels: int = 6
    prior_sigma: np.ndarray | None = None

    @classmethod
    def covering(cls, alt_msl_m: np.ndarray, step_m: float, sigmas: tuple[float, float, float],
                 length_m: float, tolerance_m: float = LEAST_TOLERANCE_M) -> ProfileGrid | None:
        """The grid over the guessed altitudes ``alt_msl_m`` (m MSL) whose blocks' windows stay exact
        for fitted altitudes up to ``tolerance_m`` (m) from the guess, with MARGIN_LEVELS more than
        a window reaches at each end; None when every sigma is zero."""
        comps = tuple(i for i, s in enumerate(sigmas) if s > 0)
        if not comps:
            return None
        reach = int(np.ceil(tolerance_m / step_m - 1e-9))
        margin = MARGIN_LEVELS + reach
        lo, hi = float(np.min(alt_msl_m)), float(np.max(alt_msl_m))
        base = np.floor(lo / step_m) * step_m - margin * step_m
        n = int(np.ceil((hi - base) / step_m)) + margin + 1
        return cls(float(base), float(step_m), n, comps, np.asarray(sigmas, float)[list(comps)], float(length_m),
                   4 + 2 * reach)

    @property
    def prior(self) -> np.ndarray:
        """The prior's 1-sigma of each component (m/s, m/s, fraction)."""
        return np.asarray(self.sigma if self.prior_sigma is None else self.prior_sigma, float)

    @property
    def n_components(self) -> int:
        return len(self.components)

    @property
    def size(self) -> int:
        """Number of unknowns (levels x components)."""
        return self.n_levels * self.n_components

    @property
    def phi(self) -> float:
        """Correlation between neighbouring levels."""
        return float(np.exp(-self.step_m / self.length_m))

    @property
    def altitudes_msl_m(self) -> np.ndarray:
        return self.base_msl_m + self.step_m * np.arange(self.n_levels)

    def cell_of(self, alt_msl_m: np.ndarray) -> np.ndarray:
        """Index of the lower level of the cell holding each altitude (clipped to the grid)."""
        j = np.floor((np.asarray(alt_msl_m, float) - self.base_msl_m) / self.step_m).astype(int)
        return np.clip(j, 0, self.n_levels - 2)

    def window_start(self, cells: np.ndarray) -> np.ndarray:
        """First level of the window_levels coefficients seen by a block of each guessed cell."""
        below = 1 + (self.window_levels - 4) // 2
        return np.clip(np.asarray(cells, np.int64) - below, 0, self.n_levels - self.window_levels)

    def window_columns(self, offset: int, cells: np.ndarray) -> np.ndarray:
        """z columns (len(cells), window_levels n_components) of the windows of the guessed cells,
        level by level from the lowest, the components of a level together."""
        n_c = self.n_components
        start = self.window_start(cells)
        return offset + (n_c * start)[:, None] + np.arange(self.window_levels * n_c)[None, :]

    def window_base_msl_m(self, cells: np.ndarray) -> np.ndarray:
        """Altitude (m MSL) of the lowest level of each guessed cell's window."""
        return self.altitudes_msl_m[self.window_start(cells)]

    def outside_windows(self, alt_msl_m: np.ndarray, cells: np.ndarray) -> np.ndarray:
        """True where an altitude (m MSL) lies where its guessed cell's window differs from the
        whole grid's spline: farther from that cell than the window reaches (except past a grid end)."""
        start, w = self.window_start(cells), self.window_levels
        u = (np.asarray(alt_msl_m, float) - self.altitudes_msl_m[start]) / self.step_m
        return ((u < 1) & (start > 0)) | ((u > w - 2) & (start < self.n_levels - w))

    def common_columns(self, offset: int, other: ProfileGrid, other_offset: int) -> tuple[np.ndarray, np.ndarray]:
        """(columns here, columns in ``other``) of the coefficients of the levels both grids have
        (same altitude, same component), for unknowns starting at ``offset`` and ``other_offset``."""
        if other.step_m != self.step_m or other.components != self.components:
            return np.zeros(0, np.int64), np.zeros(0, np.int64)
        shift = int(round((other.base_msl_m - self.base_msl_m) / self.step_m))
        here = np.arange(self.n_levels)
        there = here - shift
        keep = (there >= 0) & (there < other.n_levels)
        n_c = self.n_components
        comp = np.arange(n_c)[None, :]
        return ((offset + n_c * here[keep][:, None] + comp).ravel(),
                (other_offset + n_c * there[keep][:, None] + comp).ravel())

    def coefficients(self, z_profile: np.ndarray) -> np.ndarray:
        """Spline coefficients (n_levels, n_components), SI, from the scaled unknowns."""
        return np.asarray(z_profile).reshape(self.n_levels, self.n_components) * self.sigma

    def level_matrix(self) -> np.ndarray:
        """(n_levels, n_levels) map from the coefficients to the corrections at the levels:
        (g_j-1 + 4 g_j + g_j+1) / 6, a coefficient beyond the grid being zero."""
        return (4 * np.eye(self.n_levels) + np.eye(self.n_levels, k=1) + np.eye(self.n_levels, k=-1)) / 6

    def level_values(self, z_profile: np.ndarray) -> np.ndarray:
        """Corrections at the levels (n_levels, n_components), SI, from the scaled unknowns."""
        return self.level_matrix() @ self.coefficients(z_profile)

    def correction(self, window_values, alt_msl_m, window_base_msl_m):
        """The corrections (n_components) at altitude ``alt_msl_m`` from a window's scaled
        coefficients (window_levels levels of n_components, lowest first, the lowest at
        ``window_base_msl_m``), CasADi or numpy."""
        n_c = self.n_components
        x = (alt_msl_m - window_base_msl_m) / self.step_m
        total = 0
        for k in range(self.window_levels):
            total = total + cubic_bspline(x - k) * window_values[k * n_c:(k + 1) * n_c]
        return total * ca.DM(self.sigma)

    def add_to_parameters(self, p, correction):
        """The FlightModel parameter vector ``p`` with the corrections added to its wind-bias and
        density-factor entries."""
        rows = [PARAMETER_NAMES.index(PROFILE_PARAMETERS[c]) for c in self.components]
        return p + selection_matrix(len(PARAMETER_NAMES), rows) @ correction
