"""Are the gust-state sigmas of the weak-constraint fit right? A multi-seed study (issue 5; not a test).

For each seed, drop 3 flies a fresh Gauss-Markov gust realisation (sigma 0.5, 0.5, 0.25 m/s N, E, D,
correlation time 3 s) that the balloon did not see; synthetic IMU and GPS data are made with that
seed's noise, and the weak-constraint fit estimates the gusts at every node with the same
Gauss-Markov prior. One realisation spans only a few correlation times, so a single fit says little;
across seeds, for each gust axis:

- ``z_mean``: the error of the window mean of the gust, divided by its reported sigma (from the full
  node covariance, correlations included). Should be N(0, 1) across seeds.
- ``nees``: e^T C^-1 e of the gust error at nodes 1 s apart (C their reported covariance), which
  should follow chi-square with that many degrees of freedom.
- the parameters' NEES against chi-square with n_params degrees of freedom.

Run: python benchmarks/gust_calibration.py [--seeds 8] [--first 1] [--workers 2] [--start 15]
     [--json out.json]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import tempfile
import time
from pathlib import Path

import numpy as np
from scipy import stats

from casrecon.analysis.montecarlo import map_with_progress
from casrecon.analysis.observability import _with_data
from casrecon.analysis.synthetic import truth_disturbance, truth_parameters_by_name
from casrecon.estimation.fit import fit_drop
from casrecon.physics.disturbance import DisturbanceModel
from casrecon.scenario import Scenario

PROBLEMS = Path(__file__).resolve().parents[1] / "problems"
GUSTS = DisturbanceModel((0.5, 0.5, 0.25) + (0.0,) * 6, (3.0,) * 9)
AXES = ("gust_n_mps", "gust_e_mps", "gust_d_mps")
SUBSAMPLE_S = 1.0


def _gusty_scenario(seed: int, start_s: float, folder: Path) -> Scenario:
    """Drop 3 with gust truth and gust estimation, synthetic data of ``seed`` in ``folder``."""
    cfg = Scenario.load(PROBLEMS / "ees-drop-3").config
    cfg = dataclasses.replace(cfg, truth=dataclasses.replace(cfg.truth, disturbance=GUSTS, seed=seed),
                              estimation=dataclasses.replace(cfg.estimation, start_after_release_s=start_s,
                                                             disturbance=GUSTS))
    return _with_data(Scenario.from_config(cfg), folder, seed=seed)


def _axis_errors(r, truth: np.ndarray, j: int) -> dict:
    """Window-mean z and subsampled NEES of gust axis ``j`` of fit ``r``."""
    part, cov = r.extra["part"], r.extra["covariance"]
    jj = list(part.active).index(j)
    idx = part.u_cols[:, jj]
    value, _ = r.column(AXES[j])
    err = value - truth[:, j]
    c = cov.covariance_of(idx, np.full(idx.size, part.u_scale[jj]))
    sub = np.unique(np.searchsorted(r.flight_time_s, np.arange(r.flight_time_s[0], r.flight_time_s[-1],
                                                                SUBSAMPLE_S)))
    e_sub = err[sub]
    return {"z_mean": float(err.mean() / np.sqrt(c.mean())), "sigma_mean": float(np.sqrt(c.mean())),
            "nees": float(e_sub @ np.linalg.solve(c[np.ix_(sub, sub)], e_sub)), "dof": int(sub.size),
            "rms_error": float(np.sqrt(np.mean(err**2))), "rms_truth": float(np.sqrt(np.mean(truth[:, j] ** 2)))}


def one_seed(task: tuple[int, float]) -> dict:
    """Fit one seed's gusty drop; the per-axis and parameter calibration figures."""
    seed, start_s = task
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as tmp:
        sc = _gusty_scenario(seed, start_s, Path(tmp))
        r = fit_drop(sc)
    truth = truth_disturbance(sc, seed)(r.flight_time_s)
    out = {"seed": seed, "converged": bool(r.converged), "status": r.solver.status,
           "reduced_chi2": float(r.reduced_chi2), "fit_s": time.perf_counter() - t0}
    out.update({AXES[j]: _axis_errors(r, truth, j) for j in range(3)})
    t = truth_parameters_by_name(sc)
    e = np.array([v - t[n] for n, v in zip(r.params.names, r.values)])
    c = r.correlation * np.outer(r.sigma, r.sigma)
    out["params"] = {"nees": float(e @ np.linalg.solve(c, e)), "dof": len(e),
                     "z": dict(zip(r.params.names, (e / r.sigma).tolist()))}
    return out


def _interval(dof: int) -> tuple[float, float]:
    return float(stats.chi2.ppf(0.025, dof)), float(stats.chi2.ppf(0.975, dof))


def summarise(cases: list[dict]) -> None:
    """Print the across-seed figures."""
    ok = [c for c in cases if c["converged"]]
    print(f"{len(ok)} of {len(cases)} fits converged; median fit {np.median([c['fit_s'] for c in cases]):.0f} s; "
          f"reduced chi2 {np.mean([c['reduced_chi2'] for c in ok]):.3f} mean")
    for axis in AXES:
        z = np.array([c[axis]["z_mean"] for c in ok])
        nees, dof = sum(c[axis]["nees"] for c in ok), sum(c[axis]["dof"] for c in ok)
        lo, hi = _interval(dof)
        print(f"{axis}: window-mean z per seed {np.array2string(z, precision=2)}; RMS {np.sqrt(np.mean(z**2)):.2f} "
              f"(sigma of mean {np.mean([c[axis]['sigma_mean'] for c in ok]):.3f} m/s)")
        print(f"  NEES at 1 s nodes {nees:.0f} over {dof} dof, 95 % interval [{lo:.0f}, {hi:.0f}] -> "
              f"{'consistent' if lo <= nees <= hi else 'NOT consistent'}; RMS error "
              f"{np.mean([c[axis]['rms_error'] for c in ok]):.3f} vs RMS gust "
              f"{np.mean([c[axis]['rms_truth'] for c in ok]):.3f} m/s")
    nees, dof = sum(c["params"]["nees"] for c in ok), sum(c["params"]["dof"] for c in ok)
    lo, hi = _interval(dof)
    print(f"parameters: NEES {nees:.1f} over {dof} dof, 95 % interval [{lo:.1f}, {hi:.1f}] -> "
          f"{'consistent' if lo <= nees <= hi else 'NOT consistent'}")
    names = list(ok[0]["params"]["z"])
    z = np.array([[c["params"]["z"][n] for n in names] for c in ok])
    for n, rms, mean in zip(names, np.sqrt((z**2).mean(0)), z.mean(0)):
        print(f"  {n:16s} rms z {rms:5.2f}  mean {mean:+5.2f}")


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=8)
    ap.add_argument("--first", type=int, default=1)
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--start", type=float, default=15.0, help="fit window start after release, s")
    ap.add_argument("--json", type=Path)
    a = ap.parse_args()
    t0 = time.perf_counter()
    cases = map_with_progress(one_seed, [(s, a.start) for s in range(a.first, a.first + a.seeds)],
                              workers=a.workers)
    print(f"wall {time.perf_counter() - t0:.0f} s with {a.workers} workers")
    summarise(cases)
    if a.json:
        a.json.write_text(json.dumps(cases, indent=1))


if __name__ == "__main__":
    main()
