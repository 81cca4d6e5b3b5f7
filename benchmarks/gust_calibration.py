"""Are the weak-constraint fit's uncertainties right? A multi-seed gust study (issue 5; not a test).

Each seed is one :class:`casrecon.analysis.gust_calibration.GustCase`: drop 3 through a fresh
Gauss-Markov gust realisation the balloon did not see (sigma 0.5, 0.5, 0.25 m/s N, E, D, correlation
time 3 s), parameter truth drawn from the priors, fitted with gust states under the same prior.
One realisation spans only a few correlation times, so a single fit says little; across seeds it
prints, per gust axis, the window-mean normalised errors (should be N(0, 1)) and the pooled NEES of
the gust at nodes 1 s apart against its chi-square 95 % interval, then the parameters' pooled NEES
and per-parameter RMS and mean normalised errors. ``--no-truth-gusts`` is the control (still air).

``--marginal`` also moves each joint-MAP fit to the parameters' marginal-likelihood estimate
(``[estimation] method = "marginal"``) and prints the same figures for both, the MAP's first.

Run: python benchmarks/gust_calibration.py [--seeds 8] [--first 1] [--workers 2] [--start 15]
     [--no-truth-gusts] [--marginal] [--interval 0.0125] [--fit-noise-scale 1 1.5] [--json out.json]

``--fit-noise-scale ACCEL GYRO`` fits with the IMU noise sigmas times these (the data keep theirs):
on the 25 ms mesh a gyro sigma 1.5 times the truth's takes the east gust's NEES on seed 8 from 60.4
to 44.0 over 35 dof, an accelerometer sigma 1.5 times only to 57.9 (README, issue 13).
"""

from __future__ import annotations

import argparse
import json
import time
from functools import partial
from pathlib import Path

import numpy as np

from casrecon.analysis.estimator_mc import chi2_interval
from casrecon.analysis.gust_calibration import AXES, GustCase, run_gust_case
from casrecon.parallel import parallel_map

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"


def _verdict(nees: float, dof: int) -> str:
    lo, hi = chi2_interval(dof)
    return f"{nees:.1f} over {dof} dof, 95 % interval [{lo:.1f}, {hi:.1f}] -> " + (
        "consistent" if lo <= nees <= hi else "NOT consistent")


def summarise(cases: list[dict]) -> None:
    """Print the across-seed figures."""
    ok = [c for c in cases if c["converged"]]
    print(f"{len(ok)} of {len(cases)} fits converged; median fit {np.median([c['fit_s'] for c in cases]):.0f} s; "
          f"reduced chi2 {np.mean([c['reduced_chi2'] for c in ok]):.3f} mean")
    for axis in AXES:
        z = np.array([c[axis]["z_mean"] for c in ok])
        print(f"{axis}: window-mean z per seed {np.array2string(z, precision=2)}; RMS {np.sqrt(np.mean(z**2)):.2f} "
              f"(sigma of mean {np.mean([c[axis]['sigma_mean'] for c in ok]):.3f} m/s)")
        print(f"  NEES at 1 s nodes {_verdict(sum(c[axis]['nees'] for c in ok), sum(c[axis]['dof'] for c in ok))}; "
              f"RMS error {np.mean([c[axis]['rms_error'] for c in ok]):.3f} vs RMS gust "
              f"{np.mean([c[axis]['rms_truth'] for c in ok]):.3f} m/s")
    print("parameters: NEES " + _verdict(sum(c["params"]["nees"] for c in ok), sum(c["params"]["dof"] for c in ok)))
    names = list(ok[0]["params"]["z"])
    z = np.array([[c["params"]["z"][n] for n in names] for c in ok])
    for n, rms, mean in zip(names, np.sqrt((z**2).mean(0)), z.mean(0)):
        print(f"  {n:16s} rms z {rms:5.2f}  mean {mean:+5.2f}")


def _print_case(out: dict) -> None:
    axes = ", ".join(f"{a} z_mean {out[a]['z_mean']:+.2f} nees {out[a]['nees']:.1f}/{out[a]['dof']}" for a in AXES)
    print(f"seed {out['seed']}: {out['status']}, fit {out['fit_s']:.0f} s, reduced chi2 {out['reduced_chi2']:.3f}, "
          f"{axes}, params nees {out['params']['nees']:.1f}/{out['params']['dof']}", flush=True)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--first", type=int, default=1)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--start", type=float, default=15.0, help="fit window start after release, s")
    ap.add_argument("--no-truth-gusts", action="store_true",
                    help="the truth flies in still air (gusts are still estimated): a control run")
    ap.add_argument("--marginal", action="store_true", help="also the marginal-likelihood estimate of each case")
    ap.add_argument("--interval", type=float, help="the fit's collocation interval, s (default: the problem's)")
    ap.add_argument("--fit-noise-scale", type=float, nargs=2, default=(1.0, 1.0), metavar=("ACCEL", "GYRO"),
                    help="the fit's accelerometer and gyro noise sigmas as multiples of the data's (a diagnostic)")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    t0 = time.perf_counter()
    tasks = [GustCase(PROBLEMS / "ees-drop-3", s, a.start, truth_gusts=not a.no_truth_gusts, interval_s=a.interval,
                       fit_noise_scale=tuple(a.fit_noise_scale))
             for s in range(a.first, a.first + a.seeds)]
    cases = parallel_map(partial(run_gust_case, marginal=a.marginal), tasks, workers=a.workers)
    print(f"wall {time.perf_counter() - t0:.0f} s with {a.workers} workers")
    for label in ("map", "marginal") if a.marginal else (None,):
        of_label = [c[label] for c in cases] if label else cases
        if label:
            print(f"=== {'joint MAP' if label == 'map' else 'marginal likelihood'} ===")
        for c in of_label:
            if c["converged"]:
                _print_case(c)
            else:
                print(f"seed {c['seed']}: {c['status']}")
        summarise(of_label)
    if a.json:
        a.json.write_text(json.dumps(cases, indent=1))


if __name__ == "__main__":
    main()
