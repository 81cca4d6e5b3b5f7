"""Where one drop's unknowns sit in the decision vector z, and how a block reads them.

Decision vector of a drop (every entry scaled to order one): its node states, node after node
(state / STATE_SCALE), its parameters (value / scale; in a joint fit shared parameters point at the
same columns for every drop), and the latent disturbance values at the nodes (value / prior sigma)
when the weak constraint is on. A *two-node block* (an interval, or a measurement between two
nodes) sees the local vector [x_k, x_k+1, theta, u_k, u_k+1] in scaled units;
:class:`BlockLocals` turns it into SI quantities and picks parameters by name.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from casrecon.estimation.error_models.profile import ProfileGrid
from casrecon.estimation.sixdof.parameters import SOUNDING_SHIFT, ParameterSet
from casrecon.estimation.sixdof.subgrid import subgrid_integral_sigma
from casrecon.estimation.sixdof.transcription import STATE_SCALE, Mesh
from casrecon.physics.disturbance import N_DISTURBANCES, DisturbanceModel
from casrecon.physics.dynamics import PARAMETER_NAMES

#: Number of states of the 6-DOF model (position, velocity, quaternion, body rates).
NS = 13


@dataclass(frozen=True)
class ExtraColumns:
    """A run of further unknowns of a drop (scaled to order one by their owner).

    Attributes
    ----------
    name : str
        Owner (a measurement kind's name, e.g. ``"gps"``).
    offset, count : int
        First z column and number of columns.
    eliminable : bool
        Whether no constraint involves them and their Hessian block is sparse (they are then
        eliminated by a Schur complement in the covariance; see ``Nlp.eliminated``).
    """

    name: str
    offset: int
    count: int
    eliminable: bool = False

    @property
    def cols(self) -> np.ndarray:
        return self.offset + np.arange(self.count)


@dataclass(frozen=True)
class DropLayout:
    """One drop inside an NLP: its mesh, parameters and the z columns they occupy.

    Parameters
    ----------
    name : str
        Drop (problem) name; prefixes its residual groups in a joint fit.
    mesh : Mesh
    params : ParameterSet
    node_offset : int
        z column of the first node's first state.
    theta_cols : int array
        z column of each parameter (``params`` order).
    state_scale : (n_states,) array
        Scale of each state (SI units per scaled unit).
    guess_clock_s : float
        Clock-offset guess used to put measurements on their intervals (s).
    disturbance : DisturbanceModel or None
        Weak-constraint disturbances estimated at the nodes (None: strong constraint).
    u_offset : int
        z column of the first latent disturbance value.
    extras : tuple of ExtraColumns
        Further unknowns of the drop after everything above, in this order: the atmosphere-profile
        corrections (``"profile"``), then the kinds' (e.g. the latent GPS errors of every fix).
    profile : ProfileGrid or None
        The altitude grid of the profile corrections (:mod:`casrecon.estimation.error_models.profile`).
    ground_alt_msl_m : float
        The site's ground altitude (m MSL): altitude MSL = it - pos_d.
    interval_cells, node_cells : int arrays
        With a profile: the grid cell each interval (at its guessed mid-altitude) and each node
        (at its guessed altitude) uses.
    """

    name: str
    mesh: Mesh
    params: ParameterSet
    node_offset: int
    theta_cols: np.ndarray
    state_scale: np.ndarray = field(default_factory=STATE_SCALE.copy)
    guess_clock_s: float = 0.0
    disturbance: DisturbanceModel | None = None
    u_offset: int = 0
    extras: tuple[ExtraColumns, ...] = ()
    profile: ProfileGrid | None = None
    ground_alt_msl_m: float = 0.0
    interval_cells: np.ndarray | None = None
    node_cells: np.ndarray | None = None

    @property
    def n_profile_local(self) -> int:
        """Profile unknowns a two-node block sees: the spline coefficients of its cell's window."""
        return 0 if self.profile is None else self.profile.window_levels * self.profile.n_components

    def profile_cell_columns(self, cells: np.ndarray) -> np.ndarray:
        """z columns (len(cells), n_profile_local) of the windows of the given grid cells."""
        if self.profile is None:
            return np.zeros((len(cells), 0), np.int64)
        return self.profile.window_columns(self.extra("profile").offset, cells)

    def profile_block_data(self, k: np.ndarray) -> list:
        """Per-block data of the profile for two-node blocks on intervals ``k``: the altitude of the
        lowest level of each interval's window (m MSL) as one DM row, or nothing without a profile."""
        if self.profile is None:
            return []
        cells = self.interval_cells[np.asarray(k, np.int64)]
        return [ca.DM(self.profile.window_base_msl_m(cells)).T]

    def profile_window_violation(self, z: np.ndarray) -> str | None:
        """Why the profile corrections at ``z`` are not the grid's spline (a node more than one
        step outside the cell its blocks were given), or None when they are (or no profile)."""
        if self.profile is None:
            return None
        alt = self.profile_altitudes(z)
        bad = (self.profile.outside_windows(alt, self.node_cells)
               | self.profile.outside_windows(alt, np.r_[self.interval_cells, self.interval_cells[-1]])
               | self.profile.outside_windows(alt, np.r_[self.interval_cells[0], self.interval_cells]))
        if not np.any(bad):
            return None
        k = int(np.argmax(bad))
        return (f"{self.name}: the fitted altitude at node {k} ({alt[k]:.1f} m MSL) is farther from the one "
                f"guessed from the GPS than the atmosphere-profile windows reach "
                f"({(self.profile.window_levels - 4) // 2} steps of {self.profile.step_m:g} m); the GPS "
                f"altitudes and the fit disagree")

    def profile_altitudes(self, z: np.ndarray) -> np.ndarray:
        """Altitude of each node in the sounding's own frame (m MSL): its altitude less the
        estimated ``sounding_shift_m`` (none estimated: its altitude). The profile corrections are
        placed and evaluated there, so that sounding and corrections move as one (without, the
        corrections' grid would pin the drop's altitude to its levels, docs/design/error-models.md)."""
        alt = self.ground_alt_msl_m - self.states(z)[:, 2]
        if SOUNDING_SHIFT in self.params.names:
            alt = alt - self.values(z)[self.params.index(SOUNDING_SHIFT)]
        return alt

    def extra(self, name: str) -> ExtraColumns | None:
        """The extra unknowns called ``name`` (None when the drop has none)."""
        return next((e for e in self.extras if e.name == name), None)

    @property
    def n_extra(self) -> int:
        """Number of extra unknowns."""
        return sum(e.count for e in self.extras)

    @property
    def eliminated_cols(self) -> np.ndarray:
        """z columns of the extra unknowns that no constraint involves (see ``Nlp.eliminated``)."""
        cols = [e.cols for e in self.extras if e.eliminable]
        return np.concatenate(cols) if cols else np.zeros(0, np.int64)

    @property
    def active(self) -> tuple[int, ...]:
        """Indices (in DISTURBANCE_NAMES) of the disturbance entries estimated at the nodes."""
        return () if self.disturbance is None else tuple(int(i) for i in self.disturbance.active)

    @property
    def n_u(self) -> int:
        return len(self.active)

    @property
    def u_scale(self) -> np.ndarray:
        """Scale of the disturbance node values: their prior sigma (SI)."""
        return np.asarray(self.disturbance.sigma)[list(self.active)] if self.n_u else np.zeros(0)

    @property
    def n_nodes(self) -> int:
        return int(self.mesh.t_nodes.size)

    @property
    def u_cols(self) -> np.ndarray:
        """z indices of the disturbance node values, (K, n_u)."""
        return self.u_offset + np.arange(self.n_nodes * self.n_u).reshape(self.n_nodes, self.n_u)

    @property
    def u_mid_cols(self) -> np.ndarray:
        """z indices of the disturbance values at the interval midpoints, (K - 1, n_u), after the
        node values: the collocation evaluates the dynamics at the midpoints too, and a disturbance
        linear between nodes would leave out what it does there (docs/design.md, Weak-constraint
        disturbances)."""
        start = self.u_offset + self.n_nodes * self.n_u
        return start + np.arange((self.n_nodes - 1) * self.n_u).reshape(self.n_nodes - 1, self.n_u)

    @property
    def u_sub_cols(self) -> np.ndarray:
        """z indices (K - 1, n_u) of each interval's sub-grid integral of each disturbance entry
        (the integral over the interval of its departure from the quadratic through the node and
        midpoint values, :mod:`casrecon.estimation.sixdof.subgrid`), after the midpoint values."""
        start = self.u_offset + (2 * self.n_nodes - 1) * self.n_u
        return start + np.arange((self.n_nodes - 1) * self.n_u).reshape(self.n_nodes - 1, self.n_u)

    @property
    def u_sub_scale(self) -> np.ndarray:
        """Prior sigma of the sub-grid integrals (SI times s), their scale in z."""
        if not self.n_u:
            return np.zeros(0)
        return subgrid_integral_sigma(self.u_scale, np.asarray(self.disturbance.time_s)[list(self.active)],
                                      self.mesh.h)

    @property
    def n_u_values(self) -> int:
        """Number of latent disturbance unknowns: node and midpoint values, sub-grid integrals."""
        return (3 * self.n_nodes - 2) * self.n_u if self.n_u else 0

    @property
    def u_all_cols(self) -> np.ndarray:
        """Every latent disturbance column: node and midpoint values, sub-grid integrals."""
        if not self.n_u:
            return np.zeros(0, np.int64)
        return self.u_offset + np.arange(self.n_u_values)

    @property
    def u_chain_cols(self) -> np.ndarray:
        """z indices (2K - 1, n_u) of the disturbance values in time order: node 0, midpoint 0,
        node 1, ..., node K - 1 (half an interval apart)."""
        out = np.empty((2 * self.n_nodes - 1, self.n_u), np.int64)
        out[0::2], out[1::2] = self.u_cols, self.u_mid_cols
        return out

    @property
    def n_states(self) -> int:
        return self.state_scale.size

    @property
    def n_state_vars(self) -> int:
        return self.n_states * self.n_nodes

    @property
    def node_cols(self) -> np.ndarray:
        return self.node_offset + np.arange(self.n_state_vars)

    @property
    def dependent_cols(self) -> np.ndarray:
        """Node columns the collocation defects fix given the first node and the parameters."""
        return self.node_cols[self.n_states:]

    def group(self, name: str, prefixed: bool) -> str:
        """Residual group name of this drop (``drop/name`` in a joint fit)."""
        return f"{self.name}/{name}" if prefixed else name

    def states(self, z: np.ndarray) -> np.ndarray:
        """Node states (K, n_states), SI."""
        return np.asarray(z)[self.node_cols].reshape(-1, self.n_states) * self.state_scale

    def values(self, z: np.ndarray) -> np.ndarray:
        """The drop's parameter values (SI) in ``params`` order."""
        return np.asarray(z)[self.theta_cols] * self.params.scales

    def disturbances(self, z: np.ndarray) -> np.ndarray:
        """Disturbance at the nodes (K, 9), SI, zero in the entries not estimated."""
        out = np.zeros((self.n_nodes, N_DISTURBANCES))
        if self.n_u:
            out[:, list(self.active)] = np.asarray(z)[self.u_cols] * self.u_scale
        return out

    def midpoint_disturbances(self, z: np.ndarray) -> np.ndarray:
        """Disturbance at the interval midpoints (K - 1, 9), SI, zero in the entries not estimated."""
        out = np.zeros((self.n_nodes - 1, N_DISTURBANCES))
        if self.n_u:
            out[:, list(self.active)] = np.asarray(z)[self.u_mid_cols] * self.u_scale
        return out

    def pack(self, states: np.ndarray, values: np.ndarray, n_z: int) -> np.ndarray:
        """Scaled z (length ``n_z``) holding this drop's node states (K, n_states) and parameter
        values (SI); everything else (latent disturbances, other drops) zero."""
        z = np.zeros(n_z)
        z[self.node_cols] = (np.asarray(states) / self.state_scale).ravel()
        z[self.theta_cols] = np.asarray(values) / self.params.scales
        return z

    def two_node_columns(self, k: np.ndarray, collocation: bool = False) -> np.ndarray:
        """Global columns (len(k), 2 n_states + n_params + (2 or 4) n_u + n_profile_local) of the
        two-node blocks on intervals ``k``: [x_k, x_k+1, theta, u_k, u_k+1, (u_mid, u_sub,) profile
        cell]; ``collocation``: with the disturbance unknowns only the collocation blocks see (the
        midpoint values and the sub-grid integrals)."""
        k = np.asarray(k, np.int64)
        first = self.node_offset + self.n_states * k[:, None] + np.arange(2 * self.n_states)[None, :]
        profile = self.profile_cell_columns(self.interval_cells[k] if self.profile is not None else k)
        mid = [self.u_mid_cols[k], self.u_sub_cols[k]] if collocation and self.n_u else []
        return np.column_stack([first, np.tile(self.theta_cols, (k.size, 1)), self.u_cols[k], self.u_cols[k + 1],
                                *mid, profile])

    def interval_of(self, t_imu_s: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(interval index, fraction tau within it) of IMU-clock times (s) for measurements whose
        time is ``t_imu_s + clock guess`` on the measurement's own clock: each lies on the interval
        that holds it at the guessed clock offset (clipped to the mesh)."""
        mesh = self.mesh
        t = np.asarray(t_imu_s, float)
        k = np.clip(((t - self.guess_clock_s - mesh.t_nodes[0]) // mesh.h).astype(int), 0, mesh.n_intervals - 1)
        return k, (t - mesh.t_nodes[k]) / mesh.h


class BlockLocals:
    """SI quantities from the scaled local vector of a drop's two-node block.

    Parameters
    ----------
    layout : DropLayout
    collocation : bool
        Whether the block also holds its interval's disturbance midpoint values and sub-grid
        integrals (:meth:`DropLayout.two_node_columns` with ``collocation``; read with
        :meth:`midpoint_u` and :meth:`subgrid_integral`).
    """

    def __init__(self, layout: DropLayout, collocation: bool = False) -> None:
        self.layout = layout
        self.params = layout.params
        self.n_s, self.n_p, self.n_u = layout.n_states, layout.params.n, layout.n_u
        self.n_mid = self.n_u if collocation else 0
        self.symbol = ca.SX.sym("v", 2 * self.n_s + self.n_p + 2 * self.n_u + 2 * self.n_mid + layout.n_profile_local)
        #: Per-block data symbols the locals need (the profile window's lowest altitude), to be listed
        #: after a kind's own data, with :meth:`DropLayout.profile_block_data` as their values.
        self.data = [ca.SX.sym("profile_window_msl_m")] if layout.profile is not None else []

    def point_params(self, theta: ca.SX, x: ca.SX, v: ca.SX | None = None) -> ca.SX:
        """The FlightModel parameter vector at the point of state ``x``: :meth:`model_params` plus the
        profile corrections at its altitude (see :mod:`casrecon.estimation.error_models.profile`)."""
        p = self.model_params(theta)
        grid = self.layout.profile
        if grid is None:
            return p
        v = self.symbol if v is None else v
        cell = v[v.numel() - self.layout.n_profile_local:]
        alt = self.layout_altitude(x) - self.theta_of(theta, SOUNDING_SHIFT)  # in the sounding's frame
        return grid.add_to_parameters(p, grid.correction(cell, alt, self.data[0]))

    def layout_altitude(self, x: ca.SX) -> ca.SX:
        """Altitude MSL (m) of state ``x`` (SI)."""
        return self.layout.ground_alt_msl_m - x[2]

    def split(self, v: ca.SX | None = None):
        """(x_k, x_k+1, theta, u_k, u_k+1) in SI from the scaled local vector (default: the
        block symbol)."""
        v = self.symbol if v is None else v
        s = ca.DM(self.layout.state_scale)
        xk, xk1 = v[:self.n_s] * s, v[self.n_s:2 * self.n_s] * s
        end = 2 * self.n_s + self.n_p
        theta = v[2 * self.n_s:end] * ca.DM(self.params.scales)
        u_scale = ca.DM(self.layout.u_scale)
        uk, uk1 = v[end:end + self.n_u] * u_scale, v[end + self.n_u:end + 2 * self.n_u] * u_scale
        return xk, xk1, theta, uk, uk1

    def midpoint_u(self, v: ca.SX | None = None) -> ca.SX:
        """The disturbance values at the interval's midpoint (SI) of a block made with ``collocation``."""
        if not self.n_mid:
            raise ValueError("this block holds no midpoint disturbance values")
        v = self.symbol if v is None else v
        start = 2 * self.n_s + self.n_p + 2 * self.n_u
        return v[start:start + self.n_mid] * ca.DM(self.layout.u_scale)

    def subgrid_integral(self, v: ca.SX | None = None) -> ca.SX:
        """The sub-grid integrals (SI times s) of a block made with ``collocation``."""
        if not self.n_mid:
            raise ValueError("this block holds no sub-grid integrals")
        v = self.symbol if v is None else v
        start = 2 * self.n_s + self.n_p + 2 * self.n_u + self.n_mid
        return v[start:start + self.n_mid] * ca.DM(self.layout.u_sub_scale)

    def theta_of(self, theta: ca.SX, name: str, default: float = 0.0):
        """The parameter ``name`` from the SI parameter vector, or ``default`` when not estimated."""
        return theta[self.params.index(name)] if name in self.params.names else default

    def select(self, theta: ca.SX, names: tuple[str, ...]) -> ca.SX:
        """Vector of the parameters ``names`` (0 for those not estimated)."""
        return ca.vertcat(*[self.theta_of(theta, n) for n in names])

    def model_params(self, theta: ca.SX) -> ca.SX:
        """The FlightModel parameter vector (PARAMETER_NAMES order) from the estimated ones."""
        return self.select(theta, PARAMETER_NAMES)
