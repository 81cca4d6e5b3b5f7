"""Clock-offset continuation: keep every GPS fix (and every other measurement stamped on the
receiver's clock) on its collocation interval while the IMU-to-GPS clock offset is estimated.

Each drop's clock offset is bounded to one mesh interval around its guess, and never beyond its
plausibility limit (:func:`clock_limit_s`, 3 sigma of its prior). When a solution ends on an
interval's bound, the guess moves there, the measurements are reassigned to intervals and the fit
is redone from that solution, at most :func:`max_clock_shifts` times; a solution that ends on the
plausibility limit is held there (its ``clocks_held`` says so, and the fit's verdict names it: the
model does not fit the data, or the IMU clock is off). Held, not refused: under air twice as
rough as the error families' (benchmarks/error_families.py ``--air-factor 2``) the first fit, at
the configured error models, ran the clock to its limit on 6 of 160 drops, and a fit that stops
there leaves the user no result at all; held, the sizes from the data and the refit follow, and
the verdict and widened bands say what the model could not follow. Likewise when a fitted node
altitude has left the reach of the atmosphere-profile window its blocks were given (the GPS
altitudes the windows were placed by were off by more than the window's tolerance), the windows
are placed again by the fitted altitudes and the fit is redone from its solution, at most
MAX_PROFILE_PLACEMENTS times. With ``method = "marginal"``
the converged joint MAP solution is then moved to the marginal-likelihood estimate
(:func:`~casrecon.estimation.engine.laplace.marginal_solution`).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable

import numpy as np

from casrecon.estimation.engine.checks import FitError, check_converged, check_determined
from casrecon.estimation.engine.convergence import fit_stage, iteration_logging, nested_label
from casrecon.estimation.engine.laplace import marginal_solution
from casrecon.estimation.engine.solve import SolveResult, solve
from casrecon.estimation.kinds.gps import CLOCK
from casrecon.estimation.sixdof.drop import FitNlp
from casrecon.estimation.sixdof.settings import FitSettings

#: How many times the atmosphere-profile windows may be placed again by the fitted altitudes.
MAX_PROFILE_PLACEMENTS = 3


#: A clock offset is held at this many sigmas of its prior (its scale where it has none).
CLOCK_LIMIT_SIGMAS = 3.0


def clock_limit_s(part) -> float:
    """The plausibility limit of a drop's (a DropLayout's) IMU-to-GPS clock offset, s: CLOCK_LIMIT_SIGMAS
    times its prior sigma (its scale without a prior); beyond it the data are being bent to a model
    that does not fit them, or the clock guess is far off."""
    spec = part.params.specs[part.params.index(CLOCK)]
    return CLOCK_LIMIT_SIGMAS * (spec.prior_sigma or spec.scale)


def max_clock_shifts(fit_nlp: FitNlp) -> int:
    """How many times a clock-offset guess may move by one mesh interval: enough to cross from its
    plausibility limit on one side to the other, plus one."""
    shifts = [1]
    for part in fit_nlp.parts:
        if CLOCK in part.params.names:
            shifts.append(int(np.ceil(2 * clock_limit_s(part) / part.mesh.h)) + 1)
    return max(shifts)


def solve_fit(build: Callable[[dict[str, float], dict[str, np.ndarray]], FitNlp], start: Callable[[FitNlp], np.ndarray],
              guesses: dict[str, float], settings: FitSettings) -> tuple[FitNlp, SolveResult, float]:
    """Build and solve, keeping every receiver-clock measurement on its collocation interval and
    every node within the reach of its atmosphere-profile window.

    Parameters
    ----------
    build : callable
        ``build(guesses, altitudes) -> FitNlp`` for clock-offset guesses by drop name (s) and node
        altitude guesses by drop name (m MSL; a drop not named places its profile windows by its GPS).
    start : callable
        ``start(fit_nlp) -> z0``, the scaled initial guess.
    guesses : dict
        Initial clock-offset guess of each drop (s); not modified.
    settings : FitSettings

    Returns
    -------
    (FitNlp, SolveResult, build seconds)
    """
    guesses, altitudes, z, build_s, attempt, limit, placements = dict(guesses), {}, None, 0.0, 0, 1, 0
    earlier: list[SolveResult] = []  # the solves before a clock shift or a new placement
    previous: FitNlp | None = None
    while attempt <= limit:
        t = time.perf_counter()
        fit_nlp = build(guesses, altitudes)
        nlp = fit_nlp.nlp
        build_s += time.perf_counter() - t
        limit = max_clock_shifts(fit_nlp)
        z0 = start(fit_nlp) if z is None else transferred(previous, fit_nlp, z)
        for part in fit_nlp.parts:
            if CLOCK in part.params.names:
                i = part.params.index(CLOCK)
                z0[part.theta_cols[i]] = part.guess_clock_s / part.params.scales[i]
        if attempt == 0 and previous is None:
            check_determined(nlp, z0)
        bounds = clock_bounds(fit_nlp.parts, nlp.n_z)
        again = ([f"clock-offset shift {attempt}"] if attempt else []) + (
            [f"profile windows placed again {placements}"] if placements else [])
        with iteration_logging(label=nested_label(", ".join(again)) if again else None), \
                fit_stage("solving again from the last solution" if again else "solving"):
            sol = solve(nlp, z0, linear_solver=settings.linear_solver, max_iter=settings.max_iter,
                        tol=settings.tol, print_level=settings.print_level, bounds=bounds, method=settings.solver,
                        decrement_tol=settings.decrement_tol)
        build_s += sol.build_s
        check_converged(sol, nlp)
        previous, z = fit_nlp, sol.z
        at_bound = clocks_at_bound(sol, fit_nlp, bounds)
        held = {name: v for name, v in at_bound.items() if at_limit(fit_nlp, name, v)}
        moved = {name: v for name, v in at_bound.items() if name not in held}
        if moved:
            earlier.append(sol)
            guesses.update(moved)
            attempt += 1
            continue
        stray = [(part, why) for part in fit_nlp.parts if (why := part.profile_window_violation(sol.z)) is not None]
        if stray:
            if placements == MAX_PROFILE_PLACEMENTS:
                raise FitError(stray[0][1])
            earlier.append(sol)
            altitudes.update({part.name: part.profile_altitudes(sol.z) for part, _ in stray})
            placements += 1
            continue
        sol = dataclasses.replace(with_earlier(sol, earlier), profile_placements=placements,
                                  clocks_held=tuple(held.items()))
        if settings.method == "marginal":
            sol = marginal_solution(nlp, sol, bounds)
        return fit_nlp, sol, build_s
    raise FitError(f"the IMU-to-GPS clock offset kept reaching its bound after {limit} shifts "
                   f"({', '.join(f'{k} {v:+.3f} s' for k, v in moved.items())}); give [estimation] "
                   "clock_offset_guess_s")


def transferred(old: FitNlp, new: FitNlp, z_old: np.ndarray) -> np.ndarray:
    """The solution ``z_old`` of ``old`` as a starting point of ``new``, the same drops rebuilt for
    another clock-offset guess or profile placement: node states, parameters, disturbances and
    extra unknowns copied column for column, atmosphere-profile coefficients level by level (a
    level new to the grid starts at zero)."""
    z = np.zeros(new.nlp.n_z)
    for a, b in zip(old.parts, new.parts, strict=True):
        z[b.node_cols] = z_old[a.node_cols]
        z[b.theta_cols] = z_old[a.theta_cols]
        z[b.u_all_cols] = z_old[a.u_all_cols]
        for extra in b.extras:
            source = a.extra(extra.name)
            if extra.name == "profile":
                to, frm = b.profile.common_columns(extra.offset, a.profile, source.offset)
                z[to] = z_old[frm]
            elif source is not None and source.count == extra.count:
                z[extra.cols] = z_old[source.cols]
    return z


def with_earlier(sol: SolveResult, earlier: list[SolveResult]) -> SolveResult:
    """``sol`` with the iterations and times of the solves before it (clock shifts) added, so the
    report counts every iteration the fit took."""
    if not earlier:
        return sol
    return dataclasses.replace(sol, iterations=sol.iterations + sum(s.iterations for s in earlier),
                               solve_s=sol.solve_s + sum(s.solve_s for s in earlier),
                               evaluation_s=sol.evaluation_s + sum(s.evaluation_s for s in earlier),
                               stop_test_s=sol.stop_test_s + sum(s.stop_test_s for s in earlier),
                               linear_algebra_s=sol.linear_algebra_s + sum(s.linear_algebra_s for s in earlier))


def clock_bounds(parts, n_z: int) -> tuple[np.ndarray, np.ndarray]:
    """Scaled bounds on a decision vector of ``n_z`` entries: the clock offset of each drop of
    ``parts`` (DropLayouts) within one mesh interval of its guess (so every GPS fix stays on its
    collocation interval) and within its plausibility limit (:func:`clock_limit_s`; not where the
    guess itself lies beyond it: a clock guess given by the user); everything else free."""
    lbx, ubx = np.full(n_z, -np.inf), np.full(n_z, np.inf)
    for part in parts:
        if CLOCK in part.params.names:
            i = part.params.index(CLOCK)
            guess, limit = part.guess_clock_s, clock_limit_s(part)
            low, high = guess - part.mesh.h, guess + part.mesh.h
            if abs(guess) < limit:
                low, high = max(low, -limit), min(high, limit)
            col, scale = part.theta_cols[i], part.params.scales[i]
            lbx[col], ubx[col] = low / scale, high / scale
    return lbx, ubx


def at_limit(fit_nlp: FitNlp, name: str, clock_s: float) -> bool:
    """Whether drop ``name``'s clock offset ``clock_s`` (s, on a bound) is on its plausibility limit."""
    part = next(p for p in fit_nlp.parts if p.name == name)
    limit = clock_limit_s(part)
    return bool(abs(part.guess_clock_s) < limit <= abs(clock_s) * (1.0 + 1e-3))


