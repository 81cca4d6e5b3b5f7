"""``problem.toml`` of a GPS-only (point-mass) problem, ``[problem] kind = "point-mass"``:
parsed once into frozen dataclasses and validated like the 6-DOF problems (same field helpers).

    [problem]     kind = "point-mass", name, description
    [site]        lat_deg, lon_deg, ground_alt_msl_m
    [atmosphere]  sounding = "standard" (ICAO, no wind) or a sounding file; wind_3sigma_mps
    [vehicle]     mass_kg
    [drag]        model = "constant" | "spline", knot_spacing_s, smoothness_sigma_m2, lift
    [gps]         file (FlySight, NMEA 0183 or GNSS CSV), date (NMEA without RMC), velocity_sigma_mps,
                  max_h_acc_m, max_v_acc_m, max_s_acc_mps, min_num_sv
    [segment]     start_utc, end_utc (optional: found from the data), min_speed_mps, end_margin_s,
                  deploy_drop_mps
    [model_error] drag_area_fraction, lift_area_sigma_m2, time_s
    [estimation]  linear_solver, max_iter, tol
"""

from __future__ import annotations

import datetime as dt
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.io.gps_rules import GpsQuality, gps_date, gps_error_model, velocity_sigma
from casrecon.io.problem import parse_dynamics, parse_site, parse_utc
from casrecon.io.problem_file import problem_document
from casrecon.io.toml_fields import Fields, TomlDocument
from casrecon.physics.dynamics import DynamicsOptions, Site
from casrecon.physics.sensor_errors import GpsErrorModel


@dataclass(frozen=True)
class DragConfig:
    """Drag-area model: one constant CdA (m^2), or a cubic B-spline in time with knots every
    ``knot_spacing_s`` and a smoothness prior N(0, smoothness_sigma_m2^2) on its second differences.
    ``lift``: also estimate horizontal lift areas along north and east (same spline and smoothness
    prior, plus a N(0, lift_sigma_m2^2) prior on each coefficient: with GPS only, a horizontal lift
    and a wind bias push the body alike, and the priors share the horizontal force between them)."""

    model: str = "spline"
    knot_spacing_s: float = 2.0
    smoothness_sigma_m2: float = 0.02
    lift: bool = False
    lift_sigma_m2: float = 0.1


@dataclass(frozen=True)
class ModelErrorConfig:
    """Fast changes of the areas: what a drag-area spline cannot follow (a skydiver's changes of body
    position within a second), as first-order Gauss-Markov processes estimated at every node: one
    multiplies the drag area by exp(drag_area_fraction a) (a relative change, so the drag area
    stays positive), one is added to each horizontal lift area north and east (the weak constraint
    of the 6-DOF fit's model-error states). Whatever force the body's attitude makes goes through
    its areas, so the reported CdA(t) (spline times process) is the drag area the data say at each
    instant.

    Attributes
    ----------
    drag_area_fraction : float
        Stationary 1-sigma of the drag area's log (a relative change, -).
    lift_area_sigma_m2 : float
        Stationary 1-sigma of each horizontal lift-area process, m^2.
    time_s : float
        Correlation time of the three, s.
    """

    drag_area_fraction: float = 0.0
    lift_area_sigma_m2: float = 0.0
    time_s: float = 1.0

    @property
    def enabled(self) -> bool:
        """Whether any process is on (both sigmas 0: none, the strong constraint)."""
        return self.drag_area_fraction > 0 or self.lift_area_sigma_m2 > 0

    @property
    def sigmas(self) -> tuple[float, float, float]:
        """1-sigma of the drag-area log (-), and of the lift-north and lift-east processes (m^2)."""
        return (self.drag_area_fraction, self.lift_area_sigma_m2, self.lift_area_sigma_m2)

    def describe(self) -> str:
        """One line for reports."""
        return (f"area processes Gauss-Markov over {self.time_s:g} s, estimated at every node: drag area "
                f"{100 * self.drag_area_fraction:g} % 1-sigma (log-normal), each horizontal lift area "
                f"{self.lift_area_sigma_m2:g} m^2; adequacy tests on the Kalman innovations of the fixes")

    def transition(self, step_s: float) -> float:
        """Correlation between values ``step_s`` (s) apart, exp(-step / tau)."""
        return float(np.exp(-step_s / self.time_s))


@dataclass(frozen=True)
class SegmentConfig:
    """The fitted segment. Without start/end (UTC, ISO), it is found from the data: the longest run
    of good fixes descending faster than ``min_speed_mps``, extended back to where the descent
    began (vertical speed below 2 m/s), ending ``end_margin_s`` before the final drop (canopy
    opening or impact) began: the run's last fixes whose vertical speed is each more than
    ``deploy_drop_mps`` (m/s) below its running maximum over the preceding 2 s
    (:func:`casrecon.estimation.pointmass.segment.drop_onset`)."""

    start_unix_s: float | None = None
    end_unix_s: float | None = None
    min_speed_mps: float = 20.0
    end_margin_s: float = 0.5
    deploy_drop_mps: float = 5.0


