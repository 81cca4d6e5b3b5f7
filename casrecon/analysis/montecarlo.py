"""Dispersed Monte Carlo of a drop (the DAVINCI team ran 8000 such cases).

Each case perturbs the problem's release state and its truth parameters (the nominal ones,
zeros, when the problem has no ``[truth]``, or with ``center="nominal"``) by Gaussian draws
whose sizes a :class:`Dispersions` states (by default the problem's ``[montecarlo]`` table,
:mod:`casrecon.io.montecarlo_config`), and is flown to ground impact by the
:class:`~casrecon.simulation.batch.BatchSimulator`.

Reproducibility: case ``i`` of seed ``s`` draws its inputs from ``numpy.random.default_rng([s, i])``
only, always the same :data:`N_DRAWS` standard normals in the same order (scaled afterwards, so a
zero size leaves the other inputs unchanged). A case is thus the same whether it is run alone,
in any chunk, on any number of local processes or on a Dask cluster.

Runners: chunks of cases (one vectorised batch each) are the unit of work, mapped by
:func:`casrecon.parallel.parallel_map`: ``workers == 1`` runs them in this process,
``workers > 1`` in a spawn-context :class:`~concurrent.futures.ProcessPoolExecutor`, and a
``scheduler`` address (``"tcp://host:8786"``) sends them to a Dask distributed cluster; the
workers load the problem from its path, so they must see the same file system.

Progress: the bar counts each case as it lands inside its chunk
(:func:`casrecon.parallel.report_progress`; on a Dask cluster per chunk), and with the
``casrecon`` logger at DEBUG each finished case is logged instead (flight time, impact speed).
Smaller chunks would move the bar too but cost speed (2000 cases of ees-drop-1 on 2 processes:
chunks of 50 took 27 to 30 s against 21 to 22 s for 250).

Typical use::

    from casrecon.analysis.montecarlo import run_montecarlo
    mc = run_montecarlo("problems/ees-drop-1", n_cases=8000, seed=1, workers=2)
    mc.statistics()["impact_speed_mps"]["p99"]
"""

from __future__ import annotations

import logging
import math
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from casrecon.analysis.mc_envelopes import HISTORY_DT_S, HISTORY_MAX_CASES, Histories
from casrecon.io.montecarlo_config import Dispersions
from casrecon.io.toml_fields import TomlDocument
from casrecon.parallel import parallel_map, report_progress
from casrecon.physics.aero import DISPERSION_NAMES
from casrecon.physics.dynamics import PARAMETER_NAMES
from casrecon.simulation.batch import (
    DEFAULT_DT_S,
    BatchSimulator,
    euler_deg_from_quats,
    pad_histories,
    quats_from_euler_deg,
)

if TYPE_CHECKING:
    from casrecon.scenario import Scenario

LOG = logging.getLogger(__name__)

#: Standard normals drawn per case: h_agl, vel NED (3), Euler (3), rates (3), wind bias N/E,
#: density factor, then the aero factors (last, so that a new factor changes no other draw).
N_DRAWS = 1 + 3 + 3 + 3 + len(DISPERSION_NAMES) + 3

#: Drawn inputs written per case (SI, angles in deg).
INPUT_NAMES = (("h_agl_m", "vel_n_mps", "vel_e_mps", "vel_d_mps", "roll_deg", "pitch_deg", "yaw_deg",
                "p_dps", "q_dps", "r_dps") + DISPERSION_NAMES + ("wind_bias_n_mps", "wind_bias_e_mps",
                                                                 "density_factor"))
#: Outputs per case.
OUTPUT_COLUMNS = ("impacted", "flight_time_s", "impact_speed_mps", "impact_vel_n_mps", "impact_vel_e_mps",
                  "impact_vel_d_mps", "impact_roll_deg", "impact_pitch_deg", "impact_yaw_deg", "max_alpha_t_deg")
#: Key of the per-case histories in a chunk's columns (not a column of cases.csv).
HISTORY_KEY = "history"
#: Outputs with statistics in :meth:`MonteCarloResult.statistics`.
STATISTIC_NAMES = ("flight_time_s", "impact_speed_mps", "max_alpha_t_deg")


