"""KinematicFit.sample interpolates the Euler angles the short way round the +-180 deg wrap."""

import numpy as np
import pandas as pd
import pytest

from casrecon.results.kinematic_fit import KinematicFit
from casrecon.results.parameters import Parameters


def test_yaw_is_interpolated_across_the_wrap():
    frame = pd.DataFrame({"segment_time_s": [0.0, 1.0, 2.0], "yaw_deg": [170.0, -170.0, -150.0],
                          "vel_d_mps": [1.0, 2.0, 3.0], "vel_d_mps_3sigma": [0.3, 0.3, 0.3]})
    fit = KinematicFit("wrap", Parameters((), np.zeros((0, 0))), frame, {}, {}, "")
    s = fit.sample(["yaw_deg", "vel_d_mps"], [0.5, 0.75, 1.5])
    assert np.allclose(s["yaw_deg"], [180.0, -175.0, -160.0])
    assert np.allclose(s["vel_d_mps"], [1.5, 1.75, 2.5])


def test_sample_at_utc_instants_on_a_utc_clock_and_a_clear_refusal_without_one():
    t0 = 1726601120.0
    frame = pd.DataFrame({"time_unix_s": t0 + np.arange(3.0), "segment_time_s": [0.0, 1.0, 2.0],
                          "yaw_deg": [170.0, -170.0, -150.0], "vel_d_mps": [1.0, 2.0, 3.0]})
    fit = KinematicFit("utc", Parameters((), np.zeros((0, 0))), frame, {}, {}, "")
    at = pd.Timestamp(t0 + 0.5, unit="s", tz="UTC")
    s = fit.sample(["yaw_deg", "vel_d_mps"], [at, at + pd.Timedelta(seconds=1)])
    assert list(s.columns) == ["utc", "yaw_deg", "vel_d_mps"]
    assert np.allclose(s["yaw_deg"], [180.0, -160.0]) and np.allclose(s["vel_d_mps"], [1.5, 2.5])
    local = KinematicFit("local", Parameters((), np.zeros((0, 0))), frame.drop(columns="time_unix_s"), {}, {}, "")
    with pytest.raises(ValueError, match="no UTC time axis"):
        local.sample("vel_d_mps", at)
