"""A fit names its compiled libraries the same whatever fits ran before it in the process, so a
refit (the default profile path makes up to three) or a second fit compiles nothing new.

CasADi keeps the derivative functions made from an interpolant with it, and they are part of the
serialised expression the library key hashes: a fit that reused the interpolants of an earlier
one, which had also made the exact Hessian's, named its derivative library differently and
compiled it again (ees-drop-1 with the error models: a second 7 s build).
"""

from __future__ import annotations

import numpy as np
from conftest import PROBLEMS

from casrecon.estimation.sixdof.fit import fit_drop
from casrecon.physics import compiled
from casrecon.scenario import Scenario


def test_a_second_fit_of_the_same_scenario_uses_the_same_library_names(monkeypatch):
    scenario = Scenario.load(PROBLEMS / "ees-drop-1")
    named: list[list[tuple[str, str]]] = []
    key = compiled.library_key

    def recording(function, cc):
        out = key(function, cc)
        named[-1].append((function.name(), out))
        return out

    monkeypatch.setattr(compiled, "library_key", recording)
    results = []
    for _ in range(2):
        named.append([])
        results.append(fit_drop(scenario, information="observed"))  # the exact Hessian made after the derivatives
    assert named[0] and named[0] == named[1]
    np.testing.assert_array_equal(results[0].z, results[1].z)


def test_fresh_functions_give_the_same_numbers_from_new_interpolants():
    scenario = Scenario.load(PROBLEMS / "ees-drop-1")
    fresh = scenario.with_fresh_functions()
    assert fresh.atmosphere is not scenario.atmosphere and fresh.config == scenario.config
    for name, values in scenario.atmosphere.levels.items():
        np.testing.assert_array_equal(fresh.atmosphere.levels[name], values)
    x, p = scenario.release_state(), scenario.truth_parameters()
    np.testing.assert_array_equal(np.asarray(fresh.model.rhs(x, p)), np.asarray(scenario.model.rhs(x, p)))
