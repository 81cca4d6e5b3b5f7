"""From a validated :class:`~casrecon.io.problem.ProblemConfig` to the physics objects of one drop.

A :class:`Scenario` holds the atmosphere read from the sounding, the :class:`FlightModel`, and
knows the release state and the truth parameter vector, so the simulator, the synthetic-data
writer and (later) the estimator all start from the same place.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io.problem import ProblemConfig, load_problem
from casrecon.io.sounding import Sounding, read_sounding
from casrecon.io.toml_fields import TomlDocument
from casrecon.physics.aero import DISPERSION_NAMES
from casrecon.physics.atmosphere import Atmosphere
from casrecon.physics.dynamics import FlightModel, default_parameters
from casrecon.physics.rotations import euler_deg_to_quat


@dataclass(frozen=True)
class Scenario:
    """One drop's configuration with its atmosphere and flight model built; ``sounding`` is the
    sounding file as read (once: the pre-solve data check reads its levels from here)."""

    config: ProblemConfig
    atmosphere: Atmosphere
    model: FlightModel
    sounding: Sounding | None = None

    @classmethod
    def load(cls, source: str | Path | TomlDocument) -> Scenario:
        """Parse ``problem.toml`` (file or folder, or its parsed document) and build the model."""
        return cls.from_config(load_problem(source))

    @classmethod
    def from_config(cls, config: ProblemConfig) -> Scenario:
        sounding = read_sounding(config.atmosphere.sounding, launch=config.atmosphere.launch)
        atmosphere = Atmosphere.from_sounding(sounding, gradient_ref_alt_msl_m=config.site.ground_alt_msl_m,
                                              humidity=config.atmosphere.humidity)
        return cls(config, atmosphere, _flight_model(config, atmosphere), sounding)

    def with_fresh_functions(self) -> Scenario:
        """The same drop with its CasADi interpolants (the sounding's, the aero tables') made anew,
        and the model with them; the numbers are the same to the bit. CasADi keeps the derivative
        functions made from an interpolant with it, and they are part of the serialised expression
        that names a compiled library (:mod:`casrecon.physics.compiled`): a fit that reused another
        fit's interpolants named its libraries differently from a first fit and compiled them again
        (7 s once per vehicle and mesh rate). Each fit starts from fresh ones."""
        aero = self.config.aero  # a coefficient table's interpolant is made in its __post_init__
        config = dataclasses.replace(self.config, aero=dataclasses.replace(
            aero, coefficients=dataclasses.replace(aero.coefficients)))
        atmosphere = self.atmosphere.copy()
        return Scenario(config, atmosphere, _flight_model(config, atmosphere), self.sounding)

    def flying(self, atmosphere: Atmosphere) -> Scenario:
        """The same drop through another atmosphere (a new Scenario whose model flies ``atmosphere``;
        this one and its configuration, the sounding file included, are unchanged)."""
        return Scenario(self.config, atmosphere, _flight_model(self.config, atmosphere), self.sounding)

    @property
    def release_alt_msl_m(self) -> float:
        """Release altitude, m MSL."""
        return self.config.site.ground_alt_msl_m + self.config.release.h_agl_m

    def release_state(self) -> np.ndarray:
        """State vector at release from ``[release]`` (SI, NED position of the centre of mass)."""
        r = self.config.release
        return np.concatenate([[r.pos_ne_m[0], r.pos_ne_m[1], -r.h_agl_m], r.vel_ned_mps,
                               euler_deg_to_quat(r.euler_deg), np.radians(r.rates_dps)])

    def truth_parameters(self) -> np.ndarray:
        """Model parameter vector of ``[truth]`` (zeros where no truth is given)."""
        t = self.config.truth
        if t is None:
            return default_parameters()
        values = {n: t.dispersions[n] for n in DISPERSION_NAMES}
        values.update(wind_bias_n=t.wind_bias_mps[0], wind_bias_e=t.wind_bias_mps[1],
                      density_factor=t.density_factor, downwash_mps=t.downwash_mps,
                      sounding_shift_m=t.sounding_shift_m)
        return default_parameters(**values)


def _flight_model(config: ProblemConfig, atmosphere: Atmosphere) -> FlightModel:
    release_msl = config.site.ground_alt_msl_m + config.release.h_agl_m
    return FlightModel(config.vehicle, config.aero, atmosphere, config.site, config.dynamics, release_msl)
