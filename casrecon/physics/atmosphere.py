"""Atmosphere from a balloon sounding: smooth CasADi interpolants in altitude (docs/design.md: Atmosphere).

Pressure and density are interpolated in their logarithms, temperature and the wind components
linearly in value, all by cubic B-splines (``casadi.interpolant(..., 'bspline')``) so that Ipopt
sees exact, continuous derivatives. Beyond each end level every interpolated quantity continues by
its spline's second-order Taylor polynomial at that level, for up to EXTENSION_M, and is held
beyond: the model stays twice differentiable where a fitted trajectory crosses an end level (a
drop's last nodes cross the lowest level, usually the ground). Clamping there instead made the
derivatives jump, and Ipopt circled such an optimum for 200 iterations. Inside the sounding the
values are the spline's, unchanged.

Estimable corrections act on the balloon's profile:

- ``wind_bias`` (north, east), m/s, added at every altitude, and an optional linear change of that
  bias with altitude (``wind_gradient``, 1/s, per metre above ``gradient_ref_alt_msl_m``);
- ``density_factor`` (dimensionless): rho = rho_balloon (1 + density_factor);
- ``altitude_shift_m`` (m): the balloon's profile as it lies in the drop's frame, every level
  ``altitude_shift_m`` higher than the sounding states, air(h) = balloon(h - altitude_shift_m). A
  sounding's altitudes are registered to a few metres at best (the radiosonde's GPS or its
  hypsometric heights), and its features move up and down between the balloon's and the drop's
  place and time: without the shift a fit reads its absolute altitude from the sounding's wind
  shape, to centimetres, and is wrong by metres where the air differs (docs/design/error-models.md).

Humidity: where the sounding gives a dewpoint, the density is that of moist air,
rho = p / (R_d T) (1 - (1 - eps) e / p) with e the vapour pressure at the dewpoint (Bolton's
formula) and eps = R_d / R_v, up to 1 % below the dry p / (R_d T) in warm humid air (0.04 to
1.0 % over the lowest 3 km of the five real soundings in ../shared/realdata); levels without a
dewpoint take the mixing ratio interpolated in altitude from the levels that have one (held
beyond them). The speed of sound stays the dry sqrt(gamma R_d T): humidity raises it by under
0.3 % (at a vapour pressure of 3 % of p).
"""

from __future__ import annotations

from dataclasses import dataclass

import casadi as ca
import numpy as np

#: Specific gas constant of dry air, J/(kg K).
R_AIR = 287.05287
#: Specific gas constant of water vapour, J/(kg K).
R_VAPOUR = 461.5
#: R_AIR / R_VAPOUR: the molar mass of water over that of dry air.
EPSILON = R_AIR / R_VAPOUR
#: Ratio of specific heats of air.
GAMMA_AIR = 1.4
#: How far (m) beyond each end level of the sounding its Taylor continuation reaches (see the
#: module docstring); the values are held beyond.
EXTENSION_M = 100.0


@dataclass(frozen=True)
class AtmosphereCorrections:
    """Symbolic or numeric corrections applied to the balloon profile (see module docstring)."""

    wind_bias_n: object = 0.0
    wind_bias_e: object = 0.0
    density_factor: object = 0.0
    wind_gradient_n: object = 0.0
    wind_gradient_e: object = 0.0
    altitude_shift_m: object = 0.0


@dataclass(frozen=True)
class AtmosphereState:
    """Air properties at one point: density kg/m^3, temperature K, pressure Pa, speed of sound m/s,
    wind (NED, where the air moves to) m/s."""

    density: object
    temperature: object
    pressure: object
    sound_speed: object
    wind_ned: object


