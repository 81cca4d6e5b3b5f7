"""``casrecon montecarlo``: the dispersed Monte Carlo (:func:`run_montecarlo_command`) and, with
``--estimator``, the estimator Monte Carlo (:func:`estimator_montecarlo_command`).

The dispersed run takes its number of cases, seed and 1-sigma dispersions from the problem's
``[montecarlo]`` table (:mod:`casrecon.io.montecarlo_config`); ``--cases``, ``--seed`` and
``--center`` override it. Bad input ends with one located line and exit status 2 (see
:mod:`casrecon.cli`).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from casrecon.io.errors import InputError
from casrecon.io.toml_fields import TomlDocument

#: ``--cases`` of the estimator Monte Carlo when not given (the ``[montecarlo]`` table is the
#: dispersed run's), and ``--seed``.
ESTIMATOR_CASES, ESTIMATOR_SEED = 1000, 0


def montecarlo_command(args: argparse.Namespace) -> int:
    """``casrecon montecarlo``: the estimator Monte Carlo with ``--estimator``, else the dispersed one."""
    if args.estimator:
        return estimator_montecarlo_command(args)
    if getattr(args, "method", None) is not None:
        print("casrecon montecarlo: --method applies to the estimator Monte Carlo only (add --estimator)",
              file=sys.stderr)
        return 2
    return run_montecarlo_command(args.document, Path(args.out), args.cases, args.seed, args.workers,
                                  args.scheduler, dt_s=args.dt, center=args.center, figures=not args.no_figures,
                                  formats=args.formats, force=args.force, progress=not args.quiet)


def run_montecarlo_command(problem: Path | TomlDocument, out: Path, cases: int | None, seed: int | None,
                           workers: int, scheduler: str | None, *, dt_s: float = 0.02, chunk_size: int | None = None,
                           center: str | None = None, figures: bool = True, progress: bool = True,
                           backend: str = "auto", formats: Sequence[str] = ("png",), force: bool = False) -> int:
    """``casrecon montecarlo``: run and write ``out/`` atomically (``cases.csv``, ``envelopes.csv``,
    ``statistics.json``, ``figures/*`` in each of ``formats``); ``dt_s`` is the RK4 step, s (the Monte
    Carlo default, :data:`casrecon.simulation.batch.DEFAULT_DT_S`); ``force`` as ``--force``. ``problem``:
    its folder or ``problem.toml``, or the file as the command read it (not read again here).
    ``cases``, ``seed`` and ``center`` None take the problem's ``[montecarlo]`` table (its defaults
    without one), as do the dispersions. Returns 0, or 2 after printing one located line on bad
    input, an ``--out`` that may not be written, a scheduler that is malformed or unreachable, or
    more cases than the memory holds."""
    from casrecon.analysis.montecarlo import memory_estimate_bytes, run_montecarlo
    from casrecon.cli_guard import available_memory_bytes, scheduler_problem
    from casrecon.output.montecarlo_results import write_cases_csv, write_envelopes_csv
    from casrecon.output.out_folder import check_out_folder, input_paths
    from casrecon.output.results import atomic_folder, write_json
    from casrecon.report.montecarlo_plots import plot_montecarlo
    from casrecon.scenario import Scenario

    def bad(msg: str) -> int:
        print(f"casrecon montecarlo: {msg}", file=sys.stderr)
        return 2

    if cases is not None and (not isinstance(cases, int) or cases < 1):
        return bad(f"--cases: must be a positive integer, got {cases!r}")
    if seed is not None and (not isinstance(seed, int) or seed < 0):
        return bad(f"--seed: must be an integer >= 0, got {seed!r}")
    if not isinstance(workers, int) or workers < 1:
        return bad(f"--workers: must be a positive integer, got {workers!r}")
    if not (math.isfinite(dt_s) and 0 < dt_s <= 0.05):
        return bad(f"--dt: must lie in (0, 0.05] s, got {dt_s!r}")
    if chunk_size is not None and chunk_size < 1:
        return bad(f"--chunk-size: must be a positive integer, got {chunk_size!r}")
    if center is not None and center not in ("truth", "nominal"):
        return bad(f"--center: must be 'truth' or 'nominal', got {center!r}")
    if scheduler is not None and (why := scheduler_problem(scheduler)) is not None:
        return bad(f"--scheduler {scheduler}: {why}")
    where = problem.path if isinstance(problem, TomlDocument) else problem
    try:
        sc = Scenario.load(problem)
    except InputError as err:
        print(f"casrecon: {err}", file=sys.stderr)
        return 2
    except FileNotFoundError as err:
        return bad(f"{where}: {err.strerror or err}")
    if sc.config.release.h_agl_m <= 0:
        return bad(f"{where}: field 'release.h_agl_m': must be above ground to fly, got {sc.config.release.h_agl_m}")
    table = sc.config.montecarlo
    cases = table.cases if cases is None else cases
    seed = table.seed if seed is None else seed
    disp = table.dispersions if center is None else dataclasses.replace(table.dispersions, center=center)
    need, have = memory_estimate_bytes(cases), available_memory_bytes()
    if have is not None and need > 0.8 * have:
        return bad(f"--cases {cases}: needs about {need / 1e9:.3g} GB of memory, more than 80 % of the "
                   f"{have / 1e9:.3g} GB available; run at most {int(cases * 0.8 * have / need)} cases at a "
                   "time (several runs with different --seed)")
    inputs = input_paths([problem])
    try:
        check_out_folder(out, inputs=inputs, force=force)
    except InputError as err:
        print(f"casrecon: {err}", file=sys.stderr)
        return 2
    try:
        result = run_montecarlo(sc, cases, seed, disp, workers=workers, scheduler=scheduler,
                                chunk_size=chunk_size, dt_s=dt_s, backend=backend, progress=progress)
    except OSError as err:
        if scheduler is not None:
            return bad(f"--scheduler {scheduler}: cannot reach the Dask scheduler ({err})")
        raise
    stats = result.statistics()
    stats.update(workers=workers, scheduler=scheduler, wall_s=result.wall_s,
                 cases_per_s=result.n_cases / result.wall_s if result.wall_s > 0 else None)
    with atomic_folder(out, kind="montecarlo", force=force, inputs=inputs) as tmp:
        write_cases_csv(tmp / "cases.csv", result)
        if result.histories is not None:
            write_envelopes_csv(tmp / "envelopes.csv", result.histories.envelopes())
        write_json(tmp / "statistics.json", stats)
        if figures:
            plot_montecarlo(result, tmp / "figures", formats)
    ft, sp = stats["flight_time_s"], stats["impact_speed_mps"]
    print(f"{result.n_cases} cases ({stats['n_impacted']} impacted) in {result.wall_s:.1f} s -> {out}")
    if ft is not None:
        print(f"flight time   {ft['mean']:.3f} s    sd {ft['sd']:.3f}   p1 {ft['p1']:.3f}   p99 {ft['p99']:.3f}")
        print(f"impact speed  {sp['mean']:.3f} m/s  sd {sp['sd']:.3f}   p1 {sp['p1']:.3f}   p99 {sp['p99']:.3f}")
    return 0


def estimator_montecarlo_command(args: argparse.Namespace) -> int:
    """``casrecon montecarlo --estimator``: simulate-and-fit cases, NEES test; exit 4 if not consistent."""
    from casrecon.analysis.estimator_mc import estimator_montecarlo
    from casrecon.cli_guard import scheduler_problem
    from casrecon.output.consistency import write_consistency
    from casrecon.output.results import atomic_folder
    from casrecon.scenario import Scenario

    cases = ESTIMATOR_CASES if args.cases is None else args.cases
    seed = ESTIMATOR_SEED if args.seed is None else args.seed
    if cases < 2 or args.workers < 1 or seed < 0:
        print("casrecon montecarlo --estimator: --cases must be >= 2, --workers >= 1, --seed >= 0", file=sys.stderr)
        return 2
    if args.scheduler is not None and (why := scheduler_problem(args.scheduler)) is not None:
        print(f"casrecon montecarlo --estimator: --scheduler {args.scheduler}: {why}", file=sys.stderr)
        return 2
    Scenario.load(args.document)  # a bad problem fails here, located, before any worker starts
    t0 = time.perf_counter()
    try:
        res = estimator_montecarlo(Path(args.problem), cases, seed, args.workers, args.scheduler,
                                   progress=not args.quiet, method=args.method)
    except OSError as err:
        if args.scheduler is None:
            raise
        print(f"casrecon montecarlo --estimator: --scheduler {args.scheduler}: cannot reach the Dask scheduler "
              f"({err})", file=sys.stderr)
        return 2
    wall = time.perf_counter() - t0
    with atomic_folder(Path(args.out), **args.where) as tmp:
        write_consistency(tmp, res, wall)
    n_ok = cases - len(res.failed)
    print(f"{n_ok} of {cases} fits converged in {wall:.0f} s; NEES sum {res.nees_sum:.1f}, chi2 95 % interval "
          f"[{res.interval[0]:.1f}, {res.interval[1]:.1f}] over {n_ok * res.n_params} dof: "
          f"{'consistent' if res.consistent else 'NOT consistent'} -> {args.out}")
    return 0 if res.consistent and not res.failed else 4
