"""The estimated parameters of a fit: names, scaling, priors; and the flight model's own.

Names match ``truth.json``: the dispersion factors (``CA_mult`` ...), ``wind_bias_n``,
``wind_bias_e``, ``density_factor``, ``sounding_shift_m`` (and ``downwash_mps``) are the flight model's
(:func:`model_parameters`); the measurement kinds add theirs (IMU biases, clock offset, ...; see
:mod:`casrecon.estimation.kinds`). Each parameter is an Ipopt variable divided by its ``scale``; a
prior, when on, is a residual ``(value - 0) / sigma``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from casrecon.io.problem import ProblemConfig
from casrecon.physics.aero import DISPERSION_NAMES

#: Name of the sounding's altitude shift (m): the air at altitude h is the sounding's, and the
#: profile corrections', at h - shift (:mod:`casrecon.physics.atmosphere`).
SOUNDING_SHIFT = "sounding_shift_m"


@dataclass(frozen=True)
class ParameterSpec:
    """One estimated parameter.

    Attributes
    ----------
    name : str
    group : str
        Prior group (``"aero"``, ``"atmosphere"``, ``"imu"``, ``"clock"``, ...): its prior's
        residual group is ``prior_<group>``.
    scale : float
        Typical size, SI units: the Ipopt variable is value / scale.
    prior_sigma : float or None
        1-sigma of the zero-mean Gaussian prior, or None when the prior is off.
    unit : str
    """

    name: str
    group: str
    scale: float
    prior_sigma: float | None
    unit: str


@dataclass(frozen=True)
class ParameterSet:
    """The ordered estimated parameters of a fit."""

    specs: tuple[ParameterSpec, ...]

    @property
    def names(self) -> tuple[str, ...]:
        return tuple(s.name for s in self.specs)

    @property
    def n(self) -> int:
        return len(self.specs)

    @property
    def scales(self) -> np.ndarray:
        return np.array([s.scale for s in self.specs])

    def index(self, name: str) -> int:
        return self.names.index(name)

def model_parameters(cfg: ProblemConfig) -> tuple[ParameterSpec, ...]:
    """The flight model's parameters a per-drop fit estimates (dispersions, atmosphere
    corrections, downwash), with priors per ``[estimation]``."""
    est, sizes = cfg.estimation, cfg.aero.sizes
    active = est.estimate or tuple(n for n in DISPERSION_NAMES if getattr(sizes, n) > 0)
    if cfg.aero.vanes is None:
        active = tuple(n for n in active if n != "CLa_mult")
    specs = [ParameterSpec(n, "aero", 1.0 / 3.0, 1.0 / 3.0 if est.dispersion_prior else None, "-")
             for n in DISPERSION_NAMES if n in active]
    wind_sigma = cfg.atmosphere.wind_3sigma_mps / 3.0
    rho_sigma = cfg.atmosphere.density_3sigma / 3.0
    on = est.atmosphere_prior
    specs += [ParameterSpec("wind_bias_n", "atmosphere", wind_sigma, wind_sigma if on else None, "m/s"),
              ParameterSpec("wind_bias_e", "atmosphere", wind_sigma, wind_sigma if on else None, "m/s"),
              ParameterSpec("density_factor", "atmosphere", rho_sigma, rho_sigma if on else None, "-")]
    shift_sigma = cfg.atmosphere.sounding_shift_sigma_m
    if shift_sigma > 0:
        specs.append(ParameterSpec(SOUNDING_SHIFT, "atmosphere", shift_sigma, shift_sigma if on else None, "m"))
    if est.estimate_downwash:
        specs.append(ParameterSpec("downwash_mps", "atmosphere", est.downwash_sigma_mps,
                                   est.downwash_sigma_mps if on else None, "m/s"))
    return tuple(specs)
