"""Assembly of a fit's NLP: min 1/2 |r(z)|^2 s.t. collocation defects = 0, |q_0|^2 = 1 per drop.

One drop or several (a joint fit, whose drops share some parameter columns): each drop is a
:class:`DropPart` that says where its nodes, parameters and constraint rows sit in z and g.
Decision vector z (every entry scaled to order one): the node states, node after node
(state / STATE_SCALE), then the estimated parameters (value / scale). Residuals stack the IMU
rows (interval after interval), the GPS rows (fix after fix) and the priors; each group's slice is
kept for per-group chi-square.

Every derivative Ipopt needs is assembled from blocks (:mod:`casrecon.estimation.assembly`): an
interval block sees its two nodes and the parameters, a GPS block the two nodes around its fix and
the parameters, the prior block the parameters. Block functions are SX and mapped over the mesh
(two threads), so no large expression graph is ever differentiated.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import casadi as ca
import numpy as np

from casrecon.estimation.assembly import BlockKind, SparseTarget
from casrecon.estimation.fitdata import FitData
from casrecon.estimation.parameters import SENSOR_NAMES, ParameterSet
from casrecon.estimation.transcription import (
    D_OFFSETS,
    R_OFFSETS,
    STATE_SCALE,
    ImuBlocks,
    Mesh,
    compress_imu,
    gps_function,
    interval_function,
)
from casrecon.physics.disturbance import N_DISTURBANCES, DisturbanceModel
from casrecon.physics.dynamics import FlightModel

NS = 13


@dataclass
class DropPart:
    """One drop inside an NLP: where its nodes, parameters, constraints and residuals sit.

    ``theta_cols[i]`` is the z index of the drop's i-th parameter (``params`` order); in a joint
    fit the shared aero parameters point at the same columns for every drop.
    """

    name: str
    mesh: Mesh
    params: ParameterSet
    node_offset: int
    theta_cols: np.ndarray
    defect_offset: int
    imu_blocks: ImuBlocks | None = None
    groups: dict = field(default_factory=dict)
    state_scale: np.ndarray = field(default_factory=lambda: STATE_SCALE)
    guess_clock_s: float = 0.0
    disturbance: DisturbanceModel | None = None
    u_offset: int = 0

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
    def u_cols(self) -> np.ndarray:
        """z indices of the disturbance node values, (K, n_u)."""
        return self.u_offset + np.arange(self.mesh.t_nodes.size * self.n_u).reshape(self.mesh.t_nodes.size, self.n_u)

    def disturbances(self, z: np.ndarray) -> np.ndarray:
        """Disturbance at the nodes (K, 9), SI, zero in the entries not estimated."""
        out = np.zeros((self.mesh.t_nodes.size, N_DISTURBANCES))
        if self.n_u:
            out[:, list(self.active)] = np.asarray(z)[self.u_cols] * self.u_scale
        return out

    @property
    def n_states(self) -> int:
        return self.state_scale.size

    @property
    def n_state_vars(self) -> int:
        return self.n_states * self.mesh.t_nodes.size

    @property
    def node_cols(self) -> np.ndarray:
        return self.node_offset + np.arange(self.n_state_vars)

    def groups_size(self, suffix: str) -> int:
        """Number of residual rows in this drop's group named ``suffix`` (e.g. "imu")."""
        return sum(s.stop - s.start for g, s in self.groups.items() if g.split("/")[-1] == suffix)

    def states(self, z: np.ndarray) -> np.ndarray:
        """Node states (K, 13), SI."""
        return np.asarray(z)[self.node_cols].reshape(-1, self.n_states) * self.state_scale

    def values(self, z: np.ndarray) -> np.ndarray:
        """The drop's parameter values (SI) in ``params`` order."""
        return np.asarray(z)[self.theta_cols] * self.params.scales


