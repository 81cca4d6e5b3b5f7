"""Paper-style Markdown tables of a per-drop fit (EES paper Tables 3, 4 and 5)."""

from __future__ import annotations

import numpy as np

from casrecon.analysis.parameter_estimates import parameter_estimates
from casrecon.physics.aero import DISPERSION_NAMES

TABLE3_COLUMNS = (("h_agl_m", "h_agl, m"), ("vel_n_mps", "Vn, m/s"), ("vel_e_mps", "Ve, m/s"),
                  ("vel_d_mps", "Vd, m/s"), ("roll_deg", "phi, deg"), ("pitch_deg", "theta, deg"),
                  ("yaw_deg", "psi, deg"), ("p_dps", "p, deg/s"), ("q_dps", "q, deg/s"), ("r_dps", "r, deg/s"))
TABLE4_EXTRA = (("alpha_t_deg", "alpha_T, deg"), ("qbar_pa", "qbar, Pa"))


def _row(result, node: int, columns) -> tuple[list[str], list[str]]:
    values, sigmas = [], []
    for col, _ in columns:
        v, s = result.column(col)
        values.append(f"{v[node]:.2f}")
        sigmas.append(f"{3 * s[node]:.3g}")
    return values, sigmas


def _table(title: str, note: str, columns, rows: list[tuple[str, list[str]]]) -> str:
    head = "| | " + " | ".join(label for _, label in columns) + " |"
    sep = "|---" * (len(columns) + 1) + "|"
    body = "\n".join(f"| {name} | " + " | ".join(cells) + " |" for name, cells in rows)
    return f"### {title}\n\n{note}\n\n{head}\n{sep}\n{body}\n"


def initial_conditions_table(result) -> str:
    """Table 3 style: the state at the start of the fit window with its 3-sigma."""
    v, s = _row(result, 0, TABLE3_COLUMNS)
    t = result.flight_time_s[0]
    return _table("Reconstructed initial conditions (EES Table 3 style)",
                  f"At the start of the fit window, {t:.3f} s after release (IMU clock "
                  f"{result.node_time_s[0]:.3f} s); second row 3-sigma.",
                  TABLE3_COLUMNS, [("estimate", v), ("3-sigma", s)])


def impact_conditions_table(result) -> str:
    """Table 4 style: the state at the end of the fit window with its 3-sigma, plus |V|."""
    cols = TABLE3_COLUMNS + TABLE4_EXTRA
    v, s = _row(result, -1, cols)
    speed = float(np.linalg.norm(result.states[-1, 3:6]))
    t = result.flight_time_s[-1]
    return _table("Reconstructed impact conditions (EES Table 4 style)",
                  f"At the end of the fit window, {t:.3f} s after release and "
                  f"{result.data.impact_imu_s - result.node_time_s[-1]:.3f} s before the impact found in the "
                  f"IMU; speed |V| = {speed:.2f} m/s.", cols, [("estimate", v), ("3-sigma", s)])


def dispersion_table(result) -> str:
    """Table 5 style: aero dispersion factors with 3-sigma, and what the data added to the prior."""
    lines = ["### Aero dispersions (EES Table 5 style)", "",
             "Normalised factors (database 3-sigma = 1). 'data share' is 1 - (posterior / prior "
             "variance): near 0 means the prior, not the data, sets the value.", "",
             "| factor | estimate | 3-sigma | prior 3-sigma | data share |", "|---|---|---|---|---|"]
    estimates = {e.name: e for e in parameter_estimates(result)}
    for name in DISPERSION_NAMES:
        e = estimates.get(name)
        if e is None:
            lines.append(f"| {name} | 0 (fixed) | - | - | not estimated |")
            continue
        share = "-" if e.prior_sigma is None else f"{1 - (e.sigma / e.prior_sigma) ** 2:.3f}"
        prior_txt = "off" if e.prior_sigma is None else f"{3 * e.prior_sigma:.3g}"
        lines.append(f"| {name} | {e.value:.4f} | {e.three_sigma:.4f} | {prior_txt} | {share} |")
    return "\n".join(lines) + "\n"


def fit_tables(result) -> str:
    """All three tables as one Markdown document."""
    name = result.scenario.config.name
    return "\n".join([f"# {name}: reconstruction tables\n", initial_conditions_table(result),
                      impact_conditions_table(result), dispersion_table(result)])


def roll_rate_table(rows: list[dict], cla_mult: tuple[float, float] | None) -> str:
    """Markdown table of :func:`casrecon.analysis.fit_products.roll_rate_comparison` rows (deg/s);
    ``cla_mult`` is the fitted (value, 1-sigma) of the vane lift-curve slope multiplier, if estimated."""
    fit = "" if cla_mult is None else f" (CLa_mult {cla_mult[0]:.4f} +/- {3 * cla_mult[1]:.4f}, 3-sigma)"
    lines = ["### Roll rate: reconstruction vs spin-vane model", "",
             f"Forward simulations from the reconstructed first state with the fitted C_La{fit} and the nominal "
             "(2 pi / 5) vane lift-curve slope.", "",
             "| flight time, s | reconstructed, deg/s | 3-sigma | model, fitted C_La | model, nominal C_La |",
             "|---|---|---|---|---|"]
    for r in rows:
        lines.append(f"| {r['flight_time_s']:.1f} | {r['reconstructed_dps']:.2f} | "
                     f"{r['reconstructed_3sigma_dps']:.3f} | "
                     f"{r['model_fitted_dps']:.2f} | {r['model_nominal_dps']:.2f} |")
    return "\n".join(lines) + "\n"


def drop_tables(result, products) -> str:
    """``tables.md`` of a per-drop fit: :func:`fit_tables`, and the roll-rate table when the
    :class:`~casrecon.analysis.fit_products.FitProducts` have roll-rate rows (a vehicle with spin vanes)."""
    text = fit_tables(result)
    if products.roll_rate is not None:
        cla = result.parameter("CLa_mult") if "CLa_mult" in result.params.names else None
        text += "\n" + roll_rate_table(products.roll_rate, cla)
    return text
