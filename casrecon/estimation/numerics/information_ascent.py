"""The maximum of a smooth function of a few bounded variables (a log evidence over the log ratios
of error sizes) by Newton steps on a supplied information matrix, an approximation of the negative
Hessian such as average-information REML's: projected on the bounds, damped where the matrix is
not positive definite, the step's largest entry capped and shortened until the value rises.

Where the information is a good curvature (the evidence near its maximum) this converges in a few
evaluations: on the default fit's GPS and profile sizes (six groups) 8 to 9 where scipy's
L-BFGS-B took 20 to 29 (docs/design/error-models.md, "Correlated GPS errors").
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
from scipy.optimize import OptimizeResult

#: Largest change of any variable in one step (a log ratio: a factor e^2 of a size).
MAX_STEP = 2.0
#: Shortening of a step whose value does not rise, and the shortest step tried.
SHORTEN, SHORTEST = 0.25, 1e-3


def maximised(function: Callable[[np.ndarray], tuple[float, np.ndarray, np.ndarray | None]],
              start: np.ndarray, lower: np.ndarray, upper: np.ndarray, tolerance: float = 1e-3,
              max_evaluations: int = 100) -> OptimizeResult:
    """The maximum of ``function`` over lower <= x <= upper from ``start``.

    Parameters
    ----------
    function : callable
        x -> (value, gradient, information): the information an approximation of the negative
        Hessian (None: not available at x, the step follows the gradient's signs).
    start, lower, upper : (n,) arrays
        The first point (clipped to the bounds) and the bounds.
    tolerance : float
        Stop when the step's predicted rise (g^T step / 2, on the variables off their bounds or
        moving inwards) is below it (the function's units: nats for a log evidence).
    max_evaluations : int
        Stop after this many evaluations (the result's ``success`` False).

    Returns
    -------
    scipy.optimize.OptimizeResult
        ``x``, ``fun`` (minus the value, as scipy's minimisers), ``jac`` (minus the gradient),
        ``nfev``, ``success`` and ``message``.
    """
    lower, upper = np.asarray(lower, float), np.asarray(upper, float)
    x = np.clip(np.asarray(start, float), lower, upper)
    value, grad, information = function(x)
    evaluations, message, success = 1, "", False
    while True:
        step = _step(x, grad, information, lower, upper)
        if float(grad @ step) / 2.0 <= tolerance:
            success, message = True, "predicted rise below the tolerance"
            break
        length = 1.0
        while True:
            trial = np.clip(x + length * step, lower, upper)
            trial_value, trial_grad, trial_information = function(trial)
            evaluations += 1
            if trial_value > value or length <= SHORTEST or evaluations >= max_evaluations:
                break
            length *= SHORTEN
        if trial_value <= value:
            message = "no rise along the step" if length <= SHORTEST else "evaluation limit"
            break
        x, value, grad, information = trial, trial_value, trial_grad, trial_information
        if evaluations >= max_evaluations:
            message = "evaluation limit"
            break
    return OptimizeResult(x=x, fun=-value, jac=-grad, nfev=evaluations, success=success, message=message)


def _step(x: np.ndarray, grad: np.ndarray, information: np.ndarray | None, lower: np.ndarray,
          upper: np.ndarray) -> np.ndarray:
    """The Newton step on the variables not held at a bound (held: those the gradient, or the
    step itself, pushes out of the bounds), its largest entry at most MAX_STEP by a
    Levenberg-Marquardt shift (which shortens it most along the directions of least information:
    a variable the data hardly see, such as a size at its lower bound, does not stop the others)."""
    free = ~(((x <= lower) & (grad < 0)) | ((x >= upper) & (grad > 0)))
    step = np.zeros_like(x)
    if information is None:
        step[free] = np.sign(grad[free]) * MAX_STEP / 4.0
        return step
    symmetric = 0.5 * (information + information.T)
    for _ in range(x.size + 1):  # hold the variables the step pushes out, until none is
        step = np.zeros_like(x)
        if not free.any():
            return step
        step[free] = _capped(symmetric[np.ix_(free, free)], grad[free])
        outward = free & (((x <= lower) & (step < 0)) | ((x >= upper) & (step > 0)))
        if not outward.any():
            return step
        free &= ~outward
    return step


def _capped(block: np.ndarray, grad: np.ndarray) -> np.ndarray:
    """(block + shift I)^-1 grad, shifted to be positive definite and, where the Newton step has an
    entry above MAX_STEP, by the smallest shift (found by bisection in its logarithm) whose step has
    none."""
    smallest = float(np.linalg.eigvalsh(block)[0])
    scale = max(float(np.max(np.abs(np.diag(block)), initial=0.0)), 1.0)
    floor = max(0.0, -1.1 * smallest) + 1e-10 * scale  # damped where not positive definite
    eye = np.eye(grad.size)

    def step(shift: float) -> np.ndarray:
        return np.linalg.solve(block + shift * eye, grad)

    out = step(floor)
    if np.max(np.abs(out)) <= MAX_STEP:
        return out
    low, high = floor, floor + max(scale, float(np.max(np.abs(grad))) / MAX_STEP)
    while np.max(np.abs(step(high))) > MAX_STEP:
        high *= 10.0
    for _ in range(30):
        middle = np.sqrt(max(low, 1e-300) * high) if low > 0 else 0.5 * high
        if np.max(np.abs(step(middle))) > MAX_STEP:
            low = middle
        else:
            high = middle
        if high <= 1.1 * low:
            break
    return step(high)
