"""The ``casrecon`` command (also ``python -m casrecon``): ``inspect``, ``simulate``, ``fit``, ``joint``,
``montecarlo``, ``sensitivity`` and ``report``.

Each command computes through the estimation and analysis layers and hands the results to the
writers of :mod:`casrecon.output` and the reports of :mod:`casrecon.report`.
Bad input ends with one line ``casrecon: FILE:LINE: field 'F': MESSAGE`` and exit status 2,
never a traceback; a fit that fails (no convergence, singular KKT matrix) says why and exits 3,
leaving any earlier results folder untouched.

Results go only where casrecon owns the folder (:mod:`casrecon.output.out_folder`): ``--out`` is
checked before any work; a folder holding the problem's inputs (or the working directory) is never
replaced; an existing file, or a folder without ``.casrecon-results.json`` that does not look like
an older casrecon result, only with ``--force``.

Exit status: 0 success; 1 unexpected error (a bug; ``--debug`` or ``CASRECON_DEBUG=1`` shows the
traceback); 2 bad input or arguments, an ``--out`` that may not or cannot be written, a system
error (cannot read or write a file, disk full, not enough memory, bad or unreachable scheduler);
3 a fit failed; 4 estimator Monte Carlo not consistent; 130 SIGINT and 143 SIGTERM (earlier
results kept). See :mod:`casrecon.cli_guard`.
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from collections.abc import Sequence
from pathlib import Path

from casrecon.cli_guard import (
    EXIT_INPUT,
    add_format_argument,
    debug_enabled,
    exit_process,
    fit_failed,
    out_folder_arguments,
    run_command,
)
from casrecon.cli_montecarlo import montecarlo_command
from casrecon.cli_options import HelpFormatter, add_verbosity_arguments, configure_logging, log_level, version_text
from casrecon.parallel import single_threaded_blas


def _run(args: argparse.Namespace) -> int:
    """Read the command's problem file(s) once (``args.document``, or ``args.joint`` for ``joint``),
    check ``--out`` of a writing command with them, in milliseconds (``args.where``), then run the
    command."""
    documents: tuple = ()
    if getattr(args, "problems", None):
        from casrecon.pipelines.joint import joint_problem

        args.joint = joint_problem([Path(p) for p in args.problems], name=args.name, shared=args.shared or None,
                                   per_drop=args.per_drop, fixed=args.fixed)
        documents = args.joint.documents
    elif getattr(args, "problem", None) is not None and args.func in _READS_ITS_PROBLEM:
        from casrecon.io.problem_file import problem_document

        args.document = problem_document(args.problem)
        documents = (args.document,)
    if getattr(args, "force", None) is not None:
        args.where = out_folder_arguments(args, *(documents or [args.problem]))
    return args.func(args)


def _inspect(args: argparse.Namespace) -> int:
    from casrecon.io.inspect import inspect_file

    print(inspect_file(args.file))
    if args.plot:
        from casrecon.report.input_figures import plot_input_file

        for path in plot_input_file(args.file, args.plot, args.formats):
            print(f"figure -> {path}")
    return 0


def _simulate(args: argparse.Namespace) -> int:
    from casrecon.io.baro import write_baro_csv
    from casrecon.io.flysight import write_flysight1
    from casrecon.io.imu import write_imu_csv
    from casrecon.output.results import atomic_folder, write_json
    from casrecon.output.simulation_results import write_atmosphere_error, write_simulation_trajectory
    from casrecon.scenario import Scenario
    from casrecon.simulation.simulate import Simulator
    from casrecon.simulation.synthetic import make_synthetic

    if args.every < 1:
        print(f"casrecon: --every must be a positive integer, got {args.every}", file=sys.stderr)
        return 2
    t0 = time.perf_counter()
    scenario = Scenario.load(args.document)
    cfg = scenario.config
    if args.data:
        data = make_synthetic(scenario, seed=args.seed)
        traj = data.trajectory
    else:
        sim = Simulator(scenario.model, dt_s=1.0 / cfg.imu.rate_hz,
                        substeps=max(1, round(1.0 / cfg.imu.rate_hz / cfg.simulation.dt_s)))
        traj = sim.run(scenario.release_state(), scenario.truth_parameters(), cfg.simulation.t_max_s)
    summary = {"problem": cfg.name, **traj.summary(), "wall_time_s": time.perf_counter() - t0}
    with atomic_folder(args.out, **args.where) as out:
        write_simulation_trajectory(out / "trajectory.csv", traj, cfg, args.every)
        write_json(out / "summary.json", summary)
        if args.data:
            write_imu_csv(out / "imu.csv", data.imu_time_s, data.imu_accel_mps2, data.imu_gyro_radps, cfg.imu.spec)
            write_flysight1(out / "gps.csv", data.gps)
            if data.baro_time_unix_s is not None:
                write_baro_csv(out / "baro.csv", data.baro_time_unix_s, data.baro_pressure_pa)
            write_json(out / "truth.json", data.truth)
            if data.profile_error is not None:
                write_atmosphere_error(out / "truth_atmosphere_error.csv", data.profile_error)
            (out / "sounding.csv").write_bytes(Path(cfg.atmosphere.sounding).read_bytes())
    print(f"{cfg.name}: flight time {summary['flight_time_s']:.3f} s, impact speed "
          f"{summary['impact_speed_mps']:.2f} m/s, peak rates (x, y, z) "
          + ", ".join(f"{r:.1f}" for r in summary["max_abs_rate_dps"]) + f" deg/s -> {args.out}")
    return 0


def _fit_options(args: argparse.Namespace):
    """The pipeline options of ``casrecon fit`` / ``casrecon joint`` (products on a second core)."""
    from casrecon.pipelines.options import FitOptions

    return FitOptions(linear_solver=args.linear_solver, hessian=args.hessian, solver=args.solver,
                      method=args.method, print_level=5 if args.verbose else 0,
                      kinematic_check=getattr(args, "kinematic_check", False), concurrent=True)


def _fit(args: argparse.Namespace) -> int:
    from contextlib import nullcontext

    from casrecon.estimation.sixdof.fit import FitError
    from casrecon.estimation.sixdof.fitdata import FitDataError
    from casrecon.io.problem_file import problem_kind, problem_name
    from casrecon.pipelines import fit_problem

    t0 = time.perf_counter()
    document = args.document
    if problem_kind(document) == "six-dof" and not args.no_figures:
        from casrecon.report.figure_pool import FigurePool

        pool = FigurePool()  # figure workers forked first: they import matplotlib while this process fits
    else:
        pool = nullcontext()
    with pool as figures:
        try:
            result = fit_problem(document, _fit_options(args))
        except (FitError, FitDataError) as err:
            return fit_failed(f"fit of {problem_name(document)}", err)
        _save(result, args, figures)
    if not args.quiet:
        print(result.report_text)
    print(f"results -> {args.out} (total {time.perf_counter() - t0:.2f} s)")
    return 0


def _save(result, args: argparse.Namespace, pool=None) -> None:
    """Write ``result`` into ``--out`` atomically, with its figures unless ``--no-figures``; skipped
    figures are said on stderr."""
    from casrecon.output.results import atomic_folder
    from casrecon.progress import stage

    log = logging.getLogger(__name__)
    with atomic_folder(args.out, **args.where) as out:
        with stage(log, f"writing the results -> {args.out}"):
            result.write(out)
        if not args.no_figures:
            notes: list[str] = []
            with stage(log, "figures"):
                if pool is not None:
                    result.draw(out, args.formats, notes, pool=pool)
                else:
                    result.draw(out, args.formats, notes)
            for note in notes:
                print(f"casrecon: figure skipped: {note}", file=sys.stderr)


def _joint(args: argparse.Namespace) -> int:
    from casrecon.estimation.sixdof.fit import FitError
    from casrecon.pipelines.joint import fit_joint_problems

    t0 = time.perf_counter()
    problem = args.joint
    try:
        result = fit_joint_problems(problem, _fit_options(args), single=not args.no_single)
    except FitError as err:
        return fit_failed(f"joint fit {problem.config.name}", err)
    _save(result, args)
    if not args.quiet:
        print(result.report())
    print(f"results -> {args.out} (total {time.perf_counter() - t0:.2f} s)")
    return 0


def _sensitivity(args: argparse.Namespace) -> int:
    from casrecon.analysis import observability as obs
    from casrecon.analysis.sensitivity_documents import (
        design_document,
        fisher_document,
        parameter_unit,
        profile_document,
    )
    from casrecon.estimation.sixdof.drop import parameter_set
    from casrecon.estimation.sixdof.fit import FitError, fit_drop
    from casrecon.output.results import atomic_folder, write_json
    from casrecon.report import sensitivity_plots
    from casrecon.scenario import Scenario

    scenario = Scenario.load(args.document)
    specs = parameter_set(scenario.config).specs  # design predicts the shared (aero) factors only
    known = [sp.name for sp in specs if args.study == "profile" or sp.group == "aero"]
    if args.study != "fisher" and args.parameter not in known:
        what = "an estimated parameter" if args.study == "profile" else "an aero dispersion factor (shared in a design)"
        print(f"casrecon: sensitivity {args.study}: --parameter {args.parameter!r} is not {what} of "
              f"{scenario.config.name}; known: {', '.join(known)}", file=sys.stderr)
        return 2
    if args.study == "design":  # everything is computed before the folder is written: a failure keeps the old one
        design = obs.design_study(scenario, args.parameter)
        with atomic_folder(args.out, **args.where) as out:
            write_json(out / "design.json", design_document(design, parameter_unit(scenario.config, args.parameter)))
            sensitivity_plots.plot_design(design, out, args.formats)
        print("\n".join(f"{k}: " + ", ".join(f"{x:g} -> {y:.4g}" for x, y in v)
                        for k, v in design.items() if k != "parameter"))
        return 0
    try:
        result = fit_drop(scenario)
    except FitError as err:
        return fit_failed(f"fit of {scenario.config.name}", err)
    directions = obs.fisher_directions(result)
    print("weakest parameter combinations (parameters in units of their scale):")
    for d in directions[:5]:
        print("   " + d.describe())
    prof = obs.profile_likelihood(result, args.parameter, args.points) if args.study == "profile" else None
    fisher = fisher_document(scenario.config.name, directions, result.params.specs)
    with atomic_folder(args.out, **args.where) as out:
        write_json(out / "fisher.json", fisher)
        sensitivity_plots.plot_fisher(fisher, out, args.formats)
        if prof is not None:
            write_json(out / f"profile_{prof.name}.json",
                       profile_document(prof, parameter_unit(scenario.config, prof.name)))
            sensitivity_plots.plot_profile(prof, out, args.formats)
    if prof is not None:
        print(f"{prof.name}: profile interval {prof.interval[0]:.5g} to {prof.interval[1]:.5g}, "
              f"Fisher 3-sigma {prof.fisher_three_sigma:.4g}, ratio {prof.agreement:.3f}")
    return 0


def _report(args: argparse.Namespace) -> int:
    """Redraw the figures of a results folder: every file checked first (a damaged one is a located
    InputError, exit 2), the ``figures/`` folders checked writable (an OSError naming the folder,
    exit 2), then the figures; exit 2 when any could not be drawn or written, naming the first."""
    from casrecon.output.results_reader import folder_kind
    from casrecon.report.plots import check_writable, draw_figures

    folder = Path(args.results)
    folder_kind(folder)  # "results folder not found" before anything else
    notes: list[str] = []
    failures: list[str] = []
    check_writable(folder)
    paths = draw_figures(folder, notes, args.formats, failures)
    for note in notes:
        print(f"casrecon: figure skipped: {note}", file=sys.stderr)
    if failures:
        more = f" (and {len(failures) - 1} more)" if len(failures) > 1 else ""
        print(f"casrecon: {len(failures)} figure(s) of {folder} could not be drawn or written: "
              f"{failures[0]}{more}; {len(paths)} written", file=sys.stderr)
        return EXIT_INPUT
    if not paths:
        print(f"casrecon: no figure written to {folder} (every one lacked an input)", file=sys.stderr)
        return EXIT_INPUT
    print(f"{len(paths)} figures -> {folder}")
    return 0


#: Commands whose ``problem`` argument ``_run`` reads once, as ``args.document``.
_READS_ITS_PROBLEM = (_simulate, _fit, _sensitivity, montecarlo_command)

OUT_HELP = "results folder: written atomically, kept on failure; an existing one only if casrecon wrote it"
FORCE_HELP = ("replace an existing --out that casrecon did not write (or a file); never a folder holding "
              "the inputs")


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="casrecon", description=__doc__.splitlines()[0],
                                     formatter_class=HelpFormatter)
    parser.add_argument("--version", action="version", version=version_text())
    parser.add_argument("--debug", action="store_true", help="show the traceback of an unexpected error")
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("inspect", help="read any supported input file and say what it holds")
    p.add_argument("file", help="FlySight track, sounding or IMU CSV")
    p.add_argument("--plot", metavar="OUT.png", default=None,
                   help="also draw the file's data (IMU: specific force and rates; GPS: track, speeds, accuracies, "
                        "satellites; sounding: wind, temperature, density) into OUT")
    add_format_argument(p, default=None)
    p.set_defaults(func=_inspect)
    p = sub.add_parser("simulate", help="forward-simulate a problem from release to impact")
    p.add_argument("problem", help="problem folder or problem.toml")
    p.add_argument("--out", required=True, help=OUT_HELP)
    p.add_argument("--data", action="store_true",
                   help="also write synthetic imu.csv, gps.csv (FlySight 1), sounding.csv and truth.json")
    p.add_argument("--seed", type=int, default=None, help="noise seed (default: [truth] seed)")
    p.add_argument("--every", type=int, default=1,
                   help="write every N-th sample of the time history (and the impact sample)")
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(func=_simulate)
    p = sub.add_parser("fit", help="reconstruct one drop: trajectory, parameters and 3-sigma")
    p.add_argument("problem", help="problem folder or problem.toml")
    p.add_argument("--out", required=True, help=OUT_HELP)
    p.add_argument("--linear-solver", choices=("mumps", "spral"), default=None,
                   help="Ipopt linear solver (default: [estimation] linear_solver)")
    p.add_argument("--hessian", choices=("gauss-newton", "exact"), default=None,
                   help="Hessian for Ipopt (default: [estimation] hessian)")
    p.add_argument("--solver", choices=("auto", "ipopt"), default=None,
                   help="auto: the null-space Gauss-Newton solver where it applies, else Ipopt; ipopt: always "
                        "Ipopt (default: [estimation] solver)")
    p.add_argument("--method", choices=("map", "marginal"), default=None,
                   help="map: joint maximum a posteriori; marginal: the parameters maximise their Laplace "
                        "marginal likelihood, the latent states integrated out (unbiased under gusts; "
                        "default: [estimation] method)")
    p.add_argument("--no-figures", action="store_true", help="do not draw the figures (casrecon report can)")
    p.add_argument("--kinematic-check", action="store_true",
                   help="also reconstruct the drop from its IMU without the aero model and compare the aero "
                        "coefficients (implied_aero.csv, kinematic_check.csv/.json; a 6-DOF problem)")
    add_format_argument(p)
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(func=_fit)
    p = sub.add_parser("joint", help="joint aero fit of several drops sharing the dispersion factors")
    p.add_argument("problems", nargs="+", help="problem folders, or one joint .toml file ([joint] drops = [...])")
    p.add_argument("--out", required=True, help=OUT_HELP)
    p.add_argument("--name", default="joint", help="name of the joint fit (when problems are listed)")
    p.add_argument("--shared", nargs="*", default=None, help="dispersion factors shared (default: all estimated)")
    p.add_argument("--per-drop", nargs="*", default=[], help="dispersion factors each drop estimates for itself")
    p.add_argument("--fixed", nargs="*", default=[], help="dispersion factors held at 0")
    p.add_argument("--no-single", action="store_true", help="skip the single-drop fits of the sigma comparison")
    p.add_argument("--no-figures", action="store_true", help="do not draw the figures (casrecon report can)")
    p.add_argument("--linear-solver", choices=("mumps", "spral"), default=None,
                   help="Ipopt linear solver (default: each problem's [estimation] linear_solver)")
    p.add_argument("--hessian", choices=("gauss-newton", "exact"), default=None,
                   help="Hessian for Ipopt (default: each problem's [estimation] hessian)")
    p.add_argument("--solver", choices=("auto", "ipopt"), default=None,
                   help="auto: the null-space Gauss-Newton solver where it applies, else Ipopt; ipopt: always "
                        "Ipopt (default: each problem's [estimation] solver)")
    p.add_argument("--method", choices=("map", "marginal"), default=None,
                   help="map: joint maximum a posteriori; marginal: the parameters maximise their Laplace "
                        "marginal likelihood, the latent states integrated out (unbiased under gusts; "
                        "default: each problem's [estimation] method)")
    add_format_argument(p)
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(func=_joint)
    p = sub.add_parser("montecarlo", help="dispersed forward simulations: touchdown time and impact speed")
    p.add_argument("problem", help="problem folder or problem.toml")
    p.add_argument("--out", required=True, help=OUT_HELP)
    p.add_argument("--cases", type=int, default=None,
                   help="number of cases (default: the problem's [montecarlo] cases, 1000 without it; --estimator: "
                        "1000)")
    p.add_argument("--seed", type=int, default=None,
                   help="case i uses the random stream (seed, i) (default: [montecarlo] seed, 0 without it)")
    p.add_argument("--workers", type=int, default=2, help="local processes (ignored with --scheduler)")
    p.add_argument("--scheduler", default=None, help="Dask distributed scheduler address, e.g. tcp://host:8786")
    p.add_argument("--dt", type=float, default=0.02, help="RK4 step, s")
    p.add_argument("--center", choices=("truth", "nominal"), default=None,
                   help="disperse around the problem's [truth] or the nominal database (default: [montecarlo] "
                        "center, truth without it); the 1-sigma dispersions are the [montecarlo] table's")
    p.add_argument("--no-figures", action="store_true", help="do not draw the histograms")
    p.add_argument("--estimator", action="store_true",
                   help="estimator Monte Carlo instead: draw a truth from the fit's priors, simulate, fit, and test "
                        "the normalised estimation errors (NEES) against chi-square at 95 %%; exit 4 if not consistent")
    p.add_argument("--method", choices=("map", "marginal"), default=None,
                   help="with --estimator: the fits' estimator (default: the problem's [estimation] method)")
    add_format_argument(p)
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(func=montecarlo_command)
    p = sub.add_parser("sensitivity", help="observability: Fisher directions, profile likelihood, drop design")
    p.add_argument("study", choices=("fisher", "profile", "design"))
    p.add_argument("problem", help="problem folder or problem.toml")
    p.add_argument("--out", required=True, help=OUT_HELP)
    p.add_argument("--parameter", default="Cmq_mult", help="parameter to profile or to design for")
    p.add_argument("--points", type=int, default=9, help="profile grid points (over +-4 Fisher sigma)")
    add_format_argument(p)
    p.add_argument("--force", action="store_true", help=FORCE_HELP)
    p.set_defaults(func=_sensitivity)
    p = sub.add_parser("report", help="(re)draw the figures of a fit or joint results folder")
    p.add_argument("results", help="results folder written by casrecon fit or casrecon joint")
    add_format_argument(p)
    p.set_defaults(func=_report)
    for name, p in sub.choices.items():
        p.formatter_class = HelpFormatter  # defaults shown in every command's --help
        add_verbosity_arguments(p, "do not print the fit report or progress" if name in ("fit", "joint")
                                else "print only results and errors, no progress")
    return parser


@single_threaded_blas()
def main(argv: Sequence[str] | None = None) -> int:
    """Run one command; returns its exit status (module docstring), one line on stderr on failure."""
    args = build_parser().parse_args(argv)
    configure_logging(log_level(args))
    return run_command(_run, args, debug=debug_enabled(args.debug))


def run() -> None:
    """The console script ``casrecon``: :func:`main`, then exit with its status (see ``exit_process``)."""
    exit_process(main())


if __name__ == "__main__":
    run()
