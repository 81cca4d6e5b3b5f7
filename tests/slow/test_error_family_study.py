"""The default fit on drops whose world is the plain model and on GPS errors of other shapes
(issue 49; docs/studies/error-families.md), fresh seeds 200 and 202 (seed 100 chose the change):
every fit converges, its parameter NEES is inside the 95 % interval and the truth lies in the 3-sigma
bands of position, velocity and attitude at >= 98 % of nodes, with a trusted verdict.

Before the change (a GPS correlation time at the end of its search taken for a gross error) the
exact-model drop of seed 202 kept its 99 %-correlated GPS model: NEES 271 on 19, position bands 19 %,
attitude 0 %, not trusted (seed 100: NEES 52, position 30 %); seed 200's estimate did not reach the
end of its search and passed before too. Seed 216 (2026-12-04, fifth session): the first fit's
estimate, at the default 99 %-correlated GPS model, asked for a density error of 1.65 % over 30 km,
taken for a gross error, and the first fit stood (NEES 38.5, CA_mult -7.7 sigma before widening, not
trusted); now judged again after a refit with the GPS model alone, it ends as the plain fit.
Seed 224 (2026-12-05, seventh session): the first fit settled 7.9 m low (GPS height chi-square
30,285 on 1,200 fixes) and its estimate asked for GPS position errors 4.13 times the stated
accuracies, taken for a gross error (not trusted); judged again on a refit with that GPS model
(``plausibility.judged_again``): 0.04 m off, trusted, NEES 30.3.

Run: pytest -m slow tests/slow/test_error_family_study.py (about 8 min).
"""

from __future__ import annotations

from pathlib import Path

import pytest
from conftest import script_module

BENCH = Path(__file__).resolve().parents[2] / "benchmarks" / "error_families.py"


@pytest.mark.slow
@pytest.mark.parametrize("family,seed", [("none", 200), ("none", 202), ("gps-steps", 200), ("none", 216),
                                         ("none", 224)])
def test_the_default_fit_is_honest_where_the_world_is_the_plain_model(family, seed):
    bench = script_module(BENCH)
    case = bench.run_case(family, "ees", ("default",), seed)
    fit = case["default"]
    assert "failed" not in fit, fit.get("failed")
    pooled = bench.pooled([fit])
    lo, hi = pooled["interval"]
    assert lo <= pooled["nees_sum"] <= hi, pooled
    for group in ("position", "velocity", "attitude"):
        assert pooled["coverage"][group] >= 0.98, (group, pooled["coverage"])
    assert fit["trusted"], fit["reasons"]