class Atmosphere:
    """Interpolated balloon atmosphere.

    Parameters
    ----------
    altitude_msl_m, pressure_pa, temperature_k, wind_north_mps, wind_east_mps : array_like
        The sounding's levels, altitude strictly increasing.
    density_kgm3 : array_like, optional
        Measured density; computed from p, T and the humidity when absent.
    gradient_ref_alt_msl_m : float
        Altitude at which the wind-gradient correction is zero, m MSL.
    dewpoint_k : array_like, optional
        Dewpoint of each level, K, NaN where the level has none (see the module docstring); no
        dewpoint at all: dry air. Not used when the density is given.
    """

    def __init__(self, altitude_msl_m, pressure_pa, temperature_k, wind_north_mps, wind_east_mps,
                 density_kgm3=None, gradient_ref_alt_msl_m: float = 0.0, dewpoint_k=None) -> None:
        h = np.asarray(altitude_msl_m, dtype=float)
        if h.ndim != 1 or h.size < 2 or np.any(np.diff(h) <= 0):
            raise ValueError("atmosphere altitudes must be a strictly increasing list of >= 2 levels")
        p = np.asarray(pressure_pa, dtype=float)
        t = np.asarray(temperature_k, dtype=float)
        e = level_vapour_pressure(h, p, dewpoint_k)
        rho = moist_density(p, t, e) if density_kgm3 is None else np.asarray(density_kgm3, dtype=float)
        self.altitude_range_m = (float(h[0]), float(h[-1]))
        self.gradient_ref_alt_msl_m = float(gradient_ref_alt_msl_m)
        self._levels = {"altitude_msl_m": h, "pressure_pa": p, "temperature_k": t,
                        "wind_north_mps": np.asarray(wind_north_mps, float),
                        "wind_east_mps": np.asarray(wind_east_mps, float), "density_kgm3": rho,
                        "vapour_pressure_pa": e}
        grid, data = _resample(h, np.vstack([np.log(p), t, np.log(rho), wind_north_mps, wind_east_mps]))
        self._table = ca.interpolant("atmosphere", "bspline", [grid], data.T.ravel().tolist())
        self._ends = tuple(_taylor_coefficients(self._table, end) for end in self.altitude_range_m)

    @classmethod
    def from_sounding(cls, sounding, gradient_ref_alt_msl_m: float = 0.0, humidity: bool = True) -> Atmosphere:
        """Build from a :class:`casrecon.io.sounding_levels.Sounding` (or anything with its fields);
        ``humidity``: False ignores the sounding's dewpoints (dry air, p / (R_d T))."""
        return cls(sounding.altitude_msl_m, sounding.pressure_pa, sounding.temperature_k,
                   sounding.wind_north_mps, sounding.wind_east_mps, sounding.density_kgm3,
                   gradient_ref_alt_msl_m, getattr(sounding, "dewpoint_k", None) if humidity else None)

    @classmethod
    def standard(cls, bottom_msl_m: float = -500.0, top_msl_m: float = 11000.0) -> Atmosphere:
        """The ICAO/US-1976 standard atmosphere (troposphere: 288.15 K and 101325 Pa at sea level,
        -6.5 K/km) with no wind, for tracks with no sounding nearby."""
        h = np.arange(bottom_msl_m, top_msl_m + 1.0, 50.0)
        t = 288.15 - 0.0065 * h
        p = 101325.0 * (t / 288.15) ** (9.80665 / (R_AIR * 0.0065))
        zero = np.zeros_like(h)
        return cls(h, p, t, zero, zero)

    def copy(self) -> Atmosphere:
        """The same atmosphere (the same levels, values to the bit) with a new CasADi interpolant,
        which holds none of the derivative functions made from this one's."""
        lv = self._levels
        out = Atmosphere(lv["altitude_msl_m"], lv["pressure_pa"], lv["temperature_k"], lv["wind_north_mps"],
                         lv["wind_east_mps"], lv["density_kgm3"], self.gradient_ref_alt_msl_m)
        out._levels["vapour_pressure_pa"] = lv["vapour_pressure_pa"]
        return out

    @property
    def levels(self) -> dict[str, np.ndarray]:
        """The sounding levels this atmosphere was built from (SI units)."""
        return dict(self._levels)

    def at(self, alt_msl_m, corr: AtmosphereCorrections = AtmosphereCorrections()) -> AtmosphereState:
        """Air properties at altitude ``alt_msl_m`` (m MSL, symbolic or numeric): the sounding's at
        ``alt_msl_m - corr.altitude_shift_m``, corrected by ``corr``."""
        lo, hi = self.altitude_range_m
        (v_lo, d1_lo, d2_lo), (v_hi, d1_hi, d2_hi) = self._ends
        level = alt_msl_m - corr.altitude_shift_m  # where in the sounding's own altitudes
        u_lo, u_hi = ca.fmax(level - lo, -EXTENSION_M), ca.fmin(level - hi, EXTENSION_M)
        values = ca.if_else(level < lo, v_lo + u_lo * (d1_lo + 0.5 * u_lo * d2_lo),
                            ca.if_else(level > hi, v_hi + u_hi * (d1_hi + 0.5 * u_hi * d2_hi),
                                       self._table(ca.fmin(ca.fmax(level, lo), hi))))
        p, t = ca.exp(values[0]), values[1]
        rho = ca.exp(values[2]) * (1 + corr.density_factor)
        dh = alt_msl_m - self.gradient_ref_alt_msl_m
        wind = ca.vertcat(values[3] + corr.wind_bias_n + corr.wind_gradient_n * dh,
                          values[4] + corr.wind_bias_e + corr.wind_gradient_e * dh, 0)
        return AtmosphereState(rho, t, p, ca.sqrt(GAMMA_AIR * R_AIR * t), wind)


