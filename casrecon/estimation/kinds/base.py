"""The interface of a measurement kind, and what it sees of a drop when it makes its blocks.

A kind is an object with

``name``
    Its residual group name (``"imu"``, ``"gps"``, ``"baro"``...).
``parameters(config) -> tuple[ParameterSpec, ...]``
    The parameters it adds to the drop's fit (sensor biases, clock offset...), each with its
    prior (or none); empty when it adds none.
``load(config, data) -> object | None``
    Its measurements for the drop's fit window (``data`` is the drop's
    :class:`~casrecon.estimation.sixdof.fitdata.FitData`: the IMU-defined window and the GPS fixes), or
    None when the problem has no such sensor.
``terms(context) -> list[Term]``
    Its residual blocks, given the drop's :class:`DropContext`.
``residuals(result) -> dict[str, np.ndarray] | None``
    Its per-measurement residuals (SI) at the fit's solution, for diagnostics and plots.

Kinds return what they make; none of them mutates its arguments. The engine never imports a kind.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Protocol

from casrecon.estimation.engine.blocks import Term
from casrecon.estimation.sixdof.fitdata import FitData
from casrecon.estimation.sixdof.layout import DropLayout
from casrecon.estimation.sixdof.parameters import ParameterSpec
from casrecon.io.problem import ProblemConfig
from casrecon.physics.dynamics import FlightModel


@dataclass(frozen=True)
class DropContext:
    """What a kind sees of one drop: its model, settings, data and place in z.

    Attributes
    ----------
    model : FlightModel
    config : ProblemConfig
    layout : DropLayout
    data : FitData
    measurements : mapping of str to object
        Each present kind's own measurements (from its ``load``), by kind name.
    prefixed : bool
        Whether residual groups carry the drop's name (joint fits).
    """

    model: FlightModel
    config: ProblemConfig
    layout: DropLayout
    data: FitData
    measurements: Mapping[str, Any] = field(default_factory=dict)
    prefixed: bool = False

    def group(self, name: str) -> str:
        """This drop's name of the residual group ``name``."""
        return self.layout.group(name, self.prefixed)


class MeasurementKind(Protocol):
    """See the module docstring."""

    name: str

    def parameters(self, config: ProblemConfig) -> tuple[ParameterSpec, ...]: ...

    def load(self, config: ProblemConfig, data: FitData) -> Any | None: ...

    def terms(self, context: DropContext) -> list[Term]: ...

    def residuals(self, result) -> dict | None: ...
