"""Multi-drop joint aero fit (EES paper Table 5): one NLP in which the aero dispersion factors are
shared and every drop keeps its own node states, initial conditions, wind biases, density factor,
IMU biases, clock offset and fit window.

Which dispersions are shared, estimated per drop, or fixed at 0 is configuration
(:class:`JointConfig`). The paper's tied C_N/C_Y and C_m/C_n multipliers are single factors in
casrecon's parametrisation (``CNY_mult``, ``Cmn_mult``), so they are tied by construction.
The prior on a shared factor enters once, not once per drop.
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from casrecon.estimation.engine.checks import FitError, covariance_or_fail
from casrecon.estimation.engine.convergence import fit_stage, iteration_logging, nested_label
from casrecon.estimation.kinds.base import DropContext
from casrecon.estimation.sixdof.continuation import solve_fit
from casrecon.estimation.sixdof.drop import FitNlp, assemble_drops, load_measurements, parameter_set, with_extra_columns
from casrecon.estimation.sixdof.fit import FitResult, drop_result, prepare_drop
from casrecon.estimation.sixdof.initial_guess import initial_guess
from casrecon.estimation.sixdof.layout import NS, DropLayout
from casrecon.estimation.sixdof.parameters import ParameterSet
from casrecon.estimation.sixdof.settings import FitSettings
from casrecon.estimation.sixdof.transcription import STATE_SCALE
from casrecon.io.toml_fields import TomlDocument, load_toml
from casrecon.parallel import in_threads
from casrecon.physics.aero import DISPERSION_NAMES
from casrecon.scenario import Scenario


@dataclass(frozen=True)
class JointConfig:
    """A joint fit: the drops and what the dispersion factors do.

    Parameters
    ----------
    name : str
    drops : tuple of Path
        Problem folders (or problem.toml files).
    shared : tuple of str or None
        Dispersion factors common to all drops; None: every factor the drops estimate.
    per_drop : tuple of str
        Factors each drop estimates for itself.
    fixed : tuple of str
        Factors held at 0 (not estimated).
    """

    name: str
    drops: tuple[Path, ...]
    shared: tuple[str, ...] | None = None
    per_drop: tuple[str, ...] = ()
    fixed: tuple[str, ...] = ()


def _names(t, key: str) -> tuple[str, ...] | None:
    value = t.raw(key)
    if value is None:
        return None
    if not isinstance(value, list) or any(v not in DISPERSION_NAMES for v in value):
        raise t.error(key, f"expected a list of dispersion names from {', '.join(DISPERSION_NAMES)}")
    return tuple(value)


def load_joint(source: str | Path | TomlDocument) -> JointConfig:
    """Parse a joint file (its path, or its parsed document): ``[joint] name, drops = [...], shared,
    per_drop, fixed``."""
    f = load_toml(source)
    path = f.path
    t = f.table("joint", required=True)
    drops = t.raw("drops", required=True)
    if not isinstance(drops, list) or len(drops) < 2 or not all(isinstance(d, str) for d in drops):
        raise t.error("drops", "expected a list of at least two problem folders")
    folders = []
    for d in drops:
        p = (Path(path).parent / d).resolve()
        if not (p / "problem.toml").is_file() and not p.is_file():
            raise t.error("drops", f"no problem.toml in {d!r} (looked in {p})")
        folders.append(p)
    cfg = JointConfig(name=t.string("name", required=True), drops=tuple(folders), shared=_names(t, "shared"),
                      per_drop=_names(t, "per_drop") or (), fixed=_names(t, "fixed") or ())
    overlap = (set(cfg.shared or ()) & set(cfg.per_drop)) | (set(cfg.shared or ()) & set(cfg.fixed)) \
        | (set(cfg.per_drop) & set(cfg.fixed))
    if overlap:
        raise t.error("shared", f"a factor can be shared, per_drop or fixed, not two of them: {sorted(overlap)}")
    t.reject_unknown()
    f.reject_unknown()
    return cfg


@dataclass
class JointResult:
    """A joint fit: per-drop results (views of the one NLP) and the global parameter vector."""

    config: JointConfig
    drops: list[FitResult]
    names: tuple[str, ...]           # global parameter names (shared plain, own as drop.name)
    values: np.ndarray
    sigma: np.ndarray
    correlation: np.ndarray
    shared: tuple[str, ...]
    chi2: float
    dof: int
    reduced_chi2: float
    timings: dict[str, float]
    iterations: int
    status: str
    settings: FitSettings


def _parameter_sets(scenarios: list[Scenario], cfg: JointConfig) -> tuple[list[ParameterSet], tuple[str, ...]]:
    """Each drop's ParameterSet (fixed factors removed; shared priors kept only on the first drop)."""
    sets = []
    for sc in scenarios:
        est = sc.config.estimation
        sizes = sc.config.aero.sizes
        default = tuple(n for n in DISPERSION_NAMES if getattr(sizes, n) > 0)
        wanted = tuple(n for n in (est.estimate or default) if n not in cfg.fixed)
        sc_cfg = dataclasses.replace(sc.config, estimation=dataclasses.replace(est, estimate=wanted))
        sets.append(parameter_set(sc_cfg))
    aero_sets = [set(n for n, s in zip(p.names, p.specs) if s.group == "aero") for p in sets]
    common = set.intersection(*aero_sets)
    shared = tuple(n for n in DISPERSION_NAMES if n in common and n not in cfg.per_drop
                   and (cfg.shared is None or n in cfg.shared))
    out = [sets[0]]
    for p in sets[1:]:
        out.append(ParameterSet(tuple(dataclasses.replace(s, prior_sigma=None) if s.name in shared else s
                                      for s in p.specs)))
    return out, shared


