"""A sounding's levels, and the rules every reader of :mod:`casrecon.io.sounding` applies to them.

Rules (the same for every format):

- Geopotential height is taken as geometric altitude above mean sea level; the difference is
  under 1 m below 3 km (and about 0.15 % higher up), far inside the other errors here.
- A *level* needs altitude, pressure, temperature, wind direction and speed (or the two wind
  components) and, if the file has a density column, density. A level missing any of them
  (blank field, or -9999/-8888 in IGRA2) is dropped and counted in ``dropped_levels``.
- Text that is present but not a number, and numbers written as NaN or inf, are errors
  (a missing value must be blank or the format's missing code).
- After dropping, altitude must not decrease: a level at the same altitude as the previous
  kept level is dropped (the first is kept) and counted in ``dropped_levels``; a level lower
  than the previous one is an error naming its line.
- Pressure, temperature (K) and density must be positive, wind speed non-negative.
- A present value outside its plausible range (altitude -1 to 100 km, pressure up to
  120 kPa, temperature 100 to 400 K, wind speed up to 200 m/s, density up to 2.5 kg/m^3),
  or one that overflows in its unit conversion, is an error naming its line.
- Fewer than 2 usable levels is an error.
- The dewpoint (humidity) is optional, per level: a level without one is kept, and the
  atmosphere takes its humidity from the levels around it
  (:func:`casrecon.physics.atmosphere.level_vapour_pressure`). A dewpoint outside 150 to 350 K,
  or more than DEWPOINT_ABOVE_T_K above the level's temperature, is an error naming its line; one
  above the temperature by less (rounding) is taken as the temperature (saturated air).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io.errors import InputError
from casrecon.io.sounding_origin import NO_ORIGIN, SoundingOrigin

#: Largest amount (K) a level's dewpoint may exceed its temperature, read as rounding of saturated
#: air (the dewpoint is then taken as the temperature); more is an error.
DEWPOINT_ABOVE_T_K = 0.5
# Plausible range of each quantity in SI (inclusive): altitude from below the Dead Sea to the
# top of any balloon or rocket sounding, surface pressure records, the coldest mesopause and
# hottest surface, the fastest jet stream with margin, and density from vacuum to twice sea level.
_PLAUSIBLE = {"z": ("altitude", "m", -1000.0, 100_000.0), "p": ("pressure", "Pa", 0.0, 120_000.0),
              "t": ("temperature", "K", 100.0, 400.0), "wind": ("wind speed", "m/s", 0.0, 200.0),
              "rho": ("density", "kg/m^3", 0.0, 2.5), "dew": ("dewpoint", "K", 150.0, 350.0)}

@dataclass(frozen=True)
class Sounding:
    """An atmospheric profile from a balloon sounding, SI units, altitude increasing.

    Attributes
    ----------
    path : str
        File read.
    format : str
        ``"wyoming-csv"``, ``"wyoming-list"``, ``"igra2"`` or ``"plain-csv"``.
    altitude_msl_m : numpy.ndarray
        Altitude above mean sea level, m, strictly increasing (geopotential taken as
        geometric).
    pressure_pa : numpy.ndarray
        Static pressure, Pa.
    temperature_k : numpy.ndarray
        Air temperature, K.
    wind_north_mps, wind_east_mps : numpy.ndarray
        Wind velocity (the vector the air moves towards), north and east components, m/s.
    density_kgm3 : numpy.ndarray or None
        Air density, kg/m^3, only when the file gives it.
    description : str
        Station and time, when known.
    dropped_levels : int
        Levels of the file not used: missing a required value, or repeating the altitude of
        the previous kept level.
    dewpoint_k : numpy.ndarray or None
        Dewpoint, K, NaN at levels without one; None when the file gives no dewpoint.
    origin : SoundingOrigin
        Launch time and place as the file gives them (:mod:`casrecon.io.sounding_origin`; fields
        None when it does not).
    """

    path: str
    format: str
    altitude_msl_m: np.ndarray
    pressure_pa: np.ndarray
    temperature_k: np.ndarray
    wind_north_mps: np.ndarray
    wind_east_mps: np.ndarray
    density_kgm3: np.ndarray | None
    description: str
    dropped_levels: int
    dewpoint_k: np.ndarray | None = None
    origin: SoundingOrigin = NO_ORIGIN

    @property
    def n(self) -> int:
        """Number of levels."""
        return int(self.altitude_msl_m.size)

def wind_from_direction(direction_from_deg: np.ndarray | float, speed_mps: np.ndarray | float,
                        ) -> tuple[np.ndarray, np.ndarray]:
    """North and east wind components from meteorological direction and speed.

    Parameters
    ----------
    direction_from_deg : array_like
        Direction the wind blows FROM, degrees clockwise from true north.
    speed_mps : array_like
        Wind speed, m/s.

    Returns
    -------
    (north, east) : tuple of numpy.ndarray
        Components of the velocity of the air (where it blows TOWARDS), m/s. A wind from
        270 deg (west) gives north = 0, east = +speed.
    """
    d = np.radians(np.asarray(direction_from_deg, dtype=np.float64))
    s = np.asarray(speed_mps, dtype=np.float64)
    return -s * np.cos(d), -s * np.sin(d)

def sounding_from_levels(path: str | Path, fmt: str, cols: dict[str, np.ndarray], lines: np.ndarray,
            description: str, origin: SoundingOrigin = NO_ORIGIN) -> Sounding:
    """The Sounding of a reader's columns: incomplete levels dropped, order, signs and
    plausibility checked (the module's rules; errors name ``path`` and the line in ``lines``).

    ``cols`` holds ``z, p, t, wn, we`` and optionally ``rho`` and ``dew`` (SI, NaN = missing; a
    missing dewpoint does not drop its level); ``origin``: the launch time and place the file gives.
    """
    _check_plausible(path, cols, lines)
    have = np.ones(lines.size, dtype=bool)
    for key, v in cols.items():
        if key != "dew":
            have &= np.isfinite(v)
    dropped = int(np.count_nonzero(~have))
    cols = {k: v[have] for k, v in cols.items()}
    lines = np.asarray(lines)[have]
    if lines.size < 2:
        raise InputError(path, f"fewer than 2 usable levels ({lines.size} usable, {dropped} "
                         "dropped for missing values)")
    step = np.diff(cols["z"])
    if np.any(step < 0):
        k = int(np.argmax(step < 0)) + 1
        raise InputError(path, f"altitude decreases ({cols['z'][k - 1]:g} m then "
                         f"{cols['z'][k]:g} m); levels must go upwards", line=int(lines[k]))
    keep = np.concatenate([[True], step > 0])
    dropped += int(np.count_nonzero(~keep))
    cols = {k: v[keep] for k, v in cols.items()}
    lines = lines[keep]
    for key, name in (("p", "pressure"), ("t", "temperature"), ("rho", "density")):
        if key in cols and np.any(cols[key] <= 0):
            k = int(np.argmax(cols[key] <= 0))
            raise InputError(path, f"{name} must be positive, got {cols[key][k]:g} (SI)",
                             line=int(lines[k]), field=name)
    if cols["z"].size < 2:
        raise InputError(path, f"fewer than 2 usable levels ({cols['z'].size} usable, "
                         f"{dropped} dropped for missing values)")
    dew = cols.get("dew")
    if dew is not None:
        with np.errstate(invalid="ignore"):
            above = dew - cols["t"] > DEWPOINT_ABOVE_T_K
        if np.any(above):
            k = int(np.argmax(above))
            raise InputError(path, f"dewpoint {dew[k]:g} K is above the temperature {cols['t'][k]:g} K (by more "
                             f"than {DEWPOINT_ABOVE_T_K:g} K of rounding)", line=int(lines[k]), field="dewpoint")
        with np.errstate(invalid="ignore"):
            dew = np.where(dew > cols["t"], cols["t"], dew)  # NaN (no dewpoint) stays NaN
        if not np.isfinite(dew).any():
            dew = None
    return Sounding(str(path), fmt, cols["z"], cols["p"], cols["t"], cols["wn"], cols["we"],
                    cols.get("rho"), description, dropped, dew, origin)


def _check_plausible(path: str | Path, cols: dict[str, np.ndarray], lines: np.ndarray) -> None:
    """Reject a present value outside what the atmosphere holds (a unit slip, a corrupt digit);
    NaN is missing (dropped later), inf a number that overflowed in its unit conversion."""
    with np.errstate(invalid="ignore", over="ignore"):
        values = dict(cols, wind=np.hypot(cols["wn"], cols["we"]))
    for key, (name, unit, low, high) in _PLAUSIBLE.items():
        v = values.get(key, np.full(lines.size, np.nan))
        bad = ~np.isnan(v) & ~((v >= low) & (v <= high))
        if np.any(bad):
            k = int(np.argmax(bad))
            raise InputError(path, f"{name} {v[k]:g} {unit} (SI) is outside the plausible range "
                             f"[{low:g}, {high:g}] {unit}", line=int(lines[k]), field=name)


def checked_wind(path: str | Path, direction: np.ndarray, speed: np.ndarray, lines: np.ndarray,
                 ) -> tuple[np.ndarray, np.ndarray]:
    """North and east wind (m/s) from direction and speed (see :func:`wind_from_direction`); a
    negative speed is an error naming its line in ``lines``."""
    if np.any(speed < 0):
        k = int(np.argmax(speed < 0))
        raise InputError(path, f"negative wind speed {speed[k]:g}", line=int(lines[k]),
                         field="wind speed")
    return wind_from_direction(direction, speed)
