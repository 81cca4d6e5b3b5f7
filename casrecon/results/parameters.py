"""Estimated parameters as lmfit-style records: ``result.params["Cmq_mult"].stderr``.

:class:`Parameters` is built from the ``parameters.json`` document (:func:`from_document`), whether
that document was just computed from a fit or read back from a results folder, so a saved and
loaded result has exactly the same records (JSON floats round-trip bit-identically). Parameters the
fit held fixed (the report's "fixed" lines) are records too, with ``vary`` False.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Mapping, Sequence
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
    vary : bool
        True for an estimated parameter; False for one the fit held fixed at ``value`` (``stderr``
        and ``stderr_scaled`` are then 0 and ``correl`` is empty), as lmfit's ``vary``.

    ``sigma`` and ``sigma_chi2_scaled`` (the names of ``parameters.json``) are aliases of ``stderr``
    and ``stderr_scaled``; ``fixed`` is ``not vary``. The repr shows the 1-sigma ``stderr``.
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
    vary: bool = True

    @property
    def three_sigma(self) -> float:
        """3 * ``stderr``, in ``unit``."""
        return 3.0 * self.stderr

    @property
    def sigma(self) -> float:
        """``stderr`` under the name ``parameters.json`` gives it (absolute 1-sigma, in ``unit``)."""
        return self.stderr

    @property
    def sigma_chi2_scaled(self) -> float:
        """``stderr_scaled`` under the name ``parameters.json`` gives it (1-sigma, in ``unit``)."""
        return self.stderr_scaled

    @property
    def fixed(self) -> bool:
        """Whether the fit held this parameter fixed (``not vary``)."""
        return not self.vary

    def __repr__(self) -> str:
        unit = self.unit or "-"
        if not self.vary:
            return f"<Parameter {self.name!r}, value={self.value:.6g} (fixed) [{unit}]>"
        return f"<Parameter {self.name!r}, value={self.value:.6g} +/- {self.stderr:.3g} (1-sigma) [{unit}]>"


class Parameters(Mapping[str, Parameter]):
    """The parameters of a fit: a read-only mapping name -> :class:`Parameter`, the estimated ones in
    fit order, then those held fixed (``vary`` False), as lmfit's ``Parameters`` holds both.

    As a Mapping, iterating gives every name and ``keys()``, ``values()`` (the :class:`Parameter`
    records) and ``items()`` cover every parameter; ``var_names`` (also ``names``), ``var_values``,
    ``stderr`` (also ``sigma``) and ``correlation`` give the estimated parameters' names and arrays
    in fit order; :meth:`valuesdict` every value by name; :attr:`covar` and :attr:`correl` the
    covariance and correlation as labelled DataFrames; :meth:`to_frame` a DataFrame of every record;
    :meth:`pretty_print` a table.
    """

    def __init__(self, records: tuple[Parameter, ...], correlation: np.ndarray):
        self._records = MappingProxyType({p.name: p for p in records})
        self._correlation = np.array(correlation, dtype=float)
        self._correlation.flags.writeable = False
        n_vary = sum(p.vary for p in records)
        if self._correlation.shape != (n_vary, n_vary):
            raise ValueError(f"correlation is {self._correlation.shape}, expected ({n_vary}, {n_vary}): one row "
                             f"and column per estimated parameter")

    def __getitem__(self, name: str) -> Parameter:
        try:
            return self._records[name]
        except KeyError:
            raise KeyError(f"no parameter {name!r}; the fit has {', '.join(self._records)}") from None

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
        fixed = len(self) - len(self.var_names)
        held = f" (+{fixed} fixed)" if fixed else ""
        return f"<Parameters {len(self.var_names)} estimated{held}: {', '.join(self)}>"

    @property
    def var_names(self) -> tuple[str, ...]:
        """Names of the estimated parameters (``vary`` True) in fit order, as lmfit's ``var_names``."""
        return tuple(n for n, p in self._records.items() if p.vary)

    @property
    def names(self) -> tuple[str, ...]:
        """Names of the estimated parameters in fit order (:attr:`var_names`); ``list(params)`` gives
        every name, the fixed ones included."""
        return self.var_names

    @property
    def var_values(self) -> np.ndarray:
        """Estimates of the estimated parameters (``vary`` True) in fit order, as an ndarray (each in
        its unit); the order of :attr:`var_names`. (``values()`` is the Mapping's: every record.)"""
        return np.array([self._records[n].value for n in self.var_names])

    @property
    def stderr(self) -> np.ndarray:
        """Absolute 1-sigma in fit order (each in its unit), of the estimated parameters."""
        return np.array([self._records[n].stderr for n in self.var_names])

    @property
    def sigma(self) -> np.ndarray:
        """:attr:`stderr` under the name ``parameters.json`` gives it."""
        return self.stderr

    @property
    def correlation(self) -> np.ndarray:
        """Correlation matrix (read-only ndarray, -), rows and columns in the order of :attr:`var_names`
        (:attr:`correl` is the same, labelled)."""
        return self._correlation

    @property
    def correl(self):
        """Correlation matrix as a pandas DataFrame (-), the estimated parameters' names as index and
        columns; NaN off the diagonal where the fit records no correlations (point-mass fits)."""
        import pandas as pd

        names = list(self.var_names)
        return pd.DataFrame(np.array(self._correlation), index=pd.Index(names, name="name"), columns=names)

    @property
    def covar(self):
        """Covariance of the estimated parameters as a pandas DataFrame labelled like :attr:`correl`:
        ``stderr[i] * stderr[j] * correlation[i, j]``, each entry in the product of the two
        parameters' units (absolute, from the noise sigmas as given; NaN off the diagonal where no
        correlations are recorded)."""
        import pandas as pd

        names = list(self.var_names)
        sd = self.stderr
        return pd.DataFrame(self._correlation * np.outer(sd, sd), index=pd.Index(names, name="name"), columns=names)

    def valuesdict(self) -> dict[str, float]:
        """Every parameter's value (each in its unit) by name, the fixed ones included, as lmfit's."""
        return {n: p.value for n, p in self._records.items()}

    def to_frame(self):
        """A pandas DataFrame indexed by name, one row per parameter (the fixed ones included): value,
        stderr (1-sigma), stderr_scaled, three_sigma, unit, group, prior_sigma, vary (and shared for
        a joint fit)."""
        import pandas as pd

        rows = [{"name": p.name, "value": p.value, "stderr": p.stderr, "stderr_scaled": p.stderr_scaled,
                 "three_sigma": p.three_sigma, "unit": p.unit, "group": p.group, "prior_sigma": p.prior_sigma,
                 "vary": p.vary, **({} if p.shared is None else {"shared": p.shared})}
                for p in self._records.values()]
        return pd.DataFrame(rows).set_index("name")

    def pretty_text(self) -> str:
        """The table :meth:`pretty_print` prints: name, value, 1-sigma, 3-sigma, vary, unit."""
        width = max([4, *map(len, self._records)])
        lines = [f"{'Name':<{width}}  {'Value':>12}  {'Stderr (1-sigma)':>16}  {'3-sigma':>11}  Vary   Unit"]
        for p in self._records.values():
            sd, three = (f"{p.stderr:.4g}", f"{p.three_sigma:.4g}") if p.vary else ("fixed", "")
            lines.append(f"{p.name:<{width}}  {p.value:>12.6g}  {sd:>16}  {three:>11}  {p.vary!s:<5}  {p.unit or '-'}")
        return "\n".join(lines)

    def pretty_print(self) -> None:
        """Print one line per parameter (name, value, 1- and 3-sigma, vary, unit), as lmfit's."""
        print(self.pretty_text())


