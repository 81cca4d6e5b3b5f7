"""How a registered sample sensor's settings (:mod:`casrecon.io.sample_sensors`) make its sample kind
(:mod:`.samples`) for each fit: :data:`SAMPLE_KIND_MAKERS`, keyed by the sensor's table name.

The 6-DOF maker gets the 6-DOF problem (its vehicle places the sensor relative to the centre of
mass in body axes); the kinematic maker gets the kinematic problem (lever arms from the IMU in IMU
axes). The pipelines pass the kinds made here to ``fit_drop`` and ``fit_kinematic``.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from casrecon.estimation.kinds.samples import SampleKind
from casrecon.io.kinematic_problem import KinematicConfig
from casrecon.io.problem import ProblemConfig


@dataclass(frozen=True)
class SampleKindMaker:
    """A registered sample sensor's kind, per fit.

    Attributes
    ----------
    sixdof : callable
        ``sixdof(settings, config: ProblemConfig) -> SampleKind`` (centre of mass, body axes).
    kinematic : callable or None
        ``kinematic(settings, config: KinematicConfig) -> SampleKind`` (IMU, IMU axes); None when
        the kind cannot be used in a kinematic fit (it needs the air velocity).
    """

    sixdof: Callable[[object, ProblemConfig], SampleKind]
    kinematic: Callable[[object, KinematicConfig], SampleKind] | None = None


#: The registered sample sensors' kind makers (none is shipped yet), by table name.
SAMPLE_KIND_MAKERS: dict[str, SampleKindMaker] = {}


def _maker(table: str) -> SampleKindMaker:
    try:
        return SAMPLE_KIND_MAKERS[table]
    except KeyError:
        raise ValueError(f"sample sensor [{table}] has a table parser but no kind maker "
                         "(casrecon.estimation.kinds.sample_registry)") from None


def sixdof_sample_kinds(config: ProblemConfig) -> tuple[SampleKind, ...]:
    """The sample kinds of a 6-DOF problem's ``[sensors.X]`` tables of registered sensors."""
    return tuple(_maker(table).sixdof(settings, config) for table, settings in config.sample_sensors)


def kinematic_sample_kinds(config: KinematicConfig) -> tuple[SampleKind, ...]:
    """The sample kinds of a kinematic problem's ``[X]`` tables of registered sensors; ValueError for a
    sensor that cannot be used in a kinematic fit."""
    out = []
    for table, settings in config.sample_sensors:
        maker = _maker(table).kinematic
        if maker is None:
            raise ValueError(f"{config.path}: [{table}] cannot be used in a kinematic fit (it needs the air "
                             "velocity, and the kinematic fit has no wind)")
        out.append(maker(settings, config))
    return tuple(out)
