"""Timing of one ees-drop-1 simulation at 500 Hz output and of make_synthetic (not a test).

Run: python benchmarks/bench_simulate.py   (target: at most 1 s per 40 s drop)
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

from casrecon.scenario import Scenario
from casrecon.simulation.simulate import Simulator
from casrecon.simulation.synthetic import make_synthetic

PROBLEM = Path(__file__).resolve().parents[1] / "problems" / "ees-drop-1"
REPEATS = 7


def timed(fn):
    t0 = time.perf_counter()
    out = fn()
    return time.perf_counter() - t0, out


def report(label: str, times: list[float]) -> None:
    print(f"{label:<34s} median {statistics.median(times):7.3f} s   min {min(times):7.3f}   "
          f"max {max(times):7.3f}   (n = {len(times)})")


def main() -> None:
    build, run, synth = [], [], []
    flight = None
    for _ in range(REPEATS):
        t_load, sc = timed(lambda: Scenario.load(PROBLEM))
        t_sim, sim = timed(lambda sc=sc: Simulator(sc.model, dt_s=0.002))
        build.append(t_load + t_sim)
        t_run, traj = timed(lambda sc=sc, sim=sim: sim.run(sc.release_state(), sc.truth_parameters()))
        run.append(t_run)
        flight = traj.flight_time_s
    for _ in range(REPEATS):
        sc = Scenario.load(PROBLEM)
        synth.append(timed(lambda sc=sc: make_synthetic(sc))[0])
    print(f"ees-drop-1: {flight:.3f} s flight, 500 Hz output ({round(flight / 0.002)} RK4 steps)")
    report("model build (load + Simulator)", build)
    report("simulation run", run)
    report("make_synthetic (full)", synth)
    per40 = statistics.median(run) * 40.0 / flight
    print(f"run time per 40 s of drop: {per40:.3f} s (target <= 1 s): {'OK' if per40 <= 1.0 else 'SLOW'}")


if __name__ == "__main__":
    main()
