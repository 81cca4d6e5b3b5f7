"""Estimated parameters as lmfit-style records: ``result.params["Cmq_mult"].stderr``.

:class:`Parameters` is built from the ``parameters.json`` document (:func:`from_document`), whether
that document was just computed from a fit or read back from a results folder, so a saved and
loaded result has exactly the same records (JSON floats round-trip bit-identically).
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping
from dataclasses import dataclass, field
from types import MappingProxyType

import numpy as np


@dataclass(frozen=True)
class Parameter:
    """One estimated parameter.

    Attributes
    ----------
    name : str
        As in ``truth.json`` (``CA_mult``, ``wind_bias_n``, ...).
    value : float
        Estimate, in ``unit``.
    stderr : float
        Absolute 1-sigma (noise sigmas as given), in ``unit``.
    stderr_scaled : float
        ``stderr`` times sqrt(reduced chi-square), in ``unit``.
    unit : str
        ``"-"`` for dimensionless factors, else SI (``"m/s"``, ...) except angular rates in deg/s
        (gyro biases), as ``parameters.json`` writes them; empty when not recorded.
    group : str
        Prior group (``"aero"``, ``"atmosphere"``, ``"imu"``, ...); empty when not recorded.
    prior_sigma : float or None
        1-sigma of the zero-mean Gaussian prior (``unit``), None when the prior is off.
    correl : Mapping of str to float
        Correlation coefficient with every other parameter (not itself), like lmfit's ``correl``;
        empty when the fit records no correlations (point-mass fits).
    shared : bool or None
        Joint fits: whether the parameter is common to all drops; None for a per-drop fit.
    """

    name: str
    value: float
    stderr: float
    stderr_scaled: float
    unit: str = ""
    group: str = ""
    prior_sigma: float | None = None
    correl: Mapping[str, float] = field(default_factory=dict, hash=False)
    shared: bool | None = None

    @property
    def three_sigma(self) -> float:
        """3 * ``stderr``, in ``unit``."""
        return 3.0 * self.stderr

    def __repr__(self) -> str:
        return f"<Parameter {self.name!r}, value={self.value:.6g} +/- {self.stderr:.3g} [{self.unit or '-'}]>"


class Parameters(Mapping[str, Parameter]):
    """The estimated parameters of a fit, in fit order: a read-only mapping name -> :class:`Parameter`.

    Iterating gives the names in order; ``names``, ``values``, ``stderr`` and ``correlation`` give
    arrays; :meth:`to_frame` a pandas DataFrame.
    """

    def __init__(self, records: tuple[Parameter, ...], correlation: np.ndarray):
        self._records = MappingProxyType({p.name: p for p in records})
        self._correlation = np.array(correlation, dtype=float)
        self._correlation.flags.writeable = False

    def __getitem__(self, name: str) -> Parameter:
        try:
            return self._records[name]
        except KeyError:
            raise KeyError(f"no parameter {name!r}; the fit estimated {', '.join(self._records)}") from None

    def __iter__(self) -> Iterator[str]:
        return iter(self._records)

    def __len__(self) -> int:
        return len(self._records)

    def __eq__(self, other: object) -> bool:
        if not isinstance(other, Parameters):
            return NotImplemented
        return (tuple(self._records.values()) == tuple(other._records.values())
                and np.array_equal(self._correlation, other._correlation, equal_nan=True))

    __hash__ = None  # type: ignore[assignment]

    def __repr__(self) -> str:
        return f"<Parameters {len(self)}: {', '.join(self)}>"

    @property
    def names(self) -> tuple[str, ...]:
        """Parameter names in fit order."""
        return tuple(self._records)

    @property
    def values(self) -> np.ndarray:
        """Estimates in fit order (each in its unit)."""
        return np.array([p.value for p in self._records.values()])

    @property
    def stderr(self) -> np.ndarray:
        """Absolute 1-sigma in fit order (each in its unit)."""
        return np.array([p.stderr for p in self._records.values()])

    @property
    def correlation(self) -> np.ndarray:
        """Correlation matrix (read-only), rows and columns in fit order."""
        return self._correlation

    def to_frame(self):
        """A pandas DataFrame indexed by name: value, stderr, stderr_scaled, three_sigma, unit,
        group, prior_sigma (and shared for a joint fit)."""
        import pandas as pd

        rows = [{"name": p.name, "value": p.value, "stderr": p.stderr, "stderr_scaled": p.stderr_scaled,
                 "three_sigma": p.three_sigma, "unit": p.unit, "group": p.group, "prior_sigma": p.prior_sigma,
                 **({} if p.shared is None else {"shared": p.shared})} for p in self._records.values()]
        return pd.DataFrame(rows).set_index("name")


def _optional_float(x) -> float | None:
    return None if x is None else float(x)


def from_document(doc: dict, reduced_chi2: float | None = None) -> Parameters:
    """:class:`Parameters` of a ``parameters.json`` document (per-drop, joint or point-mass).

    Parameters
    ----------
    doc : dict
        ``{"parameters": {name: {"value", "sigma", ...}}, "correlation": {"names", "matrix"}}``;
        without a correlation (point-mass folders) the matrix is NaN off the diagonal and every
        ``correl`` is empty.
    reduced_chi2 : float, optional
        Used for ``stderr_scaled`` when an entry lacks ``sigma_chi2_scaled`` (then NaN if None).
    """
    entries = doc["parameters"]
    names = list(entries)
    corr_doc = doc.get("correlation")
    if corr_doc:
        order = [corr_doc["names"].index(n) for n in names]
        matrix = np.asarray(corr_doc["matrix"], dtype=float)[np.ix_(order, order)]
    else:
        matrix = np.full((len(names), len(names)), np.nan)
        np.fill_diagonal(matrix, 1.0)
    scale = math.sqrt(reduced_chi2) if reduced_chi2 is not None else math.nan
    records = []
    for i, name in enumerate(names):
        e = entries[name]
        sigma = float(e["sigma"])
        scaled = e.get("sigma_chi2_scaled")
        records.append(Parameter(
            name=name, value=float(e["value"]), stderr=sigma,
            stderr_scaled=float(scaled) if scaled is not None else sigma * scale,
            unit=str(e.get("unit", "")), group=str(e.get("group", "")),
            prior_sigma=_optional_float(e.get("prior_sigma")),
            correl=MappingProxyType({m: float(matrix[i, j]) for j, m in enumerate(names) if j != i}
                                    if corr_doc else {}),
            shared=e.get("shared")))
    return Parameters(tuple(records), matrix)
