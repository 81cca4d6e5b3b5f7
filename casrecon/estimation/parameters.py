"""The estimated parameters of one drop: names, scaling, priors, and where each one goes.

Names match ``truth.json``: the dispersion factors (``CA_mult`` ...), ``wind_bias_n``,
``wind_bias_e``, ``density_factor``, ``accel_bias_x/y/z`` (m/s^2, IMU axes), ``gyro_bias_x/y/z``
(rad/s, IMU axes) and ``clock_offset_s``. Each parameter is an Ipopt variable divided by its
``scale``; a prior, when on, is a residual ``(value - 0) / sigma``.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from casrecon.io.problem import ProblemConfig
from casrecon.physics.aero import DISPERSION_NAMES
from casrecon.physics.dynamics import PARAMETER_NAMES

SENSOR_NAMES = tuple(f"{k}_bias_{a}" for k in ("accel", "gyro") for a in "xyz")


@dataclass(frozen=True)
class ParameterSpec:
    """One estimated parameter.

    Attributes
    ----------
    name : str
    group : str
        ``"aero"``, ``"atmosphere"``, ``"imu"`` or ``"clock"`` (the residual group of its prior).
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

    def model_selection(self) -> list[tuple[int, int]]:
        """(model parameter index, estimated index) pairs for the FlightModel parameter vector."""
        return [(PARAMETER_NAMES.index(s.name), i) for i, s in enumerate(self.specs) if s.name in PARAMETER_NAMES]



def parameter_set(cfg: ProblemConfig) -> ParameterSet:
    """The parameters a per-drop fit estimates, with priors per ``[estimation]``."""
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
    if est.estimate_downwash:
        specs.append(ParameterSpec("downwash_mps", "atmosphere", est.downwash_sigma_mps,
                                   est.downwash_sigma_mps if on else None, "m/s"))
    for name in SENSOR_NAMES:
        sigma = cfg.imu.accel_bias_sigma_mps2 if name.startswith("accel") else cfg.imu.gyro_bias_sigma_radps
        unit = "m/s^2" if name.startswith("accel") else "rad/s"
        specs.append(ParameterSpec(name, "imu", sigma, sigma if est.imu_bias_prior else None, unit))
    if est.estimate_clock:
        specs.append(ParameterSpec("clock_offset_s", "clock", est.clock_sigma_s,
                                   est.clock_sigma_s if est.clock_prior else None, "s"))
    return ParameterSet(tuple(specs))