@dataclass(frozen=True)
class PointMassConfig:
    """A validated GPS-only problem."""

    path: Path
    name: str
    description: str
    site: Site
    sounding: Path | None            # None: the standard atmosphere
    wind_3sigma_mps: float
    mass_kg: float
    drag: DragConfig
    gps_file: Path
    quality: GpsQuality
    segment: SegmentConfig
    dynamics: DynamicsOptions
    gps_errors: GpsErrorModel = GpsErrorModel()
    gps_error_model_from_data: bool = False                       # estimate gps_errors' sizes and times, refit
    model_error: ModelErrorConfig = ModelErrorConfig()
    linear_solver: str = "mumps"
    max_iter: int = 200
    tol: float = 1e-8
    gps_date: dt.date | None = None                               # UTC date of an NMEA log without RMC
    velocity_sigma_mps: tuple[float, float, float] | None = None  # per-axis NED velocity 1-sigma (None: sAcc)
    humidity: bool = True                                         # moist-air density from the sounding's dewpoints


def _segment(t: Fields) -> SegmentConfig:
    d = SegmentConfig()
    start = parse_utc(t, "start_utc").timestamp() if t.has("start_utc") else None
    end = parse_utc(t, "end_utc").timestamp() if t.has("end_utc") else None
    if start is not None and end is not None and end <= start:
        raise t.error("end_utc", "must be after start_utc")
    cfg = SegmentConfig(start, end, t.number("min_speed_mps", d.min_speed_mps, positive=True),
                        t.number("end_margin_s", d.end_margin_s, minimum=0.0),
                        t.number("deploy_drop_mps", d.deploy_drop_mps, positive=True))
    t.reject_unknown()
    return cfg


def _model_error(t: Fields) -> ModelErrorConfig:
    d = ModelErrorConfig()
    cfg = ModelErrorConfig(t.number("drag_area_fraction", d.drag_area_fraction, minimum=0.0),
                           t.number("lift_area_sigma_m2", d.lift_area_sigma_m2, minimum=0.0),
                           t.number("time_s", d.time_s, positive=True))
    t.reject_unknown()
    return cfg


def load_point_mass(source: str | Path | TomlDocument) -> PointMassConfig:
    """Parse and validate a point-mass ``problem.toml`` (file or folder, or its parsed document)."""
    document = problem_document(source)
    path, f = document.path, document.fields()
    empty = {k: Fields({}, path, f"{k}.") for k in ("drag", "segment", "estimation", "dynamics", "model_error")}
    head = f.table("problem", required=True)
    if head.string("kind", "six-dof", choices=("six-dof", "point-mass")) != "point-mass":
        raise head.error("kind", 'this is a six-dof problem (no kind = "point-mass"): load it with '
                                 "casrecon.io.problem.load_problem")
    atm, veh = f.table("atmosphere", required=True), f.table("vehicle", required=True)
    gps = f.table("gps", required=True)
    drag = f.table("drag") or empty["drag"]
    seg = f.table("segment") or empty["segment"]
    est = f.table("estimation") or empty["estimation"]
    sounding = atm.string("sounding", required=True)
    cfg = PointMassConfig(
        path=path.resolve(), name=head.string("name", required=True), description=head.string("description", ""),
        site=parse_site(f.table("site", required=True)),
        sounding=None if sounding == "standard" else atm.path_of("sounding"),
        wind_3sigma_mps=atm.number("wind_3sigma_mps", 3.0, positive=True),
        humidity=atm.boolean("humidity", True),
        mass_kg=veh.number("mass_kg", required=True, positive=True),
        drag=DragConfig(drag.string("model", "spline", choices=("constant", "spline")),
                        drag.number("knot_spacing_s", 2.0, positive=True),
                        drag.number("smoothness_sigma_m2", 0.02, positive=True), drag.boolean("lift", False),
                        drag.number("lift_sigma_m2", 0.1, positive=True)),
        gps_file=gps.path_of("file", required=True),
        quality=GpsQuality(gps.number("max_h_acc_m", 10.0, positive=True),
                           gps.number("max_v_acc_m", 10.0, positive=True),
                           gps.number("max_s_acc_mps", 1.0, positive=True), gps.integer("min_num_sv", 6, 0)),
        segment=_segment(seg), model_error=_model_error(f.table("model_error") or empty["model_error"]),
        dynamics=parse_dynamics(f.table("dynamics") or empty["dynamics"]),
        linear_solver=est.string("linear_solver", "mumps", choices=("mumps", "spral")),
        max_iter=est.integer("max_iter", 200, 1), tol=est.number("tol", 1e-8, positive=True),
        gps_errors=gps_error_model(gps), gps_error_model_from_data=gps.boolean("error_model_from_data", False),
        gps_date=gps_date(gps), velocity_sigma_mps=velocity_sigma(gps))
    for t in (head, atm, veh, gps, drag, est, f):
        t.reject_unknown()
    return cfg
