"""An estimated parameter as every writer and report shows it: in its output unit
(:func:`casrecon.io.units.output_unit`: SI, gyro biases in deg/s), with its 1- and 3-sigma, its
chi-square-scaled sigma and its prior. Made once per parameter (:func:`parameter_estimate`), read by
``parameters.json`` (:meth:`ParameterEstimate.record`), the text report, the tables and the joint
documents, so that none of them redoes the unit conversion or the chi-square scaling."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from casrecon.io.units import output_unit


@dataclass(frozen=True)
class ParameterEstimate:
    """One parameter's estimate.

    Attributes
    ----------
    name, unit, group : str
        Name (as in truth.json), output unit, parameter group (``"aero"``, ``"imu"``...).
    value, sigma, three_sigma : float
        Estimate, its 1-sigma and 3-sigma (absolute: noise sigmas as given), in ``unit``.
    sigma_chi2_scaled : float
        1-sigma times sqrt(reduced chi-square), in ``unit``.
    prior_sigma : float or None
        Prior 1-sigma in ``unit``; None without a prior.
    """

    name: str
    unit: str
    group: str
    value: float
    sigma: float
    three_sigma: float
    sigma_chi2_scaled: float
    prior_sigma: float | None

    def record(self) -> dict:
        """The ``parameters.json`` entry."""
        return {"value": self.value, "sigma": self.sigma, "three_sigma": self.three_sigma,
                "sigma_chi2_scaled": self.sigma_chi2_scaled, "unit": self.unit, "group": self.group,
                "prior_sigma": self.prior_sigma}


def parameter_estimate(spec, value: float, sigma: float, chi2_scale: float) -> ParameterEstimate:
    """The estimate of the parameter ``spec`` (a :class:`~casrecon.estimation.sixdof.parameters.ParameterSpec`:
    ``name``, ``unit`` (SI), ``group``, ``prior_sigma``) at ``value`` +- ``sigma`` (SI), with the
    chi-square scale sqrt(reduced chi-square)."""
    unit, f = output_unit(spec.unit)
    prior = getattr(spec, "prior_sigma", None)
    return ParameterEstimate(spec.name, unit, spec.group, float(value) * f, float(sigma) * f, 3 * float(sigma) * f,
                             float(sigma) * chi2_scale * f, None if prior is None else prior * f)


def parameter_estimates(result) -> tuple[ParameterEstimate, ...]:
    """Every estimated parameter of a per-drop fit (:class:`~casrecon.estimation.sixdof.fit.FitResult`), in
    fit order."""
    scale = float(np.sqrt(result.reduced_chi2))
    return tuple(parameter_estimate(spec, result.values[i], result.sigma[i], scale)
                 for i, spec in enumerate(result.params.specs))