def held_clock_text(part, clock_s: float) -> str:
    """The verdict's finding on a drop's (a DropLayout's) clock offset ``clock_s`` (s) held at its
    plausibility limit."""
    return (f"{part.name}: the IMU-to-GPS clock offset is held at {clock_s:+.3f} s, its plausibility limit "
            f"({CLOCK_LIMIT_SIGMAS:g} sigma of its prior, {clock_limit_s(part):.3f} s), and the data ask for more: "
            "the model probably does not fit the data (forces it does not have: gusts, air rougher than the "
            "profile grid, a sounding of another place or altitude), or the IMU clock is off ([sensors.imu.clock] "
            "utc_at_zero; "
            "give [estimation] clock_offset_guess_s if the offset is known to be large)")


def clocks_at_bound(sol: SolveResult, fit_nlp: FitNlp, bounds) -> dict[str, float]:
    """{drop: clock offset (s)} of the drops whose clock offset ended on its bound."""
    moved = {}
    for part in fit_nlp.parts:
        if CLOCK not in part.params.names:
            continue
        i = part.params.index(CLOCK)
        col = part.theta_cols[i]
        width = bounds[1][col] - bounds[0][col]
        if min(sol.z[col] - bounds[0][col], bounds[1][col] - sol.z[col]) < 1e-4 * width:
            moved[part.name] = float(sol.z[col] * part.params.scales[i])
    return moved


