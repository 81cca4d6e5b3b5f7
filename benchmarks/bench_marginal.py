"""What the marginal-likelihood estimator costs on a gust fit, against the plain fit (not a test; prints).

For one gust case of the calibration study (ees-drop-3 through Gauss-Markov gusts the balloon did not
see, seed --seed, window from --start s after release to impact, gust states at every node), each
run in a fresh process: the plain fit (the same drop, truth and window in still air, fitted without
gust states: gusty data defeat a strong-constraint fit), the joint-MAP gust fit, and the
marginal-likelihood fit (``method="marginal"``: the joint MAP, the marginal Newton steps, one
covariance and bands; time of the log-determinant's gradient and of the inner solves), with each
process's peak resident memory. All on the same mesh (the default 25 ms unless --interval).
Medians over --runs runs. The issue's target: a whole-drop marginal gust fit (--start 3.5) in at
most 10 times the plain fit's time.

Run: python benchmarks/bench_marginal.py [--start 34] [--seed 2] [--runs 3] [--interval 0.025]
"""

from __future__ import annotations

import argparse
import json
import statistics
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

CASE = """
import dataclasses, json, resource, sys, tempfile, time
from pathlib import Path
from casrecon.analysis.gust_calibration import GustCase, case_scenario
from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.scenario import Scenario
start, seed, what = float(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
interval = float(sys.argv[5]) if len(sys.argv) > 5 else None
with tempfile.TemporaryDirectory() as tmp:
    case = GustCase(Path(sys.argv[4]), seed, start, truth_gusts=not what.startswith("plain"), interval_s=interval)
    sc = case_scenario(case, Path(tmp))
    out = {}
    if what.startswith("plain"):
        cfg = sc.config
        plain = Scenario.from_config(dataclasses.replace(cfg, estimation=dataclasses.replace(cfg.estimation,
                                                                                              disturbance=None)))
        t0 = time.perf_counter()
        fit_drop(plain)
        out["plain_s"] = time.perf_counter() - t0
    elif what == "map":
        t0 = time.perf_counter()
        r = fit_drop(sc)
        out["map_s"] = time.perf_counter() - t0
        out.update(solve_s=r.timings["solve_s"], covariance_s=r.timings["covariance_s"])
    else:
        t0 = time.perf_counter()
        m = fit_drop(sc, method="marginal")
        out["marginal_fit_s"] = time.perf_counter() - t0
        run = m.solver.marginal
        out.update(steps=run.outer_iterations, gradient_s=run.gradient_s, inner_s=run.inner_s,
                   shift_sigma=run.shift_sigma, n_z=m.nlp.n_z, solve_s=m.timings["solve_s"],
                   covariance_s=m.timings["covariance_s"])
out["rss_mb"] = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
print(json.dumps(out))
"""


def run(start: float, seed: int, what: str, interval: float | None = None) -> dict:
    problem = str(ROOT / "problems" / "ees-drop-3")
    extra = [] if interval is None else [str(interval)]
    proc = subprocess.run([sys.executable, "-c", CASE, str(start), str(seed), what, problem, *extra],
                          capture_output=True, text=True)
    if proc.returncode:
        raise SystemExit(f"the {what} case failed:\n{proc.stderr[-3000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--start", type=float, default=34.0, help="window start after release, s")
    ap.add_argument("--seed", type=int, default=2)
    ap.add_argument("--runs", type=int, default=3)
    ap.add_argument("--interval", type=float, help="collocation interval of all three fits, s (default: the problem's)")
    a = ap.parse_args()
    plain, joint_map, marginal = [], [], []
    for _ in range(a.runs):  # interleaved, so that a drift of the machine's speed touches all alike
        plain.append(run(a.start, a.seed, "plain", a.interval))
        joint_map.append(run(a.start, a.seed, "map", a.interval))
        marginal.append(run(a.start, a.seed, "marginal", a.interval))

    def med(rows, key):
        return statistics.median(r[key] for r in rows)

    p, g, m = med(plain, "plain_s"), med(joint_map, "map_s"), med(marginal, "marginal_fit_s")
    mesh = f"{a.interval:g} s mesh" if a.interval else "default mesh"
    print(f"ees-drop-3 gust case, seed {a.seed}, window from {a.start:g} s after release, {mesh}; medians of "
          f"{a.runs} runs")
    print(f"  plain fit (still air, no gusts)  {p:7.1f} s, peak RSS {med(plain, 'rss_mb'):.0f} MB")
    print(f"  joint-MAP gust fit               {g:7.1f} s (solve {med(joint_map, 'solve_s'):.1f} s, covariance and "
          f"bands {med(joint_map, 'covariance_s'):.1f} s), peak RSS {med(joint_map, 'rss_mb'):.0f} MB")
    print(f"  marginal gust fit                {m:7.1f} s (solve and marginal step {med(marginal, 'solve_s'):.1f} s: "
          f"{med(marginal, 'steps'):.0f} Newton steps, log-det gradient {med(marginal, 'gradient_s'):.1f} s, inner "
          f"solves {med(marginal, 'inner_s'):.1f} s; covariance and bands {med(marginal, 'covariance_s'):.1f} s; "
          f"{marginal[0]['n_z']} unknowns), peak RSS {med(marginal, 'rss_mb'):.0f} MB")
    ratios = [r["marginal_fit_s"] / q["plain_s"] for r, q in zip(marginal, plain)]
    print(f"  marginal gust fit / plain fit    {m / p:7.1f} x (target: at most 10 x for a whole drop); run by run "
          + ", ".join(f"{x:.1f}" for x in ratios))


if __name__ == "__main__":
    main()
