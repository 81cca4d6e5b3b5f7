"""The interface of a *sample* measurement kind: timed samples of a vector that a function of the
body's state at the sample's time predicts, plus the kind's own constant parameters.

A sample kind is written once and enters both the 6-DOF fit
(:class:`~casrecon.estimation.kinds.sample_terms.SampleTerms`, through ``fit_drop(...,
sample_kinds=...)``) and the kinematic fit (:func:`casrecon.estimation.kinematic.samples.sample_terms`,
through ``fit_kinematic(..., sample_kinds=...)``). Each fit builds a :class:`BodyState` at every
sample's time from its own unknowns, asks the kind for its prediction and whitens
``(y - predict) / sigma`` per component; the kind knows neither fit nor the engine.

Frames and units: SI throughout, positions and velocities in the site's NED frame (origin on the
ground below the site point), quaternions scalar first. The *reference point* is the 6-DOF fit's
centre of mass with body axes, the kinematic fit's IMU with IMU axes: a kind that needs a lever arm
is given the one of the fit it is used in. A kind needing the air velocity
(``air_velocity_body_mps``) cannot be used in a kinematic fit, which has no wind: it reads it with
:func:`air_velocity`, which raises a ValueError saying so.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from typing import Protocol

import casadi as ca
import numpy as np

from casrecon.estimation.sixdof.parameters import ParameterSpec


@dataclass(frozen=True)
class BodyState:
    """The body's state at one sample's time, as CasADi expressions of the fit's unknowns (SI, NED).

    Attributes
    ----------
    position_ned_m : SX (3,)
        The fit's reference point (6-DOF: centre of mass; kinematic: the IMU), m NED.
    velocity_ned_mps : SX (3,)
        Its velocity, m/s NED.
    quaternion : SX (4,)
        Rotation of the fit's axes (6-DOF: body; kinematic: IMU) into NED, scalar first, unit norm
        only to the solver's tolerance.
    alt_msl_m : SX
        Altitude of the reference point, m above mean sea level.
    pressure_pa, density_kgpm3 : SX
        The atmosphere's static pressure (Pa) and density (kg/m^3) at that altitude: the
        sounding's through the flight model (with its estimated corrections) in the 6-DOF fit,
        the kinematic data's atmosphere in the kinematic fit.
    air_velocity_body_mps : SX (3,) or None
        Velocity of the body relative to the air in body axes, m/s (6-DOF fit); None in the
        kinematic fit, which has no wind.
    """

    position_ned_m: ca.SX
    velocity_ned_mps: ca.SX
    quaternion: ca.SX
    alt_msl_m: ca.SX
    pressure_pa: ca.SX
    density_kgpm3: ca.SX
    air_velocity_body_mps: ca.SX | None = None


@dataclass(frozen=True)
class SampleSet:
    """Timed samples of an m-vector and their 1-sigma errors.

    Attributes
    ----------
    time_unix_s : (N,) array
        Sample times on the GPS receiver's clock (UTC), s since 1970.
    values : (N, m) array
        Measured values, SI.
    sigma : (N, m) array
        1-sigma of each value's white error, SI; finite and positive.
    name : str
        The owning kind's name, for error messages.
    """

    time_unix_s: np.ndarray
    values: np.ndarray
    sigma: np.ndarray
    name: str = "samples"

    def __post_init__(self) -> None:
        t = np.asarray(self.time_unix_s, float).ravel()
        values = np.atleast_2d(np.asarray(self.values, float))
        if values.shape[0] != t.size and values.shape[1] == t.size:
            values = values.T
        sigma = np.broadcast_to(np.asarray(self.sigma, float), values.shape).copy()
        if values.shape[0] != t.size:
            raise ValueError(f"sample kind {self.name!r}: {t.size} sample times but {values.shape[0]} samples")
        if not (np.all(np.isfinite(t)) and np.all(np.isfinite(values))):
            raise ValueError(f"sample kind {self.name!r}: sample times and values must be finite")
        if not np.all(np.isfinite(sigma) & (sigma > 0)):
            raise ValueError(f"sample kind {self.name!r}: every sigma must be finite and positive")
        if t.size > 1 and np.any(np.diff(t) <= 0):
            raise ValueError(f"sample kind {self.name!r}: sample times must increase")
        object.__setattr__(self, "time_unix_s", t)
        object.__setattr__(self, "values", values)
        object.__setattr__(self, "sigma", sigma)

    @property
    def size(self) -> int:
        """Number of samples N."""
        return int(self.time_unix_s.size)

    @property
    def width(self) -> int:
        """Components m of a sample."""
        return int(self.values.shape[1])

    def subset(self, keep: np.ndarray) -> SampleSet:
        """The samples where the boolean mask ``keep`` (N,) is True."""
        return SampleSet(self.time_unix_s[keep], self.values[keep], self.sigma[keep], self.name)


class SampleKind(Protocol):
    """A sample measurement kind (see the module docstring).

    Attributes
    ----------
    name : str
        Its residual group name (must differ from the fit's own groups: ``imu``, ``gps``, ``baro``...).
    columns : tuple of str
        Names of the m components, with a unit suffix (``"pos_n_m"``), for residual tables.
    samples : SampleSet
    """

    name: str
    columns: tuple[str, ...]
    samples: SampleSet

    def parameters(self) -> tuple[ParameterSpec, ...]:
        """The kind's own constant parameters (with priors); appended after the fit's own."""
        ...

    def predict(self, state: BodyState, theta: Mapping[str, ca.SX]) -> ca.SX:
        """The predicted sample (m,) at ``state``; ``theta`` maps the kind's parameter names to their
        SI symbols."""
        ...


def air_velocity(state: BodyState, kind: str) -> ca.SX:
    """The state's air velocity (body axes, m/s) for the kind named ``kind``; ValueError in a fit
    without one (the kinematic fit has no wind)."""
    if state.air_velocity_body_mps is None:
        raise ValueError(f"sample kind {kind!r} needs the air velocity, which this fit does not model (the kinematic "
                         "fit has no wind): use it in a 6-DOF fit")
    return state.air_velocity_body_mps


def check_kinds(kinds, taken: tuple[str, ...] = ()) -> tuple:
    """``kinds`` as a tuple, after checking that their names and parameter names are unique, differ
    from ``taken`` (the fit's own groups and parameters) and that each kind's samples have as many
    components as it has columns; ValueError otherwise."""
    kinds = tuple(kinds)
    seen = set(taken)
    for kind in kinds:
        names = (kind.name, *(s.name for s in kind.parameters()))
        clash = [n for n in names if n in seen]
        if clash:
            raise ValueError(f"sample kind {kind.name!r}: name(s) {clash} already used by the fit or another kind")
        seen.update(names)
        if kind.samples.width != len(kind.columns):
            raise ValueError(f"sample kind {kind.name!r}: {len(kind.columns)} columns but samples of "
                             f"{kind.samples.width} components")
    return kinds
