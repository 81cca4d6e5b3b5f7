"""Errors the fit's models do not contain: families of "the world is not the model" for studies
(issue 49; ``benchmarks/error_families.py``).

The ``[truth]`` error processes (:mod:`.model_errors`) are drawn from the same Gauss-Markov models
the fit assumes, so a study of them shows only that the code is consistent. The families here are
drawn from other shapes, spectra and grids:

- ``turbulence``: von Karman turbulence (the spectrum of MIL-HDBK-1797's continuous gust model)
  in altitude on a 1 m grid (wind north and east; density a fraction of it), plus gusts in
  time (north, east, down) with the same spectrum, so the air has structure down to metre and
  tenth-of-a-second scales; ``turbulence-altitude`` and ``turbulence-time`` are its two parts alone;
- ``fine-grid``: a Gauss-Markov profile error with a 100 m correlation length on a 2 m grid
  (finer and shorter than the fit's 10 m grid and configured length);
- ``coarse-grid``: a profile error given at 250 m levels and held constant between them (steps:
  a sounding interpolated otherwise than the fit does);
- ``density-ramp``: a density error growing linearly with height (from -1.5 % at the ground to
  +1.5 % at the release), no wind error;
- ``wind-jet``: a jet of 2.5 m/s peak in a random direction, Gaussian in altitude of 120 m
  half-width, centred at a random height in the middle half of the drop;
- ``gps-random-walk``: GPS position errors that are a random walk (0.15 m/sqrt(s)) plus the
  stated white noise; velocity errors white;
- ``gps-long-time``: Gauss-Markov GPS errors correlated over 400 s (position) and 40 s (velocity),
  outside the fit's search range;
- ``gps-steps``: position steps at satellite changes (every 8 s on average, each component a
  normal step of the stated 1-sigma), plus the stated white noise;
- ``sounding-pair``: the flown air differs from the sounding as one real sounding of a site differs
  from another of the same site a few hours later (:data:`SOUNDING_PAIRS`, real launches shipped in
  ``casrecon/simulation/sounding_pairs``): wind north, wind east and relative density of the later
  minus the earlier, both taken at the same height above their own lowest level, with the
  difference's mean over the flown heights removed (see :func:`sounding_pair`);
- ``none``: the world is the model (the flown air is the sounding, GPS errors white).

Each family draws from its own random stream ``(seed, 7, crc32(name))`` and never touches the simulator's
main streams, so the IMU and GPS white noise of a drop are the same in every family.
:func:`family_world` gives the :class:`SyntheticWorld` that :func:`~.synthetic.make_synthetic` flies.
"""

from __future__ import annotations

import functools
import zlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io.sounding import read_sounding
from casrecon.io.sounding_levels import Sounding
from casrecon.physics.atmosphere import level_vapour_pressure, moist_density
from casrecon.simulation.model_errors import ProfileError, unit_gauss_markov

#: Constant of the von Karman spectrum: (1 + (1.339 L Omega)^2)^(-5/6).
VON_KARMAN_A = 1.339


@dataclass(frozen=True)
class SyntheticWorld:
    """What a synthetic drop flies and measures beyond its ``[truth]`` table.

    Attributes
    ----------
    name : str
        The family's name (written into the truth document).
    profile_error : ProfileError or None
        Flown-minus-sounding atmosphere replacing the ``[truth]`` one; None: the ``[truth]``'s.
    gusts : callable or None
        Flight time (s, array) -> (n, 3) gust velocity north, east, down (m/s), added to the
        ``[truth]`` disturbance.
    gps_factors : callable or None
        (fix UTC s (n,), white standard normal noise (n, 6), stated 1-sigma (n, 6)) -> (n, 6) error
        of each fix in units of its stated 1-sigma (north, east, down position; north, east, down
        velocity), replacing the ``[truth]`` GPS errors.
    """

    name: str
    profile_error: ProfileError | None = None
    gusts: Callable[[np.ndarray], np.ndarray] | None = None
    gps_factors: Callable[[np.ndarray, np.ndarray, np.ndarray], np.ndarray] | None = None


