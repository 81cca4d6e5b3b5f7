"""The configuration tables of the registered sample sensors (the sample measurement kinds of
:mod:`casrecon.estimation.kinds.samples` that a problem configures): ``[sensors.<table>]`` in a
6-DOF ``problem.toml``, ``[<table>]`` in a kinematic one.

A shipped sample kind registers here (:data:`SAMPLE_SENSORS`: its table name and the parser of its
table into its settings) and in :data:`casrecon.estimation.kinds.sample_registry.SAMPLE_KIND_MAKERS`
(how its settings make the kind for each fit). The loaders put the parsed settings of every
registered table a problem has in its ``sample_sensors``, in registration order; nothing else in
the configuration needs to know the sensor.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

from casrecon.io.config_records import Key, Table
from casrecon.io.toml_fields import Fields


@dataclass(frozen=True)
class SampleSensor:
    """A registered sample sensor's table.

    Attributes
    ----------
    table : str
        The table's name (``"antenna2"``: ``[sensors.antenna2]``, or ``[antenna2]`` in a kinematic
        problem); also the key of its kind maker.
    parse : callable
        ``parse(fields) -> settings``: the table (a :class:`~casrecon.io.toml_fields.Fields`; paths
        relative to the problem file) to the sensor's settings, reading every key it knows and
        rejecting the others (``fields.reject_unknown()``), raising InputError on a bad value.
    keys : tuple of Key
        Its keys for the TOML reference (``docs/problem-toml.md``, :mod:`casrecon.io.config_reference`).
    note : str
        What the table is, for the reference.
    """

    table: str
    parse: Callable[[Fields], object]
    keys: tuple[Key, ...] = ()
    note: str = ""


#: The registered sample sensors (none is shipped yet): one entry per sensor.
SAMPLE_SENSORS: tuple[SampleSensor, ...] = ()


def parse_sample_sensors(tables: Fields) -> tuple[tuple[str, object], ...]:
    """(table name, settings) of every registered sample sensor whose table is among ``tables``
    (``[sensors]`` of a 6-DOF problem, the top level of a kinematic one), in registration order."""
    out = []
    for sensor in SAMPLE_SENSORS:
        table = tables.table(sensor.table)
        if table is not None:
            out.append((sensor.table, sensor.parse(table)))
    return tuple(out)


def sample_sensor_tables(prefix: str) -> tuple[Table, ...]:
    """The reference tables of the registered sample sensors, named ``prefix + table`` (``"sensors."``
    in a 6-DOF problem, ``""`` in a kinematic one)."""
    return tuple(Table(prefix + s.table, s.keys, note=s.note or "Optional: a registered sample sensor.")
                 for s in SAMPLE_SENSORS)
