"""Where the time of a per-drop fit goes, and the joint fit against one drop (not a test; prints).

Medians (min, max) over --runs runs of, for ees-drop-1 (40 s drop, every 500 Hz IMU sample used):

- import: ``import casrecon.cli`` plus what ``fit`` imports, in a fresh interpreter, minus a bare
  interpreter's start;
- the fit's parts, in-process, as ``casrecon fit`` runs them: reading the data, initial guess,
  NLP build, solve (iterations and solver; of the solve, the block evaluations, the Gauss-Newton
  solver's reduced systems, Ipopt's convergence test, and the rest, which with Ipopt is its own
  work, mostly the KKT factorisations), covariance and bands;
  products (residuals, pitching moment, aerodynamic coefficients, the two reconciled simulations,
  one of them in a forked child) and the report; writing the results folder; figures (drawn by two
  forked workers; in the command they are forked before the fit, so matplotlib's import is off the
  critical path: the whole-command rows show that);
- the whole command ``casrecon fit --out DIR`` in a fresh process, with and without figures: wall
  time and peak resident memory;
- a second process's build (the compiled block functions then come from the disk cache);
- with --joint: the four EES drops' joint fit against one drop, ees-drop-3 (acceptance: at most
  4x), both as wall time in this process with loading the problems included, alternating, --runs
  times each (the ratio of the medians, and run by run: the machine's speed drifts within minutes).

The compile cache is whatever ``CASRECON_CACHE_DIR`` names (default ~/.cache/casrecon/codegen);
``--cold`` empties a private one first, so the first run shows the compile.

Run: python benchmarks/bench_fit.py [--runs 5] [--joint] [--cold] [--problem ees-drop-1]
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PROBLEMS = ROOT / "problems"


def median(values: list[float]) -> str:
    return f"{statistics.median(values):7.2f} s (min {min(values):.2f}, max {max(values):.2f})"


def import_time(runs: int) -> list[float]:
    """Seconds to import what ``casrecon fit`` needs, over a bare interpreter's start."""
    code = ("import casrecon.cli, casrecon.estimation.sixdof.fit, casrecon.analysis.fit_products, "
            "casrecon.output.fit_results, casrecon.report.fit_report")
    out = []
    for _ in range(runs):
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", "pass"], check=True)
        bare = time.perf_counter() - t0
        t0 = time.perf_counter()
        subprocess.run([sys.executable, "-c", code], check=True)
        out.append(time.perf_counter() - t0 - bare)
    return out


def parts(problem: Path, runs: int, figures: bool) -> dict[str, list[float]]:
    """The parts of the fit command, timed in this process."""
    from casrecon.analysis.fit_products import fit_products
    from casrecon.estimation.sixdof.fit import fit_drop
    from casrecon.output.fit_results import write_fit_results
    from casrecon.report.fit_report import sixdof_sections
    from casrecon.report.plots import draw_figures
    from casrecon.report.tables import drop_tables
    from casrecon.scenario import Scenario

    keys = ("data_s", "initial_guess_s", "build_s", "solve_s", "solve_evaluation_s", "solve_stop_test_s",
            "solve_linear_algebra_s", "covariance_s")
    out: dict[str, list] = {k: [] for k in (*keys, "iterations", "ipopt_own_s", "products_s", "writing_s",
                                            "figures_s", "method")}
    for _ in range(runs):
        result = fit_drop(Scenario.load(problem))
        for k in keys:
            out[k].append(result.timings[k])
        out["iterations"].append(result.solver.iterations)
        out["method"].append(result.solver.method)
        out["ipopt_own_s"].append(result.timings["solve_s"] - result.timings["solve_evaluation_s"]
                                  - result.timings["solve_stop_test_s"] - result.timings["solve_linear_algebra_s"])
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            products = fit_products(result, concurrent=True)
            report = sixdof_sections(result, products.adequacy)
            t1 = time.perf_counter()
            write_fit_results(Path(tmp), result, products, report, drop_tables(result, products))
            t2 = time.perf_counter()
            if figures:
                draw_figures(Path(tmp), [])
            out["products_s"].append(t1 - t0)
            out["writing_s"].append(t2 - t1)
            out["figures_s"].append(time.perf_counter() - t2)
    return out