def von_karman_series(step: float, n: int, length: float, rng: np.random.Generator, columns: int = 1) -> np.ndarray:
    """Unit-variance stationary series with the von Karman spectrum, on ``n`` points ``step`` apart.

    Parameters
    ----------
    step : float
        Grid step (m or s, the unit of ``length``).
    n : int
        Number of points.
    length : float
        Turbulence scale L (same unit as ``step``): one-sided spectrum proportional to
        (1 + (1.339 L Omega)^2)^(-5/6), Omega the angular wavenumber.
    rng : numpy Generator
    columns : int
        Independent series drawn.

    Returns
    -------
    ndarray, shape (n, columns)
        Drawn by spectral synthesis on a periodic grid four times the longest of ``n`` points
        and 8 L (so that the period does not show), first ``n`` points kept, scaled so that the
        discrete spectrum sums to one (unit variance in expectation).
    """
    m = int(2 ** np.ceil(np.log2(max(4 * n, 8 * length / step, 16))))
    omega = 2 * np.pi * np.fft.rfftfreq(m, step)
    shape = (1.0 + (VON_KARMAN_A * length * omega) ** 2) ** (-5.0 / 6.0)
    shape[0] = 0.0  # zero mean over the period
    weights = np.concatenate([shape, shape[1:-1][::-1]])  # two-sided, discrete
    amplitude = np.sqrt(m * weights / weights.sum())  # ifft(fft(white) a) has variance sum(a^2) / m
    noise = rng.normal(size=(m, columns))
    x = np.fft.ifft(np.fft.fft(noise, axis=0) * amplitude[:, None], axis=0).real
    return x[:n]


def _profile(altitude_m: np.ndarray, wind_north: np.ndarray, wind_east: np.ndarray,
             density: np.ndarray) -> ProfileError:
    return ProfileError(np.asarray(altitude_m, float), np.asarray(wind_north, float), np.asarray(wind_east, float),
                        np.asarray(density, float))


def _grid(lo_m: float, hi_m: float, step_m: float) -> np.ndarray:
    return np.linspace(lo_m, hi_m, int(np.ceil((hi_m - lo_m) / step_m - 1e-9)) + 1)


@dataclass(frozen=True)
class Span:
    """Where the drop flies: the profile grid's ends (m MSL), the ground and release (m MSL) and
    the GPS fixes' and the flight's duration (s)."""

    lo_msl_m: float
    hi_msl_m: float
    ground_msl_m: float
    release_msl_m: float
    flight_s: float


def turbulence(span: Span, rng: np.random.Generator, wind_sigma_mps: float = 0.5, density_sigma: float = 0.003,
               length_m: float = 300.0, gust_sigma_mps: float = 0.3, gust_time_s: float = 2.0) -> SyntheticWorld:
    """Von Karman profile error on a 1 m grid and von Karman gusts in time (see the module)."""
    h = _grid(span.lo_msl_m, span.hi_msl_m, 1.0)
    x = von_karman_series(1.0, h.size, length_m, rng, 3)
    step_s = 0.01
    t = np.arange(-1.0, span.flight_s + 5.0, step_s)
    g = von_karman_series(step_s, t.size, gust_time_s, rng, 3) * gust_sigma_mps * np.array([1.0, 1.0, 0.6])

    def gusts(time_s: np.ndarray) -> np.ndarray:
        return np.column_stack([np.interp(time_s, t, g[:, i]) for i in range(3)])

    return SyntheticWorld("turbulence", _profile(h, wind_sigma_mps * x[:, 0], wind_sigma_mps * x[:, 1],
                                                 density_sigma * x[:, 2]), gusts=gusts)


def turbulence_altitude(span: Span, rng: np.random.Generator) -> SyntheticWorld:
    """:func:`turbulence`'s profile error alone (no gusts in time)."""
    world = turbulence(span, rng)
    return SyntheticWorld("turbulence-altitude", world.profile_error)


