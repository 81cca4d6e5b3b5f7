"""The world is not the model: the error processes the simulator draws under ``[truth]`` (issue 18;
docs/design.md: Synthetic data), seeded and deterministic.

- **Atmosphere-profile error**: the air the vehicle flies through differs from the sounding the fit
  is given by wind north, wind east and fractional density errors, each a stationary first-order
  Gauss-Markov process in altitude (correlation exp(-|dh| / L)), exactly discretised on a uniform
  grid of step at most :data:`PROFILE_STEP_M` like the disturbances in time (:mod:`casrecon.physics.disturbance`):
  x_k+1 = phi x_k + sigma sqrt(1 - phi^2) e_k, phi = exp(-step / L), x_0 = sigma e_0. Own random
  stream ``(seed, 3)``. :func:`flown_atmosphere` is the sounding's atmosphere sampled on that grid
  plus the error.
- **Coloured GPS errors**: each component of a fix's error is sigma_k (sqrt(1 - f) x_k + sqrt(f) w_k),
  x a unit-variance Gauss-Markov process in time (phi = exp(-dt / tau) between consecutive fixes,
  stationary start) from the random stream ``(seed, 4)``, w the white noise the simulator has always
  drawn, f the white fraction, sigma_k the fix's stated accuracy. A component whose correlation time
  is 0 keeps w unchanged (today's data, bit for bit).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np
from scipy.signal import lfilter

from casrecon.io.truth_errors import TruthErrors
from casrecon.physics.atmosphere import Atmosphere

#: Altitude step of the drawn profile error, m.
PROFILE_STEP_M = 10.0
#: Margin of the profile grid below the ground and above the release, m.
PROFILE_MARGIN_M = 100.0


def unit_gauss_markov(coordinate: np.ndarray, correlation: float, e: np.ndarray) -> np.ndarray:
    """A stationary unit-variance first-order Gauss-Markov process at increasing ``coordinate``
    values (time s or altitude m), exactly discretised: x_0 = e_0, x_k = phi_k x_k-1 + sqrt(1 - phi_k^2) e_k
    with phi_k = exp(-(c_k - c_k-1) / correlation).

    Parameters
    ----------
    coordinate : ndarray, shape (n,)
        Where the process is sampled, strictly increasing (unit of ``correlation``).
    correlation : float
        Correlation time or length (> 0), same unit.
    e : ndarray, shape (n,) or (n, m)
        Independent standard normal innovations (one column per independent process).

    Returns
    -------
    ndarray
        The process, shape of ``e``.
    """
    e = np.asarray(e, float)
    coordinate = np.asarray(coordinate, float)
    step = np.diff(coordinate)
    out = np.empty_like(e)
    if e.shape[0] == 0:
        return out
    out[0] = e[0]
    # uniform up to round-off (UTC stamps near 1.7e9 s carry 2.4e-7 s): a linear filter
    if step.size and np.ptp(step) <= 1e-9 * step.mean() + 4 * np.spacing(np.abs(coordinate).max()):
        phi = np.exp(-step.mean() / correlation)
        out[1:] = lfilter([np.sqrt(1.0 - phi**2)], [1.0, -phi], e[1:], axis=0, zi=phi * e[:1])[0]
        return out
    phi = np.exp(-step / correlation)
    scale = np.sqrt(1.0 - phi**2)
    for k in range(1, e.shape[0]):
        out[k] = phi[k - 1] * out[k - 1] + scale[k - 1] * e[k]
    return out


@dataclass(frozen=True)
class ProfileError:
    """One drawn flown-minus-sounding atmosphere error on a uniform altitude grid.

    Attributes
    ----------
    altitude_msl_m : ndarray
        Grid altitudes, m MSL (uniform, step at most :data:`PROFILE_STEP_M`).
    wind_north_mps, wind_east_mps : ndarray
        Wind error (flown minus sounding), m/s.
    density : ndarray
        Fractional density error e: rho_flown = rho_sounding (1 + e).
    """

    altitude_msl_m: np.ndarray
    wind_north_mps: np.ndarray
    wind_east_mps: np.ndarray
    density: np.ndarray


def profile_grid(sounding_range_m: tuple[float, float], ground_msl_m: float, release_msl_m: float) -> np.ndarray:
    """Uniform altitudes (m MSL, step at most :data:`PROFILE_STEP_M`) from the sounding's bottom to its top, extended
    to :data:`PROFILE_MARGIN_M` below the ground (above the release) where the sounding does not reach
    the ground (the release). Not extended past a sounding end the vehicle does not fly: the
    sounding is constant beyond its ends, and the flown interpolant through that corner would differ
    from the sounding's near it (by 3 mm/s in wind and 1e-4 in density within 10 m of the ground of
    ees-drop-3 for a 100 m extension)."""
    lo = sounding_range_m[0] if sounding_range_m[0] <= ground_msl_m else ground_msl_m - PROFILE_MARGIN_M
    hi = sounding_range_m[1] if sounding_range_m[1] >= release_msl_m else release_msl_m + PROFILE_MARGIN_M
    return np.linspace(lo, hi, int(np.ceil((hi - lo) / PROFILE_STEP_M - 1e-9)) + 1)


def draw_profile_error(errors: TruthErrors, altitude_msl_m: np.ndarray, seed: int) -> ProfileError | None:
    """The profile error of ``seed`` at ``altitude_msl_m`` (increasing), or None when ``errors`` has no
    profile sigma. Random stream ``(seed, 3)``: wind north, wind east and density innovations drawn
    as one (n, 3) array, so that each depends only on the seed and the grid."""
    if not errors.profile:
        return None
    h = np.asarray(altitude_msl_m, float)
    e = np.random.default_rng((seed, 3)).normal(size=(h.size, 3))
    x = unit_gauss_markov(h, errors.profile_length_m, e)
    sigma = np.array([errors.profile_wind_sigma_mps, errors.profile_wind_sigma_mps, errors.profile_density_sigma])
    x = x * sigma
    return ProfileError(h, x[:, 0], x[:, 1], x[:, 2])


def flown_atmosphere(sounding: Atmosphere, error: ProfileError) -> Atmosphere:
    """The atmosphere the vehicle flies: ``sounding`` evaluated at the error's grid altitudes (its
    smooth interpolant, continued beyond its levels as it is) with the wind errors added to north and
    east and the density multiplied by (1 + e); pressure and temperature are the sounding's."""
    h = ca.SX.sym("h")
    air = sounding.at(h)
    values = ca.Function("air", [h], [ca.vertcat(air.pressure, air.temperature, air.density,
                                                 air.wind_ned[0], air.wind_ned[1])])
    grid = error.altitude_msl_m
    p, t, rho, wn, we = np.asarray(values.map(grid.size)(grid[None, :]))
    return Atmosphere(grid, p, t, wn + error.wind_north_mps, we + error.wind_east_mps, rho * (1.0 + error.density),
                      gradient_ref_alt_msl_m=sounding.gradient_ref_alt_msl_m)


