"""Joint aero fit of the four EES drops from Python (the EES paper's Table 5), and what it shows.

Run: python examples/joint_aero_fit.py

Asserts that
- the joint NLP converges with a reduced chi-square near 1;
- every shared dispersion factor's truth lies within its joint 3-sigma;
- every shared factor is determined better jointly than by any single drop (sigma comparison);
- the reconciled simulations (fitted dispersions, as-flown initial state) land within 0.1 s and
  0.1 m/s of the reconstructed impact.
"""

import json
from pathlib import Path

from casrecon.analysis.single_sigmas import single_drop_sigmas
from casrecon.estimation.sixdof.diagnostics import reconciled_simulation
from casrecon.estimation.sixdof.joint import JointConfig, fit_joint
from casrecon.scenario import Scenario

ROOT = Path(__file__).resolve().parents[1] / "problems"
DROPS = [ROOT / f"ees-drop-{i}" for i in (1, 2, 3, 4)]


def main() -> None:
    result = fit_joint([Scenario.load(d) for d in DROPS], JointConfig("ees-joint", tuple(DROPS)))
    print(f"{result.status} in {result.iterations} iterations, reduced chi-square {result.reduced_chi2:.4f}, "
          f"build {result.timings['build_s']:.1f} s, solve {result.timings['solve_s']:.1f} s")
    assert 0.95 < result.reduced_chi2 < 1.05
    # the joint chi-square over the joint dof; each drop's over its own (not the joint one repeated)
    assert abs(result.chi2 / result.dof - result.reduced_chi2) < 1e-9 * result.reduced_chi2
    # each drop's dof counts the shared factors as its own; the joint dof counts them once
    assert result.dof == sum(d.dof for d in result.drops) + (len(result.drops) - 1) * len(result.shared)
    for drop in result.drops:
        assert abs(sum(drop.chi2.values()) / drop.dof - drop.reduced_chi2) < 1e-12
        print(f"{drop.scenario.config.name}: own reduced chi-square {drop.reduced_chi2:.4f} ({drop.dof} dof)")

    truth = json.loads((DROPS[0] / "data" / "truth.json").read_text())["parameters"]
    single = single_drop_sigmas(DROPS)
    print(f"{'factor':10s} {'joint':>9s} {'3-sigma':>8s} {'truth':>8s} {'best single sigma':>18s}")
    for name in result.shared:
        i = result.names.index(name)
        value, sigma = result.values[i], result.sigma[i]
        best_single = min(single[d.name][name] for d in DROPS)
        print(f"{name:10s} {value:9.4f} {3 * sigma:8.4f} {truth[name]:8.4f} {best_single:18.4g}")
        assert abs(value - truth[name]) < 3 * sigma, name
        assert sigma < best_single, name

    for drop in result.drops:
        rec = reconciled_simulation(drop)["summary"]
        print(f"{drop.scenario.config.name}: reconciled flight time {rec['flight_time_difference_s']:+.3f} s, "
              f"impact speed {rec['impact_speed_difference_mps']:+.3f} m/s")
        assert abs(rec["flight_time_difference_s"]) < 0.1 and abs(rec["impact_speed_difference_mps"]) < 0.1


if __name__ == "__main__":
    main()