def draw_case(seed: int, index: int, x0: np.ndarray, p0: np.ndarray, disp: Dispersions) -> tuple[np.ndarray,
                                                                                                  np.ndarray]:
    """Release state (13,) and parameters (np,) of case ``index`` of ``seed`` (resolved ``disp``)."""
    z = np.random.default_rng([int(seed), int(index)]).standard_normal(N_DRAWS)
    x = np.array(x0, float)
    p = np.array(p0, float)
    x[2] -= disp.h_agl_m * z[0]
    x[3:6] += disp.velocity_mps * z[1:4]
    if disp.euler_deg > 0:
        euler = euler_deg_from_quats(x[6:10, None]).ravel() + disp.euler_deg * z[4:7]
        x[6:10] = quats_from_euler_deg(euler[:, None]).ravel()
    x[10:13] += np.radians(disp.rate_dps * z[7:10])
    p[PARAMETER_NAMES.index("wind_bias_n")] += disp.wind_bias_mps * z[10]
    p[PARAMETER_NAMES.index("wind_bias_e")] += disp.wind_bias_mps * z[11]
    p[PARAMETER_NAMES.index("density_factor")] += disp.density_factor * z[12]
    for i, name in enumerate(DISPERSION_NAMES):
        if name in disp.aero_factors:
            p[PARAMETER_NAMES.index(name)] += disp.aero_factor * z[13 + i]
    return x, p


@dataclass(frozen=True)
class ChunkTask:
    """One unit of work: cases ``indices`` of ``seed`` for the problem at ``problem``."""

    problem: str
    seed: int
    indices: tuple[int, ...]
    dispersions: Dispersions
    dt_s: float = DEFAULT_DT_S
    t_max_s: float = 300.0
    batch: int = 250
    backend: str = "auto"
    history_every: int = 0


_CACHE: dict = {}
_CACHE_LOCK = threading.Lock()
#: The scenario this process loaded last for each problem file (resolved path): a run hands in the
#: one it read, so that its in-process chunks do not read the file again.
_SCENARIOS: dict = {}


def use_scenario(problem: str, scenario) -> None:
    """Let this process's chunks of ``problem`` (a resolved path) fly ``scenario`` (already loaded by the
    caller) instead of reading the file again; simulators of an earlier scenario of it are dropped."""
    with _CACHE_LOCK:
        if _SCENARIOS.get(problem) is not scenario:
            _SCENARIOS[problem] = scenario
            for key in [k for k in _CACHE if k[0] == problem]:
                del _CACHE[key]


def _scenario_and_simulator(problem: str, dt_s: float, batch: int, backend: str):
    from casrecon.scenario import Scenario

    key = (problem, dt_s, batch, backend)
    with _CACHE_LOCK:
        if key not in _CACHE:
            sc = _SCENARIOS.get(problem)
            if sc is None:
                sc = _SCENARIOS[problem] = Scenario.load(problem)
            _CACHE[key] = (sc, BatchSimulator(sc.model, dt_s=dt_s, batch=batch, backend=backend))
        return _CACHE[key]


