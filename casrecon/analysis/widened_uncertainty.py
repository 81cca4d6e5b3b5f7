"""Sigmas and bands widened for errors the fit's models do not contain (issue 49).

When the model-adequacy verdict does not trust a fit, or the time-block sandwich below exceeds what
the noise model expects (at p < :data:`P_WIDEN`), the fit's covariance (which takes the noise model
as true) is too narrow for what the data show. :func:`widened_result` adds to it the part of the
time-block sandwich that exceeds its expectation under the model
(:mod:`casrecon.estimation.engine.block_sandwich`): the residual rows of every measurement and
process prior are cut into blocks of :data:`BLOCK_S` seconds (:mod:`casrecon.estimation.sixdof.row_times`),
and joined into blocks of 2 and 4 s; what each block's residuals do to the estimate beyond what
white errors of the stated sizes would do widens the parameters' sigmas and the trajectory bands
(the widened covariance covers each block length's). The estimates themselves do not change. The
1 s block was chosen on the selection seed of the error-family study (seed 100: 1 s against 0.5
and 2 s alone), the union with 2 and 4 s after the first fresh seeds (200, 201) showed errors
correlated over longer than 1 s still missed (docs/studies/error-families.md).
"""

from __future__ import annotations

import dataclasses
import time
from dataclasses import dataclass

import numpy as np

from casrecon.estimation.engine.block_sandwich import BlockSandwich, block_sandwiches, covering
from casrecon.estimation.engine.covariance import Covariance
from casrecon.estimation.sixdof.bands import trajectory_with_bands
from casrecon.estimation.sixdof.row_times import residual_row_times, time_blocks

#: Length of the sandwich's shortest time blocks, s.
BLOCK_S = 1.0
#: The block lengths used, in shortest blocks (1, 2 and 4 s): the widened covariance covers each
#: one's (errors correlated over longer than a block are seen only in part by it).
MERGES = (1, 2, 4)
#: A trusted fit is widened too when its sandwich's trace exceeds the model's at this p-value.
P_WIDEN = 0.01


@dataclass(frozen=True)
class Widening:
    """How a fit's uncertainty was widened.

    Attributes
    ----------
    block_s : float
        Shortest block length, s.
    n_blocks : int
        Shortest blocks with residual rows.
    excess : float
        Mean excess of the sandwich over its expectation under the model, in units of the model
        covariance (about 0 for a right model); the largest over the block lengths.
    sigma_factor : (n_params,) array
        Widened over model 1-sigma, per estimated parameter.
    band_factor_median, band_factor_max : float
        Widened over model 1-sigma of the trajectory bands (every column and node).
    p_value : float
        The sandwich traces' p-value under the model, the smallest over the block lengths times
        their number (see
        :class:`~casrecon.estimation.engine.block_sandwich.BlockSandwich`).
    reason : str
        Why it was widened.
    """

    block_s: float
    n_blocks: int
    excess: float
    sigma_factor: np.ndarray
    band_factor_median: float
    band_factor_max: float
    p_value: float
    reason: str

    def text(self, names: tuple[str, ...]) -> str:
        """The report's line."""
        k = int(np.argmax(self.sigma_factor))
        return (f"uncertainty widened for errors the model does not contain ({self.reason}): the time-block "
                f"sandwich ({self.n_blocks} blocks of {self.block_s:g} s of every residual, and of "
                f"{', '.join(f'{m * self.block_s:g}' for m in MERGES[1:])} s) exceeds what the "
                f"noise model expects by {self.excess:.2f} of the model covariance on average "
                f"(p = {self.p_value:.2g}); "
                f"parameter sigmas x{np.min(self.sigma_factor):.2f} to x{self.sigma_factor[k]:.2f} ({names[k]}), "
                f"trajectory bands x{self.band_factor_median:.2f} (median) to x{self.band_factor_max:.2f}. "
                "The estimates are the fit's; the sigmas, bands and correlations reported are the widened ones")


def widening_refused(result) -> str | None:
    """Why ``result``'s uncertainty cannot be widened (None when it can)."""
    if not isinstance(result.covariance, Covariance):
        return "a fit with disturbance states (its covariance comes from the whole KKT matrix)"
    if result.fit_nlp is not None and len(result.fit_nlp.parts) > 1:
        return "a drop of a joint fit"
    return None