def _layouts(scenarios, meshes, psets, shared, guesses: dict[str, float],
             measurements: list[dict], altitudes: dict[str, np.ndarray]) -> tuple[list[DropLayout], int]:
    """DropLayouts with global columns: all nodes, then shared factors, then each drop's own
    parameters followed by its disturbance node values (weak constraint), then each drop's extra
    unknowns (latent sensor errors, atmosphere-profile coefficients placed by ``altitudes``)."""
    node_offsets = np.cumsum([0] + [NS * m.t_nodes.size for m in meshes])
    shared_col = {n: int(node_offsets[-1]) + i for i, n in enumerate(shared)}
    next_col = int(node_offsets[-1]) + len(shared)
    layouts = []
    for sc, mesh, ps, off in zip(scenarios, meshes, psets, node_offsets):
        cols = []
        for name in ps.names:
            if name in shared_col:
                cols.append(shared_col[name])
            else:
                cols.append(next_col)
                next_col += 1
        layouts.append(DropLayout(sc.config.name, mesh, ps, int(off), np.array(cols),
                                  guess_clock_s=guesses[sc.config.name],
                                  disturbance=sc.config.estimation.disturbance, u_offset=next_col))
        next_col += layouts[-1].n_u_values  # the drop's latent disturbance values, if any
    out = []
    for sc, layout, meas in zip(scenarios, layouts, measurements):
        layout, next_col = with_extra_columns(layout, sc.config, meas, next_col,
                                              node_alt_msl_m=altitudes.get(sc.config.name))
        out.append(layout)
    return out, next_col


def joint_settings(scenarios: list[Scenario], **overrides) -> tuple[FitSettings, list[str]]:
    """The joint fit's solver settings: the first drop's ``[estimation]`` (keyword overrides
    win), and notes naming drops whose settings differ (their values are not used)."""
    settings = [FitSettings.from_estimation(sc.config.estimation, **overrides) for sc in scenarios]
    notes = [f"{sc.config.name}: [estimation] solver settings {s} differ from the first drop's; the joint fit uses "
             f"{settings[0]}" for sc, s in zip(scenarios[1:], settings[1:]) if s != settings[0]]
    return settings[0], notes


