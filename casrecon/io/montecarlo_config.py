"""The optional ``[montecarlo]`` table of ``problem.toml``: the 1-sigma dispersions, the number of
cases and the seed of the dispersed Monte Carlo (``casrecon montecarlo``; its command-line options
override the table). Every key is optional; a problem without the table gets the defaults below.

Example (the defaults, except where the atmosphere's are taken from ``[atmosphere]``)::

    [montecarlo]
    cases = 1000
    seed = 0
    center = "truth"                # or "nominal"
    h_agl_sigma_m = 5.0
    velocity_sigma_mps = 1.0        # each NED component
    euler_sigma_deg = 5.0           # roll, pitch, yaw each
    rate_sigma_dps = 3.0            # p, q, r each
    aero_factor_sigma = 0.3333      # normalised factors: database 3-sigma = 1
    aero_factors = ["CA_mult", "Cmq_mult"]   # default: all
    wind_bias_sigma_mps = 0.3333    # default: [atmosphere] wind_3sigma_mps / 3
    density_factor_sigma = 0.0033   # default: [atmosphere] density_3sigma / 3
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field, replace

from casrecon.io.toml_fields import Fields
from casrecon.physics.aero import DISPERSION_NAMES


@dataclass(frozen=True)
class Dispersions:
    """1-sigma sizes of the Gaussian dispersions of one Monte Carlo case.

    Every draw is independent and zero-mean about the centre (the problem's release state and its
    truth or nominal parameters).

    Attributes
    ----------
    h_agl_m : float
        1-sigma of the release altitude above ground, m.
    velocity_mps : float
        1-sigma of each NED component of the release velocity, m/s.
    euler_deg : float
        1-sigma of each release Euler angle (roll, pitch, yaw), deg.
    rate_dps : float
        1-sigma of each body rate at release (p, q, r), deg/s.
    aero_factor : float
        1-sigma of each normalised aero dispersion factor; the factors are normalised so that the
        database 3-sigma is 1, hence the default 1/3.
    aero_factors : tuple of str
        Which aero dispersion factors are dispersed (default all); the others stay at the centre.
    wind_bias_mps : float or None
        1-sigma of the wind bias north and east, m/s; None (absent from ``[montecarlo]``) takes the problem's
        ``atmosphere.wind_3sigma_mps / 3`` (the balloon's stated 3-sigma; 1/3 m/s for the EES drops).
    density_factor : float or None
        1-sigma of the relative density error; None (absent) takes ``atmosphere.density_3sigma / 3``
        (0.01/3 for EES).
    center : {"truth", "nominal"}
        Parameters the dispersions are about: the problem's ``[truth]`` (nominal zeros where it has
        none) or the nominal database and sounding (all zeros).
    """

    h_agl_m: float = 5.0
    velocity_mps: float = 1.0
    euler_deg: float = 5.0
    rate_dps: float = 3.0
    aero_factor: float = 1.0 / 3.0
    aero_factors: tuple[str, ...] = DISPERSION_NAMES
    wind_bias_mps: float | None = None
    density_factor: float | None = None
    center: str = "truth"

    def __post_init__(self) -> None:
        for name in ("h_agl_m", "velocity_mps", "euler_deg", "rate_dps", "aero_factor", "wind_bias_mps",
                     "density_factor"):
            v = getattr(self, name)
            if v is not None and not (math.isfinite(v) and v >= 0):
                raise ValueError(f"Dispersions.{name} must be a finite 1-sigma >= 0, got {v}")
        unknown = set(self.aero_factors) - set(DISPERSION_NAMES)
        if unknown:
            raise ValueError(f"Dispersions.aero_factors: unknown factor(s) {sorted(unknown)}; "
                             f"known: {', '.join(DISPERSION_NAMES)}")
        if self.center not in ("truth", "nominal"):
            raise ValueError(f"Dispersions.center must be 'truth' or 'nominal', not {self.center!r}")

    @classmethod
    def none(cls, center: str = "truth") -> Dispersions:
        """Zero dispersions: every case is the centre (nominal) flight."""
        return cls(0.0, 0.0, 0.0, 0.0, 0.0, (), 0.0, 0.0, center)

    def resolved(self, wind_3sigma_mps: float, density_3sigma: float) -> Dispersions:
        """Copy with the atmosphere sizes taken from the problem where they are None."""
        return replace(self,
                       wind_bias_mps=wind_3sigma_mps / 3.0 if self.wind_bias_mps is None else self.wind_bias_mps,
                       density_factor=density_3sigma / 3.0 if self.density_factor is None else self.density_factor)

    def to_dict(self) -> dict:
        d = asdict(self)
        d["aero_factors"] = list(self.aero_factors)
        return d


@dataclass(frozen=True)
class MonteCarloConfig:
    """The ``[montecarlo]`` table: defaults of ``casrecon montecarlo`` for this problem.

    Attributes
    ----------
    cases : int
        Number of dispersed cases (``--cases`` overrides it).
    seed : int
        Case i draws from the random stream (seed, i) (``--seed`` overrides it).
    dispersions : Dispersions
        The 1-sigma dispersions (``--center`` overrides their centre).
    """

    cases: int = 1000
    seed: int = 0
    dispersions: Dispersions = field(default_factory=Dispersions)


#: TOML key of each :class:`Dispersions` field (1-sigma sizes say so in the key; units as suffix).
DISPERSION_KEYS = {"h_agl_sigma_m": "h_agl_m", "velocity_sigma_mps": "velocity_mps", "euler_sigma_deg": "euler_deg",
                   "rate_sigma_dps": "rate_dps", "aero_factor_sigma": "aero_factor",
                   "wind_bias_sigma_mps": "wind_bias_mps", "density_factor_sigma": "density_factor"}


def parse_montecarlo(t: Fields) -> MonteCarloConfig:
    """The ``[montecarlo]`` table (pass an empty :class:`Fields` when absent) as a
    :class:`MonteCarloConfig`: ``cases`` (>= 1), ``seed`` (>= 0), ``center``, the sigmas of
    :data:`DISPERSION_KEYS` (>= 0) and ``aero_factors`` (names from ``DISPERSION_NAMES``).
    Raises :class:`~casrecon.io.errors.InputError` naming the file and the field on a bad or
    unknown key."""
    d = Dispersions()
    sizes = {name: t.number(key, getattr(d, name), minimum=0.0) for key, name in DISPERSION_KEYS.items()}
    factors = t.raw("aero_factors", list(d.aero_factors))
    if not isinstance(factors, list) or not all(isinstance(f, str) for f in factors):
        raise t.error("aero_factors", f"expected a list of dispersion factor names, got {factors!r}")
    unknown = [f for f in factors if f not in DISPERSION_NAMES]
    if unknown:
        raise t.error("aero_factors", f"unknown factor {unknown[0]!r}; known: {', '.join(DISPERSION_NAMES)}")
    cfg = MonteCarloConfig(cases=t.integer("cases", MonteCarloConfig.cases, 1),
                           seed=t.integer("seed", MonteCarloConfig.seed, 0),
                           dispersions=Dispersions(**sizes, aero_factors=tuple(factors),
                                                   center=t.string("center", d.center, choices=("truth", "nominal"))))
    t.reject_unknown()
    return cfg
