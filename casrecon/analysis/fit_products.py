"""What a per-drop fit leaves for its results folder besides the fit itself: sensor residuals, the
reconstructed pitching moment, and the reconciled forward simulations (EES paper VI).

:func:`fit_products` runs the computations of :mod:`casrecon.estimation.sixdof.diagnostics` (CasADi and
two forward simulations) once and returns them as named columns, so that the writers in
:mod:`casrecon.output` only serialise.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from casrecon.analysis.adequacy import Adequacy
from casrecon.analysis.aero_coefficients import aero_coefficients
from casrecon.analysis.fit_adequacy import drop_adequacy
from casrecon.estimation.kinds.gps import clock_offset
from casrecon.estimation.kinds.sample_terms import placed_kinds
from casrecon.estimation.sixdof import diagnostics as dg
from casrecon.estimation.sixdof.drop import MEASUREMENT_KINDS
from casrecon.io.units import (
    GPS_COMPONENT_UNITS,
    IMU_CHANNEL_UNITS,
    TIME_UNIX,
    gps_residual_column,
    gps_sigma_column,
    imu_residual_column,
    imu_sigma_key,
)
from casrecon.parallel import Forked

#: GPS residual components (antenna position NED, m; velocity NED, m/s).
GPS_COMPONENTS = ("pos_n", "pos_e", "pos_d", "vel_n", "vel_e", "vel_d")
#: Columns kept of the reconciled and nominal simulations.
SIMULATION_COLUMNS = ("flight_time_s", "h_agl_m", "speed_mps", "alpha_t_deg", "p_dps")

Columns = dict[str, np.ndarray]


@dataclass(frozen=True)
class FitProducts:
    """Residuals, pitching moment and reconciled simulations of one fit, as named columns.

    Every ``Columns`` field maps a column name to a 1-D array, all of one length, in file order.

    Attributes
    ----------
    imu_residuals : Columns
        ``time_imu_s`` (s, IMU clock), measured minus predicted ``<ch>_residual_mps2`` (ax, ay, az;
        m/s^2) and ``<ch>_residual_dps`` (wx, wy, wz; deg/s), IMU axes, and ``<ch>_used`` (1 where
        fitted, 0 where masked); names from :mod:`casrecon.io.units`.
    imu_sigma : dict of str to float
        Noise 1-sigma of each IMU channel: ``<ch>_sigma_mps2`` (m/s^2), ``<ch>_sigma_dps`` (deg/s).
    gps_residuals : Columns
        ``time_imu_s`` (s), ``time_unix_s`` (the fix's UTC stamp, s), ``<c>_residual_m`` /
        ``<c>_residual_mps`` and ``<c>_sigma_m`` / ``<c>_sigma_mps`` for :data:`GPS_COMPONENTS`.
    gps_fixes : Columns
        ``time_imu_s``, ``time_unix_s`` (s) and the measured antenna ``pos_n_m`` .. ``vel_d_mps``
        (NED, m and m/s).
    pitching_moment : Columns
        ``time_imu_s`` (s), ``alpha_deg`` (deg), ``qbar_pa`` (Pa) and ``cm_recon`` (-) at the nodes.
    cm_curves : Columns
        ``alpha_deg`` (deg), ``cm_nominal`` and ``cm_fitted`` (-): the database curves at beta = 0.
    reconciled, nominal : Columns
        :data:`SIMULATION_COLUMNS` (s, m, m/s, deg, deg/s) of the forward simulation from the first
        reconstructed state with the fitted dispersions, and with the nominal database.
    summary : dict
        Simulated minus reconstructed flight time (s) and impact speed (m/s) of the reconciled
        simulation, with the nominal one's under ``nominal_database``.
    roll_rate : list of dict or None
        :func:`roll_rate_comparison` rows (deg/s) for a vehicle with spin vanes, else None.
    kind_residuals : dict of str to Columns
        Residual columns of every other measurement kind present (e.g. ``"baro"``), as the kind's
        ``residuals`` names them (units in the column names), with ``time_unix_s`` after ``time_imu_s``.
    adequacy : Adequacy or None
        The model-adequacy verdict (:mod:`casrecon.analysis.adequacy`) of these residuals and the
        fit's priors.
    aero_coefficients : Columns
        Aerodynamic coefficient histories at the nodes, reconstructed from the IMU and of the best-fit
        and nominal database, with 3-sigma (:func:`casrecon.analysis.aero_coefficients.aero_coefficients`;
        names in :mod:`casrecon.analysis.aero_columns`).
    """

    imu_residuals: Columns
    imu_sigma: dict[str, float]
    gps_residuals: Columns
    gps_fixes: Columns
    pitching_moment: Columns
    cm_curves: Columns
    reconciled: Columns
    nominal: Columns
    summary: dict
    roll_rate: list[dict] | None = None
    kind_residuals: dict[str, Columns] = field(default_factory=dict)
    adequacy: Adequacy | None = None
    aero_coefficients: Columns = field(default_factory=dict)

    @property
    def reconciled_summary(self) -> dict:
        """:attr:`summary` with the roll-rate rows under ``roll_rate`` when there are any."""
        return self.summary if self.roll_rate is None else {**self.summary, "roll_rate": self.roll_rate}


def roll_rate_comparison(result, rec: dict, nom: dict, n: int = 6) -> list[dict]:
    """Reconstructed roll rate (with 3-sigma) against the spin-vane model.

    Parameters
    ----------
    result : casrecon.estimation.sixdof.fit.FitResult
        The fit.
    rec, nom : dict
        Forward simulations with the fitted and the nominal lift-curve slope: ``flight_time_s`` (s)
        and ``p_dps`` (deg/s) arrays, as :func:`casrecon.estimation.sixdof.diagnostics.reconciled_simulation`
        returns them.
    n : int
        Number of times, evenly spaced through the fit window.

    Returns
    -------
    list of dict
        Per time: ``flight_time_s`` (s), ``reconstructed_dps``, ``reconstructed_3sigma_dps``,
        ``model_fitted_dps`` and ``model_nominal_dps`` (deg/s).
    """
    p, p_sigma = result.column("p_dps")
    t = result.flight_time_s
    out = []
    for tt in np.linspace(t[0], t[-1], n):
        out.append({"flight_time_s": float(tt), "reconstructed_dps": float(np.interp(tt, t, p)),
                    "reconstructed_3sigma_dps": float(3 * np.interp(tt, t, p_sigma)),
                    "model_fitted_dps": float(np.interp(tt, rec["flight_time_s"], rec["p_dps"])),
                    "model_nominal_dps": float(np.interp(tt, nom["flight_time_s"], nom["p_dps"]))})
    return out


def fit_products(result, concurrent: bool = False) -> FitProducts:
    """Residuals, pitching moment and reconciled simulations of a fit.

    Parameters
    ----------
    result : casrecon.estimation.sixdof.fit.FitResult
        A converged per-drop fit.
    concurrent : bool
        Run the nominal-database simulation with the model-adequacy verdict, and the aerodynamic
        coefficients, in two forked processes while this one computes the rest
        (:class:`casrecon.parallel.Forked`; the same numbers): for a command on a machine with a
        second core, not inside worker processes.

    Returns
    -------
    FitProducts
    """
    imu, gps, others = dg.imu_residuals(result), dg.gps_residuals(result), other_kind_residuals(result)
    # two children: the nominal simulation with the verdict (which imports scipy.special for its
    # quantiles, 0.1 to 0.5 s), and the aerodynamic coefficients; this process does the rest
    def nominal_and_verdict():
        return dg.reconciled_simulation(result, nominal=True), drop_adequacy(result, imu, gps, others)

    def coefficients():
        return aero_coefficients(result)

    verdict_child = Forked(nominal_and_verdict) if concurrent else None
    coefficients_child = Forked(coefficients) if concurrent else None
    factors = np.array([IMU_CHANNEL_UNITS[c][1] for c in dg.IMU_CHANNELS])
    imu_cols = {"time_imu_s": imu["time_imu_s"]}
    imu_cols.update({imu_residual_column(c): imu["residual"][:, k] * factors[k] for k, c in enumerate(dg.IMU_CHANNELS)})
    imu_cols.update({f"{c}_used": imu["valid"][:, k] for k, c in enumerate(dg.IMU_CHANNELS)})
    utc = {TIME_UNIX: unix_time(result, gps["time_imu_s"])}
    gps_cols = {"time_imu_s": gps["time_imu_s"], **utc}
    gps_cols.update({gps_residual_column(c): gps["residual"][:, k] for k, c in enumerate(GPS_COMPONENTS)})
    gps_cols.update({gps_sigma_column(c): gps["sigma"][:, k] for k, c in enumerate(GPS_COMPONENTS)})
    d = result.data
    fix_names = [f"{c}_{GPS_COMPONENT_UNITS[c]}" for c in GPS_COMPONENTS]
    fixes = np.column_stack([d.gps_pos_ned, d.gps_vel_ned])
    pm = dg.pitching_moment(result)
    rec = dg.reconciled_simulation(result)
    vanes = result.scenario.config.aero.vanes is not None
    aero = coefficients() if coefficients_child is None else coefficients_child.result()
    nom, adequacy = nominal_and_verdict() if verdict_child is None else verdict_child.result()
    return FitProducts(
        imu_residuals=imu_cols,
        imu_sigma={imu_sigma_key(c): float(sg * f) for c, sg, f in zip(dg.IMU_CHANNELS, imu["sigma"], factors)},
        gps_residuals=gps_cols,
        gps_fixes={"time_imu_s": gps["time_imu_s"], **utc, **{n: fixes[:, k] for k, n in enumerate(fix_names)}},
        pitching_moment={k: pm[k] for k in ("time_imu_s", "alpha_deg", "qbar_pa", "cm_recon")},
        cm_curves={"alpha_deg": pm["alpha_grid_deg"], "cm_nominal": pm["cm_nominal"], "cm_fitted": pm["cm_fitted"]},
        reconciled={k: rec[k] for k in SIMULATION_COLUMNS},
        nominal={k: nom[k] for k in SIMULATION_COLUMNS},
        summary={**rec["summary"], "nominal_database": nom["summary"]},
        kind_residuals=others,
        aero_coefficients=aero,
        roll_rate=roll_rate_comparison(result, rec, nom) if vanes else None,
        adequacy=adequacy)


def result_adequacy(result) -> Adequacy:
    """The model-adequacy verdict of a fit alone (its residuals, without the simulations of
    :func:`fit_products`; the same verdict)."""
    return drop_adequacy(result, dg.imu_residuals(result), dg.gps_residuals(result), other_kind_residuals(result))


def other_kind_residuals(result) -> dict[str, Columns]:
    """Residual columns of the measurement kinds other than the IMU and GPS that the fit used (its
    sample kinds' too), with ``time_unix_s`` (:func:`unix_time`) after ``time_imu_s``."""
    out = {}
    for kind in MEASUREMENT_KINDS + placed_kinds(result.measurements):
        if kind.name not in ("imu", "gps") and kind.name in result.measurements:
            columns = kind.residuals(result)
            if columns is not None:
                if "time_imu_s" in columns:
                    columns = {"time_imu_s": columns["time_imu_s"], TIME_UNIX: unix_time(result, columns["time_imu_s"]),
                               **{k: v for k, v in columns.items() if k != "time_imu_s"}}
                out[kind.name] = columns
    return out


def unix_time(result, time_imu_s: np.ndarray) -> np.ndarray:
    """UTC (Unix seconds) of IMU-clock times of a fit, on the GPS receiver's clock:
    ``utc_at_zero + t_imu + clock_offset`` with the fitted (or held) clock offset."""
    utc0 = result.scenario.config.imu.clock_utc_at_zero.timestamp()
    return utc0 + np.asarray(time_imu_s, dtype=float) + clock_offset(result)