def simulate_chunk(task: ChunkTask) -> dict[str, np.ndarray]:
    """Run one chunk; returns ``case`` and every :data:`INPUT_NAMES` and :data:`OUTPUT_COLUMNS` column,
    and with ``task.history_every`` > 0 ``"history"``: the cases' histories (float32 (n, k, 4), see
    :meth:`~casrecon.simulation.batch.BatchSimulator.run_with_history`).

    Top-level and picklable, so process pools and Dask workers can call it.
    """
    sc, sim = _scenario_and_simulator(task.problem, task.dt_s, task.batch, task.backend)
    x0, p0 = _centre(sc, task.dispersions)
    disp = task.dispersions.resolved(sc.config.atmosphere.wind_3sigma_mps, sc.config.atmosphere.density_3sigma)
    n = len(task.indices)
    xs, ps = np.empty((13, n)), np.empty((len(p0), n))
    for j, i in enumerate(task.indices):
        xs[:, j], ps[:, j] = draw_case(task.seed, i, x0, p0, disp)
    res, history = sim.run_with_history(xs, ps, task.t_max_s, task.history_every, on_landed=report_progress)
    cols = {"case": np.asarray(task.indices, int)}
    euler = euler_deg_from_quats(xs[6:10])
    inputs = [-xs[2], xs[3], xs[4], xs[5], *euler, *np.degrees(xs[10:13])]
    inputs += [ps[PARAMETER_NAMES.index(nm)] for nm in DISPERSION_NAMES]
    inputs += [ps[PARAMETER_NAMES.index(nm)] for nm in ("wind_bias_n", "wind_bias_e", "density_factor")]
    cols.update(zip(INPUT_NAMES, inputs))
    outputs = [res.impacted.astype(float), res.flight_time_s, res.impact_speed_mps, *res.impact_state[3:6],
               *res.impact_euler_deg, res.max_alpha_t_deg]
    cols.update(zip(OUTPUT_COLUMNS, outputs))
    if history is not None:
        cols[HISTORY_KEY] = history
    return cols


def _centre(sc, disp: Dispersions) -> tuple[np.ndarray, np.ndarray]:
    from casrecon.physics.dynamics import default_parameters

    p0 = sc.truth_parameters() if disp.center == "truth" else default_parameters()
    return sc.release_state(), p0


@dataclass(frozen=True)
class MonteCarloResult:
    """Every case of a Monte Carlo run, in case order.

    Attributes
    ----------
    columns : dict of str to (n,) array
        ``case`` (index i of ``default_rng([seed, i])``), :data:`INPUT_NAMES`, :data:`OUTPUT_COLUMNS`.
    seed : int
    dispersions : Dispersions
        As resolved for the problem (atmosphere sizes filled in).
    dt_s, backend, wall_s : run settings and wall time (s).
    nominal : dict
        The centre flight (zero dispersions): flight time, impact speed, etc.
    histories : Histories or None
        Every case's altitude, speed, total angle of attack and pitch on a fixed time grid, and the
        centre flight's (None when not recorded); :meth:`Histories.envelopes` gives p1/p50/p99.
    """

    columns: dict[str, np.ndarray]
    seed: int
    dispersions: Dispersions
    dt_s: float
    wall_s: float = 0.0
    nominal: dict = field(default_factory=dict)
    problem: str = ""
    histories: Histories | None = None

    @property
    def n_cases(self) -> int:
        return len(self.columns["case"])

    def __getitem__(self, name: str) -> np.ndarray:
        return self.columns[name]

    def table(self) -> tuple[list[str], np.ndarray]:
        """CSV header and (n, k) array."""
        names = list(self.columns)
        return names, np.column_stack([self.columns[n] for n in names])

    def statistics(self) -> dict:
        """Mean, sd, 3-sigma, percentiles (1, 50, 99), min and max of :data:`STATISTIC_NAMES` over
        impacted cases, plus counts and the run settings."""
        ok = self.columns["impacted"] > 0.5
        out: dict = {"problem": self.problem, "n_cases": self.n_cases, "n_impacted": int(ok.sum()),
                     "seed": self.seed, "dt_s": self.dt_s, "dispersions_1sigma": self.dispersions.to_dict(),
                     "nominal": self.nominal}
        if self.histories is not None:
            out.update(history_dt_s=self.histories.dt_s, n_history_cases=self.histories.n_cases,
                       history_memory_mb=self.histories.nbytes / 1e6)
        for name in STATISTIC_NAMES:
            v = self.columns[name][ok]
            if v.size == 0:
                out[name] = None
                continue
            mean, sd = float(v.mean()), float(v.std(ddof=1)) if v.size > 1 else 0.0
            p1, p50, p99 = (float(x) for x in np.percentile(v, [1, 50, 99]))
            out[name] = {"mean": mean, "sd": sd, "three_sigma": 3 * sd, "mean_minus_3sigma": mean - 3 * sd,
                         "mean_plus_3sigma": mean + 3 * sd, "p1": p1, "p50": p50, "p99": p99,
                         "min": float(v.min()), "max": float(v.max())}
        return out