def turbulence_time(span: Span, rng: np.random.Generator) -> SyntheticWorld:
    """:func:`turbulence`'s gusts in time alone (the flown profile is the sounding's)."""
    world = turbulence(span, rng)
    return SyntheticWorld("turbulence-time", gusts=world.gusts)


def fine_grid(span: Span, rng: np.random.Generator, wind_sigma_mps: float = 0.5, density_sigma: float = 0.005,
              length_m: float = 100.0) -> SyntheticWorld:
    """Gauss-Markov profile error of a 100 m length on a 2 m grid."""
    h = _grid(span.lo_msl_m, span.hi_msl_m, 2.0)
    x = unit_gauss_markov(h, length_m, rng.normal(size=(h.size, 3)))
    return SyntheticWorld("fine-grid", _profile(h, wind_sigma_mps * x[:, 0], wind_sigma_mps * x[:, 1],
                                                density_sigma * x[:, 2]))


def coarse_grid(span: Span, rng: np.random.Generator, wind_sigma_mps: float = 0.5, density_sigma: float = 0.005,
                level_step_m: float = 250.0) -> SyntheticWorld:
    """Independent profile errors at 250 m levels, held constant between them (on a 1 m grid)."""
    levels = np.arange(span.lo_msl_m, span.hi_msl_m + level_step_m, level_step_m)
    v = rng.normal(size=(levels.size, 3)) * np.array([wind_sigma_mps, wind_sigma_mps, density_sigma])
    h = _grid(span.lo_msl_m, span.hi_msl_m, 1.0)
    idx = np.clip(np.searchsorted(levels, h, side="right") - 1, 0, levels.size - 1)
    return SyntheticWorld("coarse-grid", _profile(h, v[idx, 0], v[idx, 1], v[idx, 2]))


def density_ramp(span: Span, rng: np.random.Generator, change: float = 0.03) -> SyntheticWorld:
    """Density error linear in height, -change/2 at the ground to +change/2 at the release (no wind
    error; ``rng`` unused: the ramp is the same for every seed)."""
    h = _grid(span.lo_msl_m, span.hi_msl_m, 10.0)
    frac = (h - span.ground_msl_m) / max(span.release_msl_m - span.ground_msl_m, 1.0)
    zero = np.zeros_like(h)
    return SyntheticWorld("density-ramp", _profile(h, zero, zero, change * (np.clip(frac, 0.0, 1.0) - 0.5)))


def wind_jet(span: Span, rng: np.random.Generator, peak_mps: float = 2.5,
             half_width_m: float = 120.0) -> SyntheticWorld:
    """A Gaussian wind jet in altitude, random direction and height in the middle half of the drop."""
    h = _grid(span.lo_msl_m, span.hi_msl_m, 5.0)
    centre = span.ground_msl_m + (span.release_msl_m - span.ground_msl_m) * rng.uniform(0.25, 0.75)
    heading = rng.uniform(0.0, 2 * np.pi)
    shape = peak_mps * np.exp(-0.5 * ((h - centre) / half_width_m) ** 2)
    return SyntheticWorld("wind-jet", _profile(h, shape * np.cos(heading), shape * np.sin(heading), np.zeros_like(h)))


