"""The atmosphere-profile error of a 6-DOF fit: how the air the vehicle flew through differs from
the sounding, as unknowns on an altitude grid (docs/design.md: Atmosphere-profile error).

The wind north and east and the relative density differ from the sounding (plus the constant wind
bias and density factor, which stay the profile's mean) by corrections that are stationary
first-order Gauss-Markov processes in altitude, sigma and correlation length L from
``[atmosphere]``. Their values at the grid levels h_j = base + j step are unknowns (scaled by
sigma), with the exactly whitened prior g_0 and (g_j+1 - phi g_j) / sqrt(1 - phi^2),
phi = exp(-step / L). Between levels the correction is linear in altitude. Each collocation
interval (and each measurement block on it) sees the two levels of the cell that holds the
interval's guessed altitude and evaluates the line through them at its points' actual altitudes
(so a point a metre past a level extrapolates that cell's line by that metre). The corrections
enter the model as per-point additions to the wind-bias and density-factor entries of its
parameter vector.
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

from casrecon.estimation.transcription import selection_matrix
from casrecon.physics.dynamics import PARAMETER_NAMES

#: The corrected quantities, and the FlightModel parameter each is added to.
PROFILE_COMPONENTS = ("wind_n", "wind_e", "density")
PROFILE_PARAMETERS = ("wind_bias_n", "wind_bias_e", "density_factor")
#: Levels added beyond the guessed altitude range at each end.
MARGIN_LEVELS = 2


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
        1-sigma of each (m/s, m/s, fraction).
    length_m : float
        Correlation length in altitude, m.
    """

    base_msl_m: float
    step_m: float
    n_levels: int
    components: tuple[int, ...]
    sigma: np.ndarray
    length_m: float

    @classmethod
    def covering(cls, alt_msl_m: np.ndarray, step_m: float, sigmas: tuple[float, float, float],
                 length_m: float) -> ProfileGrid | None:
        """The grid over the altitudes ``alt_msl_m`` (m MSL) with MARGIN_LEVELS more at each end;
        None when every sigma is zero."""
        comps = tuple(i for i, s in enumerate(sigmas) if s > 0)
        if not comps:
            return None
        lo, hi = float(np.min(alt_msl_m)), float(np.max(alt_msl_m))
        base = np.floor(lo / step_m) * step_m - MARGIN_LEVELS * step_m
        n = int(np.ceil((hi - base) / step_m)) + MARGIN_LEVELS + 1
        return cls(float(base), float(step_m), n, comps, np.asarray(sigmas, float)[list(comps)], float(length_m))

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

    def cell_columns(self, offset: int, cells: np.ndarray) -> np.ndarray:
        """z columns (len(cells), 2 n_components) of the two levels of each cell, lower level first."""
        n_c = self.n_components
        return offset + (n_c * np.asarray(cells, np.int64))[:, None] + np.arange(2 * n_c)[None, :]

    def values(self, z_profile: np.ndarray) -> np.ndarray:
        """Corrections at the levels (n_levels, n_components), SI, from the scaled unknowns."""
        return np.asarray(z_profile).reshape(self.n_levels, self.n_components) * self.sigma

    def correction(self, cell_values, alt_msl_m, cell_base_msl_m):
        """The corrections (n_components) at altitude ``alt_msl_m`` on a cell's line, from the
        cell's scaled level values [lower (n_c), upper (n_c)] (CasADi or numpy)."""
        n_c = self.n_components
        lower, upper = cell_values[:n_c], cell_values[n_c:2 * n_c]
        frac = (alt_msl_m - cell_base_msl_m) / self.step_m
        return (lower + frac * (upper - lower)) * ca.DM(self.sigma)

    def add_to_parameters(self, p, correction):
        """The FlightModel parameter vector ``p`` with the corrections added to its wind-bias and
        density-factor entries."""
        rows = [PARAMETER_NAMES.index(PROFILE_PARAMETERS[c]) for c in self.components]
        return p + selection_matrix(len(PARAMETER_NAMES), rows) @ correction
