"""Is a prior process the size the fit assumes? The test of a Gauss-Markov prior on many unknowns
(an atmosphere-profile correction at every 10 m of altitude) that the model-adequacy verdict
(:mod:`casrecon.analysis.adequacy`) makes beside its residual channels.

A process with n values has the exactly whitened prior u = W g ~ N(0, I) (``W`` the prior's
residual rows, g the unknowns); after the fit its whitened residuals are u_hat = W g_hat and the
posterior covariance of u is M = W P W^T. Under the fit's model E[u_hat u_hat^T] = I - M (prior
minus posterior, the law of total variance), so:

- the size test: the NEES of u_hat on the directions the data inform, u_hat^T S^+ u_hat with
  S = I - M (eigenvalues above :data:`~casrecon.analysis.adequacy_tests.INFORMED`), against chi-square
  with as many degrees of freedom, as the parameters' prior NEES is made. Above its interval the
  process is larger than the prior says and the bands are too narrow (a failure); below it, smaller
  (a caution: the bands are wider than the data need);
- the size the data say: sigma_hat = sigma sqrt(|u_hat|^2 / gamma), gamma = n - tr M = tr S the
  number of values the data determine (MacKay's fixed-point update of a prior variance, one step
  from the fit's sigma: the type-II maximum-likelihood estimate's fixed point, not the converged
  estimate). Measured on the shipped drops (docs/design.md, Model adequacy): 0.96, 1.10 and 0.97
  times the truth's 0.5 m/s, 0.5 m/s and 0.5 % on ``ees-drop-3-model-error``; 0.08, 0.11 and 0.41
  times the assumed on ``ees-drop-1``, which flies its sounding exactly.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np


@dataclass(frozen=True)
class ProcessScale:
    """The size test of one prior process (see the module docstring).

    Attributes
    ----------
    name : str
        E.g. ``"profile wind n"``.
    unit : str
        Unit of the sigmas (``"m/s"``, ``"%"``).
    assumed_sigma : float
        The prior's 1-sigma, in ``unit``.
    estimated_sigma : float
        The size the data say, sigma sqrt(chi2 / informed), in ``unit``.
    n : int
        Process values (whitened prior residuals).
    chi2 : float
        |u_hat|^2, -.
    informed : float
        gamma = n - tr(W P W^T): how many of the values the data determine, -.
    nees : float
        u_hat^T S^+ u_hat on the informed directions, -.
    dof : int
        Informed directions.
    interval : tuple of float
        Two-sided chi-square(dof) interval at the per-test level.
    """

    name: str
    unit: str
    assumed_sigma: float
    estimated_sigma: float
    n: int
    chi2: float
    informed: float
    nees: float
    dof: int
    interval: tuple[float, float]

    @property
    def too_large(self) -> bool:
        """The process is larger than its prior: the bands are too narrow."""
        return bool(self.dof and self.nees > self.interval[1])

    @property
    def too_small(self) -> bool:
        """The process is smaller than its prior: the bands are wider than the data need."""
        return bool(self.dof and self.nees < self.interval[0])

    def to_dict(self) -> dict:
        return asdict(self)

    @classmethod
    def from_dict(cls, doc: dict) -> ProcessScale:
        return cls(**{**doc, "interval": tuple(doc["interval"])})

    def summary(self) -> str:
        """``name about 0.04 m/s against the assumed 0.5 m/s``."""
        return (f"{self.name} about {self.estimated_sigma:.2g} {self.unit} against the assumed "
                f"{self.assumed_sigma:.2g} {self.unit}")


@dataclass(frozen=True)
class ProcessPrior:
    """One prior process after a fit, what :func:`process_scale` tests.

    Attributes
    ----------
    name, unit : str
    sigma : float
        The prior's 1-sigma, in ``unit``.
    whitened : ndarray (n,)
        u_hat, the whitened prior residuals at the estimate.
    posterior : ndarray (n, n)
        M = W P W^T, their posterior covariance.
    """

    name: str
    unit: str
    sigma: float
    whitened: np.ndarray
    posterior: np.ndarray


def process_scale(prior: ProcessPrior, alpha: float) -> ProcessScale:
    """:class:`ProcessScale` of ``prior`` at the per-test level ``alpha``."""
    from casrecon.analysis.adequacy_tests import prior_nees

    u = np.asarray(prior.whitened, dtype=float)
    m = np.asarray(prior.posterior, dtype=float)
    nees = prior_nees(u, np.ones(u.size), m, alpha)
    chi2 = float(u @ u)
    informed = float(u.size - np.trace(m))
    ratio = chi2 / informed if informed > 0 else float("nan")
    return ProcessScale(prior.name, prior.unit, float(prior.sigma), float(prior.sigma * np.sqrt(ratio)), int(u.size),
                        chi2, informed, nees.nees, nees.dof, nees.interval)


#: Why a process larger or smaller than its prior matters, for the verdict line.
PROCESS_HINTS = {
    "large": "the air flown differs from the sounding more than [atmosphere] profile_*_sigma assumes, so the bands "
             "are too narrow: raise those sigmas to the sizes the data say",
    "small": "the air flown differs from the sounding less than [atmosphere] profile_*_sigma assumes, so the bands "
             "and aero sigmas are wider than the data need; if the sounding was taken where and when the vehicle "
             "flew, set those sigmas to the sizes the data say, or to 0",
}


def process_findings(tests: tuple[ProcessScale, ...]) -> tuple[list[str], list[str], list[str], list[str]]:
    """(reasons, verdict-line items, cautions, caution clauses) of the processes' size tests."""
    large = [t for t in tests if t.too_large]
    small = [t for t in tests if t.too_small]
    reasons = [f"{t.summary()} (NEES {t.nees:.1f} above [{t.interval[0]:.1f}, {t.interval[1]:.1f}], {t.dof} dof)"
               for t in large]
    items = [("larger than assumed: " + ", ".join(t.summary() for t in large)
              + f" ({PROCESS_HINTS['large']})")] if large else []
    cautions = [f"{t.summary()} (NEES {t.nees:.1f} below [{t.interval[0]:.1f}, {t.interval[1]:.1f}], {t.dof} dof)"
                for t in small]
    clauses = [("atmosphere profile smaller than assumed: " + ", ".join(t.summary() for t in small)
                + f" ({PROCESS_HINTS['small']})")] if small else []
    return reasons, items, cautions, clauses

