"""The absolute position's bands floored by what the GPS fixes alone say (issue 49).

A 6-DOF fit places the drop horizontally by the GPS fixes alone (the IMU integrates the shape, not
the place) and in altitude by the GPS heights and by the sounding: the capsule's gyros and
accelerometers feel the sounding's wind and density shape, and a fit that holds the sounding's
altitude (``[atmosphere] sounding_shift_sigma_m = 0``, the default) registers its trajectory to
that shape to centimetres. Where the air flown differs from the sounding at scales the profile
grid cannot place, the registration has near-equal optima a profile step apart
(docs/studies/error-families.md, "The sounding's altitude shift"): the fit may sit on one 10 m
off, and its covariance, the curvature of that one optimum, gives the vertical position a band of
centimetres. With the GPS height errors correlated over the drop (the default error model, or the
sizes the data ask for), the GPS heights do not pull it back.

And no statistic of one drop's fixes sees a constant offset of all of them: the fit's GPS error
model sizes its correlated part by how the fixes' errors vary within the drop, while a receiver's
errors that last longer (orbits, ionosphere, a change of satellites that shifts every later fix)
stay whole over a 40 s drop. A receiver's stated accuracy is its own estimate of each fix's
absolute error. So for each of north, east and down, with v the variance of the
generalised-least-squares estimate of a constant offset of the fixes under the fit's GPS error
model (each fix's 1-sigma, the correlated share over its correlation time,
:func:`offset_variance`), s^2 the median of the fixes' variances (the stated accuracies times the
scale the data ask for: an offset is known no better than one fix says) and d the
accuracy-weighted mean of their residuals (GPS less fit), the position's bands (and the height
above ground's, with the down one) are at least sqrt(max(v, s^2) + d^2): the fixes' own
uncertainty of the absolute position, and the disagreement of the two placements, which the one
the fit chose cannot be trusted to resolve. (d is not the generalised-least-squares mean: the model
scales each fix's correlated error by its accuracy, and that mean then explains a constant offset
as correlated error wherever the accuracies vary: on the case below, 2.1 m for a mean of 9.6 m.)
The ground's altitude at the impact, where it is a measurement (``[estimation]
impact_ground_sigma_m``), is combined with the down one's max(v, s^2). A fit without GPS fixes of
a component gets no floor for it.

The altitude's v + d^2 was chosen on the error-family study's `fine-grid` seed 253 (a trusted fit
10.0 m low with a 0.03 m band; v alone gave 2.9 m, the truth 3.4 of them off), accepted on fresh
seeds; s^2 and the horizontal components on `gps-steps` seed 283 (EES: a trusted fit whose east
position was 3.0 to 4.0 m off with a 1.09 m band, inside it at 32 % of the nodes, the fixes'
1-sigma 2.24 m; docs/studies/error-families.md).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from casrecon.estimation.sixdof.diagnostics import gps_residuals
from casrecon.physics.sensor_errors import innovations

#: Band columns floored, per component (north, east, down) of the fixes' positions: the NED
#: position and, with the down one, the height above ground (m).
POSITION_COLUMNS = (("pos_n_m",), ("pos_e_m",), ("pos_d_m", "h_agl_m"))
#: Index of the down position among a fix's six components (pos N, E, D, vel N, E, D).
DOWN = 2


def offset_variance(time_s: np.ndarray, sigma_m: np.ndarray, fraction: float, time_constant_s: float) -> float:
    """Variance (m^2) of the generalised-least-squares estimate of a constant offset from fixes at
    ``time_s`` (s) whose errors have 1-sigma ``sigma_m`` (m), a share ``fraction`` of each variance
    a first-order Gauss-Markov process of correlation time ``time_constant_s`` (s; 0: white) and
    the rest white: 1 / (1^T S^-1 1), with 1^T S^-1 1 the squared norm of the offset's whitened
    innovations under that model (:func:`~casrecon.physics.sensor_errors.innovations`, which whitens
    the fit's GPS residuals the same way)."""
    t, s = np.asarray(time_s, float), np.asarray(sigma_m, float)
    if t.size == 0:
        return float("inf")
    order = np.argsort(t, kind="stable")
    whitened = innovations(1.0 / s[order], t[order], time_constant_s, fraction)
    return float(1.0 / np.sum(whitened ** 2))


def position_floor_m(result) -> np.ndarray:
    """The floors (m) of ``result``'s absolute-position bands, north, east and down:
    sqrt(max(v, s^2) + d^2) per component, v the :func:`offset_variance` of its fixes under its
    GPS error model, s^2 the median of the fixes' variances (the down one combined with the
    impact's ground altitude where the fit measures it), d their residuals' accuracy-weighted
    mean; 0 for a component without fixes."""
    gps = gps_residuals(result)
    errors = result.scenario.config.gps.error_model
    ground_sigma = result.scenario.config.estimation.impact_ground_sigma_m
    floors = np.zeros(len(POSITION_COLUMNS))
    for c in range(len(POSITION_COLUMNS)):
        ok = np.isfinite(gps["residual"][:, c]) & np.isfinite(gps["sigma"][:, c])
        if not np.any(ok):
            continue
        sigma = gps["sigma"][ok, c]
        variance = max(offset_variance(gps["time_imu_s"][ok], sigma, float(errors.fraction[c]),
                                       float(errors.time_s[c])), float(np.median(sigma ** 2)))
        offset = float(np.sum(gps["residual"][ok, c] / sigma ** 2) / np.sum(1.0 / sigma ** 2))
        if c == DOWN and ground_sigma is not None and ground_sigma > 0:
            variance = 1.0 / (1.0 / variance + 1.0 / ground_sigma ** 2)
        floors[c] = np.sqrt(variance + offset ** 2)
    return floors


def position_floored(result):
    """``result`` (a per-drop 6-DOF FitResult) with its :data:`POSITION_COLUMNS` bands at least
    :func:`position_floor_m`, and a note saying so when that widened any node's band; with the
    floors (m, north, east, down)."""
    floors = position_floor_m(result)
    columns = tuple(result.columns)
    table_sigma = np.array(result.table_sigma, float)
    raised = np.zeros(len(POSITION_COLUMNS), int)
    for c, names in enumerate(POSITION_COLUMNS):
        for name in names:
            if name in columns:
                i = columns.index(name)
                below = table_sigma[:, i] < floors[c]
                raised[c] = max(raised[c], int(np.sum(below)))
                table_sigma[:, i] = np.where(below, floors[c], table_sigma[:, i])
    if not raised.any():
        return result, floors
    note = (f"absolute position: the north, east and down position bands (and the height's) are at least "
            f"{floors[0]:.2f}, {floors[1]:.2f} and {floors[2]:.2f} m (1-sigma), what the GPS fixes alone say (one "
            f"fix's accuracy at least: no drop's fixes see an offset common to all of them), their offset from the "
            f"fit included (the fit's own bands were narrower at {raised[0]}, {raised[1]} and {raised[2]} of "
            f"{table_sigma.shape[0]} nodes)")
    return dataclasses.replace(result, table_sigma=table_sigma, notes=result.notes + (note,)), floors