def sandwich_of(result, block_s: float = BLOCK_S) -> list[BlockSandwich]:
    """The time-block sandwiches of a per-drop fit (:func:`widening_refused` None), blocks of
    ``block_s`` s times each of :data:`MERGES`."""
    cov, part = result.covariance, result.part
    jr = result.nlp.derivatives.jacobian_r(result.z)
    times = residual_row_times(jr, part.node_cols.reshape(-1, part.n_states), part.mesh.t_nodes)
    return block_sandwiches(jr, cov.basis, cov.cov_w, result.residuals, time_blocks(times, block_s), MERGES)


def p_value(sandwiches: list[BlockSandwich]) -> float:
    """The smallest of the block lengths' p-values, Bonferroni-corrected for their number."""
    return min(1.0, len(sandwiches) * min(sw.p_value for sw in sandwiches))


def widened_result(result, block_s: float = BLOCK_S, sandwiches: list[BlockSandwich] | None = None,
                   reason: str = "asked for"):
    """``result`` (a per-drop :class:`~casrecon.estimation.sixdof.fit.FitResult`) with its
    covariance, parameter sigmas, correlations and trajectory bands widened by the time-block
    sandwiches (``sandwiches``: already computed with ``block_s``; the widened covariance covers
    each block length's), and a note saying by how much and why (``reason``); with the :class:`Widening`.

    Raises
    ------
    ValueError
        The fit's covariance cannot be widened (:func:`widening_refused` says why).
    """
    refused = widening_refused(result)
    if refused is not None:
        raise ValueError(f"uncertainty not widened: {refused}")
    t0 = time.perf_counter()
    cov, part = result.covariance, result.part
    if sandwiches is None:
        sandwiches = sandwich_of(result, block_s)
    widened = dataclasses.replace(cov, cov_w=covering(cov.cov_w, [cov.cov_w + sw.extra_w for sw in sandwiches]))
    cov_theta = widened.covariance_of(part.theta_cols, part.params.scales)
    sigma = np.sqrt(np.diag(cov_theta))
    _, table_sigma = trajectory_with_bands(result.scenario.model, part, result.z, widened)
    ratio = table_sigma / result.table_sigma
    ratio = ratio[np.isfinite(ratio)]
    widening = Widening(block_s, sandwiches[0].n_blocks, max(sw.excess for sw in sandwiches), sigma / result.sigma,
                        float(np.median(ratio)) if ratio.size else 1.0, float(np.max(ratio)) if ratio.size else 1.0,
                        p_value(sandwiches), reason)
    timings = dict(result.timings)
    timings["widening_s"] = time.perf_counter() - t0
    return dataclasses.replace(result, covariance=widened, sigma=sigma, correlation=cov_theta / np.outer(sigma, sigma),
                               table_sigma=table_sigma, timings=timings, uncertainty="widened",
                               notes=result.notes + (widening.text(result.params.names),)), widening


def published_result(result, trusted: bool):
    """The result a fit publishes (with a note on its time-block sandwich): widened
    (:func:`widened_result`) when the verdict does not trust it (``trusted`` False) or its sandwich
    exceeds the model's at p < :data:`P_WIDEN`, else ``result``'s own sigmas; a fit whose
    covariance cannot be widened says why when it should have been. Returns (result, Widening or
    None)."""
    refused = widening_refused(result)
    if refused is not None:
        if trusted:
            return result, None
        return dataclasses.replace(result, notes=result.notes + (
            f"uncertainty not widened although the verdict does not trust the fit: {refused}",)), None
    t0 = time.perf_counter()
    sandwiches = sandwich_of(result)
    p = p_value(sandwiches)
    if trusted and not p < P_WIDEN:
        timings = dict(result.timings)
        timings["widening_s"] = time.perf_counter() - t0
        return dataclasses.replace(result, timings=timings, notes=result.notes + (
            f"time-block sandwich ({sandwiches[0].n_blocks} blocks of {BLOCK_S:g} s of every residual, and of "
            f"{', '.join(f'{m * BLOCK_S:g}' for m in MERGES[1:])} s): consistent with the noise model (p = {p:.2f}); "
            "the sigmas are the fit's",)), None
    reason = ("the verdict does not trust the fit" if not trusted else
              f"the verdict trusts the fit, but the sandwich exceeds the model's at p < {P_WIDEN:g}")
    return widened_result(result, sandwiches=sandwiches, reason=reason)