def fit_joint(scenarios: list[Scenario], cfg: JointConfig, *, hessian: str | None = None,
              linear_solver: str | None = None, max_iter: int | None = None, tol: float | None = None,
              print_level: int = 0, solver: str | None = None, method: str | None = None) -> JointResult:
    """Solve the joint NLP. Raises FitError when it does not converge or the KKT matrix is singular.

    Solver settings come from the drops' ``[estimation]`` tables (see :func:`joint_settings`);
    the keyword arguments override them.
    """
    if len({sc.config.name for sc in scenarios}) != len(scenarios):
        raise FitError("joint fit: two drops have the same problem name")
    settings, setting_notes = joint_settings(scenarios, hessian=hessian, linear_solver=linear_solver,
                                             max_iter=max_iter, tol=tol, print_level=print_level, solver=solver,
                                             method=method)
    scenarios = [sc.with_fresh_functions() for sc in scenarios]  # see Scenario.with_fresh_functions
    t0 = time.perf_counter()
    # each drop's data read and checked side by side; the initial guesses (CasADi functions, whose
    # making is not thread-safe: casadi#1355) one after the other
    with iteration_logging(label=nested_label("joint fit")):
        # unannounced: a refused input file is then the only line (it speaks if it takes long)
        with fit_stage(f"reading and checking the data of {len(scenarios)} drops, initial guesses", announce=False):
            prepared = list(in_threads(prepare_drop, scenarios))
            x0s = [initial_guess(data, mesh, sc.config.vehicle, sc.atmosphere, sc.config.site.ground_alt_msl_m)
                   for sc, (data, mesh) in zip(scenarios, prepared)]
            psets, shared = _parameter_sets(scenarios, cfg)
            measurements = [load_measurements(sc.config, data) for sc, (data, _) in zip(scenarios, prepared)]
        return _solved_joint(scenarios, cfg, settings, setting_notes, prepared, x0s, psets, shared, measurements, t0)


def _solved_joint(scenarios, cfg: JointConfig, settings: FitSettings, setting_notes: list[str], prepared, x0s,
                  psets, shared, measurements, t0: float) -> JointResult:
    """The joint NLP of the prepared drops built, solved, and its covariance (:func:`fit_joint`)."""

    def build(guesses: dict[str, float], altitudes: dict[str, np.ndarray]) -> FitNlp:
        with fit_stage("building the NLP"):
            layouts, n_z = _layouts(scenarios, [m for _, m in prepared], psets, shared, guesses, measurements,
                                    altitudes)
            contexts = [DropContext(sc.model, sc.config, layout, data, meas, prefixed=True)
                        for sc, (data, _), layout, meas in zip(scenarios, prepared, layouts, measurements)]
            return assemble_drops(contexts, n_z, settings.hessian)

    def start(fit_nlp: FitNlp) -> np.ndarray:
        z0 = np.zeros(fit_nlp.nlp.n_z)
        for part, x0 in zip(fit_nlp.parts, x0s):
            z0[part.node_cols] = (x0 / STATE_SCALE).ravel()
        return z0

    guesses0 = {sc.config.name: sc.config.estimation.clock_offset_guess_s for sc in scenarios}
    fit_nlp, sol, build_s = solve_fit(build, start, guesses0, settings)
    nlp = fit_nlp.nlp
    t2 = time.perf_counter()
    with fit_stage("covariance"):
        r = nlp.residual_vector(sol.z)
        cov = covariance_or_fail(nlp, sol.z, r, sol.reduced, information=settings.information_for(fit_nlp.parts),
                                 lam_g=sol.lam_g)
    timings = {"build_s": build_s, "solve_s": sol.solve_s}
    with fit_stage("trajectory bands of each drop"):
        drops = [drop_result(sc, data, fit_nlp, i, sol, cov, r, timings)
                 for i, (sc, (data, _)) in enumerate(zip(scenarios, prepared))]
    if setting_notes:
        drops = [dataclasses.replace(d, notes=d.notes + tuple(setting_notes)) for d in drops]
    columns = nlp.parameter_names
    cols = np.array(list(columns))
    scales = np.zeros(nlp.n_z)
    for part in fit_nlp.parts:
        scales[part.theta_cols] = part.params.scales
    c = cov.covariance_of(cols, scales[cols])
    sigma = np.sqrt(np.diag(c))
    t3 = time.perf_counter()
    timings.update(covariance_s=t3 - t2, total_s=t3 - t0)
    return JointResult(cfg, drops, tuple(columns.values()), sol.z[cols] * scales[cols], sigma,
                       c / np.outer(sigma, sigma), shared, nlp.chi2(r), nlp.dof(), cov.reduced_chi2, timings,
                       sol.iterations, sol.status, settings)
