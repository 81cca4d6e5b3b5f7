"""Model-adequacy verdict: can a fit's 3-sigma bands be trusted? (pure numpy/scipy)

A fit's sigmas are right only while its model is: white noise with the stated sigmas, the
priors' Gaussians, the vehicle and site as given. After a fit that is tested, family-wise:

- per residual channel (each IMU axis, each GPS component, the barometer), on the residuals
  divided by their sigma: the reduced chi-square against its two-sided interval (chi-square with
  n degrees of freedom over n), and whiteness by the Ljung-Box test over
  :func:`~casrecon.analysis.adequacy_tests.ljung_box_lags`
  lags (Q = n (n + 2) sum_k rho_k^2 / (n - k) against chi-square(lags)), the lag-1
  autocorrelation reported with it;
- the priors: each parameter's z = (estimate - prior mean) / prior sigma (all priors are
  zero-mean), and the NEES of the prior deviations u = D0^-1 theta_hat against chi-square. Under
  the model u ~ N(0, S) with S = I - D0^-1 P D0^-1 (prior minus posterior covariance, in prior
  units), so NEES = u^T S^+ u on the directions the data inform (eigenvalues of S above
  :data:`~casrecon.analysis.adequacy_tests.INFORMED`), with as many degrees of freedom;
- the ground: where the fit says the vehicle was at the detected impact (or lowest), against the
  site's ground altitude (:class:`GroundCheck`, made by the caller).

Every test runs at alpha / (number of tests) (Bonferroni, :data:`FAMILY_ALPHA` = 1 % in all), so
a fit of an exact model is declared trusted with probability at least 99 % (the ground check is a
tolerance, not a probability, and is not counted). Parameters beyond 3 sigma of their prior are
always named; they fail the verdict beyond the family-wise limit.

A reduced chi-square *below* its interval does not fail the verdict: residuals smaller than their
sigmas make the bands wider than the data need, not narrower. Such a channel is a caution
(:attr:`Adequacy.cautions`) and the line says the bands are conservative.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field

import numpy as np

from casrecon.analysis.adequacy_tests import (
    ChannelTest,
    PriorDeviation,
    PriorNees,
    channel_test,
    prior_nees,
    two_sided_z,
)
from casrecon.analysis.process_scale import ProcessPrior, ProcessScale, process_findings, process_scale

#: Family-wise false-alarm probability of the verdict on an exact model.
FAMILY_ALPHA = 0.01
#: Parameters at least this many prior sigmas from their prior mean are named in the report.
NAMED_Z = 3.0
@dataclass(frozen=True)
class GroundCheck:
    """Where the fit puts the vehicle against the site's ground.

    Attributes
    ----------
    what : str
        ``"impact"`` (height above ground at the detected impact), ``"measured impact"`` (the same
        where the impact was a measurement of altitude: above the measured ground) or ``"lowest"``
        (lowest point of a track that ends in the air).
    h_agl_m : float
        That height above the site's (or the measured) ground altitude, m.
    limit_m : float
        Largest magnitude accepted (the impacts) or deepest accepted below ground (``"lowest"``), m.
    explanation : str
        How ``h_agl_m`` and ``limit_m`` were obtained.
    """

    what: str
    h_agl_m: float
    limit_m: float
    explanation: str

    @property
    def ok(self) -> bool:
        if self.what in ("impact", "measured impact"):
            return bool(abs(self.h_agl_m) <= self.limit_m)
        return bool(self.h_agl_m >= -self.limit_m)


def p_text(p: float) -> str:
    """A p-value for a report line (``p<1e-10`` below 1e-10)."""
    return "p<1e-10" if p < 1e-10 else f"p={p:.2g}"


@dataclass(frozen=True)
class Adequacy:
    """The model-adequacy verdict of one fit (see the module docstring).

    Attributes
    ----------
    trusted : bool
        Whether every test passed.
    line : str
        One line: ``"bands can be trusted: ..."`` or ``"bands NOT to be trusted: <reasons>"``.
    reasons : tuple of str
        Each failed test, worst first within its kind.
    channels : tuple of ChannelTest
    deviations : tuple of PriorDeviation
        Parameters at least :data:`NAMED_Z` prior sigmas from their prior mean.
    z_limit : float
        |z| beyond which a parameter fails the verdict (family-wise).
    nees : PriorNees or None
    ground : GroundCheck or None
    alpha : float
        Family-wise level.
    n_tests : int
        Tests it is shared among (2 per channel, the NEES, one per prior, one per prior process).
    notes : tuple of str
        What was not tested and why.
    cautions : tuple of str
        Channels whose residuals are smaller than their sigmas (reduced chi-square below its
        interval): those sigmas are pessimistic, the bands wider than the data need. Under the
        fit's model that can happen only by chance (at the per-test level's lower half) or where the
        fit's own unknowns absorb a channel; neither makes a band too narrow, so a caution does not
        fail the verdict. A prior process smaller than its prior is a caution too.
    processes : tuple of ProcessScale
        The size tests of the prior processes (the atmosphere-profile corrections, when fitted).
    """

    trusted: bool
    line: str
    reasons: tuple[str, ...]
    channels: tuple[ChannelTest, ...]
    deviations: tuple[PriorDeviation, ...]
    z_limit: float
    nees: PriorNees | None
    ground: GroundCheck | None
    alpha: float
    n_tests: int
    notes: tuple[str, ...] = field(default=())
    cautions: tuple[str, ...] = field(default=())
    processes: tuple[ProcessScale, ...] = field(default=())

    def channel(self, name: str) -> ChannelTest:
        """The test of channel ``name`` (KeyError listing the channels)."""
        for c in self.channels:
            if c.name == name:
                return c
        raise KeyError(f"no channel {name!r}; channels: {', '.join(c.name for c in self.channels)}")

    def to_dict(self) -> dict:
        """JSON-ready content (``summary.json`` ``adequacy``); :meth:`from_dict` reads it back."""
        doc = asdict(self)
        doc["channels"] = [asdict(c) for c in self.channels]
        doc["per_test_alpha"] = self.alpha / max(self.n_tests, 1)
        return doc

    @classmethod
    def from_dict(cls, doc: dict) -> Adequacy:
        """Read :meth:`to_dict` content back."""
        chans = tuple(ChannelTest(**{**c, "chi2_interval": tuple(c["chi2_interval"])}) for c in doc["channels"])
        nees = doc.get("nees")
        ground = doc.get("ground")
        return cls(trusted=bool(doc["trusted"]), line=str(doc["line"]), reasons=tuple(doc["reasons"]),
                   channels=chans, deviations=tuple(PriorDeviation(**d) for d in doc["deviations"]),
                   z_limit=float(doc["z_limit"]),
                   nees=PriorNees(**{**nees, "interval": tuple(nees["interval"])}) if nees else None,
                   ground=GroundCheck(**ground) if ground else None, alpha=float(doc["alpha"]),
                   n_tests=int(doc["n_tests"]), notes=tuple(doc.get("notes", ())),
                   cautions=tuple(doc.get("cautions", ())),
                   processes=tuple(ProcessScale.from_dict(p) for p in doc.get("processes", ())))


@dataclass(frozen=True)
class IndependentCheck:
    """A quantity of the fit measured again without its model, as one test of the verdict.

    Attributes
    ----------
    name : str
        What is compared (the report's words).
    z : float
        The fit's value less the independent one, over the sigma of that difference.
    text : str
        Both values with their sigmas and units, for the report.
    """

    name: str
    z: float
    text: str


#: Why a kind of failure matters, appended once to the verdict line.
HINTS = {
    "gps_correlated": "real GPS errors are time-correlated (FlySight: lag-1 0.8 to 1.0) and the fit assumes white "
                      "noise, so its sigmas and bands are too narrow",
    "gps_model": "the GPS residuals stay correlated under the fit's GPS error model: the motion model misses "
                 "something the GPS saw (on a skydiving track, the body's own manoeuvres), or the error model "
                 "does not describe this receiver ([sensors.gps] / [gps] *_error_time_s, *_correlated_fraction)",
    "prior": "an input (mass, aero database, IMU mounting, sounding or atmosphere) or a prior is wrong: the fit "
             "moved parameters far to make up for it",
    "ground": "the site's ground altitude or the GPS height is wrong, or the IMU clock ([sensors.imu.clock] "
              "utc_at_zero): a clock error moves the impact along the descent; with the impact as a measurement "
              "([estimation] impact_ground_sigma_m), also the fit's altitude held where the sounding's wind "
              "structure lets the trajectory sit, off where the air differs from the sounding",
    "independent": "forces the flight model does not have (gusts, air rougher than the atmosphere profile) were "
                   "traded against a parameter that the data measure without the model",
    "pessimistic": "those sigmas are pessimistic for these data (a receiver's accuracy estimate, a noise figure "
                   "given as an upper bound, a GPS error model whose white part is larger than the receiver's), so "
                   "these channels weigh too little and the bands are wider than the data need",
}
#: Items of one kind named in the verdict line before "+N more".
LINE_ITEMS = 3


def _some(items: list[str]) -> str:
    more = len(items) - LINE_ITEMS
    return ", ".join(items[:LINE_ITEMS]) + (f", +{more} more" if more > 0 else "")


def _findings(tests: list[ChannelTest], deviations: tuple[PriorDeviation, ...], z_limit: float,
              nees: PriorNees | None, ground: GroundCheck | None) -> tuple[list[str], list[str], set[str]]:
    """Every failed test (``reasons``), the same condensed for the verdict line, and their kinds."""
    reasons, line, kinds = [], [], set()
    correlated = sorted((c for c in tests if not c.white), key=lambda c: (c.ljung_box_p, -abs(c.lag1)))
    reasons += [f"{c.name} residuals correlated (lag-1 {c.lag1:.2f}, Ljung-Box {p_text(c.ljung_box_p)})"
                for c in correlated]
    if correlated:
        lag1 = [c.lag1 for c in correlated]
        worst_p = max(c.ljung_box_p for c in correlated)
        lags = f"{lag1[0]:.2f}" if len(lag1) == 1 else f"{min(lag1):.2f} to {max(lag1):.2f}"
        line.append(f"{_some([c.name for c in correlated])} residuals correlated (lag-1 {lags}, Ljung-Box "
                    f"{p_text(worst_p) if len(lag1) == 1 or worst_p < 1e-10 else f'p<={worst_p:.2g}'})")
        if all(c.name.startswith("GPS") for c in correlated):
            kinds.add("gps_correlated")
    off = sorted((c for c in tests if c.above), key=lambda c: -c.reduced_chi2)
    reasons += [f"{c.name} reduced chi-square {c.reduced_chi2:.3g} above [{c.chi2_interval[0]:.3g}, "
                f"{c.chi2_interval[1]:.3g}]" for c in off]
    if off:
        line.append("reduced chi-square above its interval: " + _some([f"{c.name} {c.reduced_chi2:.3g}" for c in off]))
    far = [d for d in deviations if abs(d.z) > z_limit]
    reasons += [f"{d.name} {d.z:+.1f} sigma from its prior" for d in far]
    if far:
        line.append(_some([f"{d.name} {d.z:+.1f}" for d in far]) + " sigma from the prior")
        kinds.add("prior")
    if nees is not None and nees.too_large:
        text = f"prior NEES {nees.nees:.1f} above [{nees.interval[0]:.1f}, {nees.interval[1]:.1f}] ({nees.dof} dof)"
        reasons.append(text)
        line.append(text)
        kinds.add("prior")
    if ground is not None and not ground.ok:
        where = "above" if ground.h_agl_m > 0 else "below"
        measured = ground.what == "measured impact"
        whose, digits = ("measured", 1) if measured else ("site's", 0)
        text = (f"{'track' if ground.what == 'lowest' else 'impact'} {abs(ground.h_agl_m):.{digits}f} m {where} the "
                f"{whose} ground (limit {ground.limit_m:.{digits}f} m)")
        reasons.append(text)
        line.append(text)
        kinds.add("ground")
    return reasons, line, kinds


def _small_scale(tests: list[ChannelTest]) -> tuple[list[str], str]:
    """Channels whose reduced chi-square is below its interval: each as a caution, and the clause
    of the verdict line that names them ("" when there are none)."""
    low = sorted((c for c in tests if c.below), key=lambda c: c.reduced_chi2)
    cautions = [f"{c.name} reduced chi-square {c.reduced_chi2:.3g} below [{c.chi2_interval[0]:.3g}, "
                f"{c.chi2_interval[1]:.3g}]" for c in low]
    if not low:
        return cautions, ""
    return cautions, ("residuals smaller than their sigmas: " + _some([f"{c.name} {c.reduced_chi2:.3g}" for c in low])
                      + f" ({HINTS['pessimistic']})")


def assess(channels: dict[str, np.ndarray], prior_names: list[str], values: np.ndarray, prior_sigma: np.ndarray,
           posterior_cov: np.ndarray, units: list[str] | None = None, ground: GroundCheck | None = None,
           alpha: float = FAMILY_ALPHA, notes: tuple[str, ...] = (), gps_model: bool = False,
           prior_hint: str = HINTS["prior"], processes: tuple[ProcessPrior, ...] = (),
           gross: tuple[str, ...] = (), checks: tuple[IndependentCheck, ...] = ()) -> Adequacy:
    """The verdict of one fit.

    Parameters
    ----------
    channels : dict of str to ndarray
        Channel name -> residuals divided by their sigma (NaN where there is no sample), in time order. A
        channel without any sample (a component the GPS file does not give) is not tested or counted.
    prior_names : list of str
        Parameters with a (zero-mean) prior.
    values, prior_sigma : ndarray
        Their estimates and prior 1-sigma (same units each).
    posterior_cov : ndarray
        Their posterior covariance (same units).
    units : list of str, optional
        Their units, for the report.
    ground : GroundCheck, optional
    alpha : float
        Family-wise level.
    notes : tuple of str
        Carried to :attr:`Adequacy.notes`.
    gps_model : bool
        Whether the GPS channels were whitened under a GPS error model (changes the hint given
        when only they are correlated).
    prior_hint : str
        Why parameters far from their priors matter, for this kind of fit (default: the dynamic
        fit's inputs).
    processes : tuple of ProcessPrior
        Prior processes whose size is tested (:mod:`casrecon.analysis.process_scale`).
    gross : tuple of str
        Gross errors found before the verdict, each with its likely cause (an error-model estimate
        beyond :mod:`casrecon.estimation.error_models.plausibility`'s limits): each fails it, first
        in the line. Not counted among the tests (a limit, not a probability).
    checks : tuple of IndependentCheck
        Quantities of the fit measured again without its model: each one test, failed beyond the
        family-wise z limit.

    Returns
    -------
    Adequacy
    """
    n_priors = len(prior_names)
    channels = {name: r for name, r in channels.items() if np.isfinite(np.asarray(r, dtype=float)).any()}
    n_tests = 2 * len(channels) + (1 if n_priors else 0) + n_priors + len(processes) + len(checks)
    a = alpha / max(n_tests, 1)
    tests = [channel_test(name, r, a) for name, r in channels.items()]
    scales = tuple(process_scale(p, a) for p in processes)
    values, prior_sigma = np.asarray(values, dtype=float), np.asarray(prior_sigma, dtype=float)
    z = values / prior_sigma if n_priors else np.zeros(0)
    z_limit = two_sided_z(a)
    units = units or ["-"] * n_priors
    deviations = tuple(PriorDeviation(prior_names[i], float(values[i]), float(prior_sigma[i]), float(z[i]), units[i])
                       for i in np.argsort(-np.abs(z)) if abs(z[i]) >= NAMED_Z)
    nees = prior_nees(values, prior_sigma, posterior_cov, a) if n_priors else None
    reasons, items, kinds = _findings(tests, deviations, z_limit, nees, ground)
    cautions, small = _small_scale(tests)
    process_reasons, process_items, process_cautions, process_small = process_findings(scales)
    reasons, items, cautions = reasons + process_reasons, items + process_items, cautions + process_cautions
    failed = [f"{c.name}: {c.text}, {c.z:+.1f} sigma apart" for c in checks if abs(c.z) > z_limit]
    if failed:
        reasons, items, kinds = reasons + failed, items + failed, kinds | {"independent"}
    if gross:
        reasons, items = list(gross) + reasons, ["gross input error: " + "; ".join(gross)] + items
    small = "; ".join(([small] if small else []) + process_small)
    if not reasons:
        named = [f"{d.name} {d.z:+.1f} sigma" for d in deviations]
        extra = f"; {', '.join(named)} from its prior, within the family-wise {z_limit:.2f}" if named else ""
        if small:
            line = (f"bands can be trusted, and are conservative: {small}; the other tests passed at a family-wise "
                    f"{100 * alpha:g} %{extra}")
        else:
            line = (f"bands can be trusted: all {n_tests} tests passed at a family-wise {100 * alpha:g} % "
                    f"(residuals white and at their sigmas, priors consistent){extra}")
    else:
        line = "bands NOT to be trusted: " + "; ".join(items)
        if gps_model and "gps_correlated" in kinds:
            kinds = (kinds - {"gps_correlated"}) | {"gps_model"}
        hints = [prior_hint if k == "prior" else HINTS[k]
                 for k in ("gps_correlated", "gps_model", "prior", "ground", "independent") if k in kinds]
        if hints:
            line += " (" + "; ".join(hints) + ")"
        if small:
            line += f"; also {small}"
    return Adequacy(not reasons, line, tuple(reasons), tuple(tests), deviations, z_limit, nees, ground, alpha, n_tests,
                    tuple(notes), tuple(cautions), scales)