def _chunks(indices: list[int], chunk_size: int) -> list[tuple[int, ...]]:
    return [tuple(indices[s:s + chunk_size]) for s in range(0, len(indices), chunk_size)]


def run_cases(problem: str | Path, indices, seed: int, dispersions: Dispersions | None = None, *,
              workers: int = 1, scheduler: str | None = None, chunk_size: int = 250, dt_s: float = DEFAULT_DT_S,
              t_max_s: float = 300.0, backend: str = "auto", progress: bool = False,
              history_every: int = 0, history_cases: int | None = None) -> dict[str, np.ndarray]:
    """Simulate cases ``indices`` of ``seed``; columns in the order of ``indices``.

    ``scheduler`` (a Dask distributed address) takes precedence over ``workers``. With
    ``history_every`` > 0 the result also holds ``"history"`` (float32 (m, k, 4), NaN-padded): the
    history every ``history_every`` RK4 steps of the first m cases of ``indices`` (m = all, or
    ``history_cases``; only the chunks that hold them record any). ``dispersions`` None: the code
    defaults :class:`Dispersions` () (not the problem's ``[montecarlo]`` table; :func:`run_montecarlo` reads it).
    """
    dispersions = Dispersions() if dispersions is None else dispersions
    problem = str(Path(problem).resolve())
    indices = [int(i) for i in indices]
    if any(i < 0 for i in indices):
        raise ValueError("case indices must be >= 0")
    if chunk_size < 1 or workers < 1:
        raise ValueError(f"chunk_size and workers must be >= 1, got {chunk_size}, {workers}")
    batch = min(chunk_size, 250)
    limit = len(indices) if history_cases is None else max(0, int(history_cases))
    chunks = _chunks(indices, chunk_size)
    starts = np.cumsum([0] + [len(c) for c in chunks])
    tasks = [ChunkTask(problem, int(seed), c, dispersions, float(dt_s), float(t_max_s), batch, backend,
                       int(history_every) if start < limit else 0) for c, start in zip(chunks, starts)]
    lines = LOG.isEnabledFor(logging.DEBUG)  # one line per case: then they are the progress, not the bar
    parts = parallel_map(simulate_chunk, tasks, workers=workers, scheduler=scheduler,
                         progress="montecarlo" if progress and not lines else None, weight=lambda t: len(t.indices),
                         on_done=log_cases if lines else None)
    if not parts:
        return {}
    out = {name: np.concatenate([p[name] for p in parts]) for name in parts[0] if name != HISTORY_KEY}
    recorded = [p[HISTORY_KEY] for p in parts if HISTORY_KEY in p]
    if recorded:
        out[HISTORY_KEY] = pad_histories(recorded)[:limit]
    return out


def log_cases(task: ChunkTask, cols: dict[str, np.ndarray]) -> None:
    """Log (DEBUG) one line per case of a finished chunk: flight time and impact speed."""
    for i, case in enumerate(cols["case"]):
        if cols["impacted"][i] > 0.5:
            LOG.debug("montecarlo case %d: impact after %.3f s at %.2f m/s", case, cols["flight_time_s"][i],
                      cols["impact_speed_mps"][i])
        else:
            LOG.debug("montecarlo case %d: still flying at %.1f s", case, task.t_max_s)


def memory_estimate_bytes(n_cases: int) -> int:
    """Peak memory of :func:`run_montecarlo` with ``n_cases`` cases and of writing its result, bytes
    (an estimate): the per-case columns (``case``, :data:`INPUT_NAMES`, :data:`OUTPUT_COLUMNS`, 8 bytes
    each) three times (the chunks, their concatenation, the CSV table; measured: 870 bytes a case for
    the 36 columns of 10^6 cases, against 864 here), 150 bytes a case of work list (measured: 50 MB
    more parent memory at 10^6 cases than at 500), and 0.3 GB of interpreter, libraries and workers."""
    n_columns = 1 + len(INPUT_NAMES) + len(OUTPUT_COLUMNS)
    return int(0.3e9 + max(int(n_cases), 0) * (3 * 8 * n_columns + 150))


