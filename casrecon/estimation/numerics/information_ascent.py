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
        ``information`` (at ``x``), ``nfev``, ``success`` and ``message``.
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
    return OptimizeResult(x=x, fun=-value, jac=-grad, information=information, nfev=evaluations, success=success,
                          message=message)


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


#: Diagonal added to the information before its inverse gives the profile directions of
#: :func:`upper_bounds` (a variable the function does not see would make it singular).
RIDGE = 1e-3
#: :func:`upper_bounds` takes the quadratic (Wald) bound where it moves a variable by less than this
#: (near the maximum the function is quadratic; only weakly determined variables are searched).
WALD_ENOUGH = 0.2
#: Precision of a searched bound, in the variable's units.
BOUND_TOL = 0.05


def upper_bounds(value_at: Callable[[np.ndarray], float], x: np.ndarray, value: float, information: np.ndarray,
                 lower: np.ndarray, upper: np.ndarray, which: np.ndarray, drop: float) -> np.ndarray:
    """Each variable's likelihood-ratio upper bound at a maximum: for each index in ``which``, the
    largest x_j at which the function, along its profile direction (the other variables moved
    with x_j by the regression the information implies, then clipped to their bounds), is at
    most ``drop`` below ``value``.

    Parameters
    ----------
    value_at : callable
        x -> the function's value.
    x, value : (n,) array, float
        The maximum (:func:`maximised`'s ``x``, ``-fun``).
    information : (n, n) array
        The information at ``x`` (an approximation of the negative Hessian).
    lower, upper : (n,) arrays
        The bounds of the variables.
    which : int array
        The variables to bound.
    drop : float
        How far below ``value`` the bound lies (1.92 for a one-sided 97.5 % bound of one
        log-likelihood variable).

    Returns
    -------
    (n,) array
        ``x`` with each variable of ``which`` at its upper bound (at most ``upper``). Where the
        quadratic bound sqrt(2 drop / profile information) moves it by less than WALD_ENOUGH, that
        one; else searched along the direction by bracketing and bisection to BOUND_TOL.
    """
    x = np.asarray(x, float)
    symmetric = 0.5 * (information + information.T)
    covariance = np.linalg.inv(symmetric + RIDGE * np.eye(x.size))
    out = x.copy()
    for j in np.asarray(which, np.int64):
        direction = covariance[:, j] / covariance[j, j]
        room = upper[j] - x[j]
        wald = float(np.sqrt(2.0 * drop * covariance[j, j]))
        if room <= 0.0:
            continue
        if wald < WALD_ENOUGH:
            out[j] = x[j] + min(wald, room)
            continue

        def below(t: float, direction=direction) -> bool:
            return value - value_at(np.clip(x + t * direction, lower, upper)) >= drop

        inside, t = 0.0, min(wald, room)
        while not below(t):  # bracket: the bound lies between ``inside`` and ``t``
            inside = t
            if t >= room:
                break
            t = min(2.0 * t, room)
        else:
            while t - inside > BOUND_TOL:
                middle = 0.5 * (inside + t)
                if below(middle):
                    t = middle
                else:
                    inside = middle
        out[j] = x[j] + inside
    return out


#: Step of the central differences of the gradient that give :func:`covariance_at_maximum` its
#: Hessian (a log ratio: a smooth function with an analytic gradient, so an error of order 1e-4 of
#: the curvature).
HESSIAN_STEP = 0.01


def covariance_at_maximum(gradient: Callable[[np.ndarray], np.ndarray], x: np.ndarray,
                          which: list[int]) -> np.ndarray | None:
    """The covariance of the variables ``which`` at a maximum ``x`` of a log likelihood (a log
    evidence): the inverse of its negative Hessian over them, by central differences of
    ``gradient`` (x -> the gradient) with HESSIAN_STEP, the other variables held (conditional on
    them). None where that Hessian is not negative definite (a flat or curved-up function: no
    Laplace approximation there)."""
    x = np.asarray(x, float)
    hessian = np.zeros((len(which), len(which)))
    for j, k in enumerate(which):
        step = np.zeros_like(x)
        step[k] = HESSIAN_STEP
        hessian[:, j] = (np.asarray(gradient(x + step))[which] - np.asarray(gradient(x - step))[which]) / (
            2.0 * HESSIAN_STEP)
    try:
        chol = np.linalg.cholesky(-0.5 * (hessian + hessian.T))
    except np.linalg.LinAlgError:
        return None
    inverse = np.linalg.inv(chol)
    return inverse.T @ inverse
