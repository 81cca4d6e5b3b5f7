"""The ``[atmosphere]`` table of a 6-DOF problem: the sounding, its stated uncertainty and the
fit's profile-error model."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from casrecon.io.toml_fields import Fields


@dataclass(frozen=True)
class AtmosphereConfig:
    """Balloon sounding file, its stated uncertainty (3-sigma, as the EES paper gives it) and the
    fit's model of the profile error (1-sigma, Gauss-Markov in altitude; see
    :mod:`casrecon.estimation.profile`)."""

    sounding: Path
    launch: int = 0
    wind_3sigma_mps: float = 1.0
    density_3sigma: float = 0.01
    profile_wind_sigma_mps: float = 0.0
    profile_density_sigma: float = 0.0
    profile_length_m: float = 300.0
    profile_step_m: float = 30.0



def parse_atmosphere(t: Fields) -> AtmosphereConfig:
    """The ``[atmosphere]`` table of a 6-DOF problem, validated (located InputError on a bad key)."""
    cfg = AtmosphereConfig(sounding=t.path_of("sounding", required=True), launch=t.integer("launch", 0, 0),
                           wind_3sigma_mps=t.number("wind_3sigma_mps", 1.0, positive=True),
                           density_3sigma=t.number("density_3sigma", 0.01, positive=True),
                           profile_wind_sigma_mps=t.number("profile_wind_sigma_mps", 0.0, minimum=0.0),
                           profile_density_sigma=t.number("profile_density_sigma", 0.0, minimum=0.0),
                           profile_length_m=t.number("profile_length_m", 300.0, positive=True),
                           profile_step_m=t.number("profile_step_m", 30.0, positive=True))
    if cfg.profile_step_m > cfg.profile_length_m:
        raise t.error("profile_step_m", f"expected a grid step at most the correlation length profile_length_m = "
                                        f"{cfg.profile_length_m:g} m, got {cfg.profile_step_m:g} m")
    t.reject_unknown()
    return cfg
