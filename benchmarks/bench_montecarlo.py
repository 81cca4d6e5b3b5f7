"""8000-case dispersed Monte Carlo of ees-drop-1 on 2 local processes (not a test).

Run: python benchmarks/bench_montecarlo.py [cases] [workers]   (target: at most 180 s for 8000 cases)
"""

from __future__ import annotations

import sys
import time
from pathlib import Path

from casrecon.analysis.montecarlo import Dispersions, run_montecarlo

PROBLEM = Path(__file__).resolve().parents[1] / "problems" / "ees-drop-1"


def main() -> None:
    cases = int(sys.argv[1]) if len(sys.argv) > 1 else 8000
    workers = int(sys.argv[2]) if len(sys.argv) > 2 else 2
    t0 = time.perf_counter()
    mc = run_montecarlo(PROBLEM, cases, seed=1, dispersions=Dispersions(), workers=workers, progress=True)
    total = time.perf_counter() - t0
    print(f"{cases} cases, {workers} processes: wall {total:.1f} s (cases only {mc.wall_s:.1f} s, target <= 180 s), "
          f"{cases / total:.1f} cases/s, RK4 dt {mc.dt_s} s")
    st = mc.statistics()
    print(f"impacted {st['n_impacted']} of {st['n_cases']}")
    for name in ("flight_time_s", "impact_speed_mps", "max_alpha_t_deg"):
        s = st[name]
        print(f"{name:<18s} mean {s['mean']:8.3f}  sd {s['sd']:6.3f}  3-sigma {s['three_sigma']:6.3f}  "
              f"p1 {s['p1']:8.3f}  p50 {s['p50']:8.3f}  p99 {s['p99']:8.3f}  nominal {mc.nominal[name]:8.3f}")


if __name__ == "__main__":
    main()