@dataclass
class FitNlp:
    """The assembled NLP: symbolic z, residuals and constraints, and the block derivatives.

    ``parts`` holds one :class:`DropPart` per drop (one for a per-drop fit). ``mesh``, ``params``
    and ``imu_blocks`` are the first drop's, for the per-drop fit's convenience.
    """

    parts: list[DropPart]
    z: ca.MX
    residuals: ca.MX
    constraints: ca.MX
    groups: dict[str, slice]
    derivatives: BlockDerivatives

    @property
    def mesh(self) -> Mesh:
        return self.parts[0].mesh

    @property
    def params(self) -> ParameterSet:
        return self.parts[0].params

    @property
    def imu_blocks(self) -> ImuBlocks:
        return self.parts[0].imu_blocks

    @property
    def n_state_vars(self) -> int:
        return sum(p.n_state_vars for p in self.parts)

    def parameter_columns(self) -> dict[int, str]:
        """z index -> parameter name; parameters that several drops share keep their plain name,
        a drop's own parameters are ``drop.name`` when there is more than one drop."""
        count: dict[int, int] = {}
        for part in self.parts:
            for col in part.theta_cols:
                count[int(col)] = count.get(int(col), 0) + 1
        out = {}
        for part in self.parts:
            for name, col in zip(part.params.names, part.theta_cols):
                own = len(self.parts) > 1 and count[int(col)] == 1
                out[int(col)] = f"{part.name}.{name}" if own else name
        return dict(sorted(out.items()))

    def dependent_columns(self) -> np.ndarray:
        """z indices fixed by the defects given the first node of each drop and the parameters."""
        return np.concatenate([p.node_cols[p.n_states:] for p in self.parts])

    def unpack(self, z: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Per-drop fit: node states (K, 13) and parameter values, SI."""
        return self.parts[0].states(z), self.parts[0].values(z)

    def pack(self, states: np.ndarray, values: np.ndarray) -> np.ndarray:
        """Per-drop fit: scaled z from node states (K, 13) and parameter values (SI); estimated
        disturbances (if any) start at zero."""
        part = self.parts[0]
        return np.concatenate([(states / part.state_scale).ravel(), np.asarray(values) / part.params.scales,
                               np.zeros(part.u_cols.size)])


@dataclass
class _BlockSet:
    """All blocks of one kind: the kind, its local-to-global columns (n_blocks, n_local),
    numeric data inputs, and the global rows of its constraints (or None)."""

    kind: BlockKind
    cols: np.ndarray
    data: list
    g_rows: np.ndarray | None = None
    group: str = ""

    def __post_init__(self) -> None:
        n = self.cols.shape[0]
        self.derivs = self.kind.derivatives.map(n, "thread", 2) if n > 1 else self.kind.derivatives
        self.hess = self.kind.exact_hessian.map(n, "thread", 2) if n > 1 else self.kind.exact_hessian

    def local(self, z: np.ndarray) -> np.ndarray:
        return z[self.cols].T


class BlockDerivatives:
    """Gradient, constraint Jacobian and Hessian of the NLP at z, from the block functions.

    The three are computed together and cached for the last z, because Ipopt asks for all of them
    at each new iterate. ``hessian="gauss-newton"`` gives sigma triu(J^T J) (the constraint
    curvature is left out); ``"exact"`` the exact Hessian of the Lagrangian, block by block.
    """

    def __init__(self, sets: list[_BlockSet], n_z: int, n_g: int, quat_cols: np.ndarray, hessian: str):
        self.sets, self.n_z, self.n_g, self.hessian = sets, n_z, n_g, hessian
        self.quat_cols = np.asarray(quat_cols).reshape(-1, 4)
        key = "jtj" if hessian == "gauss-newton" else "hess"
        h_rows, h_cols = self._stack(key, rows_from_cols=True)
        if hessian != "gauss-newton":  # curvature of each unit-norm row |q_0|^2 - 1: 2 lam I on q_0
            h_rows, h_cols = np.r_[h_rows, self.quat_cols.ravel()], np.r_[h_cols, self.quat_cols.ravel()]
        # a block's upper triangle maps to the global upper triangle once each pair is ordered
        self.hess_target = SparseTarget((n_z, n_z), np.minimum(h_rows, h_cols), np.maximum(h_rows, h_cols))
        if hessian == "gauss-newton":
            self.jtj_target = self.hess_target
        else:  # the covariance always uses J^T J, whatever Hessian Ipopt was given
            g_rows, g_cols = self._stack("jtj", rows_from_cols=True)
            self.jtj_target = SparseTarget((n_z, n_z), np.minimum(g_rows, g_cols), np.maximum(g_rows, g_cols))
        jg_rows, jg_cols = self._stack("jg", rows_from_cols=False)
        n_q = self.quat_cols.shape[0]
        q_rows = np.repeat(n_g - n_q + np.arange(n_q), 4)
        self.jac_target = SparseTarget((n_g, n_z), np.r_[jg_rows, q_rows], np.r_[jg_cols, self.quat_cols.ravel()])
        self._z = None

    def _stack(self, key: str, rows_from_cols: bool):
        rows, cols = [], []
        for bs in self.sets:
            if key not in bs.kind.patterns:
                continue
            lr, lc = bs.kind.patterns[key]
            rows.append(bs.cols[:, lr].ravel() if rows_from_cols else (bs.g_rows[:, None] + lr[None, :]).ravel())
            cols.append(bs.cols[:, lc].ravel())
        return np.concatenate(rows), np.concatenate(cols)

    def evaluate(self, z: np.ndarray) -> None:
        """Compute and cache the gradient, J_g nonzeros and J^T J nonzeros at z (scaled)."""
        z = np.asarray(z, float).ravel()
        if self._z is not None and np.array_equal(z, self._z):
            return
        grad, jtj, jg = np.zeros(self.n_z), [], []
        for bs in self.sets:
            out = [np.asarray(o) for o in bs.derivs(bs.local(z), *bs.data)]
            grad += np.bincount(bs.cols.ravel(), weights=out[0].T.ravel(), minlength=self.n_z)
            jtj.append(bs.kind.jtj_values(out[1].T).ravel())
            if len(out) > 2:
                jg.append(out[2].T.ravel())
        jg.append(2 * z[self.quat_cols.ravel()])
        self._z, self.grad, self._jtj, self._jg = z, grad, np.concatenate(jtj), np.concatenate(jg)

    def gradient(self, z) -> np.ndarray:
        self.evaluate(z)
        return self.grad

    def jacobian_g(self, z) -> ca.DM:
        self.evaluate(z)
        return self.jac_target.assemble(self._jg)

    def gauss_newton(self, z) -> ca.DM:
        """Upper triangle of J^T J at z (the Fisher information the covariance uses)."""
        self.evaluate(z)
        return self.jtj_target.assemble(self._jtj)

    def hessian_lagrangian(self, z, sigma: float, lam_g: np.ndarray) -> ca.DM:
        """Upper triangle of the Hessian of sigma f + lam_g^T g (Gauss-Newton or exact)."""
        if self.hessian == "gauss-newton":
            self.evaluate(z)
            return self.hess_target.assemble(sigma * self._jtj)
        z = np.asarray(z, float).ravel()
        parts = []
        for bs in self.sets:
            n_c, n_b = bs.kind.n_constraints, bs.cols.shape[0]
            lam = lam_g[bs.g_rows[:, None] + np.arange(n_c)[None, :]].T if n_c else np.zeros((0, n_b))
            parts.append(np.asarray(bs.hess(bs.local(z), *bs.data, sigma, lam)).T.ravel())
        n_q = self.quat_cols.shape[0]
        parts.append(np.repeat(2.0 * lam_g[self.n_g - n_q:], 4))
        return self.hess_target.assemble(np.concatenate(parts))


def _selection(rows: int, pairs: list[tuple[int, int]], n_cols: int) -> ca.DM:
    s = np.zeros((rows, n_cols))
    for r, c in pairs:
        s[r, c] = 1.0
    return ca.DM(s)


def _imu_sigma(cfg) -> np.ndarray:
    return np.r_[np.full(3, cfg.imu.accel_noise_mps2), np.full(3, cfg.imu.gyro_noise_radps)]


class _Unscale:
    """SI quantities from the scaled local variables of a block."""

    def __init__(self, model: FlightModel, params: ParameterSet, u_scale=np.zeros(0)) -> None:  # noqa: B008
        self.n_p, self.u_scale = params.n, ca.DM(np.asarray(u_scale, float))
        self.p_sel = _selection(model.n_params, params.model_selection(), params.n)
        self.b_sel = _selection(6, [(j, params.index(n)) for j, n in enumerate(SENSOR_NAMES)
                                    if n in params.names], params.n)
        self.scales = ca.DM(params.scales)
        self.clock = params.index("clock_offset_s") if "clock_offset_s" in params.names else None

    def split(self, v: ca.SX):
        """(xk, xk1, theta, uk, uk1) in SI from a block's scaled locals [xk, xk1, theta, uk, uk1]."""
        xk = v[:NS] * ca.DM(STATE_SCALE)
        xk1 = v[NS:2 * NS] * ca.DM(STATE_SCALE)
        end = 2 * NS + self.n_p
        theta = v[2 * NS:end] * self.scales
        n_u = self.u_scale.numel()
        uk, uk1 = v[end:end + n_u] * self.u_scale, v[end + n_u:end + 2 * n_u] * self.u_scale
        return xk, xk1, theta, uk, uk1

    def model_params(self, theta):
        return self.p_sel @ theta

    def biases(self, theta):
        return self.b_sel @ theta


def _interval_kind(model, mesh, params, un: _Unscale, active=()) -> BlockKind:
    v = ca.SX.sym("v", 2 * NS + params.n + 2 * len(active))
    d, rr = ca.SX.sym("d", int(D_OFFSETS[-1])), ca.SX.sym("R", int(R_OFFSETS[-1]))
    xk, xk1, theta, uk, uk1 = un.split(v)
    defect, r_imu, _ = interval_function(model, mesh.h, active)(
        xk, xk1, un.model_params(theta), un.biases(theta), d, rr, uk, uk1)
    return BlockKind("interval", v, [d, rr], r_imu, defect)


def _gps_kind(model, mesh, params, un: _Unscale, guess: float = 0.0, active=()) -> BlockKind:
    v = ca.SX.sym("v", 2 * NS + params.n + 2 * len(active))
    tau0, y, w = ca.SX.sym("tau0"), ca.SX.sym("y", 6), ca.SX.sym("w", 6)
    xk, xk1, theta, uk, uk1 = un.split(v)
    tau = tau0 - (theta[un.clock] if un.clock is not None else guess) / mesh.h
    r = gps_function(model, mesh.h, active)(xk, xk1, un.model_params(theta), tau, y, w, uk, uk1)
    return BlockKind("gps", v, [tau0, y, w], r, None)


def _process_kinds(part: DropPart) -> tuple[BlockKind, BlockKind]:
    """Gauss-Markov prior of the disturbance node values (scaled by sigma): the first node's
    u_0 / sigma, and per interval (u_k+1 - phi u_k) / (sigma sqrt(1 - phi^2))."""
    n_u = part.n_u
    phi = part.disturbance.transition(part.mesh.h)
    u0 = ca.SX.sym("u0", n_u)
    v = ca.SX.sym("v", 2 * n_u)
    step = (v[n_u:] - ca.DM(phi) * v[:n_u]) / ca.DM(np.sqrt(1.0 - phi**2))
    return BlockKind("disturbance_start", u0, [], u0, None), BlockKind("disturbance_step", v, [], step, None)


def _prior_kind(params: ParameterSet) -> tuple[BlockKind | None, dict[str, slice]]:
    v = ca.SX.sym("v", params.n)
    rows, groups = [], {}
    for group in ("atmosphere", "aero", "imu", "clock"):
        members = [(i, s) for i, s in enumerate(params.specs) if s.group == group and s.prior_sigma]
        if members:
            groups[f"prior_{group}"] = slice(len(rows), len(rows) + len(members))
            rows += [v[i] * s.scale / s.prior_sigma for i, s in members]
    if not rows:
        return None, {}
    return BlockKind("prior", v, [], ca.vertcat(*rows), None), groups


def drop_block_sets(model: FlightModel, data: FitData, part: DropPart, cfg) -> list[_BlockSet]:
    """The interval, GPS and prior blocks of one drop, with global columns from ``part``."""
    mesh, params, active = part.mesh, part.params, part.active
    n_int, k = mesh.n_intervals, mesh.samples_per_interval
    un = _Unscale(model, params, part.u_scale)
    y = np.column_stack([data.accel_imu, data.gyro_imu])[:n_int * k]
    valid = np.column_stack([data.accel_valid, data.gyro_valid])[:n_int * k]
    part.imu_blocks = compress_imu(mesh, y, valid, _imu_sigma(cfg))

    def node_cols(kk: np.ndarray) -> np.ndarray:
        first = part.node_offset + NS * kk[:, None] + np.arange(2 * NS)[None, :]
        return np.column_stack([first, np.tile(part.theta_cols, (kk.size, 1)), part.u_cols[kk], part.u_cols[kk + 1]])

    t_fix = data.gps_time_s
    kfix = np.clip(((t_fix - part.guess_clock_s - mesh.t_nodes[0]) // mesh.h).astype(int), 0, n_int - 1)
    gps_data = [ca.DM((t_fix - mesh.t_nodes[kfix]) / mesh.h).T,
                ca.DM(np.column_stack([data.gps_pos_ned, data.gps_vel_ned]).T), ca.DM(1.0 / data.gps_sigma.T)]
    sets = [_BlockSet(_interval_kind(model, mesh, params, un, active), node_cols(np.arange(n_int)),
                      [ca.DM(part.imu_blocks.d), ca.DM(part.imu_blocks.R)],
                      part.defect_offset + NS * np.arange(n_int), "imu"),
            _BlockSet(_gps_kind(model, mesh, params, un, part.guess_clock_s, active), node_cols(kfix), gps_data,
                      group="gps")]
    if part.n_u:
        start, step = _process_kinds(part)
        sets += [_BlockSet(start, part.u_cols[:1], [], group="disturbance_start"),
                 _BlockSet(step, np.column_stack([part.u_cols[:-1], part.u_cols[1:]]), [], group="disturbance")]
    return sets + prior_block_sets(part)


def prior_block_sets(part: DropPart) -> list[_BlockSet]:
    """The prior block of a drop's parameters (empty when no prior is on)."""
    prior_kind, prior_groups = _prior_kind(part.params)
    if prior_kind is None:
        return []
    part.groups = prior_groups
    return [_BlockSet(prior_kind, part.theta_cols[None, :], [], group="prior")]


def assemble_nlp(parts: list[DropPart], sets_per_part: list[list[_BlockSet]], n_z: int,
                 hessian: str = "gauss-newton", prefix_groups: bool = False, quaternions: bool = True) -> FitNlp:
    """Residuals, constraints and derivatives of the NLP made of every drop's blocks.

    Constraint rows: every drop's defects (drop after drop), then one quaternion-norm row per drop.
    Residual groups: imu, gps, prior_* per drop (prefixed ``name/`` when ``prefix_groups``).
    """
    z = ca.MX.sym("z", n_z)
    residual_parts, groups, start, defects = [], {}, 0, []
    for part, sets in zip(parts, sets_per_part):
        pre = f"{part.name}/" if prefix_groups else ""
        prior_groups, part.groups = part.groups, {}
        for bs in sets:
            name = bs.group
            n_b = bs.cols.shape[0]
            local = ca.reshape(z[bs.cols.ravel().tolist()], bs.kind.n_local, n_b)
            fn = bs.kind.values.map(n_b, "thread", 2) if n_b > 1 else bs.kind.values
            out = fn(local, *bs.data)
            out = out if isinstance(out, (list, tuple)) else [out]
            r = ca.vec(out[0])
            named = ({pre + g: slice(start + s_.start, start + s_.stop) for g, s_ in prior_groups.items()}
                     if name == "prior" else {pre + name: slice(start, start + r.numel())})
            groups.update(named)
            part.groups.update(named)
            residual_parts.append(r)
            start += r.numel()
            if len(out) > 1:
                defects.append(ca.vec(out[1]))
    quat_cols = np.array([p.node_offset + np.arange(6, 10) for p in parts] if quaternions else [],
                         np.int64).reshape(-1, 4)
    quats = [ca.dot(z[c.tolist()], z[c.tolist()]) - 1 for c in quat_cols]
    constraints = ca.vertcat(*defects, *quats)
    all_sets = [bs for sets in sets_per_part for bs in sets]
    derivs = BlockDerivatives(all_sets, n_z, constraints.numel(), quat_cols, hessian)
    return FitNlp(parts, z, ca.vertcat(*residual_parts), constraints, groups, derivs)


def build_nlp(model: FlightModel, data: FitData, mesh: Mesh, params: ParameterSet, cfg,
              hessian: str = "gauss-newton", guess_clock_s: float | None = None) -> FitNlp:
    """Assemble the NLP of one drop (see the module docstring). GPS fixes are put on collocation
    intervals for the clock offset ``guess_clock_s`` (default: the configured guess)."""
    n_sv = NS * mesh.t_nodes.size
    guess = cfg.estimation.clock_offset_guess_s if guess_clock_s is None else guess_clock_s
    part = DropPart(cfg.name, mesh, params, 0, n_sv + np.arange(params.n), 0, guess_clock_s=guess,
                    disturbance=cfg.estimation.disturbance, u_offset=n_sv + params.n)
    sets = drop_block_sets(model, data, part, cfg)
    return assemble_nlp([part], [sets], n_sv + params.n + part.u_cols.size, hessian)