def gps_random_walk(span: Span, rng: np.random.Generator, walk_m_per_sqrt_s: float = 0.15) -> SyntheticWorld:
    """Position errors: a random walk (m/sqrt(s), each component, from 0 at the first fix) plus the
    stated white noise; velocity errors white (the walk, in metres, is divided by each fix's stated
    sigma to give its factor)."""
    seed = int(rng.integers(2**31))

    def factors(utc_s: np.ndarray, white: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        dt = np.diff(utc_s, prepend=utc_s[0])
        steps = np.random.default_rng(seed).normal(size=(utc_s.size, 3)) * np.sqrt(dt)[:, None]
        walk = np.cumsum(steps, axis=0) * walk_m_per_sqrt_s
        out = white.copy()
        out[:, :3] += walk / sigma[:, :3]
        return out

    return SyntheticWorld("gps-random-walk", gps_factors=factors)


def gps_long_time(span: Span, rng: np.random.Generator, position_time_s: float = 400.0,
                  velocity_time_s: float = 40.0, white_fraction: float = 0.1) -> SyntheticWorld:
    """Gauss-Markov GPS errors correlated over 400 s (position) and 40 s (velocity), 10 % white."""
    seed = int(rng.integers(2**31))

    def factors(utc_s: np.ndarray, white: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        e = np.random.default_rng(seed).normal(size=white.shape)
        out = white.copy()
        for cols, tau in ((slice(0, 3), position_time_s), (slice(3, 6), velocity_time_s)):
            out[:, cols] = (np.sqrt(1 - white_fraction) * unit_gauss_markov(utc_s, tau, e[:, cols])
                            + np.sqrt(white_fraction) * white[:, cols])
        return out

    return SyntheticWorld("gps-long-time", gps_factors=factors)


def gps_steps(span: Span, rng: np.random.Generator, mean_interval_s: float = 8.0) -> SyntheticWorld:
    """Position steps at satellite changes (Poisson, ``mean_interval_s`` apart on average; each
    component a normal step of the fix's stated 1-sigma) plus the stated white noise."""
    seed = int(rng.integers(2**31))

    def factors(utc_s: np.ndarray, white: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        r = np.random.default_rng(seed)
        dt = np.diff(utc_s, prepend=utc_s[0])
        change = r.uniform(size=utc_s.size) < dt / mean_interval_s
        offset = np.cumsum(change[:, None] * r.normal(size=(utc_s.size, 3)), axis=0)
        out = white.copy()
        out[:, :3] += offset
        return out

    return SyntheticWorld("gps-steps", gps_factors=factors)


#: Where the real soundings of :data:`SOUNDING_PAIRS` are (package data; sources and licences in its README.md).
SOUNDING_DIR = Path(__file__).resolve().parent / "sounding_pairs"
#: How far apart in time (h) the two launches of a pair may be.
PAIR_HOURS = (3.0, 24.0)
#: Altitude step (m) of a pair's difference profile and of the family's grid.
PAIR_STEP_M = 5.0


@dataclass(frozen=True)
class SoundingPair:
    """Two real soundings of one site a few hours apart: the earlier (``first``) and the later
    (``second``), each a file of :data:`SOUNDING_DIR` (or of the directory given) and its 0-based
    IGRA2 launch (ignored by the other formats)."""

    name: str
    first: str
    second: str
    first_launch: int = 0
    second_launch: int = 0


#: The real pairs the ``sounding-pair`` family draws from (provenance and licences:
#: ``casrecon/simulation/sounding_pairs/README.md``).
SOUNDING_PAIRS = (
    SoundingPair("Utqiagvik AK 2010-06-01 00Z to 12Z (IGRA2)", "USM00070026-data.txt",
                 "USM00070026-data.txt", 0, 1),
    SoundingPair("Utqiagvik AK 2014-09-10 00Z to 12Z (IGRA2 derived)",
                 "BRW_USM00070026_2014-09-10_00Z.csv",
                 "BRW_USM00070026_2014-09-10_12Z.csv"),
    SoundingPair("Nashville TN 2014-02-20 12Z to 02-21 12Z (Wyoming)",
                 "BNA_72327_2014-02-20_12Z_wyoming.txt",
                 "BNA_72327_2014-02-21_12Z_wyoming.txt"),
)


@dataclass(frozen=True)
class PairDifference:
    """Later-minus-earlier sounding of a :class:`SoundingPair` against height above each one's
    lowest level.

    Attributes
    ----------
    pair : SoundingPair
    hours : float
        Time between the launches, h (from the files' own dates).
    height_agl_m : ndarray
        Height above the lowest level, m, uniform (:data:`PAIR_STEP_M`) from 0 to the lower of the
        two tops.
    wind_north_mps, wind_east_mps : ndarray
        Wind difference, m/s.
    density : ndarray
        Relative density difference rho_later / rho_earlier - 1.
    """

    pair: SoundingPair
    hours: float
    height_agl_m: np.ndarray
    wind_north_mps: np.ndarray
    wind_east_mps: np.ndarray
    density: np.ndarray


def _same_site(a: Sounding, b: Sounding) -> bool:
    oa, ob = a.origin, b.origin
    if oa.lat_deg is None or ob.lat_deg is None:
        return True  # the files do not say where; the pair's name and README do
    return abs(oa.lat_deg - ob.lat_deg) < 0.1 and abs(oa.lon_deg - ob.lon_deg) < 0.1


@functools.lru_cache(maxsize=32)
def pair_difference(pair: SoundingPair, directory: Path = SOUNDING_DIR) -> PairDifference:
    """Read a pair's two soundings (:func:`casrecon.io.sounding.read_sounding`) and difference them.

    Each sounding is referred to its own lowest usable level (its surface: the two launches of
    a site start at the same height up to the launch-pad, and a lowest level below the ground
    would be dropped for its missing values); wind north, wind east and the natural log of the
    moist density (:func:`casrecon.physics.atmosphere.moist_density`, humidity from the dewpoints)
    are interpolated linearly in that height, the same as the fit's atmosphere resamples levels,
    onto a :data:`PAIR_STEP_M` grid; the difference is later minus earlier.

    Raises
    ------
    InputError
        A file that cannot be read (named, with the line).
    ValueError
        Launch times (from the files) not :data:`PAIR_HOURS` apart, or two different places.
    """
    a = read_sounding(Path(directory) / pair.first, pair.first_launch)
    b = read_sounding(Path(directory) / pair.second, pair.second_launch)
    ta, tb = a.origin.time_unix_s, b.origin.time_unix_s
    if ta is None or tb is None:
        raise ValueError(f"sounding pair {pair.name!r}: a file gives no launch time")
    hours = (tb - ta) / 3600.0
    if not PAIR_HOURS[0] <= hours <= PAIR_HOURS[1]:
        raise ValueError(f"sounding pair {pair.name!r}: the launches are {hours:g} h apart; expected the "
                         f"later {PAIR_HOURS[0]:g} to {PAIR_HOURS[1]:g} h after the earlier")
    if not _same_site(a, b):
        raise ValueError(f"sounding pair {pair.name!r}: the two files give different places")
    top = min(a.altitude_msl_m[-1] - a.altitude_msl_m[0], b.altitude_msl_m[-1] - b.altitude_msl_m[0])
    h = np.arange(0.0, top + 1e-9, PAIR_STEP_M)

    def on_grid(s: Sounding) -> np.ndarray:
        e = level_vapour_pressure(s.altitude_msl_m, s.pressure_pa, s.dewpoint_k)
        rho = s.density_kgm3 if s.density_kgm3 is not None else moist_density(s.pressure_pa, s.temperature_k, e)
        agl = s.altitude_msl_m - s.altitude_msl_m[0]
        return np.array([np.interp(h, agl, v) for v in (s.wind_north_mps, s.wind_east_mps, np.log(rho))])

    d = on_grid(b) - on_grid(a)
    return PairDifference(pair, hours, h, d[0], d[1], np.expm1(d[2]))


def sounding_pair(span: Span, rng: np.random.Generator, pairs: tuple[SoundingPair, ...] = SOUNDING_PAIRS,
                  directory: Path = SOUNDING_DIR) -> SyntheticWorld:
    """The flown air = the sounding + a real pair's difference (:func:`pair_difference`).

    Each seed draws one of ``pairs`` (uniformly) and a sign (+1: later minus earlier, -1: earlier
    minus later; both are differences a sounding hours old shows). The difference is placed at the
    same height above the drop's ground as above the pair's surface (held at its surface value
    below the ground), on a :data:`PAIR_STEP_M` grid, and its mean over the flown heights (ground to
    release) is removed from each of wind north, wind east and density: a constant offset is what
    the fit's wind biases and density factor are for, and the truth's values of those parameters
    stay the ones drawn from their priors; what is left is the difference's shape over the drop.

    Raises
    ------
    ValueError
        A pair whose soundings do not reach the span's top above their surface (and as
        :func:`pair_difference`).
    """
    pair = pairs[int(rng.integers(len(pairs)))]
    sign = float(rng.choice([-1.0, 1.0]))
    diff = pair_difference(pair, Path(directory))
    h = _grid(span.lo_msl_m, span.hi_msl_m, PAIR_STEP_M)
    agl = np.clip(h - span.ground_msl_m, 0.0, None)
    if agl[-1] > diff.height_agl_m[-1]:
        raise ValueError(f"sounding pair {pair.name!r} reaches {diff.height_agl_m[-1]:g} m above its surface; "
                         f"the drop needs {agl[-1]:g} m")
    flown = (h >= span.ground_msl_m) & (h <= span.release_msl_m)
    out = []
    for v in (diff.wind_north_mps, diff.wind_east_mps, diff.density):
        x = sign * np.interp(agl, diff.height_agl_m, v)
        out.append(x - x[flown].mean())
    return SyntheticWorld("sounding-pair", _profile(h, *out))


def no_error(span: Span, rng: np.random.Generator) -> SyntheticWorld:
    """The world is the model: the ``[truth]``'s profile error (none, on a problem without one),
    white GPS errors."""

    def white(utc_s: np.ndarray, noise: np.ndarray, sigma: np.ndarray) -> np.ndarray:
        return noise

    return SyntheticWorld("none", gps_factors=white)


#: Every family, by name: (span, rng) -> SyntheticWorld.
FAMILIES: dict[str, Callable[[Span, np.random.Generator], SyntheticWorld]] = {
    "turbulence": turbulence,
    "turbulence-altitude": turbulence_altitude,
    "turbulence-time": turbulence_time,
    "fine-grid": fine_grid,
    "coarse-grid": coarse_grid,
    "density-ramp": density_ramp,
    "wind-jet": wind_jet,
    "gps-random-walk": gps_random_walk,
    "gps-long-time": gps_long_time,
    "gps-steps": gps_steps,
    "sounding-pair": sounding_pair,
    "none": no_error,
}
#: The atmosphere families: their data's GPS errors are white (the family is the only model error).
ATMOSPHERE_FAMILIES = ("turbulence", "turbulence-altitude", "turbulence-time", "fine-grid", "coarse-grid",
                       "density-ramp", "wind-jet", "sounding-pair")


def with_air_scaled(world: SyntheticWorld, factor: float) -> SyntheticWorld:
    """``world`` with its air's departures from the sounding (profile error: wind and density; gusts)
    times ``factor`` (e.g. 2: twice the size); its GPS errors unchanged."""
    profile, gusts = world.profile_error, world.gusts
    if profile is not None:
        profile = ProfileError(profile.altitude_msl_m, factor * profile.wind_north_mps, factor * profile.wind_east_mps,
                               factor * profile.density)
    if gusts is not None:
        gusts = functools.partial(_scaled_gusts, gusts, factor)
    return SyntheticWorld(world.name if factor == 1.0 else f"{world.name} x{factor:g}", profile, gusts,
                          world.gps_factors)


def _scaled_gusts(gusts: Callable[[np.ndarray], np.ndarray], factor: float, time_s: np.ndarray) -> np.ndarray:
    return factor * gusts(time_s)


def family_world(name: str, span: Span, seed: int) -> SyntheticWorld:
    """The world of family ``name`` for drop ``seed`` (own random stream ``(seed, 7, crc32(name))``,
    so a family's draws do not move when families are added). ValueError for an unknown family."""
    if name not in FAMILIES:
        raise ValueError(f"unknown error family {name!r}; expected one of {', '.join(FAMILIES)}")
    return FAMILIES[name](span, np.random.default_rng((seed, 7, zlib.crc32(name.encode()))))