def _optional_float(x) -> float | None:
    return None if x is None else float(x)


def fixed_parameter(name: str, value: float = 0.0, unit: str = "-", group: str = "") -> Parameter:
    """The record of a parameter the fit held at ``value`` (in ``unit``): ``vary`` False, no error bar
    (``stderr`` 0), no correlations."""
    return Parameter(name=name, value=float(value), stderr=0.0, stderr_scaled=0.0, unit=unit, group=group,
                     correl=MappingProxyType({}), vary=False)


def from_document(doc: dict, reduced_chi2: float | None = None, fixed: Sequence[Parameter] = ()) -> Parameters:
    """:class:`Parameters` of a ``parameters.json`` document (per-drop, joint or point-mass).

    Parameters
    ----------
    doc : dict
        ``{"parameters": {name: {"value", "sigma", ...}}, "correlation": {"names", "matrix"}}``;
        without a correlation (point-mass folders) the matrix is NaN off the diagonal and every
        ``correl`` is empty.
    reduced_chi2 : float, optional
        Used for ``stderr_scaled`` when an entry lacks ``sigma_chi2_scaled`` (then NaN if None).
    fixed : sequence of Parameter
        Records of the parameters the fit held fixed (:func:`fixed_parameter`), placed after the
        estimated ones; a name the document estimates is not repeated.
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
    records += [p for p in fixed if p.name not in entries]
    return Parameters(tuple(records), matrix)
