"""casrecon.fit_joint on two shipped drops (about 2 minutes): the joint result saves and loads back
with identical parameters, sigmas and correlations, and each drop's trajectory to 9 digits."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import casrecon

ROOT = Path(__file__).resolve().parents[2]


@pytest.mark.slow
def test_fit_joint_round_trip(tmp_path):
    joint = casrecon.fit_joint([ROOT / "problems" / "ees-drop-1", ROOT / "problems" / "ees-drop-3"], name="pair")
    assert joint.converged and 0.95 < joint.reduced_chi2 < 1.05 and "CA_mult" in joint.shared
    assert joint.params["CA_mult"].shared and not joint.params["ees-drop-1.wind_bias_n"].shared
    loaded = casrecon.load_results(joint.save(tmp_path / "pair"))
    assert isinstance(loaded, casrecon.JointFit) and loaded.params == joint.params
    for name, drop in joint.drops.items():
        assert loaded.drops[name].params == drop.params
        again = loaded.drops[name].trajectory
        np.testing.assert_allclose(again.select_dtypes("number").to_numpy(),
                                   drop.trajectory.select_dtypes("number").to_numpy(), rtol=1e-8)
        assert (again["utc"] == drop.trajectory["utc"]).all()  # UTC timestamps from the same ISO 8601 text