def standard_pressure(alt_msl_m: np.ndarray | float) -> np.ndarray:
    """Pressure, Pa, of the ICAO standard atmosphere's troposphere (288.15 K and 101325 Pa at sea level,
    -6.5 K/km; the law :meth:`Atmosphere.standard` tabulates) at ``alt_msl_m`` (m MSL, below 11 km)."""
    t = 288.15 - 0.0065 * np.asarray(alt_msl_m, dtype=float)
    return 101325.0 * (t / 288.15) ** (9.80665 / (R_AIR * 0.0065))


def vapour_pressure(dewpoint_k: np.ndarray | float) -> np.ndarray:
    """Water-vapour pressure, Pa, of air whose dewpoint is ``dewpoint_k`` (K): the saturation
    vapour pressure over water at the dewpoint, by Bolton's (1980) formula
    e = 611.2 exp(17.67 t / (t + 243.5)), t the dewpoint in deg C (within 0.1 % from -30 to 35 C)."""
    t_c = np.asarray(dewpoint_k, dtype=float) - 273.15
    return 611.2 * np.exp(17.67 * t_c / (t_c + 243.5))


def moist_density(pressure_pa: np.ndarray | float, temperature_k: np.ndarray | float,
                  vapour_pressure_pa: np.ndarray | float = 0.0) -> np.ndarray:
    """Density of moist air, kg/m^3: dry air at p - e plus water vapour at e, both at T,
    rho = p / (R_d T) (1 - (1 - EPSILON) e / p) (e = 0: the dry p / (R_d T))."""
    p = np.asarray(pressure_pa, dtype=float)
    return p / (R_AIR * np.asarray(temperature_k, dtype=float)) * (1.0 - (1.0 - EPSILON) * vapour_pressure_pa / p)


def level_vapour_pressure(altitude_msl_m: np.ndarray, pressure_pa: np.ndarray,
                          dewpoint_k: np.ndarray | None = None) -> np.ndarray:
    """Vapour pressure (Pa) at every level: from the level's dewpoint where it has one, else from
    the mixing ratio eps e / (p - e) interpolated linearly in altitude between the levels that
    have one and held beyond them; zero at every level when no level has a dewpoint."""
    p = np.asarray(pressure_pa, dtype=float)
    if dewpoint_k is None:
        return np.zeros_like(p)
    dew = np.asarray(dewpoint_k, dtype=float)
    known = np.isfinite(dew)
    if not known.any():
        return np.zeros_like(p)
    e_known = vapour_pressure(dew[known])
    ratio = np.interp(altitude_msl_m, np.asarray(altitude_msl_m, float)[known],
                      EPSILON * e_known / (p[known] - e_known))
    return p * ratio / (EPSILON + ratio)


def _taylor_coefficients(table: ca.Function, alt_msl_m: float) -> tuple[ca.DM, ca.DM, ca.DM]:
    """(value, first derivative, second derivative) in altitude of every row of the interpolant
    ``table`` at ``alt_msl_m`` (an end level: the derivatives of its end cell's polynomial)."""
    h = ca.SX.sym("h")
    value = table(h)
    slope = ca.jacobian(value, h)
    derivatives = ca.Function("derivatives", [h], [value, slope, ca.jacobian(slope, h)])
    return tuple(ca.DM(v) for v in derivatives(alt_msl_m))


def _resample(h: np.ndarray, data: np.ndarray, step_m: float = 10.0):
    """Resample levels linearly onto a uniform grid so the B-spline cannot ring between sparse
    levels; the spline then smooths the corners of the linear profile over about one step."""
    n = max(int(np.ceil((h[-1] - h[0]) / step_m)) + 1, 4)
    grid = np.linspace(h[0], h[-1], n)
    return grid, np.vstack([np.interp(grid, h, row) for row in data])
