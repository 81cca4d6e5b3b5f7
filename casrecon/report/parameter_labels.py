"""Short mathtext labels of parameter names for figure axes (``CA_mult`` -> ``$C_A$ mult``).

The names are those of ``parameters.json``; a joint fit's per-drop parameters are
``<drop>.<name>`` and are labelled by ``<name>`` (the drop is shown by the figure's blocks). A
name without a known label is shown as it is.
"""

from __future__ import annotations

#: Aero coefficient of each dispersion factor's stem (``<stem>_mult`` or ``<stem>_add``).
COEFFICIENTS = {"CA": "C_A", "CN": "C_N", "CNY": "C_{N,Y}", "CY": "C_Y", "Cm": "C_m", "Cmn": "C_{m,n}",
                "Cn": "C_n", "Cmq": "C_{m_q}", "Cl": "C_l", "CLa": r"C_{L_\alpha}", "Cmq_a2": r"C_{m_q\alpha^2}"}

#: Labels of the other parameters (atmosphere, IMU, clock, barometer).
LABELS = {
    "wind_bias_n": r"$\Delta w_N$", "wind_bias_e": r"$\Delta w_E$", "density_factor": r"$\Delta\rho/\rho$",
    "wind_gradient_n": r"$\partial w_N/\partial h$", "wind_gradient_e": r"$\partial w_E/\partial h$",
    "downwash_mps": r"$w_{\mathrm{rotor}}$", "sounding_shift_m": r"$\Delta h_{\mathrm{sounding}}$",
    **{f"accel_bias_{a}": rf"$b_{{a,{a}}}$" for a in "xyz"},
    **{f"gyro_bias_{a}": rf"$b_{{\omega,{a}}}$" for a in "xyz"},
    "clock_offset_s": r"$\Delta t_{\mathrm{clock}}$", "baro_bias_pa": r"$b_p$", "baro_qbar_coef": r"$k_{\bar q}$",
}


def split_name(name: str) -> tuple[str, str]:
    """(drop, parameter) of a joint parameter name; drop is "" for a shared (undotted) name."""
    drop, _, param = name.rpartition(".")
    return drop, param


def short_label(name: str) -> str:
    """A short mathtext label of parameter ``name`` (drop prefix dropped)."""
    param = split_name(name)[1]
    if param in LABELS:
        return LABELS[param]
    for suffix in ("_mult", "_add"):
        stem = param.removesuffix(suffix)
        if stem != param and stem in COEFFICIENTS:
            return f"${COEFFICIENTS[stem]}$ {suffix[1:]}"
    return param