#: The console script's own ending (``cli.run``: ``main``, then ``exit_process``), with the peak RSS printed.
RUN_AND_REPORT_RSS = ("import resource, sys; from casrecon.cli import main; "
                      "from casrecon.cli_guard import exit_process; code = main(sys.argv[1:]); "
                      "print('maxrss', resource.getrusage(resource.RUSAGE_SELF).ru_maxrss, flush=True); "
                      "exit_process(code)")


def command(problem: Path, runs: int, extra: list[str]) -> tuple[list[float], list[float], list[dict]]:
    """Wall time, peak RSS (MB) and summary timings of ``casrecon fit`` in a fresh process."""
    walls, rss, timings = [], [], []
    for _ in range(runs):
        with tempfile.TemporaryDirectory() as tmp:
            t0 = time.perf_counter()
            argv = ["fit", str(problem), "--out", str(Path(tmp) / "out"), "--quiet", *extra]
            proc = subprocess.run([sys.executable, "-c", RUN_AND_REPORT_RSS, *argv],
                                  check=True, capture_output=True, text=True)
            walls.append(time.perf_counter() - t0)
            rss.append(float(proc.stdout.split("maxrss")[-1]) / 1024)
            timings.append(json.loads((Path(tmp) / "out" / "summary.json").read_text()).get("timings", {}))
    return walls, rss, timings


def joint_ratio(runs: int) -> None:
    from casrecon.estimation.sixdof.fit import fit_drop
    from casrecon.estimation.sixdof.joint import JointConfig, fit_joint
    from casrecon.scenario import Scenario

    drops = [PROBLEMS / f"ees-drop-{i}" for i in (1, 2, 3, 4)]
    one, joint = [], []
    for _ in range(runs):  # both timed alike: wall time, loading the problems included
        t0 = time.perf_counter()
        fit_drop(Scenario.load(PROBLEMS / "ees-drop-3"))
        one.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        fit_joint([Scenario.load(d) for d in drops], JointConfig("bench", tuple(drops)))
        joint.append(time.perf_counter() - t0)
    print(f"joint fit of the 4 EES drops {median(joint)}; one drop (ees-drop-3) {median(one)}; ratio of medians "
          f"{statistics.median(joint) / statistics.median(one):.2f} (acceptance: <= 4); run by run "
          + ", ".join(f"{j / o:.2f}" for j, o in zip(joint, one)))


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--problem", default="ees-drop-1")
    ap.add_argument("--joint", action="store_true", help="also time the four-drop joint fit")
    ap.add_argument("--cold", action="store_true", help="start from an empty private compile cache")
    args = ap.parse_args()
    problem = PROBLEMS / args.problem
    if args.cold:
        os.environ["CASRECON_CACHE_DIR"] = tempfile.mkdtemp(prefix="casrecon-bench-cache-")
        walls, _, _ = command(problem, 1, ["--no-figures"])
        print(f"first run with an empty compile cache (compiles): casrecon fit --no-figures {walls[0]:.2f} s")

    print(f"{args.problem}: {args.runs} runs, medians (min, max); CASRECON_CODEGEN="
          f"{os.environ.get('CASRECON_CODEGEN', 'on')}")
    print(f"  import              {median(import_time(args.runs))}")
    p = parts(problem, args.runs, figures=True)
    for k in ("data_s", "initial_guess_s", "build_s", "solve_s"):
        print(f"  {k[:-2]:19s} {median(p[k])}")
    n_it = statistics.median(p["iterations"])
    for k, label in (("solve_evaluation_s", "evaluations"), ("solve_linear_algebra_s", "reduced systems"),
                     ("solve_stop_test_s", "convergence test"), ("ipopt_own_s", "rest (Ipopt's KKT)")):
        print(f"    {label:17s} {median(p[k])}; per iteration {statistics.median(p[k]) / max(n_it, 1):.3f} s")
    print(f"    iterations        {n_it:g} ({', '.join(sorted(set(p['method'])))})")
    for k in ("covariance_s", "products_s", "writing_s", "figures_s"):
        print(f"  {k[:-2]:19s} {median(p[k])}")
    for label, extra in (("casrecon fit --no-figures", ["--no-figures"]), ("casrecon fit", [])):
        walls, rss, timings = command(problem, args.runs, extra)
        builds = [t.get("build_s", float("nan")) for t in timings]
        print(f"  {label:27s} wall {median(walls)}; peak RSS {statistics.median(rss):.0f} MB; "
              f"build in that process {statistics.median(builds):.2f} s")
    if args.joint:
        joint_ratio(max(1, args.runs))


if __name__ == "__main__":
    main()
