"""A 6-DOF fit's NLP: one drop or several (a joint fit, whose drops share some parameter columns).

Each drop has a :class:`~casrecon.estimation.sixdof.layout.DropLayout` (where its nodes, parameters and
latent disturbances sit in z) and a :class:`~casrecon.estimation.kinds.base.DropContext` (model,
settings, data). Its residual groups come from the measurement kinds of :data:`MEASUREMENT_KINDS`
(the IMU kind's interval blocks also carry the collocation defects), then the priors, then the
disturbance process when the weak constraint is on; one unit-norm constraint per drop keeps its
first quaternion normalised (the defects carry the norm along the mesh). Adding a kind of
measurement means adding a module under :mod:`casrecon.estimation.kinds` and listing it here, or,
for a sample kind (:mod:`casrecon.estimation.kinds.samples`), passing it to ``fit_drop``, which
appends its adapter to these kinds (every function here takes the kinds as ``kinds``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from casrecon.estimation.engine.blocks import Term, unit_norm_term
from casrecon.estimation.engine.checks import FitError
from casrecon.estimation.engine.nlp import Nlp, assemble_nlp
from casrecon.estimation.error_models.profile import LEAST_TOLERANCE_M, ProfileGrid
from casrecon.estimation.kinds.baro import BaroKind
from casrecon.estimation.kinds.base import DropContext, MeasurementKind
from casrecon.estimation.kinds.disturbance import disturbance_terms, profile_terms
from casrecon.estimation.kinds.gps import GpsKind
from casrecon.estimation.kinds.ground import GroundKind
from casrecon.estimation.kinds.imu import ImuKind
from casrecon.estimation.kinds.priors import prior_terms
from casrecon.estimation.sixdof.fitdata import FitData, FitDataError
from casrecon.estimation.sixdof.layout import NS, DropLayout, ExtraColumns
from casrecon.estimation.sixdof.parameters import ParameterSet, model_parameters
from casrecon.estimation.sixdof.transcription import Mesh
from casrecon.io.problem import ProblemConfig
from casrecon.physics.dynamics import FlightModel

#: The measurement kinds of a 6-DOF drop fit, in residual order (a kind whose ``load`` returns
#: None for a problem contributes nothing to it).
MEASUREMENT_KINDS: tuple[MeasurementKind, ...] = (ImuKind(), GpsKind(), BaroKind(), GroundKind())
#: z columns of the first quaternion of a drop, relative to its first node.
QUATERNION = np.arange(6, 10)


def parameter_set(cfg: ProblemConfig, kinds: tuple[MeasurementKind, ...] = MEASUREMENT_KINDS) -> ParameterSet:
    """The parameters a per-drop fit estimates: the flight model's, then each kind's."""
    specs = list(model_parameters(cfg))
    for kind in kinds:
        specs += kind.parameters(cfg)
    return ParameterSet(tuple(specs))


def load_measurements(cfg: ProblemConfig, data: FitData,
                      kinds: tuple[MeasurementKind, ...] = MEASUREMENT_KINDS) -> dict[str, object]:
    """Each present kind's measurements for the fit window, by kind name; FitError when a kind's
    data cannot support the fit (e.g. too few samples in the window)."""
    out = {}
    for kind in kinds:
        try:
            m = kind.load(cfg, data)
        except FitDataError as err:
            raise FitError(str(err)) from None
        if m is not None:
            out[kind.name] = m
    return out


def with_extra_columns(layout: DropLayout, cfg: ProblemConfig, measurements: dict[str, object], first_col: int,
                       kinds: tuple[MeasurementKind, ...] = MEASUREMENT_KINDS,
                       node_alt_msl_m: np.ndarray | None = None,
                       profile_prior_sigma: np.ndarray | None = None) -> tuple[DropLayout, int]:
    """The layout with the extra unknowns its kinds ask for (a kind's optional
    ``latent_size(config, measurements) -> (count, eliminable)``) from z column ``first_col`` on,
    and the next free column. ``node_alt_msl_m``: the altitude guess of the nodes (m MSL) the
    profile grid is placed by (default: the GPS altitudes, see :func:`profile_grid`);
    ``profile_prior_sigma``: the profile prior's 1-sigma per corrected component, when not the
    configured ones (:attr:`~casrecon.estimation.error_models.profile.ProfileGrid.prior_sigma`)."""
    extras, col = [], first_col
    grid, interval_cells, node_cells = profile_grid(layout, cfg, measurements, node_alt_msl_m)
    if grid is not None and profile_prior_sigma is not None:
        grid = replace(grid, prior_sigma=np.asarray(profile_prior_sigma, float))
    if grid is not None:
        extras.append(ExtraColumns("profile", col, grid.size))
        col += grid.size
    for kind in kinds:
        if kind.name in measurements and hasattr(kind, "latent_size"):
            count, eliminable = kind.latent_size(cfg, measurements[kind.name])
            if count:
                extras.append(ExtraColumns(kind.name, col, count, eliminable))
                col += count
    return replace(layout, extras=tuple(extras), profile=grid, ground_alt_msl_m=cfg.site.ground_alt_msl_m,
                   interval_cells=interval_cells, node_cells=node_cells), col


def profile_grid(layout: DropLayout, cfg: ProblemConfig, measurements: dict[str, object],
                 node_alt_msl_m: np.ndarray | None = None):
    """(ProfileGrid, cell of each interval, cell of each node) of a drop from ``[atmosphere]`` and
    the nodes' altitude guess ``node_alt_msl_m`` (m MSL; default the GPS altitudes interpolated to
    the nodes), or (None, None, None) without a profile error."""
    atm = cfg.atmosphere
    data = measurements.get("gps")
    sigmas = (atm.profile_wind_sigma_mps, atm.profile_wind_sigma_mps, atm.profile_density_sigma)
    if data is None or not any(sigmas):
        return None, None, None
    t = layout.mesh.t_nodes
    alt = cfg.site.ground_alt_msl_m - np.interp(t, data.gps_time_s - layout.guess_clock_s, data.gps_pos_ned[:, 2]) \
        if node_alt_msl_m is None else np.asarray(node_alt_msl_m, float)
    vertical = data.gps_sigma[:, 2]
    vertical = vertical[np.isfinite(vertical)]
    tolerance = max(LEAST_TOLERANCE_M, 4 * float(np.median(vertical)) if vertical.size else 0.0)
    grid = ProfileGrid.covering(alt, atm.profile_step_m, sigmas, atm.profile_length_m, tolerance)
    return grid, grid.cell_of(0.5 * (alt[:-1] + alt[1:])), grid.cell_of(alt)


def drop_terms(context: DropContext, kinds: tuple[MeasurementKind, ...] = MEASUREMENT_KINDS) -> list[Term]:
    """The residual terms of one drop: its present kinds, its priors and its disturbance process."""
    terms: list[Term] = []
    for kind in kinds:
        if kind.name in context.measurements:
            terms += kind.terms(context)
    terms += prior_terms(context.layout.params, context.layout.theta_cols, lambda g: context.group(f"prior_{g}"))
    return terms + disturbance_terms(context.layout, context.group) + profile_terms(context.layout, context.group)


@dataclass(frozen=True)
class FitNlp:
    """A 6-DOF fit's NLP and its drops (one for a per-drop fit)."""

    nlp: Nlp
    contexts: tuple[DropContext, ...]

    @property
    def parts(self) -> tuple[DropLayout, ...]:
        """Each drop's layout."""
        return tuple(c.layout for c in self.contexts)

    def pack(self, states: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Per-drop fit: scaled z from node states (K, 13) and parameter values (SI)."""
        return self.parts[0].pack(states, values, self.nlp.n_z)


def parameter_names(layouts: list[DropLayout]) -> dict[int, str]:
    """z column -> parameter name; parameters several drops share keep their plain name, a drop's
    own parameters are ``drop.name`` when there is more than one drop."""
    count: dict[int, int] = {}
    for layout in layouts:
        for col in layout.theta_cols:
            count[int(col)] = count.get(int(col), 0) + 1
    out = {}
    for layout in layouts:
        for name, col in zip(layout.params.names, layout.theta_cols):
            own = len(layouts) > 1 and count[int(col)] == 1
            out[int(col)] = f"{layout.name}.{name}" if own else name
    return dict(sorted(out.items()))


def assemble_drops(contexts: list[DropContext], n_z: int, hessian: str = "gauss-newton",
                   kinds: tuple[MeasurementKind, ...] = MEASUREMENT_KINDS) -> FitNlp:
    """The NLP of every drop's terms (from ``kinds``), plus one unit-norm constraint on each drop's
    first quaternion."""
    layouts = [c.layout for c in contexts]
    # one drop after the other: CasADi's symbolic constructions are not thread-safe (casadi#1355,
    # #3518; two drops' ca.jacobian on two threads aborted a test run)
    terms = [t for context in contexts for t in drop_terms(context, kinds)]
    terms.append(unit_norm_term(np.array([lay.node_offset + QUATERNION for lay in layouts])))
    nlp = assemble_nlp(terms, n_z, dependent=np.concatenate([lay.dependent_cols for lay in layouts]),
                       parameter_names=parameter_names(layouts), hessian=hessian,
                       latent=any(lay.n_u for lay in layouts),
                       eliminated=np.concatenate([lay.eliminated_cols for lay in layouts]),
                       stages=node_stages(layouts, n_z))
    return FitNlp(nlp, tuple(contexts))


def node_stages(layouts: list[DropLayout], n_z: int) -> np.ndarray:
    """The node of each of ``n_z`` columns (:attr:`Nlp.stages`): each drop's node states at their
    node, the drops one after another; every other column -1."""
    stages, first = np.full(n_z, -1, np.int64), 0
    for layout in layouts:
        stages[layout.node_cols] = first + np.arange(layout.node_cols.size) // layout.n_states
        first += layout.n_nodes
    return stages


def build_nlp(model: FlightModel, data: FitData, mesh: Mesh, params: ParameterSet, cfg: ProblemConfig,
              hessian: str = "gauss-newton", guess_clock_s: float | None = None,
              measurements: dict[str, object] | None = None, node_alt_msl_m: np.ndarray | None = None,
              profile_prior_sigma: np.ndarray | None = None,
              kinds: tuple[MeasurementKind, ...] = MEASUREMENT_KINDS) -> FitNlp:
    """The NLP of one drop, of the measurement kinds ``kinds``. GPS fixes are put on collocation
    intervals for the clock offset ``guess_clock_s`` (default: the configured guess).
    ``measurements`` are the kinds' data from :func:`load_measurements` (read here when not given);
    ``node_alt_msl_m`` places the atmosphere-profile grid and ``profile_prior_sigma`` sets its
    prior (see :func:`with_extra_columns`)."""
    n_sv = NS * mesh.t_nodes.size
    guess = cfg.estimation.clock_offset_guess_s if guess_clock_s is None else guess_clock_s
    layout = DropLayout(cfg.name, mesh, params, 0, n_sv + np.arange(params.n), guess_clock_s=guess,
                        disturbance=cfg.estimation.disturbance, u_offset=n_sv + params.n)
    if measurements is None:
        measurements = load_measurements(cfg, data, kinds)
    layout, n_z = with_extra_columns(layout, cfg, measurements, n_sv + params.n + layout.n_u_values, kinds,
                                     node_alt_msl_m=node_alt_msl_m, profile_prior_sigma=profile_prior_sigma)
    context = DropContext(model, cfg, layout, data, measurements)
    return assemble_drops([context], n_z, hessian, kinds)
