"""The ``[truth]`` keys of the world-is-not-the-model errors the simulator draws (issue 18): the
difference between the air flown and the sounding the fit is given, and time-correlated GPS errors.
What they mean is in :class:`TruthErrors`; the simulator is :mod:`casrecon.simulation.model_errors`."""

from __future__ import annotations

from dataclasses import dataclass

from casrecon.io.toml_fields import Fields


@dataclass(frozen=True)
class TruthErrors:
    """Atmosphere-profile and coloured GPS errors of the synthetic data (all 0: none, the white GPS
    noise of earlier versions, bit for bit).

    Parameters
    ----------
    profile_wind_sigma_mps : float
        1-sigma of the flown-minus-sounding wind, each of north and east (independent), m/s: a
        stationary first-order Gauss-Markov process in altitude; 0: the vehicle flies the sounding.
    profile_density_sigma : float
        1-sigma of the fractional flown-minus-sounding density e (rho_flown = rho_sounding (1 + e)),
        Gauss-Markov in altitude like the wind; 0: none.
    profile_length_m : float
        Correlation length in altitude of the profile errors, m: correlation exp(-|dh| / L).
    gps_position_time_s : float
        Correlation time of the GPS position error (north, east, down each, independent; first-order
        Gauss-Markov between consecutive fixes, 1-sigma the fix's hAcc or vAcc), s; 0: white.
    gps_velocity_time_s : float
        Correlation time of the GPS velocity error (1-sigma the fix's sAcc), s; 0: white.
    gps_white_fraction : float
        Fraction, in [0, 1], of each coloured component's error variance that is white noise (the rest
        is the Gauss-Markov part); unused for a component whose time is 0.
    """

    profile_wind_sigma_mps: float = 0.0
    profile_density_sigma: float = 0.0
    profile_length_m: float = 300.0
    gps_position_time_s: float = 0.0
    gps_velocity_time_s: float = 0.0
    gps_white_fraction: float = 0.0

    @property
    def profile(self) -> bool:
        """True when the flown atmosphere differs from the sounding."""
        return self.profile_wind_sigma_mps > 0 or self.profile_density_sigma > 0

    @property
    def coloured_gps(self) -> bool:
        """True when a GPS error component is time-correlated."""
        return self.gps_position_time_s > 0 or self.gps_velocity_time_s > 0


def read_truth_errors(t: Fields) -> TruthErrors:
    """The :class:`TruthErrors` keys of a ``[truth]`` table (validated, located errors)."""
    d = TruthErrors()
    white = t.number("gps_white_fraction", d.gps_white_fraction, minimum=0.0)
    if white > 1.0:
        raise t.error("gps_white_fraction", f"expected a fraction in [0, 1], got {white}")
    return TruthErrors(
        profile_wind_sigma_mps=t.number("profile_wind_sigma_mps", d.profile_wind_sigma_mps, minimum=0.0),
        profile_density_sigma=t.number("profile_density_sigma", d.profile_density_sigma, minimum=0.0),
        profile_length_m=t.number("profile_length_m", d.profile_length_m, positive=True),
        gps_position_time_s=t.number("gps_position_time_s", d.gps_position_time_s, minimum=0.0),
        gps_velocity_time_s=t.number("gps_velocity_time_s", d.gps_velocity_time_s, minimum=0.0),
        gps_white_fraction=white)