def run_montecarlo(problem: str | Path | TomlDocument | Scenario, n_cases: int | None = None,
                   seed: int | None = None, dispersions: Dispersions | None = None, *, workers: int = 1,
                   scheduler: str | None = None, chunk_size: int | None = None, dt_s: float = DEFAULT_DT_S,
                   t_max_s: float = 300.0, backend: str = "auto", progress: bool = False,
                   history_dt_s: float | None = HISTORY_DT_S, history_cases: int = HISTORY_MAX_CASES
                   ) -> MonteCarloResult:
    """Cases 0 .. ``n_cases`` - 1 of ``seed``, plus the nominal (undispersed) flight, of ``problem`` (its
    folder or ``problem.toml``, parsed or not, or its loaded Scenario: read once in this process;
    worker processes read it once each).

    ``n_cases``, ``seed`` and ``dispersions`` default to the problem's ``[montecarlo]`` table
    (:class:`~casrecon.io.montecarlo_config.MonteCarloConfig`; without it 1000 cases, seed 0 and
    :class:`Dispersions` ()). ``chunk_size`` defaults to 250 cases, fewer when that would leave
    workers idle; ``progress`` draws a bar on stderr that counts each case as it lands. Each case's
    altitude, speed, total angle of attack and pitch are kept every ``history_dt_s`` s (rounded to
    whole RK4 steps; None keeps none) for the first ``history_cases`` cases (the envelopes' sample):
    float32, :data:`~casrecon.simulation.batch.HISTORY_SAMPLE_BYTES` = 16 bytes per case and sample,
    6.4 kB per case for a 40 s flight at the default 0.1 s, at most 64 MB with the default
    :data:`~casrecon.analysis.mc_envelopes.HISTORY_MAX_CASES` = 10 000 cases whatever ``n_cases``.
    """
    from casrecon.scenario import Scenario

    sc = problem if isinstance(problem, Scenario) else Scenario.load(problem)  # the one read in this process
    problem = str(sc.config.path)
    use_scenario(problem, sc)
    table = sc.config.montecarlo
    n_cases = table.cases if n_cases is None else n_cases
    seed = table.seed if seed is None else seed
    dispersions = table.dispersions if dispersions is None else dispersions
    if n_cases < 1:
        raise ValueError(f"n_cases must be >= 1, got {n_cases}")
    if seed < 0:
        raise ValueError(f"seed must be >= 0, got {seed}")
    resolved = dispersions.resolved(sc.config.atmosphere.wind_3sigma_mps, sc.config.atmosphere.density_3sigma)
    if chunk_size is None:
        par = max(workers, 1) if scheduler is None else 8
        chunk_size = max(1, min(250, math.ceil(n_cases / par)))
    every = max(1, round(history_dt_s / dt_s)) if history_dt_s else 0
    t0 = time.perf_counter()
    cols = run_cases(problem, range(n_cases), seed, resolved, workers=workers, scheduler=scheduler,
                     chunk_size=chunk_size, dt_s=dt_s, t_max_s=t_max_s, backend=backend, progress=progress,
                     history_every=every, history_cases=history_cases)
    wall = time.perf_counter() - t0
    nom = simulate_chunk(ChunkTask(str(Path(problem).resolve()), 0, (0,), Dispersions.none(dispersions.center),
                                   float(dt_s), float(t_max_s), 1, backend, every))
    nominal = {k: float(nom[k][0]) for k in OUTPUT_COLUMNS}
    histories = None
    if HISTORY_KEY in cols:
        data = cols.pop(HISTORY_KEY)
        histories = Histories(every * float(dt_s), data, cols["impacted"][:data.shape[0]] > 0.5, nom[HISTORY_KEY][0])
    return MonteCarloResult(cols, int(seed), resolved, float(dt_s), wall, nominal, sc.config.name, histories)
