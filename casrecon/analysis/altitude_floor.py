"""The absolute altitude's bands floored by what the GPS heights alone say (issue 49).

A 6-DOF fit places the drop in altitude by the GPS heights and by the sounding: the capsule's
gyros and accelerometers feel the sounding's wind and density shape, and a fit that holds the
sounding's altitude (``[atmosphere] sounding_shift_sigma_m = 0``, the default) registers its
trajectory to that shape to centimetres. Where the air flown differs from the sounding at scales
the profile grid cannot place, the registration has near-equal optima a profile step apart
(docs/studies/error-families.md, "The sounding's altitude shift"): the fit may sit on one 10 m
off, and its covariance, the curvature of that one optimum, gives the vertical position a band of
centimetres. With the GPS height errors correlated over the drop (the default error model, or the
sizes the data ask for), the GPS heights do not pull it back.

So the vertical-position and height-above-ground bands are at least what the GPS heights alone
say about the drop's absolute altitude, and how far the fit sits from them: with v the variance of
the generalised-least-squares estimate of a constant offset of the fixes' down positions under the
fit's GPS error model (each fix's 1-sigma, the correlated share over its correlation time,
:func:`offset_variance`) and d the accuracy-weighted mean of their residuals (GPS less fit), the
floor's variance is v + d^2: the GPS heights' own uncertainty of the absolute altitude, and the
disagreement of the two placements, which the one the fit chose cannot be trusted to resolve. (d
is not the generalised-least-squares mean: the model scales each fix's correlated error by its
accuracy, and that mean then explains a constant offset as correlated error wherever the
accuracies vary: on the case below, 2.1 m for a mean of 9.6 m.) The ground's altitude at the
impact, where it is a measurement (``[estimation] impact_ground_sigma_m``), is combined with v. A
fit without GPS heights gets no floor. A fit whose GPS height
errors are white gets a floor of about its accuracy over the root of the fix count (centimetres to
decimetres), one with correlated errors the correlated part's size; a fit registered a profile step
off, that step. Chosen on the error-family study's `fine-grid` seed 253 (a trusted fit 10.0 m low
with a 0.03 m band; v alone gave 2.9 m, the truth 3.4 of them off), accepted on fresh seeds
(docs/studies/error-families.md).
"""

from __future__ import annotations

import dataclasses

import numpy as np

from casrecon.estimation.sixdof.diagnostics import gps_residuals
from casrecon.physics.sensor_errors import innovations

#: Band columns floored, each holding the absolute altitude (m).
ALTITUDE_COLUMNS = ("pos_d_m", "h_agl_m")
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


def altitude_floor_m(result) -> float:
    """The floor (m) of ``result``'s absolute-altitude bands: sqrt(v + d^2), v the
    :func:`offset_variance` of its fixes' down positions under its GPS error model (combined with
    the impact's ground altitude where the fit measures it), d their residuals' accuracy-weighted
    mean; 0 without GPS heights."""
    gps = gps_residuals(result)
    ok = np.isfinite(gps["residual"][:, DOWN]) & np.isfinite(gps["sigma"][:, DOWN])
    if not np.any(ok):
        return 0.0
    errors = result.scenario.config.gps.error_model
    sigma = gps["sigma"][ok, DOWN]
    variance = offset_variance(gps["time_imu_s"][ok], sigma, float(errors.fraction[DOWN]), float(errors.time_s[DOWN]))
    offset = float(np.sum(gps["residual"][ok, DOWN] / sigma ** 2) / np.sum(1.0 / sigma ** 2))
    ground_sigma = result.scenario.config.estimation.impact_ground_sigma_m
    if ground_sigma is not None and ground_sigma > 0:
        variance = 1.0 / (1.0 / variance + 1.0 / ground_sigma ** 2)
    return float(np.sqrt(variance + offset ** 2))


def altitude_floored(result):
    """``result`` (a per-drop 6-DOF FitResult) with its :data:`ALTITUDE_COLUMNS` bands at least
    :func:`altitude_floor_m`, and a note saying so when that widened any node's band; with the
    floor (m)."""
    floor = altitude_floor_m(result)
    columns = tuple(result.columns)
    table_sigma = np.array(result.table_sigma, float)
    raised = 0
    for name in ALTITUDE_COLUMNS:
        if name in columns:
            i = columns.index(name)
            below = table_sigma[:, i] < floor
            raised = max(raised, int(np.sum(below)))
            table_sigma[:, i] = np.where(below, floor, table_sigma[:, i])
    if not raised:
        return result, floor
    note = (f"absolute altitude: the vertical-position and height bands are at least {floor:.2f} m (1-sigma), what "
            f"the GPS heights alone say under the fit's GPS error model, their offset from the fit included "
            f"(at {raised} of {table_sigma.shape[0]} nodes the fit's own band was narrower: its registration to the "
            "sounding's wind and density shape, which the air flown need not share)")
    return dataclasses.replace(result, table_sigma=table_sigma, notes=result.notes + (note,)), floor
