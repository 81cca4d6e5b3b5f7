"""KinematicFit.sample interpolates the Euler angles the short way round the +-180 deg wrap."""

import numpy as np
import pandas as pd

from casrecon.results.kinematic_fit import KinematicFit
from casrecon.results.parameters import Parameters


def test_yaw_is_interpolated_across_the_wrap():
    frame = pd.DataFrame({"time_s": [0.0, 1.0, 2.0], "yaw_deg": [170.0, -170.0, -150.0],
                          "vel_d_mps": [1.0, 2.0, 3.0], "vel_d_mps_3sigma": [0.3, 0.3, 0.3]})
    fit = KinematicFit("wrap", Parameters((), np.zeros((0, 0))), frame, {}, {}, "")
    s = fit.sample(["yaw_deg", "vel_d_mps"], [0.5, 0.75, 1.5])
    assert np.allclose(s["yaw_deg"], [180.0, -175.0, -160.0])
    assert np.allclose(s["vel_d_mps"], [1.5, 1.75, 2.5])