def gps_error_factors(time_s: np.ndarray, errors: TruthErrors, white: np.ndarray, seed: int) -> np.ndarray:
    """Each fix's error in units of its stated 1-sigma, columns north, east, down position and
    north, east, down velocity.

    Parameters
    ----------
    time_s : ndarray, shape (n,)
        Fix times, s, increasing.
    errors : TruthErrors
        Correlation times and white fraction.
    white : ndarray, shape (n, 6)
        The white standard normal noise of each fix (the simulator's main random stream).
    seed : int
        Seed of the correlated part's stream ``(seed, 4)`` (drawn as one (n, 6) array).

    Returns
    -------
    ndarray, shape (n, 6)
        ``white`` itself where the component's correlation time is 0, else
        sqrt(1 - f) x + sqrt(f) w with x unit-variance Gauss-Markov.
    """
    if not errors.coloured_gps:
        return white
    f = errors.gps_white_fraction
    e = np.random.default_rng((seed, 4)).normal(size=white.shape)
    out = white.copy()
    for cols, tau in ((slice(0, 3), errors.gps_position_time_s), (slice(3, 6), errors.gps_velocity_time_s)):
        if tau > 0:
            out[:, cols] = np.sqrt(1.0 - f) * unit_gauss_markov(time_s, tau, e[:, cols]) + np.sqrt(f) * white[:, cols]
    return out
