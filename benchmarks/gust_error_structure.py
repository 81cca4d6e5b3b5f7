"""Where the gust estimate's error and its reported covariance disagree (a diagnostic, not a test;
prints).

For each seed of the whole-drop gust calibration case (ees-drop-3 from --start s, full-size gusts),
fitted and moved to the marginal-likelihood estimate, per gust axis and node spacing: the NEES of
the gust error at nodes that far apart (full covariance), the NEES of its successive differences,
the window-mean z, and the mean of the per-node z^2 (diagonal only). A NEES excess carried by the
differences while the per-node z^2 stay small says the covariance puts too much of the error in
slowly varying components and too little in the changes between nodes.

Run: python benchmarks/gust_error_structure.py [--seeds 2] [--first 7] [--workers 2] [--start 3.5]
"""

from __future__ import annotations

import tempfile
from pathlib import Path

import numpy as np
from gust_cases import case_arguments, whole_drop_cases

from casrecon.analysis.gust_calibration import AXES, GustCase, case_scenario
from casrecon.estimation.sixdof.fit import fit_drop, with_marginal_estimate
from casrecon.parallel import parallel_map
from casrecon.simulation.synthetic import truth_disturbance

SPACINGS_S = (1.0, 0.25)


def error_structure(case: GustCase) -> list[str]:
    """The printed lines of one case."""
    with tempfile.TemporaryDirectory() as tmp:
        sc = case_scenario(case, Path(tmp))
        m = with_marginal_estimate(fit_drop(sc))
    truth = truth_disturbance(sc, case.seed)(m.flight_time_s)
    t = m.flight_time_s
    lines = []
    for spacing in SPACINGS_S:
        sub = np.unique(np.searchsorted(t, np.arange(t[0], t[-1], spacing)))
        diff = np.diff(np.eye(sub.size), axis=0)
        for j, axis in enumerate(AXES):
            jj = list(m.part.active).index(j)
            idx, scale = m.part.u_cols[sub, jj], m.part.u_scale[jj]
            e = m.column(axis)[0][sub] - truth[sub, j]
            c = m.covariance.covariance_of(idx, np.full(idx.size, scale))
            de, dc = diff @ e, diff @ c @ diff.T
            nees, nees_diff = e @ np.linalg.solve(c, e), de @ np.linalg.solve(dc, de)
            lines.append(f"seed {case.seed}, {spacing:g} s, {axis}: NEES {nees:.1f} over {sub.size}, "
                         f"differences {nees_diff:.1f} over {sub.size - 1}, window-mean z "
                         f"{e.mean() / np.sqrt(c.mean()):+.2f}, mean per-node z^2 {np.mean(e ** 2 / np.diag(c)):.2f}")
    return lines


def main() -> None:
    a = case_arguments(__doc__.splitlines()[0]).parse_args()
    cases = whole_drop_cases(a)
    for lines in parallel_map(error_structure, cases, workers=a.workers):
        print("\n".join(lines))


if __name__ == "__main__":
    main()
